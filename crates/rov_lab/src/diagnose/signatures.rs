//! Effect-specific signature checks that a fit alone cannot make: a sensor drift must
//! persist at rest and depart from the measured rates.

use rov_dynamics::models::Channel;

use crate::data::{Run, SegmentKind};
use crate::model::LabModel;

/// least 4 s), pooled: (slope m/s, standard error). A sensor drift keeps growing while
/// the vehicle is still; a dynamic mismatch does not.
pub(super) fn rest_depth_slope(model: &LabModel, runs: &[Run]) -> Option<(f64, f64)> {
    let (mut sxy, mut sxx, mut n_tot, mut rss) = (0.0, 0.0, 0usize, 0.0);
    let mut pieces = Vec::new();
    for run in runs {
        let y = run.channel(Channel::Depth)?;
        let pred = crate::sim::simulate_run(model, run, &[0]).ok()?;
        let p = pred.channel(Channel::Depth)?;
        for seg in &run.segments {
            if seg.kind != SegmentKind::Rest || seg.t_end_s - seg.t_start_s < 4.0 {
                continue;
            }
            let start = seg.start + (seg.end - seg.start) * 2 / 5;
            let pts: Vec<(f64, f64)> = (start..seg.end)
                .filter(|k| y[*k].is_finite() && p[*k].is_finite())
                .map(|k| (run.t[k], p[k] - y[k]))
                .collect();
            if pts.len() < 5 {
                continue;
            }
            let m = pts.len() as f64;
            let tm = pts.iter().map(|q| q.0).sum::<f64>() / m;
            let em = pts.iter().map(|q| q.1).sum::<f64>() / m;
            let a: f64 = pts.iter().map(|q| (q.0 - tm) * (q.1 - em)).sum();
            let b: f64 = pts.iter().map(|q| (q.0 - tm).powi(2)).sum();
            sxy += a;
            sxx += b;
            pieces.push((pts, tm, em));
        }
    }
    if sxx <= 0.0 {
        return None;
    }
    // Model error e = prediction − measurement; a reading drifting up makes e fall.
    let slope = sxy / sxx;
    for (pts, tm, em) in &pieces {
        for q in pts {
            rss += (q.1 - em - slope * (q.0 - tm)).powi(2);
            n_tot += 1;
        }
    }
    let dof = (n_tot as f64 - 2.0 * pieces.len() as f64).max(1.0);
    let se = (rss / dof / sxx).sqrt();
    Some((-slope, se))
}

/// Kinematic check of a sensor effect on depth or heading against the measured rates
/// (heave velocity with surge, sway and attitude when present; yaw rate with pitch rate
/// and attitude). Per run, the discrepancy D_k = y_k − y_0 − ∫ ẏ dt between the reading
/// and the integrated measured rate is regressed (through the origin, pooled over runs)
/// on the reading offset S_k = o_k − o_0 that the fitted sensor effect predicts:
/// (β, standard error, inflated for the residual's lag-1 autocorrelation). β ≈ 1: the
/// reading departs from the motion as the effect says; β ≈ 0: the motion accounts for
/// the reading. `None` when the rate is not measured or the effect predicts no offset.
pub(super) fn kinematic_ratio(
    runs: &[Run],
    ch: Channel,
    offset: impl Fn(&Run, usize) -> f64,
) -> Option<(f64, f64)> {
    let rate_ch = match ch {
        Channel::Depth => Channel::Heave,
        Channel::Heading => Channel::YawRate,
        _ => return None,
    };
    let (mut sds, mut sss) = (0.0, 0.0);
    let mut pairs: Vec<Vec<(f64, f64)>> = Vec::new();
    for run in runs {
        let (Some(y), Some(main_rate)) = (run.channel(ch), run.channel(rate_ch)) else {
            continue;
        };
        let get = |c: Channel, k: usize| -> f64 {
            run.channel(c)
                .and_then(|v| v.get(k))
                .copied()
                .filter(|x| x.is_finite())
                .unwrap_or(0.0)
        };
        // The channel's rate from the measured body rates and attitude, per second.
        let rate = |k: usize| -> Option<f64> {
            let r = main_rate.get(k).copied().filter(|x| x.is_finite())?;
            let (th, ph) = (
                get(Channel::Pitch, k).to_radians(),
                get(Channel::Roll, k).to_radians(),
            );
            Some(match ch {
                Channel::Depth => {
                    -get(Channel::Surge, k) * th.sin()
                        + get(Channel::Sway, k) * th.cos() * ph.sin()
                        + r * th.cos() * ph.cos()
                }
                _ => (get(Channel::PitchRate, k) * ph.sin() + r * ph.cos()) / th.cos().max(0.1),
            })
        };
        let (Some(&y0), Some(r0)) = (y.first(), rate(0)) else {
            continue;
        };
        let o0 = offset(run, 0);
        let mut integral = 0.0;
        let mut prev = r0;
        let mut pts = Vec::with_capacity(run.len());
        for (k, yk) in y.iter().enumerate().skip(1) {
            let rk = rate(k).unwrap_or(prev);
            integral += 0.5 * (prev + rk) * (run.t[k] - run.t[k - 1]);
            prev = rk;
            if !yk.is_finite() || !y0.is_finite() {
                continue;
            }
            let d = yk - y0 - integral;
            let sk = offset(run, k) - o0;
            sds += d * sk;
            sss += sk * sk;
            pts.push((d, sk));
        }
        pairs.push(pts);
    }
    if sss <= 0.0 || !sss.is_finite() {
        return None;
    }
    let beta = sds / sss;
    let (mut rss, mut c1, mut n) = (0.0, 0.0, 0usize);
    for pts in &pairs {
        let mut prev: Option<f64> = None;
        for (d, sk) in pts {
            let e = d - beta * sk;
            rss += e * e;
            if let Some(p) = prev {
                c1 += p * e;
            }
            prev = Some(e);
            n += 1;
        }
    }
    if n < 3 || rss <= 0.0 {
        return Some((beta, 0.0));
    }
    let rho = (c1 / rss).clamp(0.0, 0.99);
    let se = (rss / (n as f64 - 1.0) / sss).sqrt() * ((1.0 + rho) / (1.0 - rho)).sqrt();
    Some((beta, se))
}

/// Whether a kinematic ratio (see [`kinematic_ratio`]) confirms a sensor effect: the
/// reading departs from the integrated motion by at least half and at most twice the
/// fitted offset, clearly (three standard errors) above zero.
pub(super) fn kinematic_consistent(beta: f64, se: f64) -> bool {
    (0.5..=2.0).contains(&beta) && beta > 3.0 * se
}
