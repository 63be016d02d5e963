//! Judging a confirmed candidate on the held-out runs (both error views, the veto rules,
//! plausibility), and the prediction-change similarity behind "ambiguous".

use std::collections::BTreeMap;

use rov_dynamics::models::Channel;

use crate::calibrate::{REWEIGHT_FACTOR, SHOOTING_WINDOW_S, View};
use crate::evaluate::{ChannelKey, Evaluation};
use crate::model::LabModel;
use crate::params::Param;

use super::*;

#[derive(Debug, Clone)]
pub(super) struct Judgement {
    pub(super) significant: bool,
    pub(super) channels: Vec<ChannelKey>,
    /// The view that shows the finding best (its home channels' larger reduction).
    pub(super) view: View,
    pub(super) primary: BTreeMap<String, f64>,
    pub(super) free: BTreeMap<String, f64>,
    pub(super) shoot: BTreeMap<String, f64>,
    pub(super) score: f64,
    pub(super) explained: BTreeMap<ChannelKey, f64>,
    pub(super) reason: String,
    /// Channels the candidate makes clearly worse in either view, in words.
    pub(super) conflicts: Vec<String>,
    /// For each of `conflicts` (same order): the channel, and whether it is excited,
    /// worse in the multiple-shooting view and not within rule (b)'s tolerance (what
    /// [`veto_on_inadequate_base`] weighs).
    pub(super) conflict_channels: Vec<(String, bool)>,
    /// What the base still misses with this finding granted ([`Inadequacy::left_by`]).
    pub(super) leaves: Option<Inadequacy>,
}

pub(super) fn reduction(base: f64, new: f64) -> f64 {
    if base > 0.0 { 1.0 - new / base } else { 0.0 }
}

/// RMS change of a channel's held-out prediction between two evaluations, in the
/// (shooting, free-run) views.
pub(super) fn prediction_change_rms(a: &Evaluation, b: &Evaluation, ch: Channel) -> (f64, f64) {
    let rms = |pa: &[crate::sim::Prediction], pb: &[crate::sim::Prediction]| {
        let (mut s, mut n) = (0.0, 0usize);
        for (x, y) in pa.iter().zip(pb) {
            if let (Some(x), Some(y)) = (x.channel(ch), y.channel(ch)) {
                for (p, q) in x.iter().zip(y) {
                    let d = crate::metrics::residual(ch, *p, *q);
                    if d.is_finite() {
                        s += d * d;
                        n += 1;
                    }
                }
            }
        }
        if n > 0 { (s / n as f64).sqrt() } else { 0.0 }
    };
    (rms(&a.shooting, &b.shooting), rms(&a.free_run, &b.free_run))
}

/// An effect parameter of a fitted candidate that sits at (within [`BOUND_MARGIN`] of the
/// range) a bound that is a plausibility limit, not a physical one: (key, value, bound),
/// display units.
pub(super) fn pinned_param(c: &Confirmed) -> Option<(String, f64, f64)> {
    pinned_in(&c.fit.model, &c.params)
}

/// [`pinned_param`] for a model and a parameter list.
pub(super) fn pinned_in(model: &LabModel, params: &[Param]) -> Option<(String, f64, f64)> {
    for p in params {
        let m = p.meta();
        let Some(v) = model.get(*p) else {
            continue;
        };
        let margin = BOUND_MARGIN * (m.hi - m.lo);
        for (bound, upper) in [(m.lo, false), (m.hi, true)] {
            if (v - bound).abs() <= margin && !p.bound_is_physical(upper) {
                return Some((p.key(), p.display(v).0, p.display(bound).0));
            }
        }
    }
    None
}

/// Judges a fitted candidate against the current model on the held-out runs. Every
/// candidate is judged the same way, on both error views (multiple shooting and free
/// run), whichever view it was fitted in:
///
/// * **explained channel**: its held-out RMSE falls by [`MIN_REDUCTION`] in *both* views
///   (a real effect improves the re-initialised windows and the free run alike; a gain in
///   one view only is that view's artefact: slow compensation accumulating in the free
///   run, re-initialisation in the windows); it was above [`NOISE_FACTOR`] noise floors in
///   at least one view; and switching the effect's own term off again (base refit kept)
///   brings the error back (the "base refit only" control, as the two views' mean). At
///   least one explained channel must be a home channel of the fitted parameters.
///   An effect the catalog judges in the free run alone (`EffectInfo::judged_in`: a
///   sensor drift, which every re-initialised window removes) needs the reduction, the
///   floor and the control in the free run only (open-loop data).
/// * **made worse**: a channel whose RMSE rises by more than [`MAX_WORSE`] above the
///   floor in *either* view on its own, with its held-out prediction moved in that view
///   by at least [`WORSE_NOISE_FRACTION`] of its noise floor (RMS; a smaller change is
///   within what the noise makes of any change), is a *conflict*: reported with the
///   finding in every case, and, when the finding is accepted, in the summary ("accepted
///   with a conflict"). It is a veto when the two-view mean RMSE rises by more than
///   [`MAX_WORSE`] with the prediction moved beyond noise (mean of the views) — unless
///   (b) the channel is *already badly fitted for reasons the effect does not touch*: not
///   one the effect claims, the base misses it by more than [`REWEIGHT_FACTOR`] noise
///   floors (a structural misfit: missing physics elsewhere), and the rise is at most
///   [`MAX_WORSE_UNEXPLAINED`] of that misfit — its error is dominated by what is still
///   missing and moves with any coupling; the greedy loop judges it again once that is
///   found; or (c) the loss is small against the gain, both in noise floors
///   ([`WORSE_FRACTION_OF_GAIN`]). A right effect refitted jointly with the base can
///   trade a little of another channel in one view (a thruster lag refit moving the
///   depth free run); a veto on every such trade would lose it, so the trade is said,
///   not hidden.
/// * **plausible parameters**: no effect parameter sits at a plausibility bound
///   ([`pinned_param`]): a fit pinned there stands in for something else (a depth drift
///   at its 60 cm/min limit absorbing a thrust asymmetry).
/// * training ΔBIC above [`MIN_DBIC`] and the effect's signature checks.
///
/// The ranking score is the same for every candidate: the noise-normalised held-out RMSE
/// gain summed over channels, both views counting half.
pub(super) fn judge(base: &Evaluation, c: &Confirmed, closed_loop: bool) -> Judgement {
    let mut free = BTreeMap::new();
    let mut shoot = BTreeMap::new();
    let mut channels = Vec::new();
    let mut score = 0.0;
    // (channel, how much worse in which views, the rules' view of it, excited and not
    // claimed).
    let mut worsened_channels: Vec<(String, String, Worsened, bool)> = Vec::new();
    let home = fitted_home_channels(c);
    let mut claimed = home.clone();
    for ch in c.subject.home() {
        if !claimed.contains(&ch) {
            claimed.push(ch);
        }
    }
    let mut home_hit = false;
    // Best home-channel reduction per view (for the reported view).
    let (mut best_shoot, mut best_free) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    // An effect the re-anchored windows cannot show (the catalog's `judged_in`) is judged
    // in the free run alone; closed-loop data has no free run, so both views stay the
    // shooting one there.
    let free_only = !closed_loop
        && matches!(c.subject, Subject::Effect(e)
            if e.info().judged_in == crate::catalog::JudgedIn::FreeRun);
    let judged: &[usize] = if free_only { &[1] } else { &[0, 1] };
    for (k, b) in &base.channels {
        let Some(n) = c.eval.channels.get(k) else {
            continue;
        };
        let ch = k.channel();
        let name = k.name().to_string();
        // Closed-loop data: the free run is not a test of the model (module docs of
        // `crate::ingest`), so both "views" are the multiple-shooting one.
        let fr = |s: f64, f: f64| if closed_loop { s } else { f };
        let bv = [b.shooting.rmse, fr(b.shooting.rmse, b.free_run.rmse)];
        let nv = [n.shooting.rmse, fr(n.shooting.rmse, n.free_run.rmse)];
        let red = [reduction(bv[0], nv[0]), reduction(bv[1], nv[1])];
        shoot.insert(name.clone(), 100.0 * red[0]);
        free.insert(name.clone(), 100.0 * red[1]);
        if claimed.contains(&ch) {
            best_shoot = best_shoot.max(red[0]);
            best_free = best_free.max(red[1]);
        }
        let floor = b.noise * NOISE_FACTOR;
        let above = judged.iter().any(|v| bv[*v] > floor);
        let control_ok = match &c.control {
            None => true,
            Some(ctrl) => ctrl.channels.get(k).is_some_and(|cc| {
                let cv = [cc.shooting.rmse, fr(cc.shooting.rmse, cc.free_run.rmse)];
                let back = [cv[0] - nv[0], cv[1] - nv[1]];
                let n_views = judged.len() as f64;
                let back_rel = judged
                    .iter()
                    .map(|v| if cv[*v] > 0.0 { back[*v] / cv[*v] } else { 0.0 })
                    .sum::<f64>()
                    / n_views;
                let back_sum: f64 = judged.iter().map(|v| back[*v]).sum();
                let gain_sum: f64 = judged.iter().map(|v| bv[*v] - nv[*v]).sum();
                back_sum >= CONTROL_FRACTION * gain_sum && back_rel >= MIN_REDUCTION
            }),
        };
        let reduced = judged.iter().all(|v| red[*v] >= MIN_REDUCTION);
        if above && reduced && control_ok {
            channels.push(*k);
            home_hit |= home.contains(&ch);
        }
        let sigma = b.noise.max(1e-12);
        let (ds, df) = prediction_change_rms(&c.eval, base, ch);
        if let Some(w) = worsened(
            bv,
            nv,
            [ds, fr(ds, df)],
            sigma,
            claimed.contains(&ch),
            closed_loop,
        ) {
            let views: Vec<String> = w
                .views
                .iter()
                .map(|(v, rise)| {
                    format!(
                        "{:.0} % worse in the {}",
                        rise * 100.0,
                        if *v == 0 {
                            "multiple-shooting view"
                        } else {
                            "free run"
                        }
                    )
                })
                .collect();
            // Claimed or not (a finding that makes one of its own home channels clearly
            // worse explains it no better than one that makes another channel worse), in
            // the multiple-shooting view: the verdict's view, where a rise is not the
            // free run's accumulation of a small trade.
            // Rule (b)'s tolerance (a channel the base already misses structurally, the
            // rise small against that misfit) stands: another missing effect's channel
            // moves with any refit (two simultaneous effects).
            let other_excited = channel_excited(b, closed_loop)
                && w.views.iter().any(|(v, _)| *v == 0)
                && !w.structural;
            worsened_channels.push((name.clone(), views.join(" and "), w, other_excited));
        }
        score += 0.5 * (((bv[0] - nv[0]) / sigma).max(0.0) + ((bv[1] - nv[1]) / sigma).max(0.0));
    }
    let view = if best_free > best_shoot {
        View::FreeRun
    } else {
        View::Shooting(SHOOTING_WINDOW_S)
    };
    let primary = match view {
        View::FreeRun => free.clone(),
        _ => shoot.clone(),
    };
    let mut explained = BTreeMap::new();
    for k in &channels {
        if let (Some(b), Some(n)) = (base.channels.get(k), c.eval.channels.get(k)) {
            let (bb, nn) = match view {
                View::FreeRun => (b.free_run.rmse, n.free_run.rmse),
                _ => (b.shooting.rmse, n.shooting.rmse),
            };
            explained.insert(*k, (1.0 - (nn / bb.max(1e-300)).powi(2)).max(0.0));
        }
    }
    // (c): a worsened channel whose loss is small against the gain does not block.
    let blocks = |w: &Worsened| w.vetoing && w.loss > WORSE_FRACTION_OF_GAIN * score;
    let worse: Vec<String> = worsened_channels
        .iter()
        .filter(|(_, _, w, _)| blocks(w))
        .map(|(n, _, _, _)| n.clone())
        .collect();
    let mut reason = String::new();
    if channels.is_empty() {
        reason = format!(
            "no channel above its noise floor improved by {:.0} % on the held-out data in {} with the effect's own term mattering",
            MIN_REDUCTION * 100.0,
            if free_only {
                "the free-run view (the view its signature shows in)"
            } else {
                "both the shooting and the free-run view"
            }
        );
    } else if !home_hit {
        reason = format!(
            "it improves only {} on the held-out data, not where its signature lives",
            channels
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    } else if !worse.is_empty() {
        reason = format!(
            "it makes {} worse on the held-out data, by more than the noise and more than a channel's unexplained misfit can account for",
            worse.join(", ")
        );
    } else if let Some((key, v, bound)) = pinned_param(c) {
        reason = format!(
            "its {key} = {v:.3} sits at the bound of its plausible range ({bound}); a fit pinned there stands in for another effect rather than measuring this one"
        );
    } else if c.dbic < MIN_DBIC {
        reason = format!("training ΔBIC {:.1} is below {MIN_DBIC}", c.dbic);
    } else if let Some(why) = &c.signature_failed {
        reason = why.clone();
    }
    let conflicting: Vec<&(String, String, Worsened, bool)> = worsened_channels
        .iter()
        .filter(|(_, views, _, _)| !views.is_empty())
        .collect();
    let conflict_channels = conflicting
        .iter()
        .map(|(ch, _, _, other)| (ch.clone(), *other))
        .collect();
    let conflicts = conflicting
        .iter()
        .map(|(ch, views, w, _)| {
            if blocks(w) {
                format!(
                    "{ch} gets {views}; this blocks the finding — the fit bends the base to explain its home channels at the cost of {ch}, which usually means the base's structure (a coupling between these channels) is wrong or missing"
                )
            } else if w.structural {
                format!(
                    "{ch} gets {views}; tolerated because the base already misses {ch} by more than {REWEIGHT_FACTOR} noise floors, but a trade between channels suggests a base-structure problem there"
                )
            } else {
                format!(
                    "{ch} gets {views}, beyond its noise; the gain elsewhere outweighs it, but a fit that buys its home channels with another channel usually means the base's structure (a coupling between these channels) is wrong or missing"
                )
            }
        })
        .collect();
    Judgement {
        significant: reason.is_empty(),
        channels,
        view,
        primary,
        free,
        shoot,
        score,
        explained,
        reason,
        conflicts,
        conflict_channels,
        leaves: Inadequacy::left_by(base, &c.eval, closed_loop),
    }
}

/// Whether a held-out channel is excited: its measurement moves beyond the noise-floor
/// gate of fit % ([`crate::metrics`]) in the multiple-shooting view, or (open-loop data)
/// in the free run.
pub(super) fn channel_excited(c: &crate::evaluate::ChannelEval, closed_loop: bool) -> bool {
    c.shooting.fit_pct.is_some() || (!closed_loop && c.free_run.fit_pct.is_some())
}

/// A model that misses several excited channels structurally (see
/// [`veto_on_inadequate_base`]): each such channel with its multiple-shooting held-out
/// RMSE in noise floors, worst first.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Inadequacy {
    pub(super) channels: Vec<(String, f64)>,
}

impl Inadequacy {
    /// "depth 5.7×, surge 13.7×" (worst first).
    pub(super) fn listed(&self) -> String {
        self.channels
            .iter()
            .map(|(n, r)| format!("{n} {r:.1}×"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl Inadequacy {
    /// What a base (held-out evaluation `base`) still misses with a finding (`with`)
    /// granted: the excited channels beyond [`INADEQUATE_FACTOR`] noise floors, each at
    /// the finding's level or, where the finding makes it worse, at the base's (its own
    /// damage is not counted against the base). `Some` when at least
    /// [`INADEQUATE_CHANNELS`] remain and they carry at least [`INADEQUATE_SHARE`] of the
    /// base's misfit beyond that level (Σ of ratio − factor): then the finding is not
    /// what the base lacks, the structure is. A finding that accounts for nearly all of
    /// the base's misfit (a tether explaining a heading missed 119×, leaving pitch and
    /// roll at 3.7× and 2.8×: 2 % of it) leaves no structural inadequacy however many
    /// small misses remain.
    pub(super) fn left_by(base: &Evaluation, with: &Evaluation, closed_loop: bool) -> Option<Self> {
        let (mut total, mut left) = (0.0, 0.0);
        let mut channels = Vec::new();
        for (k, b) in &base.channels {
            if !channel_excited(b, closed_loop) {
                continue;
            }
            let sigma = b.noise.max(1e-12);
            let rb = b.shooting.rmse / sigma;
            if !rb.is_finite() || rb <= INADEQUATE_FACTOR {
                continue;
            }
            total += rb - INADEQUATE_FACTOR;
            let rn = with
                .channels
                .get(k)
                .map_or(rb, |n| (n.shooting.rmse / sigma).min(rb));
            if rn.is_finite() && rn > INADEQUATE_FACTOR {
                left += rn - INADEQUATE_FACTOR;
                channels.push((k.name().to_string(), rn));
            }
        }
        channels.sort_by(|a, b| b.1.total_cmp(&a.1));
        (channels.len() >= INADEQUATE_CHANNELS && total > 0.0 && left >= INADEQUATE_SHARE * total)
            .then_some(Inadequacy { channels })
    }
}

/// Whether a model's held-out evaluation leaves at least [`INADEQUATE_CHANNELS`] excited
/// channels beyond [`INADEQUATE_FACTOR`] noise floors in the multiple-shooting view (the
/// verdict's view): after calibration that is more than one missing effect usually
/// accounts for, a sign that the base's structure does not fit the data.
pub(super) fn inadequacy(eval: &Evaluation, closed_loop: bool) -> Option<Inadequacy> {
    let mut channels: Vec<(String, f64)> = eval
        .channels
        .iter()
        .filter(|(_, c)| channel_excited(c, closed_loop))
        .map(|(k, c)| (k.name().to_string(), c.shooting.rmse / c.noise.max(1e-12)))
        .filter(|(_, r)| r.is_finite() && *r > INADEQUATE_FACTOR)
        .collect();
    channels.sort_by(|a, b| b.1.total_cmp(&a.1));
    (channels.len() >= INADEQUATE_CHANNELS).then_some(Inadequacy { channels })
}

/// Marks a conflict that [`veto_on_inadequate_base`] made blocking.
pub(super) const BASE_VETO_MARK: &str = "the base is structurally inadequate for this data";

/// The structural-base veto: on a model that is structurally inadequate for the data
/// ([`inadequacy`]) and stays so with the finding granted ([`Inadequacy::left_by`]), a
/// finding that makes an excited channel (any it does not explain, its own home
/// channels included) clearly worse — a conflict of [`judge`] in the multiple-shooting
/// view, the verdict's: worse there by more than [`MAX_WORSE`] above the floor, its
/// prediction moved beyond noise — is refused, not only reported. On such a base the
/// exemption (c) of [`judge`] (a loss small against the gain) no longer holds: the misfit
/// is everywhere, and a fit that trades channels bends the base rather than measuring an
/// effect (probe case 8: model2 on model3's
/// closed-loop dives took a dead zone that made heading and yaw rate 21–35 % worse).
/// A rise in the free run alone stays a conflict under [`judge`]'s rules: a right effect
/// can move the free run's accumulated heading (the paper truth's thrust asymmetry,
/// heading +91 % in the free run next to a missing moment arm), and so does exemption
/// (b), a rise of at most [`MAX_WORSE_UNEXPLAINED`] on a channel the base already misses
/// structurally and the finding does not claim: with two effects missing, the second's
/// channels move with any refit for the first (nulls_and_pairs' asymmetry next to a
/// propeller torque moves pitch). Returns whether it refused the finding.
pub(super) fn veto_on_inadequate_base(j: &mut Judgement, inadequate: Option<&Inadequacy>) -> bool {
    let Some(inad) = inadequate else {
        return false;
    };
    if !j.significant {
        return false;
    }
    let Some(left) = j.leaves.clone() else {
        return false;
    };
    let traded: Vec<String> = j
        .conflict_channels
        .iter()
        .filter(|(_, other)| *other)
        .map(|(ch, _)| ch.clone())
        .collect();
    if traded.is_empty() {
        return false;
    }
    j.significant = false;
    j.reason = base_veto_reason(&traded, inad, &left);
    mark_base_veto(&mut j.conflicts, &traded, inad);
    true
}

/// A channel a finding makes worse (see [`judge`]).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Worsened {
    /// (view: 0 multiple shooting, 1 free run; relative RMSE rise) of each view where it
    /// is worse beyond its noise: a conflict, reported whatever else is decided.
    pub(super) views: Vec<(usize, f64)>,
    /// Whether it blocks the finding before the gain is weighed (rule (c) of [`judge`]).
    pub(super) vetoing: bool,
    /// The two-view mean rise of its RMSE, in noise floors.
    pub(super) loss: f64,
    /// Whether the base already misses the channel structurally and the rise is small
    /// against that misfit (rule (b)).
    pub(super) structural: bool,
}

/// The "made worse" rules of [`judge`] for one channel: RMSE before `bv` and after `nv`
/// and the RMS change of its prediction `moved`, each in (multiple shooting, free run);
/// `sigma` its noise floor; `claimed` whether the finding claims the channel. `None` when
/// the channel is not worse beyond its noise in either view.
pub(super) fn worsened(
    bv: [f64; 2],
    nv: [f64; 2],
    moved: [f64; 2],
    sigma: f64,
    claimed: bool,
    closed_loop: bool,
) -> Option<Worsened> {
    let floor = sigma * NOISE_FACTOR;
    let red = [reduction(bv[0], nv[0]), reduction(bv[1], nv[1])];
    let worse_above = |v: usize| red[v] < -MAX_WORSE && nv[v] > floor;
    if !(0..2).any(worse_above) {
        return None;
    }
    // Each view on its own: worse beyond its noise in that view.
    let views: Vec<(usize, f64)> = (0..2)
        .filter(|v| !(closed_loop && *v == 1))
        .filter(|v| worse_above(*v) && moved[*v] >= WORSE_NOISE_FRACTION * sigma)
        .map(|v| (v, -red[v]))
        .collect();
    // The veto weighs the two views together.
    let mean_red = 0.5 * (red[0] + red[1]);
    let within_noise = 0.5 * (moved[0] + moved[1]) < WORSE_NOISE_FRACTION * sigma;
    let structural =
        !claimed && bv[0] > REWEIGHT_FACTOR * sigma && -mean_red <= MAX_WORSE_UNEXPLAINED;
    let vetoing = mean_red < -MAX_WORSE && !within_noise && !structural;
    if views.is_empty() && !vetoing {
        return None;
    }
    Some(Worsened {
        views,
        vetoing,
        loss: 0.5 * ((nv[0] - bv[0]) + (nv[1] - bv[1])) / sigma.max(1e-300),
        structural,
    })
}

/// Home channels of a fitted effect: those of its parameters that moved noticeably
/// from "off" (so a torque that only moved its roll part must show in roll).
pub(super) fn fitted_home_channels(c: &Confirmed) -> Vec<Channel> {
    let mut out: Vec<Channel> = Vec::new();
    let mut any_param = false;
    for p in &c.params {
        let (Some(off), Some(home)) = (p.off_value(), p.home_channels()) else {
            continue;
        };
        any_param = true;
        let v = c.fit.model.get(*p).unwrap_or(off);
        if (v - off).abs() >= 0.25 * (p.probe_value() - off).abs() {
            for ch in home {
                if !out.contains(ch) {
                    out.push(*ch);
                }
            }
        }
    }
    if out.is_empty() && !any_param {
        return c.subject.home();
    }
    out
}

/// The change of the held-out multiple-shooting predictions of some channels between two
/// evaluations, in noise floors, as one vector (for the cosine of two such changes).
pub(super) fn prediction_change(
    a: &Evaluation,
    b: &Evaluation,
    ch: &[ChannelKey],
    noise: &BTreeMap<ChannelKey, f64>,
) -> Vec<f64> {
    let mut v = Vec::new();
    for (pa, pb) in a.shooting.iter().zip(&b.shooting) {
        for k in ch {
            let c = k.channel();
            if let (Some(x), Some(y)) = (pa.channel(c), pb.channel(c)) {
                let s = noise.get(k).copied().unwrap_or(1.0).max(1e-12);
                v.extend(x.iter().zip(y).map(|(p, q)| {
                    let d = crate::metrics::residual(c, *p, *q) / s;
                    if d.is_finite() { d } else { 0.0 }
                }));
            }
        }
    }
    v
}

/// Cosine similarity of two vectors (0 when either is zero).
pub(super) fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    if aa <= 0.0 || bb <= 0.0 {
        0.0
    } else {
        ab / (aa * bb).sqrt()
    }
}

/// Why a finding that traded `traded` on an inadequate base (`inad`, leaving `left` with
/// the findings granted) is not significant.
pub(super) fn base_veto_reason(traded: &[String], inad: &Inadequacy, left: &Inadequacy) -> String {
    format!(
        "it makes {} clearly worse on the held-out data, and the base looks structurally inadequate for this data (it misses {} beyond {INADEQUATE_FACTOR} noise floors, and with the findings still {}): on such a base a fit that trades one channel for another bends the base instead of measuring an effect",
        traded.join(", "),
        inad.listed(),
        left.listed()
    )
}

/// Rewrites the conflicts (each "<channel> gets <views>; …") of the `traded` channels as
/// blocking for a structurally inadequate base.
pub(super) fn mark_base_veto(conflicts: &mut [String], traded: &[String], inad: &Inadequacy) {
    for c in conflicts.iter_mut() {
        let Some((ch, rest)) = c.split_once(" gets ") else {
            continue;
        };
        if !traded.iter().any(|t| t == ch) || c.contains(BASE_VETO_MARK) {
            continue;
        }
        let views = rest.split([';', ',']).next().unwrap_or("").to_string();
        *c = format!(
            "{ch} gets {views}; this blocks the finding — {BASE_VETO_MARK} (it misses {}), and a finding that makes another channel clearly worse there is refused",
            inad.listed()
        );
    }
}

/// The report's sentence on a structurally inadequate base: `base` the calibrated base's
/// [`inadequacy`], `after` the final model's, `refused` the findings the veto refused with
/// the channels they would have made worse. `None` when the base is adequate in this sense,
/// or when the findings brought the model out of it and the veto refused nothing.
pub(super) fn inadequacy_note(
    base: Option<&Inadequacy>,
    after: Option<&Inadequacy>,
    refused: &[(String, Vec<String>)],
) -> Option<String> {
    let base = base?;
    if after.is_none() && refused.is_empty() {
        return None;
    }
    let mut s = format!(
        "the calibrated base looks structurally inadequate for this data: after calibration it still misses {} excited channels beyond {INADEQUATE_FACTOR} noise floors ({}; held-out multiple-shooting RMSE), more than a missing effect usually leaves, and no refit of its parameters closes that",
        base.channels.len(),
        base.listed()
    );
    match after {
        Some(a) if a != base => s.push_str(&format!(
            "; with the accepted findings it still misses {}",
            a.listed()
        )),
        _ => {}
    }
    if !refused.is_empty() {
        let r: Vec<String> = refused
            .iter()
            .map(|(f, chans)| format!("{f} (it makes {} clearly worse)", chans.join(", ")))
            .collect();
        s.push_str(&format!(
            "; findings that trade one channel for another are refused on such a base: {}",
            r.join(", ")
        ));
    }
    s.push_str("; a base with the missing degrees of freedom or couplings is needed before effects can be named reliably");
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_channel_worse_in_either_view_beyond_its_noise_is_a_conflict() {
        let sigma = 0.1;
        // Heading +86 % in the multiple-shooting view, 20 % better in the free run (the
        // GUI's synthetic moment-arm case): the two views' mean (+33 %) vetoes unless the
        // gain outweighs it, and the multiple-shooting view is a conflict either way.
        let w = worsened([0.3, 0.5], [0.558, 0.4], [0.3, 0.2], sigma, false, false).unwrap();
        assert_eq!(w.views.len(), 1, "{w:?}");
        assert_eq!(w.views[0].0, 0);
        assert!((w.views[0].1 - 0.86).abs() < 1e-9);
        assert!(w.vetoing && !w.structural);
        assert!((w.loss - 0.79).abs() < 1e-9, "{w:?}");
        // Worse in one view by more than the other improves: no veto, still a conflict.
        let w = worsened([0.3, 0.5], [0.4, 0.3], [0.3, 0.3], sigma, false, false).unwrap();
        assert!(
            !w.vetoing && w.views.len() == 1 && w.views[0].0 == 0,
            "{w:?}"
        );
        // The same in the free run only.
        let w = worsened([0.5, 0.3], [0.3, 0.4], [0.3, 0.3], sigma, false, false).unwrap();
        assert!(!w.vetoing && w.views[0].0 == 1, "{w:?}");
        // Closed loop: the free run is no test, so a free-run-only rise is no conflict.
        assert!(worsened([0.5, 0.3], [0.3, 0.4], [0.3, 0.3], sigma, false, true).is_none());
        // A rise the prediction change cannot account for beyond noise is not evidence.
        assert!(worsened([0.3, 0.5], [0.558, 0.4], [0.04, 0.02], sigma, false, false).is_none());
        // Within the floor: nothing to say.
        assert!(worsened([0.08, 0.08], [0.1, 0.1], [0.3, 0.3], sigma, false, false).is_none());
        // A channel the base misses structurally (3 floors), not claimed, rising by at
        // most 25 %: tolerated (no veto), still reported as a conflict ...
        let w = worsened([0.3, 0.3], [0.36, 0.33], [0.3, 0.3], sigma, false, false).unwrap();
        assert!(!w.vetoing && w.structural && !w.views.is_empty(), "{w:?}");
        // ... but not when the finding claims it, nor beyond 25 %.
        assert!(
            worsened([0.3, 0.3], [0.36, 0.33], [0.3, 0.3], sigma, true, false)
                .unwrap()
                .vetoing
        );
        assert!(
            worsened([0.3, 0.3], [0.45, 0.4], [0.3, 0.3], sigma, false, false)
                .unwrap()
                .vetoing
        );
    }

    fn judgement(conflict_channels: Vec<(String, bool)>, leaves: Option<Inadequacy>) -> Judgement {
        Judgement {
            significant: true,
            channels: Vec::new(),
            view: View::FreeRun,
            primary: BTreeMap::new(),
            free: BTreeMap::new(),
            shoot: BTreeMap::new(),
            score: 1.0,
            explained: BTreeMap::new(),
            reason: "significant".into(),
            conflicts: conflict_channels
                .iter()
                .map(|(ch, _)| format!("{ch} gets 40 % worse in multiple shooting"))
                .collect(),
            conflict_channels,
            leaves,
        }
    }

    #[test]
    fn a_trade_on_a_base_that_stays_inadequate_is_refused_and_says_why() {
        let inad = Inadequacy {
            channels: vec![
                ("surge".into(), 16.4),
                ("depth".into(), 5.5),
                ("heading".into(), 4.2),
            ],
        };
        let left = Inadequacy {
            channels: vec![
                ("surge".into(), 16.0),
                ("heading".into(), 5.0),
                ("depth".into(), 2.6),
            ],
        };
        // Trades heading for depth on a base that stays inadequate: refused.
        let mut j = judgement(vec![("heading".into(), true)], Some(left.clone()));
        assert!(veto_on_inadequate_base(&mut j, Some(&inad)));
        assert!(!j.significant);
        assert!(j.reason.contains("structurally inadequate"), "{}", j.reason);
        assert!(j.reason.contains("heading"), "{}", j.reason);
        assert!(
            j.conflicts.iter().all(|c| c.contains(BASE_VETO_MARK)),
            "{:?}",
            j.conflicts
        );
        // No trade (nothing worse outside rule (b)): kept.
        let mut j = judgement(vec![("heading".into(), false)], Some(left.clone()));
        assert!(!veto_on_inadequate_base(&mut j, Some(&inad)) && j.significant);
        // The finding brings the model out of inadequacy: kept.
        let mut j = judgement(vec![("heading".into(), true)], None);
        assert!(!veto_on_inadequate_base(&mut j, Some(&inad)) && j.significant);
        // An adequate base: kept.
        let mut j = judgement(vec![("heading".into(), true)], Some(left));
        assert!(!veto_on_inadequate_base(&mut j, None) && j.significant);
    }
}
