//! Measured runs prepared for the lab: commands, channels (heading unwrapped), noise
//! floors, smoothed values for re-initialisation, and manoeuvre segments.
//!
//! Timing (measurement CSV rule): row k's measurement is taken at t_k *before* row k's
//! command acts; the command is held from t_k to t_{k+1}. So the sample at t_k responds
//! to commands 0..k−1 only; [`crate::sim`] follows exactly this.

use rov_dynamics::models::Channel;
use rov_dynamics::models::vehicle::{ChannelTable, CommandChannel, Commands, N_COMMANDS};
use rov_dynamics::thrusters::ThrustPct;
use rov_types::measurement::{MeasurementSeries, OptionalChannel};
use serde::Serialize;

use crate::LabError;

/// Number of channels ([`Channel::ALL`]).
pub const N_CHANNELS: usize = 12;

/// Index of a channel in [`Channel::ALL`].
pub fn ch_index(ch: Channel) -> usize {
    match ch {
        Channel::Depth => 0,
        Channel::Heading => 1,
        Channel::Pitch => 2,
        Channel::Roll => 3,
        Channel::Surge => 4,
        Channel::Sway => 5,
        Channel::Heave => 6,
        Channel::RollRate => 7,
        Channel::PitchRate => 8,
        Channel::YawRate => 9,
        Channel::North => 10,
        Channel::East => 11,
    }
}

/// Lower-case channel name used in reports ("depth", "heading", "yaw_rate" …).
pub fn ch_name(ch: Channel) -> &'static str {
    match ch {
        Channel::Depth => "depth",
        Channel::Heading => "heading",
        Channel::Pitch => "pitch",
        Channel::Roll => "roll",
        Channel::Surge => "surge",
        Channel::Sway => "sway",
        Channel::Heave => "heave",
        Channel::RollRate => "roll_rate",
        Channel::PitchRate => "pitch_rate",
        Channel::YawRate => "yaw_rate",
        Channel::North => "north",
        Channel::East => "east",
    }
}

/// Unit of a channel in reports.
pub fn ch_unit(ch: Channel) -> &'static str {
    match ch {
        Channel::Depth | Channel::North | Channel::East => "m",
        Channel::Heading | Channel::Pitch | Channel::Roll => "deg",
        Channel::Surge | Channel::Sway | Channel::Heave => "m/s",
        Channel::RollRate | Channel::PitchRate | Channel::YawRate => "deg/s",
    }
}

/// Whether residuals of a channel are angles to wrap to ±180° (heading, and roll: a
/// vehicle that rolls over reads its roll modulo 360°).
pub fn ch_wraps(ch: Channel) -> bool {
    matches!(ch, Channel::Heading | Channel::Roll)
}

/// Longest stretch at the start of a run fitted together for the initial state, s.
const START_WINDOW_S: f64 = 2.0;

/// Lowest noise floor assumed for a channel (quantisation and numerics).
pub(crate) fn noise_floor_min(ch: Channel) -> f64 {
    match ch {
        Channel::Depth => 0.002,
        Channel::Heading | Channel::Pitch | Channel::Roll => 0.03,
        Channel::RollRate | Channel::PitchRate | Channel::YawRate => 0.05,
        Channel::Surge | Channel::Sway | Channel::Heave => 0.002,
        Channel::North | Channel::East => 0.005,
    }
}

/// Wraps an angle difference to (−180, 180] degrees.
#[inline]
pub fn wrap180(x: f64) -> f64 {
    rov_types::angle::wrap_deg_180_incl(x)
}

/// Kind of manoeuvre segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentKind {
    /// All thrusters off.
    Rest,
    /// Port thruster alone.
    Port,
    /// Starboard thruster alone.
    Starboard,
    /// Vertical thruster alone.
    Vertical,
    /// Port and starboard with the same sign.
    Surge,
    /// Port and starboard with opposite signs.
    Yaw,
    /// Surge with vertical.
    SurgeHeave,
    /// Yaw with vertical.
    YawHeave,
    /// Anything else.
    Combined,
}

impl SegmentKind {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            SegmentKind::Rest => "rest",
            SegmentKind::Port => "port",
            SegmentKind::Starboard => "starboard",
            SegmentKind::Vertical => "vertical",
            SegmentKind::Surge => "surge",
            SegmentKind::Yaw => "yaw",
            SegmentKind::SurgeHeave => "surge+heave",
            SegmentKind::YawHeave => "yaw+heave",
            SegmentKind::Combined => "combined",
        }
    }

    /// Classifies a command.
    pub fn of(cmd: &ThrustPct) -> Self {
        let on = |x: f64| x.abs() >= 0.5;
        let (p, s, v) = (on(cmd.port), on(cmd.starboard), on(cmd.vertical));
        match (p, s, v) {
            (false, false, false) => SegmentKind::Rest,
            (true, false, false) => SegmentKind::Port,
            (false, true, false) => SegmentKind::Starboard,
            (false, false, true) => SegmentKind::Vertical,
            (true, true, heave) => {
                let same = cmd.port.signum() == cmd.starboard.signum();
                match (same, heave) {
                    (true, false) => SegmentKind::Surge,
                    (false, false) => SegmentKind::Yaw,
                    (true, true) => SegmentKind::SurgeHeave,
                    (false, true) => SegmentKind::YawHeave,
                }
            }
            _ => SegmentKind::Combined,
        }
    }
}

/// A stretch of constant command.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Segment {
    /// First sample.
    pub start: usize,
    /// One past the last sample.
    pub end: usize,
    /// Start time, s.
    pub t_start_s: f64,
    /// End time (time of the last sample), s.
    pub t_end_s: f64,
    /// The command held.
    #[serde(skip)]
    pub cmd: ThrustPct,
    /// Kind.
    pub kind: SegmentKind,
    /// Largest |command|, %, rounded to 5 %.
    pub level_pct: f64,
}

/// The command channels a Pro 4 log holds: port, starboard and vertical.
pub(crate) fn pro4_present() -> [bool; N_COMMANDS] {
    let mut p = [false; N_COMMANDS];
    for c in [
        CommandChannel::PORT,
        CommandChannel::STARBOARD,
        CommandChannel::VERTICAL,
    ] {
        p[c.index()] = true;
    }
    p
}

/// A measured run ready for the lab.
#[derive(Debug, Clone)]
pub struct Run {
    /// Label (file name).
    pub name: String,
    /// Sample times, s.
    pub t: Vec<f64>,
    /// The Pro 4 thruster commands held from each sample (port, starboard, vertical).
    pub cmd: Vec<ThrustPct>,
    /// Every command channel held from each sample (percent; [`CommandChannel`] index
    /// order of [`Run::channels`]): the Pro 4's three thrusters, and any other channel the
    /// data has (a lateral thruster, a vehicle's body-axis demands, free-named channels
    /// such as per-thruster ESC commands).
    pub inputs: Vec<Commands>,
    /// Which command channels the data holds.
    pub input_present: [bool; N_COMMANDS],
    /// Names of the run's free command channels (indices from
    /// [`rov_dynamics::models::vehicle::N_BUILTIN`]); a model with free channels reads a
    /// run only after [`Run::align_channels`] to its own table.
    pub channels: ChannelTable,
    /// Measured channels (heading unwrapped, deg); NaN = missing sample.
    pub y: [Option<Vec<f64>>; N_CHANNELS],
    /// Locally smoothed channels (quadratic fit over ±0.3 s), for re-initialisation.
    pub smooth: [Option<Vec<f64>>; N_CHANNELS],
    /// Estimated white-noise floor per channel (same units).
    pub noise: [f64; N_CHANNELS],
    /// Constant-command segments.
    pub segments: Vec<Segment>,
    /// Initial velocity estimates (ν, SI) from the first second of data.
    pub nu0: [f64; 6],
    /// What was done to the raw data, for the report.
    pub treatment: Treatment,
}

/// Samples excluded as spikes, per channel (index as [`Channel::ALL`]).
pub type SpikeCounts = [usize; N_CHANNELS];

/// A command that follows the measured outputs (closed-loop data).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FeedbackLink {
    /// The command channel.
    pub command: String,
    /// The output its changes follow best.
    pub output: String,
    /// Fraction of the variance of the command's changes that the past outputs explain.
    pub explained: f64,
}

/// What was done to a run's raw data (see [`crate::ingest`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Treatment {
    /// The source (file) label.
    pub source: String,
    /// Piece `segment` of `segments` when gaps split the source (1-based).
    pub segment: usize,
    /// Pieces the source was split into.
    pub segments: usize,
    /// Rows dropped because their time did not increase.
    pub dropped_time_rows: usize,
    /// Gaps that split the source: (time of the last sample before, length), s.
    pub gaps: Vec<(f64, f64)>,
    /// Spikes excluded per channel.
    #[serde(skip)]
    pub spikes: SpikeCounts,
    /// Median, smallest and largest sample interval, s.
    pub dt_median_min_max_s: (f64, f64, f64),
    /// Commands that follow the measured outputs (closed-loop data), if any.
    pub closed_loop: Vec<FeedbackLink>,
    /// Other notes in words.
    pub notes: Vec<String>,
}

impl Treatment {
    /// Total spikes excluded.
    pub fn total_spikes(&self) -> usize {
        self.spikes.iter().sum()
    }

    /// Whether the data was recorded in closed loop.
    pub fn closed_loop(&self) -> bool {
        !self.closed_loop.is_empty()
    }
}

/// Heading/roll unwrapping one sample at a time (non-finite samples pass unchanged and
/// do not move the reference).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Unwrapper {
    offset: f64,
    prev: Option<f64>,
}

impl Unwrapper {
    /// The next sample, unwrapped.
    pub(crate) fn next(&mut self, x: f64) -> f64 {
        if !x.is_finite() {
            return x;
        }
        if let Some(p) = self.prev {
            let d = x + self.offset - p;
            if d > 180.0 {
                self.offset -= 360.0 * ((d + 180.0) / 360.0).floor();
            } else if d < -180.0 {
                self.offset += 360.0 * ((-d + 180.0) / 360.0).floor();
            }
        }
        let y = x + self.offset;
        self.prev = Some(y);
        y
    }
}

fn unwrap_deg(v: &mut [f64]) {
    let mut u = Unwrapper::default();
    for x in v.iter_mut() {
        *x = u.next(*x);
    }
}

/// The third difference the noise estimate is built on (a smooth signal cancels; white
/// noise of σ gives σ·√20).
#[inline]
pub(crate) fn third_difference(w: [f64; 4]) -> f64 {
    (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs()
}

/// White-noise σ from the median absolute third difference (1.4826 × median is the
/// normal σ of the differences, whose variance is 20 σ²).
#[inline]
pub(crate) fn noise_from_median(median_abs_third_difference: f64) -> f64 {
    1.4826 * median_abs_third_difference / 20f64.sqrt()
}

/// Fewest finite third differences a noise estimate needs.
pub(crate) const NOISE_MIN_DIFFERENCES: usize = 8;

/// Robust white-noise estimate from third differences (smooth signals cancel).
fn noise_estimate(v: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = v
        .windows(4)
        .map(|w| third_difference([w[0], w[1], w[2], w[3]]))
        .filter(|x| x.is_finite())
        .collect();
    if d.len() < NOISE_MIN_DIFFERENCES {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let med = d[d.len() / 2];
    Some(noise_from_median(med))
}

/// Length of the run-start stretch fitted by one straight line for the initial state
/// (0 = none): the first [`START_WINDOW_S`] of a first segment that rests at least 1 s.
pub(crate) fn start_window(first: Option<&Segment>) -> f64 {
    match first {
        Some(s) if s.kind == SegmentKind::Rest && s.t_end_s - s.t_start_s >= 1.0 => {
            (s.t_end_s - s.t_start_s).min(START_WINDOW_S)
        }
        _ => 0.0,
    }
}

/// Samples within this time of the run start take the run-start estimate, s.
pub(crate) const START_SPAN_S: f64 = 0.3;

/// Straight line y ≈ a + b (t − t₀) through the finite samples of the first `win_s`
/// seconds: (a, b, (se a, se b)).
pub(crate) fn line_fit(t: &[f64], y: &[f64], win_s: f64) -> Option<(f64, f64, (f64, f64))> {
    let t0 = *t.first()?;
    let pts: Vec<(f64, f64)> = t
        .iter()
        .zip(y)
        .take_while(|(ti, _)| **ti - t0 <= win_s + 1e-9)
        .filter(|(_, yi)| yi.is_finite())
        .map(|(ti, yi)| (*ti - t0, *yi))
        .collect();
    let m = pts.len() as f64;
    if m < 5.0 {
        return None;
    }
    let (st, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mt, my) = (st / m, sy / m);
    let stt: f64 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
    if stt <= 0.0 {
        return None;
    }
    let b = pts.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum::<f64>() / stt;
    let a = my - b * mt;
    let s2 = pts.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum::<f64>() / (m - 2.0);
    let se_b = (s2 / stt).sqrt();
    let se_a = (s2 * (1.0 / m + mt * mt / stt)).sqrt();
    Some((a, b, (se_a, se_b)))
}

/// Local quadratic least-squares fit: value and slope at `t[i]` from samples within
/// `[t_i − before, t_i + after]`.
pub(crate) fn local_quadratic(
    t: &[f64],
    y: &[f64],
    i: usize,
    before_s: f64,
    after_s: f64,
) -> Option<(f64, f64)> {
    let ti = *t.get(i)?;
    let mut s = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    let mut n = 0;
    let mut lo = i;
    while lo > 0 && t[lo - 1] >= ti - before_s - 1e-9 {
        lo -= 1;
    }
    let mut hi = i;
    while hi + 1 < t.len() && t[hi + 1] <= ti + after_s + 1e-9 {
        hi += 1;
    }
    for k in lo..=hi {
        let yk = y[k];
        if !yk.is_finite() {
            continue;
        }
        let x = t[k] - ti;
        let phi = [1.0, x, x * x];
        for r in 0..3 {
            b[r] += phi[r] * yk;
            for c in 0..3 {
                s[r][c] += phi[r] * phi[c];
            }
        }
        n += 1;
    }
    if n < 4 {
        return None;
    }
    let m = nalgebra::Matrix3::from_fn(|r, c| s[r][c]);
    let sol = m.lu().solve(&nalgebra::Vector3::new(b[0], b[1], b[2]))?;
    (sol[0].is_finite() && sol[1].is_finite()).then_some((sol[0], sol[1]))
}

impl Run {
    /// Prepares a measurement series. Fails when the series has fewer than 10 rows or a
    /// time step above 5 s (split such data with [`crate::ingest`] first).
    pub fn from_series(series: &MeasurementSeries, name: &str) -> Result<Self, LabError> {
        Self::from_series_inputs(series, name, None)
    }

    /// Runs of a series whose commands come as named series (channel name → percent on
    /// the series' rows, one value per row; NaN holds the previous value, 0 before the
    /// first; values outside −100..100 % are clamped and counted in the notes): the
    /// constructor for any log whose command channels a map names (built-in
    /// names keep their meaning; any other valid name becomes a free channel of the runs'
    /// [`ChannelTable`], in the order given). The runs get the same real-log treatment as a
    /// measurement CSV ([`crate::ingest::series_runs_with`]: gaps split them, spikes are
    /// excluded, closed-loop commands are recognised). The Pro 4 view ([`Run::cmd`]) is
    /// the `port`/`starboard`/`vertical` series where named, else the series' own columns.
    /// `raw` as in [`crate::ingest::series_runs_with`] (for a decimated log).
    pub fn runs_from_named_commands(
        series: &MeasurementSeries,
        label: &str,
        commands: &[(String, Vec<f64>)],
        raw: Option<&crate::stream::RawStats>,
    ) -> Result<Vec<Self>, LabError> {
        let n = series.rows.len();
        let mut table = ChannelTable::builtin();
        let mut present = [false; N_COMMANDS];
        let mut inputs: Vec<Commands> = vec![[0.0; N_COMMANDS]; n];
        let mut series = series.clone();
        let mut notes = Vec::new();
        for (name, values) in commands {
            let c = table.intern(name).map_err(|e| LabError::Data {
                run: label.into(),
                detail: e.to_string(),
            })?;
            if values.len() != n {
                return Err(LabError::Data {
                    run: label.into(),
                    detail: format!(
                        "command channel {name} has {} values for {n} rows",
                        values.len()
                    ),
                });
            }
            let i = c.index();
            present[i] = true;
            let mut held = 0.0;
            let mut clamped = 0usize;
            for (row, (v, inp)) in series.rows.iter_mut().zip(values.iter().zip(&mut inputs)) {
                if v.is_finite() {
                    held = v.clamp(-100.0, 100.0);
                    clamped += usize::from(held != *v);
                }
                inp[i] = held;
                match c {
                    CommandChannel::PORT => row.port_pct = held,
                    CommandChannel::STARBOARD => row.starboard_pct = held,
                    CommandChannel::VERTICAL => row.vertical_pct = held,
                    _ => {}
                }
            }
            if clamped > 0 {
                notes.push(format!(
                    "{clamped} value(s) of command channel {name} outside -100..100 % clamped"
                ));
            }
        }
        // The Pro 4 view's channels not named keep the series' own columns.
        for c in [
            CommandChannel::PORT,
            CommandChannel::STARBOARD,
            CommandChannel::VERTICAL,
        ] {
            if !present[c.index()] {
                for (row, inp) in series.rows.iter().zip(&mut inputs) {
                    inp[c.index()] = match c {
                        CommandChannel::PORT => row.port_pct,
                        CommandChannel::STARBOARD => row.starboard_pct,
                        _ => row.vertical_pct,
                    };
                }
            }
        }
        let mut runs =
            crate::ingest::series_runs_with(&series, label, Some((inputs, present)), raw)?;
        for r in &mut runs {
            r.channels = table.clone();
            r.treatment.closed_loop = crate::ingest::feedback_links(r);
            r.treatment.notes.extend(notes.iter().cloned());
        }
        Ok(runs)
    }

    /// Re-indexes the run's commands to a model's channel table (by name): the table's
    /// channels take its indices, the run's other free channels follow (dropped, with a
    /// note, beyond the capacity). Built-in channels never move; a run and a table with
    /// the same free names in the same order are left as they are.
    pub fn align_channels(&mut self, table: &ChannelTable) {
        if self.channels == *table {
            return;
        }
        let mut target = table.clone();
        let mut dropped = Vec::new();
        for (k, n) in self.channels.free_names().iter().enumerate() {
            let from = rov_dynamics::models::vehicle::N_BUILTIN + k;
            if self.input_present.get(from).copied().unwrap_or(false) && target.intern(n).is_err() {
                dropped.push(n.clone());
            }
        }
        let map = target.remap_from(&self.channels);
        for c in &mut self.inputs {
            let old = *c;
            for (i, m) in map.iter().enumerate() {
                c[i] = m.and_then(|j| old.get(j).copied()).unwrap_or(0.0);
            }
        }
        let old = self.input_present;
        for (i, m) in map.iter().enumerate() {
            self.input_present[i] = m.and_then(|j| old.get(j).copied()).unwrap_or(false);
        }
        self.channels = target;
        if !dropped.is_empty() {
            self.treatment.notes.push(format!(
                "command channel(s) {} not read: the model's channels fill the command vector",
                dropped.join(", ")
            ));
        }
    }

    /// The name of one of the run's command channels.
    pub fn channel_name(&self, c: CommandChannel) -> String {
        self.channels
            .name(c)
            .map(str::to_string)
            .unwrap_or_else(|| format!("channel{}", c.index()))
    }

    /// [`Run::from_series`] with the full set of command channels (one vector per row and
    /// which channels are present) when the data has more than the Pro 4's three.
    pub fn from_series_inputs(
        series: &MeasurementSeries,
        name: &str,
        extra_inputs: Option<(Vec<Commands>, [bool; N_COMMANDS])>,
    ) -> Result<Self, LabError> {
        let n = series.rows.len();
        if n < 10 {
            return Err(LabError::Data {
                run: name.into(),
                detail: format!("{n} rows; the lab needs at least 10"),
            });
        }
        let t: Vec<f64> = series.rows.iter().map(|r| r.time_s).collect();
        if let Some(w) = t.windows(2).find(|w| w[1] - w[0] > 5.0) {
            return Err(LabError::Data {
                run: name.into(),
                detail: format!(
                    "gap of {:.1} s at t = {} s; split the run at gaps",
                    w[1] - w[0],
                    w[0]
                ),
            });
        }
        let cmd: Vec<ThrustPct> = series
            .rows
            .iter()
            .map(|r| ThrustPct::new(r.port_pct, r.starboard_pct, r.vertical_pct))
            .collect();
        let (inputs, input_present) = match extra_inputs {
            Some((i, p)) if i.len() == n => (i, p),
            _ => (cmd.iter().map(commands_of_pct).collect(), pro4_present()),
        };
        let all_segments = segments_of_inputs(&t, &cmd, &inputs, &input_present);
        let mut y: [Option<Vec<f64>>; N_CHANNELS] = Default::default();
        type Pick = fn(&rov_types::MeasurementRow) -> f64;
        let main: [(Channel, Pick); 4] = [
            (Channel::Depth, |r| r.depth_m),
            (Channel::Heading, |r| r.heading_deg),
            (Channel::Pitch, |r| r.pitch_deg),
            (Channel::Roll, |r| r.roll_deg),
        ];
        for (ch, pick) in main {
            let v: Vec<f64> = series.rows.iter().map(pick).collect();
            if v.iter().filter(|x| x.is_finite()).count() >= 10 {
                y[ch_index(ch)] = Some(v);
            }
        }
        for ch in Channel::ALL {
            let Some(opt) = ch.optional_column() else {
                continue;
            };
            if !series.present[opt as usize] {
                continue;
            }
            let v: Vec<f64> = series
                .rows
                .iter()
                .map(|r| r.get(opt).unwrap_or(f64::NAN))
                .collect();
            if v.iter().filter(|x| x.is_finite()).count() >= 10 {
                y[ch_index(ch)] = Some(v);
            }
        }
        // Isolated spikes (a sample far from both neighbours and from the local median)
        // are excluded before anything is estimated from the channel; an angle sample
        // interpolated across the wrap by the log's resampler counts as one (found
        // before unwrapping, which would make it half of a 360° step).
        let mut spikes = [0usize; N_CHANNELS];
        for ch in [Channel::Heading, Channel::Roll] {
            if let Some(h) = y[ch_index(ch)].as_mut() {
                spikes[ch_index(ch)] = crate::ingest::exclude_wrap_interpolations(h);
                unwrap_deg(h);
            }
        }
        for (i, v) in y.iter_mut().enumerate() {
            if let Some(v) = v.as_mut() {
                spikes[i] += crate::ingest::exclude_spikes(v);
            }
        }
        let mut noise = [0.0; N_CHANNELS];
        let mut smooth: [Option<Vec<f64>>; N_CHANNELS] = Default::default();
        let first = all_segments.first().copied();
        let first_len_s = first.map_or(0.0, |s| s.t_end_s - s.t_start_s);
        // The free run starts from the smoothed first sample. A one-sided 0.3 s quadratic
        // there has ~5× the variance of a centred one, and its error (an initial heave
        // velocity off by one noise σ) persists as an offset over the whole free run. When
        // the run starts with the thrusters at rest, the vehicle coasts smoothly, so the
        // first samples come from a straight line through the first [`START_WINDOW_S`] of
        // that rest instead (a measured rate whose line is within 3 standard errors of zero
        // starts at zero, like the rates derived below).
        let start_win = start_window(first.as_ref());
        for ch in Channel::ALL {
            let i = ch_index(ch);
            if let Some(v) = &y[i] {
                // Never below what quantisation alone leaves (q/√12 on a lattice of step q).
                noise[i] = noise_estimate(v)
                    .unwrap_or(0.0)
                    .max(noise_floor_min(ch))
                    .max(crate::analysis::quantisation_floor(v));
                let mut s: Vec<f64> = (0..n)
                    .map(|k| {
                        local_quadratic(&t, v, k, 0.3, 0.3)
                            .map(|(a, _)| a)
                            .unwrap_or(v[k])
                    })
                    .collect();
                if start_win > 0.0
                    && let Some((a, b, se)) = line_fit(&t, v, start_win)
                {
                    let is_rate = matches!(
                        ch,
                        Channel::Surge
                            | Channel::Sway
                            | Channel::Heave
                            | Channel::RollRate
                            | Channel::PitchRate
                            | Channel::YawRate
                    );
                    for k in 0..n {
                        let dt0 = t[k] - t[0];
                        if dt0 >= START_SPAN_S {
                            break;
                        }
                        s[k] = if is_rate && a.abs() <= 3.0 * se.0 && b.abs() <= 3.0 * se.1 {
                            0.0
                        } else {
                            a + b * dt0
                        };
                    }
                }
                smooth[i] = Some(s);
            }
        }
        // Initial rates: a straight-line fit over the first quiet stretch (at most 2 s),
        // kept only when clearly non-zero (a noisy slope would start a drift).
        let win = first_len_s.min(2.0);
        let slope = |ch: Channel| -> f64 {
            let Some(v) = y[ch_index(ch)].as_ref() else {
                return 0.0;
            };
            if win < 0.5 {
                return 0.0;
            }
            let pts: Vec<(f64, f64)> = t
                .iter()
                .zip(v)
                .take_while(|(ti, _)| **ti - t[0] <= win + 1e-9)
                .filter(|(_, yi)| yi.is_finite())
                .map(|(ti, yi)| (*ti - t[0], *yi))
                .collect();
            let m = pts.len() as f64;
            if m < 5.0 {
                return 0.0;
            }
            let (st, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
            let (mt, my) = (st / m, sy / m);
            let stt: f64 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
            let sty: f64 = pts.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum();
            if stt <= 0.0 {
                return 0.0;
            }
            let b = sty / stt;
            let res: f64 = pts
                .iter()
                .map(|p| (p.1 - my - b * (p.0 - mt)).powi(2))
                .sum::<f64>()
                / (m - 2.0);
            let se = (res / stt).sqrt();
            if b.abs() > 3.0 * se { b } else { 0.0 }
        };
        let opt_or = |ch: Channel, fallback: f64| -> f64 {
            y[ch_index(ch)]
                .as_ref()
                .and_then(|v| v.first().copied())
                .filter(|x| x.is_finite())
                .unwrap_or(fallback)
        };
        let nu0 = [
            opt_or(Channel::Surge, 0.0),
            opt_or(Channel::Sway, 0.0),
            opt_or(Channel::Heave, slope(Channel::Depth)),
            opt_or(Channel::RollRate, slope(Channel::Roll)).to_radians(),
            opt_or(Channel::PitchRate, slope(Channel::Pitch)).to_radians(),
            opt_or(Channel::YawRate, slope(Channel::Heading)).to_radians(),
        ];
        let segments = all_segments;
        let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        let treatment = Treatment {
            source: name.into(),
            segment: 1,
            segments: 1,
            spikes,
            dt_median_min_max_s: (
                dts.get(dts.len() / 2).copied().unwrap_or(0.0),
                dts.first().copied().unwrap_or(0.0),
                dts.last().copied().unwrap_or(0.0),
            ),
            ..Default::default()
        };
        Ok(Self {
            name: name.into(),
            t,
            cmd,
            inputs,
            input_present,
            channels: ChannelTable::builtin(),
            y,
            smooth,
            noise,
            segments,
            nu0,
            treatment,
        }
        .with_feedback_check())
    }

    /// Runs the closed-loop check (see [`crate::ingest::feedback_links`]) and records it.
    fn with_feedback_check(mut self) -> Self {
        self.treatment.closed_loop = crate::ingest::feedback_links(&self);
        self
    }

    /// Parses a measurement CSV text.
    pub fn from_csv(text: &str, name: &str) -> Result<Self, LabError> {
        let s = MeasurementSeries::parse_csv(text, name)?;
        Self::from_series(&s, name)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the run is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        match (self.t.first(), self.t.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// The measured samples of a channel, if present.
    pub fn channel(&self, ch: Channel) -> Option<&[f64]> {
        self.y[ch_index(ch)].as_deref()
    }

    /// Whether a channel was measured.
    pub fn has(&self, ch: Channel) -> bool {
        self.y[ch_index(ch)].is_some()
    }

    /// Sample indices where a shooting window starts: run start, then the first segment
    /// start at least `min_window_s` after the previous reset.
    pub fn shooting_starts(&self, min_window_s: f64) -> Vec<usize> {
        let mut out = vec![0];
        if !min_window_s.is_finite() {
            return out;
        }
        let mut last_t = self.t.first().copied().unwrap_or(0.0);
        for s in &self.segments {
            if s.start == 0 {
                continue;
            }
            if s.t_start_s - last_t >= min_window_s - 1e-9
                && self.t.last().is_some_and(|e| e - s.t_start_s >= 1.0)
            {
                out.push(s.start);
                last_t = s.t_start_s;
            }
        }
        out
    }

    /// Reset indices every `k` samples (k-step view).
    pub fn every_k(&self, k: usize) -> Vec<usize> {
        (0..self.len()).step_by(k.max(1)).collect()
    }

    /// Median sample period, s.
    pub fn median_dt(&self) -> f64 {
        let mut d: Vec<f64> = self.t.windows(2).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return 0.05;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    }

    /// Whether any thruster command takes both signs (reverse steps present) per
    /// thruster.
    pub fn reverse_present(&self) -> [bool; 3] {
        let mut r = [false; 3];
        for c in &self.cmd {
            r[0] |= c.port <= -5.0;
            r[1] |= c.starboard <= -5.0;
            r[2] |= c.vertical <= -5.0;
        }
        r
    }
}

/// A Pro 4 command as a command vector (the port, starboard and vertical channels).
pub fn commands_of_pct(c: &ThrustPct) -> Commands {
    let mut out = [0.0; N_COMMANDS];
    out[CommandChannel::PORT.index()] = c.port;
    out[CommandChannel::STARBOARD.index()] = c.starboard;
    out[CommandChannel::VERTICAL.index()] = c.vertical;
    out
}

/// The runs re-indexed to a channel table (borrowed as they are when every run already
/// uses it, the case of every Pro 4 model and every vehicle whose log names the same free
/// channels): the lab's entry points call it so a model reads each run's channels by name.
pub fn aligned<'a>(runs: &'a [Run], table: &ChannelTable) -> std::borrow::Cow<'a, [Run]> {
    if runs.iter().all(|r| r.channels == *table) {
        return std::borrow::Cow::Borrowed(runs);
    }
    std::borrow::Cow::Owned(
        runs.iter()
            .map(|r| {
                let mut r = r.clone();
                r.align_channels(table);
                r
            })
            .collect(),
    )
}

/// Constant-command segments of the Pro 4's three thrusters (a change of more than
/// 0.5 % starts a new one).
pub fn segments_of(t: &[f64], cmd: &[ThrustPct]) -> Vec<Segment> {
    let inputs: Vec<Commands> = cmd.iter().map(commands_of_pct).collect();
    segments_of_inputs(t, cmd, &inputs, &pro4_present())
}

/// Constant-command segments over every present command channel (a change of more than
/// 0.5 % in any channel starts a new one); kinds and levels from the Pro 4 view.
pub fn segments_of_inputs(
    t: &[f64],
    cmd: &[ThrustPct],
    inputs: &[Commands],
    present: &[bool; N_COMMANDS],
) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut start = 0;
    let changed = |a: &Commands, b: &Commands| {
        a.iter()
            .zip(b)
            .zip(present)
            .any(|((x, y), p)| *p && (x - y).abs() > 0.5)
    };
    for k in 1..=inputs.len() {
        if k == inputs.len() || changed(&inputs[k], &inputs[start]) {
            let c = cmd.get(start).copied().unwrap_or(ThrustPct::ZERO);
            let level = inputs[start]
                .iter()
                .zip(present)
                .filter(|(_, p)| **p)
                .map(|(x, _)| x.abs())
                .fold(0.0f64, f64::max);
            let any_on = level >= 0.5;
            let mut kind = SegmentKind::of(&c);
            if kind == SegmentKind::Rest && any_on {
                kind = SegmentKind::Combined;
            }
            out.push(Segment {
                start,
                end: k,
                t_start_s: t[start],
                t_end_s: t[k - 1],
                cmd: c,
                kind,
                level_pct: (level / 5.0).round() * 5.0,
            });
            start = k;
        }
    }
    out
}

/// Convenience: the optional-channel column of a channel (re-export for callers).
pub fn optional_of(ch: Channel) -> Option<OptionalChannel> {
    ch.optional_column()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(rows: &[(f64, f64, f64)]) -> String {
        let mut s = String::from(
            "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg\n",
        );
        for (t, v, h) in rows {
            s.push_str(&format!("{t},0,0,{v},1.0,{h},0,0\n"));
        }
        s
    }

    #[test]
    fn heading_is_unwrapped_and_segments_follow_command_changes() {
        let rows: Vec<(f64, f64, f64)> = (0..40)
            .map(|k| {
                let t = k as f64 * 0.1;
                let v = if (10..25).contains(&k) { 60.0 } else { 0.0 };
                (t, v, (350.0 + 2.0 * k as f64) % 360.0)
            })
            .collect();
        let run = Run::from_csv(&csv(&rows), "r").unwrap();
        let h = run.channel(Channel::Heading).unwrap();
        assert!((h[39] - (350.0 + 78.0)).abs() < 1e-9, "{}", h[39]);
        assert_eq!(run.segments.len(), 3);
        assert_eq!(run.segments[1].kind, SegmentKind::Vertical);
        assert_eq!(run.segments[1].start, 10);
        assert_eq!(run.segments[1].end, 25);
        assert_eq!(run.segments[1].level_pct, 60.0);
        assert!(!run.has(Channel::YawRate));
    }

    #[test]
    fn wrap_and_noise_floor() {
        assert_eq!(wrap180(190.0), -170.0);
        assert_eq!(wrap180(-180.0), 180.0);
        assert!((wrap180(720.5) - 0.5).abs() < 1e-12);
        // White noise of σ = 0.01 on a slow ramp: the third-difference estimate finds σ.
        let mut x = 12345u64;
        let v: Vec<f64> = (0..4000)
            .map(|k| {
                // Sum of uniforms ≈ normal (Irwin–Hall, 12 terms, σ = 1).
                let mut s = 0.0;
                for _ in 0..12 {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    s += (x >> 11) as f64 / (1u64 << 53) as f64;
                }
                k as f64 * 1e-3 + 0.01 * (s - 6.0)
            })
            .collect();
        let s = noise_estimate(&v).unwrap();
        assert!((s - 0.01).abs() < 0.0015, "{s}");
    }

    #[test]
    fn local_quadratic_is_exact_on_quadratics() {
        let t: Vec<f64> = (0..30).map(|k| k as f64 * 0.05).collect();
        let y: Vec<f64> = t.iter().map(|x| 1.0 + 2.0 * x - 3.0 * x * x).collect();
        let (v, s) = local_quadratic(&t, &y, 10, 0.3, 0.3).unwrap();
        assert!((v - y[10]).abs() < 1e-9);
        assert!((s - (2.0 - 6.0 * t[10])).abs() < 1e-9);
    }

    #[test]
    fn too_short_and_gappy_runs_are_rejected() {
        let rows: Vec<(f64, f64, f64)> = (0..5).map(|k| (k as f64, 0.0, 0.0)).collect();
        assert!(matches!(
            Run::from_csv(&csv(&rows), "s"),
            Err(LabError::Data { .. })
        ));
        let mut rows: Vec<(f64, f64, f64)> = (0..20).map(|k| (k as f64 * 0.1, 0.0, 0.0)).collect();
        rows[15].0 = 10.0;
        for (i, r) in rows.iter_mut().enumerate().skip(16) {
            r.0 = 10.0 + i as f64 * 0.1;
        }
        let e = Run::from_csv(&csv(&rows), "g").unwrap_err();
        assert!(e.to_string().contains("gap"), "{e}");
    }
}
