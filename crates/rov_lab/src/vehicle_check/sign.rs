//! The sign and response check: for each command channel of a vehicle file, which degree
//! of freedom moves in a log when the channel is commanded, with which sign and lag,
//! against what the file's mixing says. It catches the commonest bring-up error (a
//! flipped thruster, a swapped pair of channels, an axis sign) before any calibration.
//!
//! # Method
//!
//! * Each degree of freedom's rate from the log: the measured velocity (`surge_mps`,
//!   `sway_mps`, `heave_mps`, roll/pitch/yaw rates) where the log has it, else the time
//!   derivative of the smoothed depth, roll, pitch or (unwrapped) heading (the body rates
//!   of a near-level vehicle). Surge and sway without a velocity measurement are not
//!   observed.
//! * For each channel c, degree of freedom i and lag ℓ in 0..[`MAX_LAG_S`] (steps of
//!   [`LAG_STEP_S`]): the **partial correlation** of u_c(t) with rate_i(t + ℓ) given every
//!   other excited channel at the same time (from the inverse of the covariance matrix of
//!   the excited channels and the rate, pooled over the runs without crossing a run's
//!   ends), so channels commanded together do not take each other's response. Where the
//!   channels are collinear (always commanded together) it falls back to the plain
//!   correlation and says so.
//! * A channel is **excited** when the log holds it with a standard deviation of at least
//!   [`MIN_EXCITATION_PCT`]; otherwise `agree` is null.
//! * The observed degree of freedom is the one with the largest |ρ| over lags (its sign
//!   and lag reported). `agree` is null when no |ρ| reaches [`MIN_RESPONSE`]; otherwise it
//!   is true when the file says the channel moves the observed degree of freedom (share ≥
//!   [`super::SHARE_NEGLIGIBLE`]) and every strongly responding degree of freedom (|ρ| ≥
//!   [`STRONG_FRACTION`] of the largest and ≥ [`STRONG_MIN`]) that the file says the
//!   channel moves responds with the file's sign.
//!
//! Closed-loop data (an autopilot or a stabilised mode) correlates commands with the
//! outputs they react to; lags are ≥ 0 (response after command), but such data can still
//! mislead: the data notes say when the lab recognised closed-loop commands.

use rov_dynamics::models::Channel;
use rov_dynamics::models::vehicle::{CommandChannel, VehicleDef};
use serde::Serialize;

use super::{DOF_NAMES, SHARE_NEGLIGIBLE, VehicleReport};
use crate::data::Run;

/// Longest lag searched, s.
pub const MAX_LAG_S: f64 = 2.0;
/// Lag step, s.
pub const LAG_STEP_S: f64 = 0.05;
/// Smallest standard deviation of a command that counts as excited, %.
pub const MIN_EXCITATION_PCT: f64 = 2.0;
/// Smallest |ρ| that counts as a response.
pub const MIN_RESPONSE: f64 = 0.1;
/// A degree of freedom responds strongly at this fraction of the largest |ρ|...
pub const STRONG_FRACTION: f64 = 0.6;
/// ... and at least this |ρ|.
pub const STRONG_MIN: f64 = 0.2;

/// One degree of freedom's response to a channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DofResponse {
    /// Degree of freedom.
    pub dof: String,
    /// What the rate was taken from.
    pub signal: String,
    /// Partial correlation at the lag of largest |ρ|.
    pub correlation: f64,
    /// That lag, s.
    pub lag_s: f64,
    /// The file's τ at +100 % on this axis (N or N m).
    pub expected_tau: f64,
}

/// The check of one command channel (the pinned keys first).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelCheck {
    /// Command channel.
    pub channel: String,
    /// The degree of freedom the file says it moves most.
    pub expected_dof: String,
    /// Its sign at +100 % (+1, −1).
    pub expected_sign: i8,
    /// The degree of freedom that responds most in the log (null: no response, channel
    /// absent or not excited).
    pub observed_dof: Option<String>,
    /// Its sign.
    pub observed_sign: Option<i8>,
    /// The partial correlation there.
    pub correlation: Option<f64>,
    /// Its lag, s.
    pub lag_s: Option<f64>,
    /// Whether the file and the log agree (null where the log does not excite the channel
    /// or nothing responds).
    pub agree: Option<bool>,
    /// Why, in words.
    pub note: String,
    /// Every observed degree of freedom.
    pub responses: Vec<DofResponse>,
}

/// The rate of each degree of freedom in a run, with its source.
fn rates(run: &Run) -> [Option<(Vec<f64>, &'static str)>; 6] {
    let deriv = |ch: Channel| -> Option<Vec<f64>> {
        let i = Channel::ALL.iter().position(|c| *c == ch)?;
        let y = run.smooth.get(i)?.as_deref().or(run.channel(ch))?;
        let n = y.len().min(run.t.len());
        Some(
            (0..n)
                .map(|k| {
                    let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
                    let dt = run.t[b] - run.t[a];
                    if dt > 0.0 {
                        (y[b] - y[a]) / dt
                    } else {
                        f64::NAN
                    }
                })
                .collect(),
        )
    };
    let meas = |ch: Channel| run.channel(ch).map(<[f64]>::to_vec);
    [
        meas(Channel::Surge).map(|v| (v, "surge_mps")),
        meas(Channel::Sway).map(|v| (v, "sway_mps")),
        meas(Channel::Heave)
            .map(|v| (v, "heave_mps"))
            .or_else(|| deriv(Channel::Depth).map(|v| (v, "d(depth_m)/dt"))),
        meas(Channel::RollRate)
            .map(|v| (v, "roll_rate_dps"))
            .or_else(|| deriv(Channel::Roll).map(|v| (v, "d(roll_deg)/dt"))),
        meas(Channel::PitchRate)
            .map(|v| (v, "pitch_rate_dps"))
            .or_else(|| deriv(Channel::Pitch).map(|v| (v, "d(pitch_deg)/dt"))),
        meas(Channel::YawRate)
            .map(|v| (v, "yaw_rate_dps"))
            .or_else(|| deriv(Channel::Heading).map(|v| (v, "d(heading_deg)/dt"))),
    ]
}

/// Pooled first and second moments of (u_1..u_m, y).
#[derive(Clone)]
struct Moments {
    n: f64,
    s: Vec<f64>,
    ss: Vec<f64>,
}

impl Moments {
    fn new(d: usize) -> Self {
        Self {
            n: 0.0,
            s: vec![0.0; d],
            ss: vec![0.0; d * d],
        }
    }

    fn add(&mut self, x: &[f64]) {
        let d = self.s.len();
        self.n += 1.0;
        for i in 0..d {
            self.s[i] += x[i];
            for j in i..d {
                self.ss[i * d + j] += x[i] * x[j];
            }
        }
    }

    fn cov(&self) -> nalgebra::DMatrix<f64> {
        let d = self.s.len();
        let n = self.n.max(1.0);
        nalgebra::DMatrix::from_fn(d, d, |i, j| {
            let (a, b) = if i <= j { (i, j) } else { (j, i) };
            (self.ss[a * d + b] - self.s[a] * self.s[b] / n) / n
        })
    }
}

/// (ρ per regressor, whether the plain correlation was used) from moments whose last
/// variable is the response.
fn partial_correlations(m: &Moments) -> (Vec<f64>, bool) {
    let c = m.cov();
    let d = c.nrows();
    let y = d - 1;
    if c[(y, y)] <= 1e-18 || m.n < 10.0 {
        return (vec![0.0; y], false);
    }
    if let Some(p) = c.clone().try_inverse()
        && (0..d).all(|i| p[(i, i)] > 0.0 && p[(i, i)].is_finite())
    {
        let r = (0..y)
            .map(|i| -p[(i, y)] / (p[(i, i)] * p[(y, y)]).sqrt())
            .collect();
        return (r, false);
    }
    let r = (0..y)
        .map(|i| {
            let v = c[(i, i)] * c[(y, y)];
            if v > 0.0 { c[(i, y)] / v.sqrt() } else { 0.0 }
        })
        .collect();
    (r, true)
}

fn std_of(v: impl Iterator<Item = f64>) -> f64 {
    let (mut n, mut s, mut ss) = (0.0, 0.0, 0.0);
    for x in v.filter(|x| x.is_finite()) {
        n += 1.0;
        s += x;
        ss += x * x;
    }
    if n < 2.0 {
        return 0.0;
    }
    (ss / n - (s / n).powi(2)).max(0.0).sqrt()
}

/// The sign and response check of a vehicle file (`report` from
/// [`super::check_vehicle`] of the same `def`) on logged runs.
pub fn sign_check(def: &VehicleDef, report: &VehicleReport, runs: &[Run]) -> Vec<ChannelCheck> {
    let runs = crate::data::aligned(runs, &def.channel_table);
    let chans: Vec<CommandChannel> = def.channels();
    // Excitation per channel over every run.
    let excited: Vec<bool> = chans
        .iter()
        .map(|c| {
            let i = c.index();
            let present = runs
                .iter()
                .any(|r| r.input_present.get(i).copied().unwrap_or(false));
            present
                && std_of(
                    runs.iter()
                        .filter(|r| r.input_present.get(i).copied().unwrap_or(false))
                        .flat_map(|r| {
                            r.inputs
                                .iter()
                                .map(move |u| u.get(i).copied().unwrap_or(0.0))
                        }),
                ) >= MIN_EXCITATION_PCT
        })
        .collect();
    let regressors: Vec<usize> = chans
        .iter()
        .zip(&excited)
        .filter(|(_, e)| **e)
        .map(|(c, _)| c.index())
        .collect();
    let n_lags = (MAX_LAG_S / LAG_STEP_S).round() as usize + 1;
    let d = regressors.len() + 1;
    // moments[dof][lag]
    let mut moments = vec![vec![Moments::new(d); n_lags]; 6];
    let mut signal: [Option<&'static str>; 6] = [None; 6];
    for run in runs.iter() {
        let rt = rates(run);
        let n = run.len();
        if n < 3 {
            continue;
        }
        let mut dts: Vec<f64> = run.t.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        let dt = dts.get(dts.len() / 2).copied().unwrap_or(0.1).max(1e-3);
        let mut x = vec![0.0; d];
        for (dof, r) in rt.iter().enumerate() {
            let Some((y, src)) = r else { continue };
            signal[dof] = Some(src);
            for (j, m) in moments[dof].iter_mut().enumerate() {
                let shift = ((j as f64 * LAG_STEP_S) / dt).round() as usize;
                for k in 0..n.saturating_sub(shift) {
                    let Some(yv) = y.get(k + shift).copied().filter(|v| v.is_finite()) else {
                        continue;
                    };
                    let Some(u) = run.inputs.get(k) else { continue };
                    let mut ok = true;
                    for (xi, ci) in x.iter_mut().zip(&regressors) {
                        let v = u.get(*ci).copied().unwrap_or(0.0);
                        ok &= v.is_finite();
                        *xi = v;
                    }
                    if !ok {
                        continue;
                    }
                    x[d - 1] = yv;
                    m.add(&x);
                }
            }
        }
    }
    // best[dof][regressor] = (ρ, lag index); whether any fallback.
    let mut best = vec![vec![(0.0f64, 0usize); regressors.len()]; 6];
    let mut collinear = false;
    for dof in 0..6 {
        if signal[dof].is_none() {
            continue;
        }
        for (j, m) in moments[dof].iter().enumerate() {
            let (r, fb) = partial_correlations(m);
            collinear |= fb;
            for (b, rho) in best[dof].iter_mut().zip(r) {
                if rho.abs() > b.0.abs() {
                    *b = (rho, j);
                }
            }
        }
    }
    let mut out = Vec::new();
    for (ci, c) in chans.iter().enumerate() {
        let Some(row) = report.mixing.get(ci) else {
            continue;
        };
        let name = row.channel.clone();
        let mut check = ChannelCheck {
            channel: name,
            expected_dof: row.expected_dof.clone(),
            expected_sign: row.expected_sign,
            observed_dof: None,
            observed_sign: None,
            correlation: None,
            lag_s: None,
            agree: None,
            note: String::new(),
            responses: Vec::new(),
        };
        let present = runs
            .iter()
            .any(|r| r.input_present.get(c.index()).copied().unwrap_or(false));
        if !present {
            check.note = "the log does not hold this channel".into();
            out.push(check);
            continue;
        }
        let Some(k) = regressors.iter().position(|i| *i == c.index()) else {
            check.note = format!(
                "not excited: the command's standard deviation is under {MIN_EXCITATION_PCT} %"
            );
            out.push(check);
            continue;
        };
        for dof in 0..6 {
            let Some(src) = signal[dof] else { continue };
            let (rho, j) = best[dof][k];
            check.responses.push(DofResponse {
                dof: DOF_NAMES[dof].to_string(),
                signal: src.to_string(),
                correlation: rho,
                lag_s: (j as f64 * LAG_STEP_S * 1000.0).round() / 1000.0,
                expected_tau: row.tau_plus_100[dof],
            });
        }
        let Some(top) = check
            .responses
            .iter()
            .max_by(|a, b| a.correlation.abs().total_cmp(&b.correlation.abs()))
            .cloned()
        else {
            check.note = "the log has no rate of any degree of freedom".into();
            out.push(check);
            continue;
        };
        if top.correlation.abs() < MIN_RESPONSE {
            check.note = format!(
                "no degree of freedom responds (largest |partial correlation| {:.2} < {MIN_RESPONSE})",
                top.correlation.abs()
            );
            out.push(check);
            continue;
        }
        let obs_i = DOF_NAMES.iter().position(|n| *n == top.dof).unwrap_or(0);
        check.observed_dof = Some(top.dof.clone());
        check.observed_sign = Some(if top.correlation < 0.0 { -1 } else { 1 });
        check.correlation = Some(top.correlation);
        check.lag_s = Some(top.lag_s);
        let strong = STRONG_MIN.max(STRONG_FRACTION * top.correlation.abs());
        let mut wrong = Vec::new();
        for r in &check.responses {
            let i = DOF_NAMES.iter().position(|n| *n == r.dof).unwrap_or(0);
            if r.correlation.abs() >= strong
                && row.share[i] >= SHARE_NEGLIGIBLE
                && (r.correlation > 0.0) != (row.tau_plus_100[i] > 0.0)
            {
                wrong.push(format!(
                    "{} ({} in the log, {} in the file)",
                    r.dof,
                    if r.correlation > 0.0 { "+" } else { "−" },
                    if row.tau_plus_100[i] > 0.0 {
                        "+"
                    } else {
                        "−"
                    }
                ));
            }
        }
        let moves_observed = row.share[obs_i] >= SHARE_NEGLIGIBLE;
        check.agree = Some(moves_observed && wrong.is_empty());
        check.note = if !moves_observed {
            format!(
                "the log's strongest response is {} but the file says this channel hardly moves it (share {:.2})",
                top.dof, row.share[obs_i]
            )
        } else if !wrong.is_empty() {
            format!("sign differs on {}", wrong.join(", "))
        } else {
            "the file's signs agree with the log".into()
        };
        if collinear {
            check
                .note
                .push_str("; some channels are collinear in the log (plain correlation used)");
        }
        out.push(check);
    }
    out
}
