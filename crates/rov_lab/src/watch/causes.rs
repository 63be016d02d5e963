//! The causes the watch ranks, and how each is fitted to the residuals.
//!
//! Every cause is a change of the lab model along the parameters the lab already has
//! for that physics (the calibration's thrust coefficients and damping, and the catalog
//! effects' own parameters), so its signature on every channel is the lab model's
//! response through the lab's simulator, not a second description of the physics:
//!
//! | cause id | lab parameters (catalog effect) | size, unit |
//! |---|---|---|
//! | `thrust-loss:<thruster>` | the thruster's `ThrustLin`, `ThrustQuad` × (1 − θ) (calibration) | θ, `fraction` lost |
//! | `buoyancy` | `NetWeight` + θ (`net-buoyancy`, H1) | θ, `N` (positive = heavier) |
//! | `drag` | every axis' `DragLin`, `DragQuad` × (1 + θ) (the damping `drag-form`, H6, scales per direction) | 1 + θ, `factor` |
//! | `snag` | `TetherN`, `TetherE` + θ (`tether`, H8: a horizontal pull at the tether's exit) | ‖θ‖, `N` |
//! | `depth-sensor` | the sensor group's output equation (`depth-sensor-drift`, M1): the reading departs from the motion with no acceleration phase | offset, `m` |
//! | `compass` | the same on heading (`compass-deviation`, M2) | offset, `deg` |
//!
//! The physical causes are fitted by Gauss–Newton on the lab model itself (finite
//! differences through [`crate::sim::simulate_run`]), each alone, to the normalised
//! residual of the hops after the onset, their change time fitted too (the onset
//! estimate, or the latest onset the detection allows: a thrust loss flown from before
//! the vehicle lost it predicts a turn that its heading hold, with nothing to correct
//! yet, never had to stop, and a 2-parameter snag then explains that residual better
//! than the true loss); the sensor causes are a step of the reading
//! (a jump) or a reading that stops following the motion (stuck) from a time scanned
//! around the onset. The score is the share of the normalised residual energy the
//! fitted cause explains, 1 − RSS(θ̂)/RSS(0), in [0, 1], halved when the fitted size
//! ends at its search bound (not a plausible size, so not a finding); a compass cause's
//! score is scaled by the share of its fitted size that the gyro confirms (the compass
//! moving unlike the integrated gyro, [`super::steps::compass_minus_gyro_deg`]). A reading that repeats one
//! value exactly where it was noisy before (the detector's freeze test) is a sensor
//! fault: its sensor cause gets score 1.

use rov_types::measurement::MeasurementRow;
use serde::Serialize;

use crate::catalog::EffectId;
use crate::model::LabModel;
use crate::params::{Axis, Param, Thr};

use super::features::{
    Chunk, Hop, Trajectory, chunk, chunk_between, diff, residual_features, sub_means, trajectory,
};
use super::noise::ChannelNoise;
use super::{CHANNELS, SUB, WatchConfig};

/// Score factor of a cause whose fitted size ends at its search bound.
const BOUND_PENALTY: f64 = 0.5;

/// One ranked cause (the pinned JSON shape).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CauseScore {
    /// Cause id: `thrust-loss:<thruster>`, `buoyancy`, `drag`, `snag`, `depth-sensor`,
    /// `compass`.
    pub cause: String,
    /// Estimated size in `unit`.
    pub size: f64,
    /// `fraction`, `N`, `factor`, `m` or `deg`.
    pub unit: String,
    /// Share of the residual the cause explains, 0..1.
    pub score: f64,
    /// Words for the pilot, e.g. "PORT THRUST −40 %" (not part of the pinned JSON).
    #[serde(skip)]
    pub words: String,
    /// For a sensor cause: when the reading went wrong (s), if it was fitted.
    #[serde(skip)]
    pub from_s: Option<f64>,
    /// The cause and its fitted parameters (what the watch adopts after a change).
    #[serde(skip)]
    pub fitted: Option<(Cause, Vec<f64>)>,
}

impl CauseScore {
    /// Folds a follow-on fit of the same physical cause (measured against the model that
    /// already adopted this one) into this one: weights and pulls add, drag factors and
    /// remaining thrust multiply.
    pub(crate) fn fold(&mut self, next: &CauseScore) {
        let (Some((cause, a)), Some((_, b))) = (self.fitted.as_ref(), next.fitted.as_ref()) else {
            return;
        };
        let cause = *cause;
        let at = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(0.0);
        let theta: Vec<f64> = match cause {
            Cause::ThrustLoss(_) => vec![1.0 - (1.0 - at(a, 0)) * (1.0 - at(b, 0))],
            Cause::Drag => vec![(1.0 + at(a, 0)) * (1.0 + at(b, 0)) - 1.0],
            Cause::Snag => vec![at(a, 0) + at(b, 0), at(a, 1) + at(b, 1)],
            _ => vec![at(a, 0) + at(b, 0)],
        };
        let size = match cause {
            Cause::Snag => at(&theta, 0).hypot(at(&theta, 1)),
            Cause::Drag => 1.0 + at(&theta, 0),
            _ => at(&theta, 0),
        };
        self.size = round_sig(size);
        self.words = cause.words(size, &theta);
        self.score = self.score.max(next.score);
        self.fitted = Some((cause, theta));
    }

    /// A sensor cause measured as a step of the reading at `from_s`.
    pub(crate) fn set_step(&mut self, size: f64, from_s: f64) {
        let cause = if self.cause == "depth-sensor" {
            Cause::DepthSensor
        } else {
            Cause::Compass
        };
        self.size = round_sig(size);
        self.words = cause.words(size, &[size]);
        self.from_s = Some(from_s);
        self.fitted = Some((cause, vec![size]));
    }

    /// Whether this is a physical cause (a change of the vehicle, not of a sensor).
    pub fn is_physical(&self) -> bool {
        self.fitted
            .as_ref()
            .is_some_and(|(c, _)| !matches!(c, Cause::DepthSensor | Cause::Compass))
    }
}

/// A cause the watch knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// A thruster gives less thrust.
    ThrustLoss(Thr),
    /// The vehicle is heavier (or lighter).
    Buoyancy,
    /// Hydrodynamic drag is scaled.
    Drag,
    /// A horizontal pull at the tether's exit.
    Snag,
    /// The depth reading is wrong.
    DepthSensor,
    /// The heading reading is wrong.
    Compass,
}

impl Cause {
    /// The catalog effect whose signature the cause uses (`None`: the calibration's
    /// thrust coefficients).
    pub fn effect(self) -> Option<EffectId> {
        match self {
            Cause::ThrustLoss(_) => None,
            Cause::Buoyancy => Some(EffectId::NetBuoyancy),
            Cause::Drag => Some(EffectId::DragForm),
            Cause::Snag => Some(EffectId::Tether),
            Cause::DepthSensor => Some(EffectId::DepthSensorDrift),
            Cause::Compass => Some(EffectId::CompassDeviation),
        }
    }

    /// The pinned id.
    pub fn id(self) -> String {
        match self {
            Cause::ThrustLoss(t) => format!("thrust-loss:{}", t.name()),
            Cause::Buoyancy => "buoyancy".into(),
            Cause::Drag => "drag".into(),
            Cause::Snag => "snag".into(),
            Cause::DepthSensor => "depth-sensor".into(),
            Cause::Compass => "compass".into(),
        }
    }

    /// The size's unit.
    pub fn unit(self) -> &'static str {
        match self {
            Cause::ThrustLoss(_) => "fraction",
            Cause::Buoyancy | Cause::Snag => "N",
            Cause::Drag => "factor",
            Cause::DepthSensor => "m",
            Cause::Compass => "deg",
        }
    }

    /// The causes that apply to a model (a thrust loss per thruster group it has).
    pub fn all_for(model: &LabModel) -> Vec<Cause> {
        let mut out: Vec<Cause> = Thr::ALL
            .iter()
            .copied()
            .filter(|g| model.has_group(*g))
            .map(Cause::ThrustLoss)
            .collect();
        out.extend([
            Cause::Buoyancy,
            Cause::Drag,
            Cause::Snag,
            Cause::DepthSensor,
            Cause::Compass,
        ]);
        out
    }

    /// Number of parameters of a physical cause (0 for a sensor cause).
    fn n_params(self) -> usize {
        match self {
            Cause::Snag => 2,
            Cause::DepthSensor | Cause::Compass => 0,
            _ => 1,
        }
    }

    /// Finite-difference step and bounds of θ.
    fn step_bounds(self) -> (f64, f64, f64) {
        match self {
            Cause::ThrustLoss(_) => (0.05, 0.0, 0.99),
            Cause::Buoyancy => (0.5, -60.0, 60.0),
            // Drag ×0.2..×5: fouling, a snagged line or a lost panel; more is no longer
            // "drag" but something the vehicle is attached to.
            Cause::Drag => (0.1, -0.8, 4.0),
            Cause::Snag => (1.0, -300.0, 300.0),
            Cause::DepthSensor | Cause::Compass => (1.0, f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    /// The model changed by θ along the cause's parameters.
    pub fn apply(self, base: &LabModel, theta: &[f64]) -> Option<LabModel> {
        let t0 = theta.first().copied().unwrap_or(0.0);
        let mut params = Vec::new();
        let mut values = Vec::new();
        let mut scale = |p: Param, f: f64| {
            if let Some(v) = base.get(p) {
                params.push(p);
                values.push(v * f);
            }
        };
        match self {
            Cause::ThrustLoss(g) => {
                scale(Param::ThrustLin(g), 1.0 - t0);
                scale(Param::ThrustQuad(g), 1.0 - t0);
            }
            Cause::Drag => {
                for a in Axis::ALL {
                    scale(Param::DragLin(a), 1.0 + t0);
                    scale(Param::DragQuad(a), 1.0 + t0);
                }
            }
            Cause::Buoyancy => {
                let v = base.get(Param::NetWeight)?;
                params.push(Param::NetWeight);
                values.push(v + t0);
            }
            Cause::Snag => {
                let t1 = theta.get(1).copied().unwrap_or(0.0);
                for (p, d) in [(Param::TetherN, t0), (Param::TetherE, t1)] {
                    let v = base.get(p)?;
                    params.push(p);
                    values.push(v + d);
                }
            }
            Cause::DepthSensor | Cause::Compass => return Some(base.clone()),
        }
        if params.is_empty() {
            return None;
        }
        base.with(&params, &values).ok()
    }

    /// Words for the pilot.
    fn words(self, size: f64, theta: &[f64]) -> String {
        match self {
            Cause::ThrustLoss(g) => format!(
                "{} THRUST −{:.0} %",
                g.name().to_uppercase(),
                (size * 100.0).round()
            ),
            Cause::Buoyancy => {
                if size >= 0.0 {
                    format!("HEAVIER BY {size:.1} N")
                } else {
                    format!("LIGHTER BY {:.1} N", -size)
                }
            }
            Cause::Drag => format!("DRAG ×{size:.1}"),
            Cause::Snag => {
                let (n, e) = (
                    theta.first().copied().unwrap_or(0.0),
                    theta.get(1).copied().unwrap_or(0.0),
                );
                let bearing = rov_types::angle::wrap_deg_360(e.atan2(n).to_degrees());
                // A pull under 10 N to a tenth (a 0.3 N pull is not "0 N").
                let digits = if size < 10.0 { 1 } else { 0 };
                format!("SNAG {size:.digits$} N TOWARDS {bearing:03.0}°")
            }
            Cause::DepthSensor => format!("DEPTH SENSOR OFF {size:+.2} m"),
            Cause::Compass => format!("COMPASS OFF {size:+.0}°"),
        }
    }
}

/// One hop prepared for fitting: its chunk, the nominal trajectory and residual, the
/// weights (1/σ) per channel and sub-window.
struct Prepared {
    chunk: Chunk,
    traj: Trajectory,
    f: [[f64; SUB]; 4],
    mu: [[f64; SUB]; 4],
    w: [[f64; SUB]; 4],
}

impl Prepared {
    /// Weighted residual vector of features `f` (0 where absent).
    fn residual(&self, f: &[[f64; SUB]; 4]) -> Vec<f64> {
        let mut out = Vec::with_capacity(4 * SUB);
        for i in 0..4 {
            for j in 0..SUB {
                let r = (f[i][j] - self.mu[i][j]) * self.w[i][j];
                out.push(if r.is_finite() { r } else { 0.0 });
            }
        }
        out
    }
}

/// What the fit needs.
pub(crate) struct FitInput<'a> {
    pub model: &'a LabModel,
    pub rows: &'a [MeasurementRow],
    pub present: [bool; 8],
    pub cfg: &'a WatchConfig,
    pub hops: &'a [Hop],
    pub noise: &'a [Option<ChannelNoise>; 4],
    /// Subtract the baseline's offsets (a change) or not (a mismatch from the start).
    pub subtract_mu: bool,
    /// Onset estimate, s (a mismatch: the first hop's time).
    pub onset_s: f64,
    /// The latest time the change can have begun, s (the onset estimate when the
    /// detection says no more, or when too few windows start after it). The physical
    /// causes' change time is fitted between the two; `hops` start after both.
    pub latest_onset_s: f64,
    /// Channel whose reading froze, if that is what was detected.
    pub frozen: Option<usize>,
}

/// The chunk a change is fitted on: after the onset only, so the changed model never
/// flies the time before the change. Its unmeasured velocities at the onset come from the
/// nominal model's run over the full history (the vehicle was nominal until then). A
/// window too close to the onset for that keeps the full history.
fn post_onset_chunk(input: &FitInput<'_>, t_end_s: f64, start: f64) -> Option<Chunk> {
    let full = chunk(input.rows, input.present, t_end_s, input.cfg)?;
    let straddles = full.run.t.first().is_some_and(|t0| *t0 < start - 0.5);
    if !input.subtract_mu || !straddles || t_end_s - start < input.cfg.window_s + 0.5 {
        return Some(full);
    }
    let Some(mut short) = chunk_between(input.rows, input.present, start, t_end_s, input.cfg)
    else {
        return Some(full);
    };
    let k = full.run.t.iter().position(|t| *t >= start - 1e-9)?;
    let states = crate::sim::simulate_states(input.model, &full.run, &[]).ok()?;
    let nu = states.get(k)?.state.nu;
    short.run.nu0 = [nu[0], nu[1], nu[2], nu[3], nu[4], nu[5]];
    Some(short)
}

/// The hops prepared with the changed model flying from `start`.
fn prepare(input: &FitInput<'_>, start: f64) -> Vec<Prepared> {
    let mut out = Vec::new();
    for h in input.hops {
        let Some(c) = post_onset_chunk(input, h.t_s, start) else {
            continue;
        };
        let Some(traj) = trajectory(input.model, &c) else {
            continue;
        };
        let (f, a) = residual_features(&traj);
        let mut mu = [[0.0; SUB]; 4];
        let mut w = [[0.0; SUB]; 4];
        for i in 0..4 {
            if let Some(n) = &input.noise[i] {
                for j in 0..SUB {
                    if input.subtract_mu {
                        mu[i][j] = n.mu[j];
                    }
                    w[i][j] = 1.0 / n.sigma(a[i][j]).max(1e-12);
                }
            }
        }
        out.push(Prepared {
            chunk: c,
            traj,
            f,
            mu,
            w,
        });
    }
    out
}

/// Weighted residual of every prepared hop for a model (`None` if a simulation fails).
fn stacked(prep: &[Prepared], model: &LabModel) -> Option<Vec<f64>> {
    let mut out = Vec::new();
    for p in prep {
        let tr = trajectory(model, &p.chunk)?;
        let (f, _) = residual_features(&tr);
        out.extend(p.residual(&f));
    }
    Some(out)
}

fn ss(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Solves the (at most 2×2) normal equations JᵀJ Δ = −Jᵀr.
fn gn_step(jac: &[Vec<f64>], r: &[f64]) -> Option<Vec<f64>> {
    let p = jac.len();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    match p {
        1 => {
            let j = jac.first()?;
            let d = dot(j, j);
            (d > 1e-300).then(|| vec![-dot(j, r) / d])
        }
        2 => {
            let (a, b) = (jac.first()?, jac.get(1)?);
            let (aa, ab, bb) = (dot(a, a), dot(a, b), dot(b, b));
            let (ar, br) = (dot(a, r), dot(b, r));
            let det = aa * bb - ab * ab;
            if det.abs() <= 1e-300 * aa.max(bb).max(1.0) {
                return None;
            }
            Some(vec![-(bb * ar - ab * br) / det, -(aa * br - ab * ar) / det])
        }
        _ => None,
    }
}

/// Fits a physical cause by Gauss–Newton: (θ̂, RSS(θ̂)).
fn fit_physical(
    prep: &[Prepared],
    model: &LabModel,
    cause: Cause,
    r0: &[f64],
) -> Option<(Vec<f64>, f64)> {
    let p = cause.n_params();
    let (step, lo, hi) = cause.step_bounds();
    let mut theta = vec![0.0; p];
    let mut r = r0.to_vec();
    let mut rss = ss(&r);
    for _ in 0..4 {
        let mut jac = Vec::with_capacity(p);
        for k in 0..p {
            let mut th = theta.clone();
            // Step inwards at the upper bound.
            let s = if theta[k] + step > hi { -step } else { step };
            th[k] += s;
            let m = cause.apply(model, &th)?;
            let rk = stacked(prep, &m)?;
            jac.push(
                rk.iter()
                    .zip(&r)
                    .map(|(a, b)| (a - b) / s)
                    .collect::<Vec<f64>>(),
            );
        }
        let Some(delta) = gn_step(&jac, &r) else {
            break;
        };
        // Halve until the residual falls (at most 5 times).
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..5 {
            let cand: Vec<f64> = theta
                .iter()
                .zip(&delta)
                .map(|(t, d)| (t + scale * d).clamp(lo, hi))
                .collect();
            let m = cause.apply(model, &cand)?;
            let rc = stacked(prep, &m)?;
            let rss_c = ss(&rc);
            if rss_c < rss {
                theta = cand;
                r = rc;
                let gain = rss - rss_c;
                rss = rss_c;
                improved = gain > 1e-4 * rss.max(1e-12);
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            break;
        }
    }
    Some((theta, rss))
}

/// Fits a sensor cause on channel `i` (0 depth, 1 heading): the better of a jump and a
/// stuck reading from a time scanned around the onset: (size, RSS, from_s).
fn fit_sensor(
    prep: &[Prepared],
    i: usize,
    r0: &[f64],
    onset_s: f64,
    scan: bool,
) -> (f64, f64, Option<f64>) {
    let ch = CHANNELS[i];
    let rss0 = ss(r0);
    let mut best = (0.0, rss0, None);
    let candidates: Vec<f64> = if scan {
        (0..=60).map(|k| onset_s - 3.0 + 0.1 * k as f64).collect()
    } else {
        vec![f64::NEG_INFINITY]
    };
    for tf in candidates {
        for stuck in [false, true] {
            // The column: the residual the sensor fault adds, per unit size.
            let mut col = Vec::with_capacity(r0.len());
            let mut last_motion: f64 = 0.0;
            for p in prep {
                let tr = &p.traj;
                let (Some(t0), Some(_)) = (tr.t.first().copied(), tr.t.last()) else {
                    col.extend(std::iter::repeat_n(0.0, 4 * SUB));
                    continue;
                };
                let yhat = &tr.yhat[i];
                let anchor_t = tf.max(t0);
                let anchor =
                    tr.t.iter()
                        .position(|t| *t >= anchor_t - 1e-9)
                        .and_then(|k| yhat.get(k).copied())
                        .unwrap_or(f64::NAN);
                let means = sub_means(tr, |k| {
                    let t = tr.t.get(k).copied().unwrap_or(f64::NAN);
                    if t < tf || yhat.is_empty() {
                        return 0.0;
                    }
                    if stuck {
                        yhat.get(k).map_or(0.0, |y| -diff(ch, *y, anchor))
                    } else if tf > t0 {
                        1.0
                    } else {
                        0.0
                    }
                });
                if stuck && let Some(m) = means.last() {
                    last_motion = -m;
                }
                for ii in 0..4 {
                    for j in 0..SUB {
                        let v = if ii == i { means[j] * p.w[ii][j] } else { 0.0 };
                        col.push(if v.is_finite() { v } else { 0.0 });
                    }
                }
            }
            let Some(d) = gn_step(&[col.clone()], r0) else {
                continue;
            };
            let Some(beta) = d.first().map(|x| -x) else {
                continue;
            };
            // A stuck reading has β ≈ 1 (it stopped following the motion).
            let beta = if stuck { beta.clamp(0.0, 1.5) } else { beta };
            let rss: f64 = r0
                .iter()
                .zip(&col)
                .map(|(r, c)| (r - beta * c).powi(2))
                .sum();
            if rss < best.1 {
                let size = if stuck { -beta * last_motion } else { beta };
                best = (size, rss, tf.is_finite().then_some(tf));
            }
        }
    }
    best
}

/// Ranks every cause, best first.
pub(crate) fn rank(input: &FitInput<'_>) -> Vec<CauseScore> {
    let prep = prepare(input, input.onset_s);
    let residual0 = |prep: &[Prepared]| -> Vec<f64> {
        let mut r0 = Vec::new();
        for p in prep {
            r0.extend(p.residual(&p.f));
        }
        r0
    };
    let r0 = residual0(&prep);
    let rss0 = ss(&r0).max(1e-12);
    // The physical causes' change time, fitted: the onset estimate or the latest onset
    // the detection allows, on the same windows. A changed model flown from before the
    // vehicle changed predicts a response the vehicle never made: a thrust loss applied
    // while the commands were still the old ones turns the model where the vehicle, its
    // heading hold having had nothing to correct yet, did not.
    let late = (input.latest_onset_s > input.onset_s + 1e-6)
        .then(|| prepare(input, input.latest_onset_s))
        .filter(|p| !p.is_empty())
        .map(|p| {
            let r = residual0(&p);
            let rss = ss(&r).max(1e-12);
            (p, r, rss)
        });
    let mut out = Vec::new();
    for cause in Cause::all_for(input.model) {
        let (theta, score, from_s) = match cause {
            Cause::DepthSensor | Cause::Compass => {
                let i = if cause == Cause::DepthSensor { 0 } else { 1 };
                let (size, rss, from) = fit_sensor(&prep, i, &r0, input.onset_s, input.subtract_mu);
                (vec![size], 1.0 - rss / rss0, from)
            }
            _ => {
                let mut best: Option<(Vec<f64>, f64)> =
                    fit_physical(&prep, input.model, cause, &r0)
                        .map(|(t, rss)| (t, 1.0 - rss / rss0));
                if let Some((p, r, rss_l)) = &late
                    && let Some((t, rss)) = fit_physical(p, input.model, cause, r)
                    && best.as_ref().is_none_or(|b| 1.0 - rss / rss_l > b.1)
                {
                    best = Some((t, 1.0 - rss / rss_l));
                }
                match best {
                    Some((t, score)) => (t, score, None),
                    None => continue,
                }
            }
        };
        let mut score = score.clamp(0.0, 1.0);
        // A fit that ends at its search bound did not find the cause's size within
        // what is physically plausible: it explains the residual only by being pushed
        // as far as allowed, so it is not presented as a finding of that size.
        let at_bound = cause.n_params() > 0 && {
            let (_, lo, hi) = cause.step_bounds();
            let span = (hi - lo).abs();
            theta
                .iter()
                .any(|t| (t - lo).abs() < 0.01 * span || (hi - t).abs() < 0.01 * span)
        };
        if at_bound {
            score *= BOUND_PENALTY;
        }
        // A compass fault is a compass that disagrees with the gyro: a fitted compass
        // error the gyro does not show (the compass moved as the gyro says, so the
        // vehicle really turned, or really did not) is another cause's residual. The
        // score keeps only the share of the fitted size the gyro confirms.
        if cause == Cause::Compass
            && let Some(size) = theta.first().copied().filter(|s| s.abs() > 1e-9)
            && let Some(d) =
                super::steps::compass_minus_gyro_deg(input.rows, from_s.unwrap_or(input.onset_s))
        {
            score *= (d / size).clamp(0.0, 1.0);
        }
        let frozen_here = match cause {
            Cause::DepthSensor => input.frozen == Some(0),
            Cause::Compass => input.frozen == Some(1),
            _ => false,
        };
        if frozen_here {
            score = 1.0;
        }
        let size = match cause {
            Cause::Snag => {
                let n = theta.first().copied().unwrap_or(0.0);
                let e = theta.get(1).copied().unwrap_or(0.0);
                n.hypot(e)
            }
            Cause::Drag => 1.0 + theta.first().copied().unwrap_or(0.0),
            _ => theta.first().copied().unwrap_or(0.0),
        };
        out.push(CauseScore {
            cause: cause.id(),
            size: round_sig(size),
            unit: cause.unit().to_string(),
            score: (score * 1000.0).round() / 1000.0,
            words: cause.words(size, &theta),
            from_s,
            fitted: Some((cause, theta)),
        });
    }
    out.sort_by(|a, b| {
        b.score
            .total_cmp(&a.score)
            .then_with(|| a.cause.cmp(&b.cause))
    });
    out
}

/// Rounds to 4 significant digits (sizes are estimates).
fn round_sig(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return if x.is_finite() { x } else { 0.0 };
    }
    let mag = 10f64.powi(3 - x.abs().log10().floor() as i32);
    (x * mag).round() / mag
}
