//! The lab's simulator: a lab model driven by a measured run's commands, with the
//! measurement-CSV timing rule (output k at t_k before command k acts; command k held
//! until t_{k+1}), RK4 sub-steps of at most [`DT_MAX_S`], and re-initialisation from the
//! measurements at chosen samples.
//!
//! Error views:
//! * free run: one initialisation at the first sample;
//! * multiple shooting: re-initialised at manoeuvre-segment starts;
//! * k-step: re-initialised every k samples.
//!
//! Re-initialisation sets what the sensors see — depth, heading, pitch, roll (smoothed
//! by a local quadratic fit, through the inverse sensor model), and any measured rates,
//! body velocities and positions. Velocities that are not measured (heave, surge, …)
//! carry over from the model's own trajectory, which is the best estimate available
//! without a velocity sensor (a derivative across a command step would be biased).
//!
//! Thruster lag is updated exactly on the held command: a ← u + (a − u) e^{−h/τ}, with
//! the thrust over the sub-step taken at the lag state's mean u + (a − u)(τ/h)(1 − e^{−h/τ});
//! both tend to u as τ → 0, so the lag candidate can start from "off".

use rov_dynamics::Vector6;
use rov_dynamics::kinematics::{QuatPose, normalize_quat_state, quat_state, unpack_quat_state};
use rov_dynamics::models::vehicle::MAX_THRUSTERS;
use rov_dynamics::models::{Channel, ModelState};
use rov_dynamics::process::CurrentSample;

use crate::LabError;
use crate::data::{N_CHANNELS, Run, ch_index};
use crate::model::{LabModel, MAX_FILTERS, PerThruster};
use crate::terms::FILTER_TAUS_S;

/// Largest integration sub-step, s.
pub const DT_MAX_S: f64 = 0.05;

/// A prediction of a run: one value per sample for each channel that is both measured
/// and predicted. The samples are shared (a clone, e.g. of a remembered simulation, copies
/// no samples).
#[derive(Debug, Clone, Default)]
pub struct Prediction {
    /// Per channel (index as [`Channel::ALL`]).
    pub y: [Option<std::sync::Arc<Vec<f64>>>; N_CHANNELS],
}

impl Prediction {
    /// A channel's predicted samples.
    pub fn channel(&self, ch: Channel) -> Option<&[f64]> {
        self.y[ch_index(ch)].as_deref().map(Vec::as_slice)
    }
}

/// The channels of a run that a model predicts.
pub fn compared_channels(model: &LabModel, run: &Run) -> Vec<Channel> {
    Channel::ALL
        .iter()
        .copied()
        .filter(|c| run.has(*c) && model.predicts_channel(*c))
        .collect()
}

/// The thruster commands (%) acting just before sample k (those of sample 0 at k = 0).
pub(crate) fn prev_targets(model: &LabModel, run: &Run, k: usize) -> PerThruster {
    let j = k.saturating_sub(1);
    run.inputs
        .get(j)
        .map(|c| model.thruster_targets(c))
        .unwrap_or([0.0; MAX_THRUSTERS])
}

/// Re-initialises the measured part of the state at sample k.
fn reinit(model: &LabModel, run: &Run, k: usize, state: &mut ModelState) {
    // Smoothed measurement at k. With a compass effect the heading samples are first
    // mapped through the inverse sensor model (each with its own heading and command), so
    // that jumps of the reading (thruster interference) are not smoothed into the state.
    // The other sensor effects are offsets (a bias, a drift linear in time), which the
    // local polynomial smoother reproduces exactly, so the smoothed reading is inverted
    // directly (and keeps the run-start estimate of [`Run::smooth`]).
    let fx = model.effect_values();
    let compass = fx.compass_dev_deg != [0.0; 2] || fx.emi_deg.iter().any(|e| *e != 0.0);
    let t_rel = run.t[k] - run.t[0];
    let sm = |ch: Channel| -> Option<f64> {
        let i = ch_index(ch);
        if model.has_sensor_effects()
            && matches!(ch, Channel::Depth | Channel::Pitch | Channel::Roll)
        {
            let v = run.smooth[i]
                .as_ref()
                .map(|v| v[k])
                .filter(|x| x.is_finite())?;
            return Some(model.sensor_inverse(ch, v, t_rel, &prev_targets(model, run, k)));
        }
        if compass && ch == Channel::Heading {
            let y = run.y[i].as_ref()?;
            let start_win = crate::data::start_window(run.segments.first());
            if start_win > 0.0 && t_rel < crate::data::START_SPAN_S {
                // Run start: one line through the inverted readings of the first rest
                // (as `Run::smooth` does for the raw readings).
                let xs: Vec<f64> = (0..run.len())
                    .take_while(|j| run.t[*j] - run.t[0] <= start_win + 1e-9)
                    .map(|j| {
                        model.sensor_inverse(
                            ch,
                            y[j],
                            run.t[j] - run.t[0],
                            &prev_targets(model, run, j),
                        )
                    })
                    .collect();
                let ts = &run.t[..xs.len()];
                if let Some((a, b, _)) = crate::data::line_fit(ts, &xs, start_win) {
                    return Some(a + b * t_rel).filter(|x| x.is_finite());
                }
            }
            let lo = k.saturating_sub(12);
            let hi = (k + 13).min(run.len());
            let tt: Vec<f64> = run.t[lo..hi].to_vec();
            let xs: Vec<f64> = (lo..hi)
                .map(|j| {
                    model.sensor_inverse(
                        ch,
                        y[j],
                        run.t[j] - run.t[0],
                        &prev_targets(model, run, j),
                    )
                })
                .collect();
            let v = crate::data::local_quadratic(&tt, &xs, k - lo, 0.3, 0.3).map(|(a, _)| a);
            return v.filter(|x| x.is_finite());
        }
        run.smooth[i]
            .as_ref()
            .map(|v| v[k])
            .filter(|x| x.is_finite())
    };
    for ch in Channel::ALL {
        if let Some(v) = sm(ch) {
            ch.set_value(state, v);
        }
    }
    *state = model.restrict_state(*state);
}

/// Command signals and filter states held over one integration sub-step (the terms'
/// inputs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TermDrive<'a> {
    pub(crate) signals: &'a [f64],
    pub(crate) filt: &'a [f64],
}

#[inline]
fn rk4(
    model: &LabModel,
    x: &ModelState,
    tau: &Vector6,
    drive: &TermDrive<'_>,
    cur: &CurrentSample,
    h: f64,
) -> ModelState {
    let has_terms = !model.terms().is_empty();
    if model.uses_quaternion() {
        return rk4_quat(model, x, tau, drive, cur, h);
    }
    let f = |e: &Vector6, n: &Vector6| {
        if has_terms {
            let t = tau + model.terms_tau(&ModelState::new(*e, *n), drive.signals, drive.filt);
            model.eta_nu_derivative(e, n, &t, cur)
        } else {
            model.eta_nu_derivative(e, n, tau, cur)
        }
    };
    // The one RK4 (rov_dynamics::integrators) on the [η; ν] pair.
    let x0 = rov_dynamics::integrators::EtaNu {
        eta: x.eta,
        nu: x.nu,
    };
    let x1 = rov_dynamics::integrators::rk4_step(
        |_, s: &rov_dynamics::integrators::EtaNu| {
            let (eta, nu) = f(&s.eta, &s.nu);
            rov_dynamics::integrators::EtaNu { eta, nu }
        },
        0.0,
        &x0,
        h,
    );
    ModelState::new(x1.eta, x1.nu)
}

/// RK4 on the quaternion 13-state (6-DOF vehicle files: valid at any attitude); the
/// Euler angles come back on the branches nearest the previous ones.
fn rk4_quat(
    model: &LabModel,
    x: &ModelState,
    tau: &Vector6,
    drive: &TermDrive<'_>,
    cur: &CurrentSample,
    h: f64,
) -> ModelState {
    let hint = x.eta[5];
    let has_terms = !model.terms().is_empty();
    let q0 = quat_state(&QuatPose::from_eta(&x.eta), &x.nu);
    let f = |q: &rov_dynamics::kinematics::QuatState| {
        let t = if has_terms {
            let (pose, nu) = unpack_quat_state(q);
            let st = ModelState::new(pose.to_eta(hint), nu);
            tau + model.terms_tau(&st, drive.signals, drive.filt)
        } else {
            *tau
        };
        model
            .quat_derivative(q, &t, cur, hint)
            .unwrap_or_else(rov_dynamics::kinematics::QuatState::zeros)
    };
    let k1 = f(&q0);
    let k2 = f(&(q0 + k1 * (0.5 * h)));
    let k3 = f(&(q0 + k2 * (0.5 * h)));
    let k4 = f(&(q0 + k3 * h));
    let mut q = q0 + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    normalize_quat_state(&mut q);
    let (pose, nu) = unpack_quat_state(&q);
    let mut eta = pose.to_eta(hint);
    eta[3] = rov_dynamics::kinematics::unwrap_near(eta[3], x.eta[3]);
    ModelState::new(eta, nu)
}

static SIMULATIONS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Number of run simulations done by this process so far (for cost accounting).
pub fn simulation_count() -> usize {
    SIMULATIONS.load(std::sync::atomic::Ordering::Relaxed)
}

/// The model's state at one sample, with what drives it from there on.
#[derive(Debug, Clone, Copy)]
pub struct SampleState {
    /// The state (η, ν) at the sample (after any re-initialisation).
    pub state: ModelState,
    /// The lagged thruster commands at the sample, %.
    pub lagged: PerThruster,
    /// The filtered command signals of the terms at the sample (`filt[cmd * 2 + k]`).
    pub filt: [f64; 2 * crate::model::MAX_SIGNALS],
}

/// Simulates a run, re-initialising at the given sorted sample indices (0 is implied),
/// handing every sample's state to `on_sample` (the one loop behind [`simulate_run`]
/// and [`simulate_states`]).
fn simulate_core(
    model: &LabModel,
    run: &Run,
    resets: &[usize],
    mut on_sample: impl FnMut(usize, &SampleState),
) -> Result<(), LabError> {
    SIMULATIONS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let n = run.len();
    let mut state = ModelState::new(
        Vector6::zeros(),
        Vector6::new(
            run.nu0[0], run.nu0[1], run.nu0[2], run.nu0[3], run.nu0[4], run.nu0[5],
        ),
    );
    reinit(model, run, 0, &mut state);
    let n_thr = model.n_thrusters().min(MAX_THRUSTERS);
    let lag_taus = model.lag_taus();
    let c0 = run
        .inputs
        .first()
        .copied()
        .unwrap_or([0.0; rov_dynamics::models::vehicle::N_COMMANDS]);
    let mut lag = model.thruster_targets(&c0);
    let filters = model.filters();
    let sig0 = model.command_signals(&c0);
    let mut filt_state = [0.0; MAX_FILTERS];
    let mut filt = [0.0; 2 * crate::model::MAX_SIGNALS];
    for (fs, (ci, fk)) in filt_state.iter_mut().zip(filters) {
        *fs = sig0.get(*ci as usize).copied().unwrap_or(0.0);
        if let Some(slot) = filt.get_mut(*ci as usize * FILTER_TAUS_S.len() + *fk as usize) {
            *slot = *fs;
        }
    }
    let cur = CurrentSample::none();
    let mut decay_h = f64::NAN;
    let mut lag_decay = [(0.0, 0.0); MAX_THRUSTERS];
    let mut filt_decay = [0.0; MAX_FILTERS];
    let mut next_reset = resets.iter().copied().filter(|&r| r > 0).peekable();
    // The thrusters' τ of the last sub-step and the lagged commands it came from: τ is a
    // function of those commands alone (no lab base reads the state there, see
    // `LabModel::thrust_tau`), and without lag they stay the same while a command is held.
    let mut thrust_memo: Option<(PerThruster, Vector6)> = None;
    for k in 0..n {
        if next_reset.peek() == Some(&k) {
            next_reset.next();
            reinit(model, run, k, &mut state);
        }
        on_sample(
            k,
            &SampleState {
                state,
                lagged: lag,
                filt,
            },
        );
        if k + 1 == n {
            break;
        }
        let dt = run.t[k + 1] - run.t[k];
        let nsub = ((dt / DT_MAX_S) - 1e-9).ceil().max(1.0) as usize;
        let h = dt / nsub as f64;
        let u = run.inputs.get(k).unwrap_or(&c0);
        let target = model.thruster_targets(u);
        let signals = model.command_signals(u);
        // The decay factors depend on the sub-step only; at a steady sample rate they are
        // the same every step, so they are computed again only when h changes (the same
        // expressions on the same h: the numbers do not change).
        if h.to_bits() != decay_h.to_bits() {
            decay_h = h;
            for i in 0..n_thr {
                let tau = lag_taus[i];
                if tau > 0.0 {
                    let e = (-h / tau).exp();
                    lag_decay[i] = (e, tau / h * (1.0 - e));
                }
            }
            for (j, (_, fk)) in filters.iter().enumerate() {
                let tau = FILTER_TAUS_S.get(*fk as usize).copied().unwrap_or(1.0);
                if let Some(slot) = filt_decay.get_mut(j) {
                    *slot = (-h / tau).exp();
                }
            }
        }
        for _ in 0..nsub {
            let mut eff = target;
            for i in 0..n_thr {
                let tau = lag_taus[i];
                if tau > 0.0 {
                    let (e, mean_w) = lag_decay[i];
                    eff[i] = target[i] + (lag[i] - target[i]) * mean_w;
                    lag[i] = target[i] + (lag[i] - target[i]) * e;
                } else {
                    lag[i] = target[i];
                }
            }
            // Filtered command signals of the terms: the mean over the sub-step, exact
            // update on the held command (as the lag).
            for (j, (ci, fk)) in filters.iter().enumerate() {
                let tau = FILTER_TAUS_S.get(*fk as usize).copied().unwrap_or(1.0);
                let target = signals.get(*ci as usize).copied().unwrap_or(0.0);
                let e = filt_decay
                    .get(j)
                    .copied()
                    .unwrap_or_else(|| (-h / tau).exp());
                let mean = target + (filt_state[j] - target) * tau / h * (1.0 - e);
                filt_state[j] = target + (filt_state[j] - target) * e;
                if let Some(slot) = filt.get_mut(*ci as usize * FILTER_TAUS_S.len() + *fk as usize)
                {
                    *slot = mean;
                }
            }
            let tau = match &thrust_memo {
                Some((e, tau)) if same_bits(e, &eff) => *tau,
                _ => {
                    let tau = model.thrust_tau(&model.thrusts(&eff), &state);
                    thrust_memo = Some((eff, tau));
                    tau
                }
            };
            let drive = TermDrive {
                signals: &signals,
                filt: &filt,
            };
            state = rk4(model, &state, &tau, &drive, &cur, h);
        }
        for (j, (ci, fk)) in filters.iter().enumerate() {
            if let Some(slot) = filt.get_mut(*ci as usize * FILTER_TAUS_S.len() + *fk as usize) {
                *slot = filt_state[j];
            }
        }
        let finite = state
            .eta
            .iter()
            .chain(state.nu.iter())
            .all(|x| x.is_finite())
            && state.nu.iter().all(|x| x.abs() < 1e3);
        if !finite {
            return Err(LabError::Model {
                detail: format!(
                    "{} diverged on run {} at t = {:.2} s",
                    model_name(model),
                    run.name,
                    run.t[k + 1]
                ),
            });
        }
    }
    Ok(())
}

/// Whether two command vectors are the same to the last bit.
#[inline]
fn same_bits(a: &PerThruster, b: &PerThruster) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The memo of one diagnosis's run simulations (see [`memo_scope`]).
struct Memo {
    /// Addresses of the runs the scope's caller borrows (alive while the scope is).
    runs: Vec<*const Run>,
    /// Remembered simulations, most recently used last.
    entries: std::collections::VecDeque<MemoEntry>,
}

/// One remembered simulation.
struct MemoEntry {
    /// The model in full (its `Debug` text).
    model: String,
    run: *const Run,
    resets: Vec<usize>,
    prediction: Prediction,
    /// Whether it was asked for again (the current model of a diagnosis is, many times;
    /// a finite-difference column never is).
    reused: bool,
}

/// Most simulations a [`Memo`] keeps (a training prediction is about 0.5 MB per channel
/// and 10 min at 20 Hz).
const MEMO_ENTRIES: usize = 16;

/// Most bytes of predictions a [`Memo`] keeps beyond its [`MEMO_MIN_ENTRIES`]: on a long
/// dive sixteen whole-run predictions would be hundreds of MB (a 1-hour, 50 Hz dive's
/// is 15 MB), memory that grows with the data.
const MEMO_BYTES: usize = 64 << 20;

/// Entries a [`Memo`] keeps whatever their size (the current model on the training and
/// the held-out runs, asked for again and again).
const MEMO_MIN_ENTRIES: usize = 4;

impl Prediction {
    /// Bytes of its samples.
    fn bytes(&self) -> usize {
        self.y
            .iter()
            .flatten()
            .map(|v| v.len() * std::mem::size_of::<f64>())
            .sum()
    }
}

thread_local! {
    static MEMO: std::cell::RefCell<Option<Memo>> = const { std::cell::RefCell::new(None) };
}

/// While alive, [`simulate_run`] on this thread remembers its last simulations of the
/// given runs and returns a remembered prediction instead of simulating the same model
/// (compared field by field, every parameter exactly) on the same run with the same
/// resets again. A diagnosis simulates its current model on its training runs many times
/// over (channel weights, screening, the term search's nulls, confirmations); the
/// prediction does not depend on the weights.
pub(crate) struct MemoScope<'a> {
    prev: Option<Memo>,
    _runs: std::marker::PhantomData<&'a Run>,
}

/// Starts a [`MemoScope`] over `runs` (nested scopes restore the outer one on drop).
pub(crate) fn memo_scope<'a>(runs: &[&'a [Run]]) -> MemoScope<'a> {
    let memo = Memo {
        runs: runs
            .iter()
            .flat_map(|rs| rs.iter().map(|r| r as *const Run))
            .collect(),
        entries: std::collections::VecDeque::new(),
    };
    let prev = MEMO.with(|m| m.borrow_mut().replace(memo));
    MemoScope {
        prev,
        _runs: std::marker::PhantomData,
    }
}

impl Drop for MemoScope<'_> {
    fn drop(&mut self) {
        let prev = self.prev.take();
        MEMO.with(|m| *m.borrow_mut() = prev);
    }
}

/// Simulates a run, re-initialising at the given sorted sample indices (0 is implied).
pub fn simulate_run(model: &LabModel, run: &Run, resets: &[usize]) -> Result<Prediction, LabError> {
    // Every simulation is a cancellation point (see `crate::progress`).
    crate::progress::checkpoint()?;
    if run.channels != *model.channel_table() {
        // A run whose free channels the model names otherwise: read them by name.
        let mut r = run.clone();
        r.align_channels(model.channel_table());
        return simulate_run(model, &r, resets);
    }
    let ptr = run as *const Run;
    let key = MEMO.with(|m| {
        let mut m = m.borrow_mut();
        let memo = m.as_mut().filter(|memo| memo.runs.contains(&ptr))?;
        // The model's every field (Debug prints each number exactly, in its shortest
        // round-trip form).
        let key = format!("{model:?}");
        let at = memo
            .entries
            .iter()
            .rposition(|e| e.run == ptr && e.resets.as_slice() == resets && e.model == key);
        // A hit moves to the back (most recently used).
        let hit = at.and_then(|i| memo.entries.remove(i)).map(|mut e| {
            e.reused = true;
            let p = e.prediction.clone();
            memo.entries.push_back(e);
            p
        });
        Some((key, hit))
    });
    match key {
        Some((_, Some(hit))) => Ok(hit),
        Some((key, None)) => {
            let p = simulate_uncached(model, run, resets)?;
            MEMO.with(|m| {
                if let Some(memo) = m.borrow_mut().as_mut() {
                    let over = |memo: &Memo| {
                        let bytes: usize = memo.entries.iter().map(|e| e.prediction.bytes()).sum();
                        memo.entries.len() >= MEMO_ENTRIES
                            || (memo.entries.len() >= MEMO_MIN_ENTRIES
                                && bytes + p.bytes() > MEMO_BYTES)
                    };
                    while !memo.entries.is_empty() && over(memo) {
                        // The least recently used of those never asked for again, else
                        // the least recently used.
                        let i = memo.entries.iter().position(|e| !e.reused).unwrap_or(0);
                        memo.entries.remove(i);
                    }
                    memo.entries.push_back(MemoEntry {
                        model: key,
                        run: ptr,
                        resets: resets.to_vec(),
                        prediction: p.clone(),
                        reused: false,
                    });
                }
            });
            Ok(p)
        }
        None => simulate_uncached(model, run, resets),
    }
}

fn simulate_uncached(
    model: &LabModel,
    run: &Run,
    resets: &[usize],
) -> Result<Prediction, LabError> {
    let chans = compared_channels(model, run);
    let n = run.len();
    let mut y: [Option<Vec<f64>>; N_CHANNELS] = Default::default();
    for ch in &chans {
        y[ch_index(*ch)] = Some(Vec::with_capacity(n));
    }
    let t0 = run.t.first().copied().unwrap_or(0.0);
    // The previous commands matter only to a sensor effect (thruster interference).
    let sensor_fx = model.has_sensor_effects();
    simulate_core(model, run, resets, |k, s| {
        let pc = if sensor_fx {
            prev_targets(model, run, k)
        } else {
            [0.0; MAX_THRUSTERS]
        };
        let t_rel = run.t[k] - t0;
        for ch in &chans {
            if let Some(v) = y[ch_index(*ch)].as_mut() {
                v.push(model.sensor_value(*ch, &s.state, t_rel, &pc));
            }
        }
    })?;
    Ok(Prediction {
        y: y.map(|v| v.map(std::sync::Arc::new)),
    })
}

/// Simulates a run like [`simulate_run`] and returns the state at every sample.
pub fn simulate_states(
    model: &LabModel,
    run: &Run,
    resets: &[usize],
) -> Result<Vec<SampleState>, LabError> {
    let mut out = Vec::with_capacity(run.len());
    simulate_core(model, run, resets, |_, s| out.push(*s))?;
    Ok(out)
}

fn model_name(model: &LabModel) -> String {
    use rov_dynamics::models::VehicleModel;
    model.name().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Param;
    use rov_types::measurement::{MeasurementRow, MeasurementSeries};

    fn step_run() -> Run {
        let rows = (0..200)
            .map(|k| MeasurementRow {
                time_s: k as f64 * 0.05,
                vertical_pct: if k >= 20 { 80.0 } else { 0.0 },
                depth_m: 2.0,
                heading_deg: 10.0,
                ..Default::default()
            })
            .collect();
        Run::from_series(
            &MeasurementSeries {
                rows,
                ..Default::default()
            },
            "step",
        )
        .unwrap()
    }

    fn memo_len() -> Option<(usize, usize)> {
        MEMO.with(|m| {
            m.borrow().as_ref().map(|memo| {
                (
                    memo.entries.len(),
                    memo.entries.iter().filter(|e| e.reused).count(),
                )
            })
        })
    }

    #[test]
    fn a_remembered_simulation_is_the_same_and_any_change_simulates_again() {
        let runs = vec![step_run()];
        let m = LabModel::default_base(crate::BaseKind::Model3).unwrap();
        let fresh = simulate_run(&m, &runs[0], &[0]).unwrap();
        {
            let _scope = memo_scope(&[&runs]);
            let a = simulate_run(&m, &runs[0], &[0]).unwrap();
            assert_eq!(memo_len(), Some((1, 0)));
            let b = simulate_run(&m, &runs[0], &[0]).unwrap();
            assert_eq!(
                memo_len(),
                Some((1, 1)),
                "the same model and resets: remembered"
            );
            for ch in Channel::ALL {
                assert_eq!(a.channel(ch), fresh.channel(ch));
                assert_eq!(b.channel(ch), fresh.channel(ch));
            }
            // Other resets, or a parameter changed in its last bit, simulate again.
            simulate_run(&m, &runs[0], &[0, 100]).unwrap();
            let v = m.get(Param::LagTau).unwrap_or(0.0);
            let m2 = m.with(&[Param::LagTau], &[v + 1e-12]).unwrap();
            let c = simulate_run(&m2, &runs[0], &[0]).unwrap();
            assert_eq!(memo_len(), Some((3, 1)));
            assert_ne!(c.channel(Channel::Depth), fresh.channel(Channel::Depth));
            // A run outside the scope's runs is never remembered.
            let other = step_run();
            simulate_run(&m, &other, &[0]).unwrap();
            assert_eq!(memo_len(), Some((3, 1)));
        }
        assert_eq!(memo_len(), None, "the scope ends with its owner");
    }

    #[test]
    fn thrust_tau_reads_no_state_on_any_base() {
        // The simulator reuses τ of the thrusters while the lagged commands stay the same.
        let text = std::fs::read_to_string(
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../config/vehicles/bluerov2_heavy.toml"),
        )
        .unwrap();
        let mut models: Vec<LabModel> = [
            crate::BaseKind::Model1,
            crate::BaseKind::Model2,
            crate::BaseKind::Model3,
        ]
        .into_iter()
        .map(|k| LabModel::default_base(k).unwrap())
        .collect();
        models.push(LabModel::from_vehicle_text(&text, "bluerov2_heavy.toml").unwrap());
        let a = ModelState::default();
        let b = ModelState::new(
            Vector6::new(3.0, -2.0, 5.0, 0.4, -0.3, 2.5),
            Vector6::new(0.5, -0.2, 0.3, 0.2, -0.1, 0.4),
        );
        for m in models {
            let mut pct = [0.0; MAX_THRUSTERS];
            for (i, p) in pct.iter_mut().enumerate() {
                *p = 40.0 - 13.0 * i as f64;
            }
            let f = m.thrusts(&pct);
            let (ta, tb) = (m.thrust_tau(&f, &a), m.thrust_tau(&f, &b));
            assert!(ta.iter().any(|x| *x != 0.0));
            for (x, y) in ta.iter().zip(tb.iter()) {
                assert_eq!(x.to_bits(), y.to_bits(), "{}", model_name(&m));
            }
        }
    }

    #[test]
    fn timing_rule_the_sample_at_a_step_precedes_its_command() {
        let run = step_run();
        let m = LabModel::default_base(crate::BaseKind::Model1).unwrap();
        let p = simulate_run(&m, &run, &[0]).unwrap();
        let z = p.channel(Channel::Depth).unwrap();
        // Command 20 acts from t_20 on: z_20 is still at rest, z_21 has moved.
        assert_eq!(z[20], z[0]);
        assert!(z[21] > z[20]);
    }

    #[test]
    fn lag_update_is_continuous_as_tau_goes_to_zero() {
        let run = step_run();
        let m = LabModel::default_base(crate::BaseKind::Model3).unwrap();
        let p0 = simulate_run(&m, &run, &[0]).unwrap();
        let tiny = m.with(&[Param::LagTau], &[1e-7]).unwrap();
        let p1 = simulate_run(&tiny, &run, &[0]).unwrap();
        let slow = m.with(&[Param::LagTau], &[0.5]).unwrap();
        let p2 = simulate_run(&slow, &run, &[0]).unwrap();
        let (a, b, c) = (
            p0.channel(Channel::Depth).unwrap(),
            p1.channel(Channel::Depth).unwrap(),
            p2.channel(Channel::Depth).unwrap(),
        );
        assert!((a[199] - b[199]).abs() < 1e-6, "{} {}", a[199], b[199]);
        assert!(c[60] < a[60], "a lag slows the descent");
    }

    #[test]
    fn sensor_effects_are_inverted_at_reinitialisation() {
        let run = step_run();
        let m = LabModel::default_base(crate::BaseKind::Model1)
            .unwrap()
            .with(
                &[Param::Emi(crate::params::Thr::Vertical), Param::DepthDrift],
                &[6.0, 0.002],
            )
            .unwrap();
        // The reading at rest (no thrust yet): heading 10° means ψ = 10°, depth 2 m at t = 0.
        let p = simulate_run(&m, &run, &[0]).unwrap();
        assert!((p.channel(Channel::Heading).unwrap()[0] - 10.0).abs() < 0.2);
        // Thrust on: the reading jumps by the interference of the previous command.
        let h = p.channel(Channel::Heading).unwrap();
        assert!(
            (h[22] - h[20] - 6.0 * 0.8).abs() < 0.2,
            "{} {}",
            h[20],
            h[22]
        );
    }
}
