//! Reading real logs into lab runs, and saying what was done to them.
//!
//! Real logs are not the clean step files the lab was first built on. Every treatment is
//! recorded in the run's [`Treatment`] and reported in words ([`treatment_sentences`]):
//!
//! * **Time stamps.** Rows whose time does not increase are dropped (counted). Uneven
//!   intervals need no treatment: the simulator integrates each interval with its real
//!   length ([`crate::sim`]); the report gives the spread.
//! * **Gaps.** An interval longer than max([`GAP_MIN_S`], [`GAP_MEDIAN_FACTOR`] × the
//!   median interval) splits the log into separate runs (a model cannot be held to what
//!   happened while nothing was recorded); pieces shorter than [`MIN_PIECE_ROWS`] rows are
//!   dropped.
//! * **Spikes.** In each measured channel, a run of at most [`MAX_SPIKE_SAMPLES`] samples
//!   that departs from the median of its ±[`SPIKE_HALF_WINDOW`] neighbours *and* from the
//!   samples on both sides by more than [`SPIKE_K`] robust standard deviations (1.4826 ×
//!   the median absolute departure from the local median, the Hampel identifier) is
//!   excluded: set missing, so it counts in neither the fits nor the metrics. White
//!   Gaussian noise exceeds 6 σ on both sides about once in 10⁹ samples. The departure
//!   must also exceed [`SPIKE_FLANK_RATIO`] times the signal's own change between the
//!   samples just outside it, so the sharp tip of a real, nearly noise-free signal (a
//!   yaw rate reversing under an autopilot) is not taken for a spike.
//! * **Angles interpolated across the wrap.** A log resampled by linear interpolation of
//!   a wrapped angle (heading or roll in ±180°) gets, where the angle wraps, a sample
//!   half-way between +180° and −180°: about 180° from the truth. Unwrapped, it is not a
//!   spike but half of a 360° step, so it is found before unwrapping
//!   ([`exclude_wrap_interpolations`]: its neighbours agree within [`WRAP_GLITCH_DEG`]
//!   modulo 360° while their raw values differ by more than 360° minus that, and it lies
//!   between them in raw value but more than a quarter turn from both modulo 360°) and
//!   counted with the channel's spikes.
//! * **Closed loop.** A command whose sample-to-sample changes follow the measured outputs
//!   (an autopilot reacting to depth or heading, [`feedback_links`]) marks the run as
//!   closed-loop. The diagnosis then judges on multiple shooting only: in a free run the
//!   model is not corrected by the autopilot that corrected the real vehicle, so the free
//!   run's drift says nothing about the model.

use rov_dynamics::models::Channel;
use rov_dynamics::models::vehicle::{Commands, N_COMMANDS};
use rov_types::measurement::MeasurementSeries;

use crate::LabError;
use crate::data::{FeedbackLink, N_CHANNELS, Run, ch_index, ch_name};

/// Shortest interval that splits a log, s.
pub const GAP_MIN_S: f64 = 1.0;
/// An interval longer than this many median intervals splits a log.
pub const GAP_MEDIAN_FACTOR: f64 = 10.0;
/// Fewest rows a piece of a split log keeps.
pub const MIN_PIECE_ROWS: usize = 20;
/// Spike threshold, robust standard deviations.
pub const SPIKE_K: f64 = 6.0;
/// Half-width of the spike detector's median window, samples.
pub const SPIKE_HALF_WINDOW: usize = 4;
/// A spike departs from its neighbours by more than this many times the signal's own
/// sample-to-sample change on its flanks.
pub const SPIKE_FLANK_RATIO: f64 = 3.0;
/// Longest run of samples taken as one spike.
pub const MAX_SPIKE_SAMPLES: usize = 2;
/// A command is closed-loop when the past outputs explain at least this fraction of the
/// variance of its changes ...
pub const FEEDBACK_EXPLAINED: f64 = 0.25;
/// ... and it changes in at least this fraction of the samples (a schedule of steps
/// changes rarely; an autopilot's output changes nearly every sample).
pub const FEEDBACK_CHANGING: f64 = 0.2;

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Neighbours of a wrap interpolation agree within this (deg, modulo 360): the vehicle
/// turns less than that in two sample intervals.
pub const WRAP_GLITCH_DEG: f64 = 60.0;

/// Excludes (sets NaN) the samples of a wrapped angle channel (deg, before unwrapping)
/// that a resampler interpolated across the ±180° wrap; returns how many (module docs).
pub fn exclude_wrap_interpolations(v: &mut [f64]) -> usize {
    let wrap = crate::data::wrap180;
    let mut bad = Vec::new();
    for k in 1..v.len().saturating_sub(1) {
        let (a, c, b) = (v[k - 1], v[k], v[k + 1]);
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            continue;
        }
        let between = c > a.min(b) && c < a.max(b);
        if (b - a).abs() > 360.0 - WRAP_GLITCH_DEG
            && wrap(b - a).abs() < WRAP_GLITCH_DEG
            && between
            && wrap(c - a).abs() > 90.0
            && wrap(c - b).abs() > 90.0
        {
            bad.push(k);
        }
    }
    for k in &bad {
        v[*k] = f64::NAN;
    }
    bad.len()
}

/// Excludes isolated spikes from a channel (sets them NaN); returns how many samples.
pub fn exclude_spikes(v: &mut [f64]) -> usize {
    let n = v.len();
    if n < 4 * SPIKE_HALF_WINDOW {
        return 0;
    }
    // Departure of each sample from the median of its neighbours (itself excluded).
    let mut dep = vec![f64::NAN; n];
    let mut buf: Vec<f64> = Vec::with_capacity(2 * SPIKE_HALF_WINDOW);
    for (k, d) in dep.iter_mut().enumerate() {
        if !v[k].is_finite() {
            continue;
        }
        buf.clear();
        let lo = k.saturating_sub(SPIKE_HALF_WINDOW);
        let hi = (k + SPIKE_HALF_WINDOW + 1).min(n);
        buf.extend(
            (lo..hi)
                .filter(|j| *j != k)
                .map(|j| v[j])
                .filter(|x| x.is_finite()),
        );
        if buf.len() >= SPIKE_HALF_WINDOW
            && let Some(m) = median(&mut buf)
        {
            *d = v[k] - m;
        }
    }
    let mut abs: Vec<f64> = dep
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    let Some(mad) = median(&mut abs) else {
        return 0;
    };
    // A floor for quantised or constant channels: half the smallest non-zero step.
    let step = v
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold(f64::INFINITY, f64::min);
    let scale = (1.4826 * mad).max(if step.is_finite() { 0.5 * step } else { 0.0 });
    if scale <= 0.0 {
        return 0;
    }
    let thr = SPIKE_K * scale;
    let flagged: Vec<bool> = dep.iter().map(|d| d.abs() > thr).collect();
    let mut out = 0;
    let mut k = 0;
    while k < n {
        if !flagged[k] {
            k += 1;
            continue;
        }
        let start = k;
        while k < n && flagged[k] {
            k += 1;
        }
        let end = k;
        if end - start > MAX_SPIKE_SAMPLES || start == 0 || end >= n {
            continue;
        }
        let before = v[start - 1];
        let after = v[end];
        if !(before.is_finite() && after.is_finite()) {
            continue;
        }
        let sign = dep[start].signum();
        // The signal's own sample-to-sample change just outside the candidate: a sharp
        // but real peak (a noise-free rate reversing) changes as fast on its flanks as at
        // its tip; a spike leaves and rejoins a signal that barely moves.
        let flank = |a: usize, b: usize| -> f64 {
            match (v.get(a), v.get(b)) {
                (Some(x), Some(y)) if x.is_finite() && y.is_finite() => (x - y).abs(),
                _ => 0.0,
            }
        };
        let slope = flank(start - 1, start.saturating_sub(2)).max(flank(end + 1, end));
        let departs = (start..end).all(|j| {
            let d = ((v[j] - before) * sign).min((v[j] - after) * sign);
            dep[j].signum() == sign && d > thr && d > SPIKE_FLANK_RATIO * slope
        });
        if departs {
            for x in &mut v[start..end] {
                *x = f64::NAN;
            }
            out += end - start;
        }
    }
    out
}

/// The outputs a feedback check looks at.
const FEEDBACK_OUTPUTS: [Channel; 7] = [
    Channel::Depth,
    Channel::Heading,
    Channel::Pitch,
    Channel::Roll,
    Channel::YawRate,
    Channel::Heave,
    Channel::Surge,
];

/// Least-squares R² of y on the columns of x (with a constant), NaN rows skipped.
fn r_squared(y: &[f64], x: &[Vec<f64>]) -> Option<f64> {
    let p = x.len() + 1;
    let rows: Vec<usize> = (0..y.len())
        .filter(|k| y[*k].is_finite() && x.iter().all(|c| c.get(*k).is_some_and(|v| v.is_finite())))
        .collect();
    if rows.len() < 10 * p {
        return None;
    }
    let mut a = nalgebra::DMatrix::<f64>::zeros(p, p);
    let mut b = nalgebra::DVector::<f64>::zeros(p);
    let mut row = vec![0.0; p];
    let (mut sy, mut syy) = (0.0, 0.0);
    for &k in &rows {
        row[0] = 1.0;
        for (j, c) in x.iter().enumerate() {
            row[j + 1] = c[k];
        }
        for i in 0..p {
            b[i] += row[i] * y[k];
            for j in 0..p {
                a[(i, j)] += row[i] * row[j];
            }
        }
        sy += y[k];
        syy += y[k] * y[k];
    }
    let nf = rows.len() as f64;
    let tss = syy - sy * sy / nf;
    if tss <= 0.0 {
        return None;
    }
    for i in 0..p {
        a[(i, i)] += 1e-12 * a[(i, i)].abs().max(1e-300);
    }
    let beta = a.clone().lu().solve(&b)?;
    // RSS = yᵀy − βᵀ(Xᵀy) for the least-squares β.
    let rss = syy - beta.dot(&b);
    Some((1.0 - rss / tss).clamp(0.0, 1.0))
}

/// Commands of a run that follow its measured outputs: for each present command channel
/// that changes in at least [`FEEDBACK_CHANGING`] of the samples, the fraction of the
/// variance of its changes Δu_k explained (least squares) by the output's changes Δy_k,
/// Δy_{k−1} and its level y_k (measured before command k acts, so causation can only run
/// from output to command); listed when at least [`FEEDBACK_EXPLAINED`]. A step schedule
/// changes too rarely to qualify; a human pilot rarely reaches the fraction.
pub fn feedback_links(run: &Run) -> Vec<FeedbackLink> {
    let n = run.len();
    let mut out = Vec::new();
    if n < 50 {
        return out;
    }
    for c in run.channels.all() {
        if !run.input_present[c.index()] {
            continue;
        }
        let u: Vec<f64> = run.inputs.iter().map(|x| x[c.index()]).collect();
        let du: Vec<f64> = (0..n)
            .map(|k| if k == 0 { f64::NAN } else { u[k] - u[k - 1] })
            .collect();
        let changing = du.iter().filter(|d| d.abs() > 1e-9).count();
        if (changing as f64) < FEEDBACK_CHANGING * n as f64 {
            continue;
        }
        let mut best: Option<(Channel, f64)> = None;
        for ch in FEEDBACK_OUTPUTS {
            let Some(y) = run.channel(ch) else { continue };
            let dy: Vec<f64> = (0..n)
                .map(|k| if k == 0 { f64::NAN } else { y[k] - y[k - 1] })
                .collect();
            let dy1: Vec<f64> = (0..n)
                .map(|k| if k < 2 { f64::NAN } else { dy[k - 1] })
                .collect();
            if let Some(r2) = r_squared(&du, &[dy, dy1, y.to_vec()])
                && best.is_none_or(|(_, b)| r2 > b)
            {
                best = Some((ch, r2));
            }
        }
        if let Some((ch, r2)) = best
            && r2 >= FEEDBACK_EXPLAINED
        {
            out.push(FeedbackLink {
                command: run.channel_name(c),
                output: ch_name(ch).to_string(),
                explained: r2,
            });
        }
    }
    out
}

/// A measurement CSV as runs ([`crate::loader::read_measurement_csv`], then
/// [`crate::loader::LoadedLog::runs`]).
pub fn measurement_runs(text: &str, label: &str) -> Result<Vec<Run>, LabError> {
    crate::loader::read_measurement_csv(text, label)?.runs()
}

/// A series (with optional full command channels) as runs split at gaps.
pub fn series_runs(
    series: &MeasurementSeries,
    label: &str,
    inputs: Option<(Vec<Commands>, [bool; N_COMMANDS])>,
) -> Result<Vec<Run>, LabError> {
    series_runs_with(series, label, inputs, None)
}

/// [`series_runs`] of the kept rows of a decimated log ([`crate::stream`]): the gap rule
/// on the raw median interval, and each run given the raw noise floors and intervals.
/// With `raw` = `None` it is [`series_runs`].
pub fn series_runs_with(
    series: &MeasurementSeries,
    label: &str,
    inputs: Option<(Vec<Commands>, [bool; N_COMMANDS])>,
    raw: Option<&crate::stream::RawStats>,
) -> Result<Vec<Run>, LabError> {
    let t: Vec<f64> = series.rows.iter().map(|r| r.time_s).collect();
    let limit = match raw {
        Some(r) => r.gap_limit_s(),
        None => {
            let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
            dts.sort_by(f64::total_cmp);
            let med = dts.get(dts.len() / 2).copied().unwrap_or(0.05);
            GAP_MIN_S.max(GAP_MEDIAN_FACTOR * med)
        }
    };
    let mut cuts = vec![0usize];
    let mut gaps = Vec::new();
    for (k, w) in t.windows(2).enumerate() {
        if w[1] - w[0] > limit {
            cuts.push(k + 1);
            gaps.push((w[0], w[1] - w[0]));
        }
    }
    cuts.push(t.len());
    let pieces: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
    let kept: Vec<(usize, usize)> = pieces
        .iter()
        .copied()
        .filter(|(a, b)| b - a >= MIN_PIECE_ROWS)
        .collect();
    let short = pieces.len() - kept.len();
    if kept.is_empty() {
        return Err(LabError::Data {
            run: label.into(),
            detail: format!(
                "{} rows; after splitting at gaps no piece has the {MIN_PIECE_ROWS} rows the lab needs",
                t.len()
            ),
        });
    }
    let mut out = Vec::with_capacity(kept.len());
    for (i, (a, b)) in kept.iter().enumerate() {
        let piece = MeasurementSeries {
            rows: series.rows[*a..*b].to_vec(),
            present: series.present,
            warnings: Vec::new(),
        };
        let name = if kept.len() > 1 {
            format!("{label}#{}", i + 1)
        } else {
            label.to_string()
        };
        let inp = inputs.as_ref().map(|(v, p)| (v[*a..*b].to_vec(), *p));
        let mut run = Run::from_series_inputs(&piece, &name, inp)?;
        if let Some(r) = raw {
            r.apply(&mut run);
        }
        run.treatment.source = label.to_string();
        run.treatment.segment = i + 1;
        run.treatment.segments = kept.len();
        run.treatment.gaps = gaps.clone();
        if short > 0 {
            run.treatment.notes.push(format!(
                "{short} piece(s) between gaps shorter than {MIN_PIECE_ROWS} rows dropped"
            ));
        }
        out.push(run);
    }
    Ok(out)
}

/// Log maps shipped with the lab (`config/maps/`), by file name: a CSV whose header has
/// every column one of them reads is read through it ([`runs_from_text`]).
pub const SHIPPED_MAPS: [(&str, &str); 1] = [(
    "config/maps/bluerov2_saabmarine_mex.toml",
    include_str!("../../../config/maps/bluerov2_saabmarine_mex.toml"),
)];

/// The shipped map whose columns a CSV header has, if any.
pub fn shipped_map_for(text: &str) -> Option<rov_logs::LogMap> {
    let first = text.lines().next().unwrap_or("");
    let header: std::collections::BTreeSet<&str> = first.split(',').map(str::trim).collect();
    SHIPPED_MAPS.iter().find_map(|(name, toml)| {
        let map = rov_logs::LogMap::parse(toml, name).ok()?;
        let fields = map.fields();
        let time_ok = map.time_field.as_deref().is_none_or(|t| header.contains(t));
        (time_ok && fields.iter().all(|f| header.contains(f.as_str()))).then_some(map)
    })
}

/// Reads a log of any supported text format: a CSV with the columns of a shipped log map
/// ([`SHIPPED_MAPS`]: the BlueROV2 tank data set) through that map, else a measurement CSV.
pub fn runs_from_text(text: &str, label: &str) -> Result<Vec<Run>, LabError> {
    crate::loader::read_text(text, label)?.runs()
}

/// The treatments of some runs in words, one sentence per source.
pub fn treatment_sentences(runs: &[Run]) -> Vec<String> {
    let mut sources: Vec<&str> = Vec::new();
    for r in runs {
        if !sources.contains(&r.treatment.source.as_str()) {
            sources.push(&r.treatment.source);
        }
    }
    let mut out = Vec::new();
    for src in sources {
        let pieces: Vec<&Run> = runs.iter().filter(|r| r.treatment.source == src).collect();
        let Some(first) = pieces.first() else {
            continue;
        };
        let tr = &first.treatment;
        let mut parts: Vec<String> = Vec::new();
        let mut spikes = [0usize; N_CHANNELS];
        for p in &pieces {
            for (s, x) in spikes.iter_mut().zip(p.treatment.spikes) {
                *s += x;
            }
        }
        for ch in Channel::ALL {
            let k = spikes[ch_index(ch)];
            if k > 0 {
                parts.push(format!(
                    "{k} {} spike{} excluded",
                    ch_name(ch),
                    if k == 1 { "" } else { "s" }
                ));
            }
        }
        if !tr.gaps.is_empty() {
            let g: Vec<String> = tr
                .gaps
                .iter()
                .map(|(t, d)| format!("{d:.1} s at t = {t:.1} s"))
                .collect();
            parts.push(format!(
                "{} gap{} ({}) split the run into {} segment{}",
                tr.gaps.len(),
                if tr.gaps.len() == 1 { "" } else { "s" },
                g.join(", "),
                tr.segments,
                if tr.segments == 1 { "" } else { "s" }
            ));
        }
        if tr.dropped_time_rows > 0 {
            parts.push(format!(
                "{} row{} whose time did not increase dropped",
                tr.dropped_time_rows,
                if tr.dropped_time_rows == 1 { "" } else { "s" }
            ));
        }
        let (med, lo, hi) = tr.dt_median_min_max_s;
        if med > 0.0 && hi > 1.5 * lo {
            parts.push(format!(
                "uneven sample intervals ({:.3}–{:.3} s, median {:.3} s) simulated with their real lengths",
                lo, hi, med
            ));
        }
        let mut links: Vec<&FeedbackLink> = Vec::new();
        for p in &pieces {
            for l in &p.treatment.closed_loop {
                if !links.iter().any(|x| x.command == l.command) {
                    links.push(l);
                }
            }
        }
        if !links.is_empty() {
            let l: Vec<String> = links
                .iter()
                .map(|l| {
                    format!(
                        "the {} command follows the measured {} ({:.0} % of its changes)",
                        l.command,
                        l.output,
                        l.explained * 100.0
                    )
                })
                .collect();
            parts.push(format!(
                "closed-loop data: {}; judged on multiple shooting only (a free-running model is not corrected by the autopilot that corrected the vehicle)",
                l.join(", ")
            ));
        }
        for n in &tr.notes {
            if !parts.contains(n) {
                parts.push(n.clone());
            }
        }
        if !parts.is_empty() {
            out.push(format!("{src}: {}", parts.join("; ")));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(n: usize, seed: u64) -> Vec<f64> {
        let mut x = seed;
        (0..n)
            .map(|k| {
                let mut s = 0.0;
                for _ in 0..12 {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    s += (x >> 11) as f64 / (1u64 << 53) as f64;
                }
                (k as f64 * 0.01).sin() * 3.0 + 0.02 * (s - 6.0)
            })
            .collect()
    }

    #[test]
    fn a_heading_interpolated_across_the_wrap_is_excluded() {
        // 146°, 151°, then the resampler's mid value between 156° and −204° (≡ 156°).
        let mut v = vec![141.0, 146.0, 151.0, -28.0, -203.4, -198.0, -193.0];
        assert_eq!(exclude_wrap_interpolations(&mut v), 1);
        assert!(v[3].is_nan());
        assert!(v.iter().enumerate().all(|(k, x)| k == 3 || x.is_finite()));
        // The same in a 0–360° log: the mid value between 359° and 1°.
        let mut v = vec![357.0, 359.0, 180.0, 1.0, 3.0];
        assert_eq!(exclude_wrap_interpolations(&mut v), 1);
        assert!(v[2].is_nan());
        // A real crossing of ±180° (no mid value), a fast turn and a slow signal stay.
        for mut w in [
            vec![170.0, 175.0, -179.0, -174.0],
            vec![0.0, 60.0, 120.0, 180.0, 240.0],
            vec![170.0, 175.0, -179.0, 5.0, -174.0],
            vec![10.0, 10.5, 11.0, 11.5],
        ] {
            let before = w.clone();
            assert_eq!(exclude_wrap_interpolations(&mut w), 0);
            assert_eq!(w, before);
        }
    }

    #[test]
    fn spikes_are_excluded_and_noise_is_not() {
        let mut v = noisy(5000, 7);
        assert_eq!(exclude_spikes(&mut v.clone()), 0);
        v[1000] += 1.0;
        v[2000] -= 0.5;
        v[2001] -= 0.5;
        // A step is not a spike.
        for x in v.iter_mut().skip(3000) {
            *x += 2.0;
        }
        let n = exclude_spikes(&mut v);
        assert_eq!(n, 3, "{n}");
        assert!(v[1000].is_nan() && v[2000].is_nan() && v[2001].is_nan());
        assert!(v[3000].is_finite() && v[2999].is_finite());
    }
}
