//! Long logs streamed into the lab, decimated to a bounded number of rows.
//!
//! An 8-hour session at 50 Hz has 1.44 M measurement rows; held whole as rows and then as
//! a [`Run`] (with its smoothed copies, predictions and residuals) it needed about 1 GB.
//! The lab does not need 50 Hz over hours: the simulator integrates every interval in
//! sub-steps of at most its own step ([`crate::sim`]), so a longer interval between
//! samples costs no integration accuracy, only comparison points. So a log is read one
//! row at a time ([`LogStream::push`]) and, when it has more than [`MAX_LAB_ROWS`] rows,
//! decimated while it streams:
//!
//! * **Plan.** The factor k = ⌈rows / [`MAX_LAB_ROWS`]⌉ comes from the row count known
//!   before reading (an MCAP session's summary counts its nav messages), so a log of at
//!   most [`MAX_LAB_ROWS`] rows (k = 1) takes exactly the path it always took and gives
//!   exactly the results it always gave.
//! * **Measurements.** Every k-th row is kept as it was sampled (a point sample, not an
//!   average: its noise is the sensor's, as the noise floor below says).
//! * **Commands.** The command held from a kept row to the next is the time-weighted mean
//!   of the raw commands held over that interval (the same impulse to first order; a
//!   block whose commands are all equal keeps the value bit for bit).
//! * **Gaps.** A raw interval longer than [`crate::ingest::GAP_MIN_S`]/k ends a block, and
//!   the row before it is kept on its own, so the interval survives exactly; every other
//!   kept interval spans at most k raw intervals of at most GAP_MIN_S/k and so is never
//!   taken for a gap. The gap rule itself uses the raw median interval.
//! * **Noise floors and intervals** are measured on the raw rows while they stream (third
//!   differences, as [`Run`] does, into a log-binned histogram: the median within 0.2 %
//!   in constant memory), so a decimated run reports the sensor's noise, not the signal's
//!   change over k samples. Spikes are still excluded on the kept samples.
//!
//! What it changes on a long log (said in the run's treatment notes): the comparison
//! points are k times fewer (metrics over ⌈n/k⌉ samples of the same time span), the
//! commands within a kept interval are averaged (a closed-loop command changing every
//! sample is smoothed over k samples), and the smoothed re-initialisation values use the
//! kept samples of the same ±0.3 s window.
//!
//! Measured on a 2-hour closed-loop `record --sim` dive with model3 (the ignored test
//! `long_session::lab_decimation_changes_compare_little`): at 2:1 the multiple-shooting
//! RMSE of every channel above 1e-3 moves by at most 3.8 % and the noise floors by
//! < 0.2 %. At 8:1 (an 8-hour session's factor) the noise floors still agree, but the
//! shooting RMSE rises by up to 49 % (depth; heading 21 %, rates 15–21 %) and the
//! free-run depth error 38-fold: an autopilot's 50 Hz command averaged over 160 ms does
//! not give the thrust of the raw sequence (the thrust map is not linear), and the
//! re-initialisation quadratic has only ~4 samples in its window. So 8:1 numbers are
//! comparable with each other, not with a full-rate comparison. The remedy (not done
//! yet): keep the raw command sequence (3 × f32 per raw row, 17 MB for 8 hours) for the
//! simulator and smooth the re-initialisation values from the raw rows while streaming.

use rov_dynamics::models::Channel;
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

use crate::LabError;
use crate::data::{
    N_CHANNELS, NOISE_MIN_DIFFERENCES, Run, Unwrapper, ch_index, noise_floor_min,
    noise_from_median, third_difference,
};
use crate::ingest::{GAP_MEDIAN_FACTOR, GAP_MIN_S};

/// Most rows the lab keeps of one log; a longer log is decimated (about 1.1 h at 50 Hz).
pub const MAX_LAB_ROWS: usize = 200_000;

/// The decimation factor for a log of `rows` rows: 1 (none) up to [`MAX_LAB_ROWS`].
pub fn decimation_factor(rows: usize) -> usize {
    rows.div_ceil(MAX_LAB_ROWS).max(1)
}

/// Exponent range of [`LogHistogram`] (values below 2⁻⁴⁰ ≈ 9e-13 count as zero, above
/// 2²⁴ as 2²⁴).
const HIST_EXP_MIN: i64 = -40;
const HIST_EXP_MAX: i64 = 24;
/// Bins per octave (the top mantissa bits): relative bin width 2⁻⁸.
const HIST_MANTISSA_BITS: u32 = 8;

/// Counts of non-negative values in log-spaced bins, for a median in constant memory.
#[derive(Debug, Clone)]
struct LogHistogram {
    /// Values below the first bin (zero included).
    small: u64,
    bins: Vec<u64>,
    total: u64,
}

impl LogHistogram {
    fn new() -> Self {
        Self {
            small: 0,
            bins: vec![0; ((HIST_EXP_MAX - HIST_EXP_MIN) as usize) << HIST_MANTISSA_BITS],
            total: 0,
        }
    }

    fn add(&mut self, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            return;
        }
        self.total += 1;
        let bits = x.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i64 - 1023;
        if exp < HIST_EXP_MIN {
            self.small += 1;
            return;
        }
        let last = self.bins.len() - 1;
        let i = if exp >= HIST_EXP_MAX {
            last
        } else {
            let m = (bits >> (52 - HIST_MANTISSA_BITS)) & ((1 << HIST_MANTISSA_BITS) - 1);
            (((exp - HIST_EXP_MIN) as usize) << HIST_MANTISSA_BITS) + m as usize
        };
        if let Some(b) = self.bins.get_mut(i.min(last)) {
            *b += 1;
        }
    }

    /// The value of rank ⌊total/2⌋ (the median the in-memory estimate takes), as the
    /// middle of its bin; `None` when empty.
    fn median(&self) -> Option<f64> {
        if self.total == 0 {
            return None;
        }
        let rank = self.total / 2;
        if rank < self.small {
            return Some(0.0);
        }
        let mut seen = self.small;
        for (i, c) in self.bins.iter().enumerate() {
            seen += c;
            if rank < seen {
                let exp = (i >> HIST_MANTISSA_BITS) as i64 + HIST_EXP_MIN;
                let m = (i & ((1 << HIST_MANTISSA_BITS) - 1)) as f64;
                let width = f64::from(1u32 << HIST_MANTISSA_BITS);
                return Some(2f64.powi(exp as i32) * (1.0 + (m + 0.5) / width));
            }
        }
        Some(2f64.powi(HIST_EXP_MAX as i32))
    }
}

/// A channel's value in a row (NaN when absent).
fn channel_value(row: &MeasurementRow, ch: Channel) -> f64 {
    match ch {
        Channel::Depth => row.depth_m,
        Channel::Heading => row.heading_deg,
        Channel::Pitch => row.pitch_deg,
        Channel::Roll => row.roll_deg,
        other => other
            .optional_column()
            .and_then(|c| row.get(c))
            .unwrap_or(f64::NAN),
    }
}

/// The raw-rate noise estimate of one channel, built while the rows stream.
#[derive(Debug, Clone)]
struct NoiseAcc {
    unwrap: Option<Unwrapper>,
    last: [f64; 3],
    seen: usize,
    hist: LogHistogram,
}

impl NoiseAcc {
    fn new(ch: Channel) -> Self {
        Self {
            unwrap: crate::data::ch_wraps(ch).then(Unwrapper::default),
            last: [f64::NAN; 3],
            seen: 0,
            hist: LogHistogram::new(),
        }
    }

    fn push(&mut self, x: f64) {
        let x = match self.unwrap.as_mut() {
            Some(u) => u.next(x),
            None => x,
        };
        if self.seen >= 3 {
            let d = third_difference([self.last[0], self.last[1], self.last[2], x]);
            if d.is_finite() {
                self.hist.add(d);
            }
        }
        self.last = [self.last[1], self.last[2], x];
        self.seen += 1;
    }

    fn noise(&self) -> Option<f64> {
        if self.hist.total < NOISE_MIN_DIFFERENCES as u64 {
            return None;
        }
        self.hist.median().map(noise_from_median)
    }
}

/// What the raw rows of a decimated log showed (applied to its runs by
/// [`RawStats::apply`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RawStats {
    /// Raw rows read.
    pub rows: usize,
    /// Rows kept.
    pub kept: usize,
    /// The decimation factor.
    pub factor: usize,
    /// Raw median, smallest and largest interval, s.
    pub dt_median_min_max_s: (f64, f64, f64),
    /// White-noise σ per channel at the raw rate (index as [`Channel::ALL`]).
    pub noise: [Option<f64>; N_CHANNELS],
}

impl RawStats {
    /// The interval above which the log is split (the rule of [`crate::ingest`] on the
    /// raw median interval), s.
    pub fn gap_limit_s(&self) -> f64 {
        GAP_MIN_S.max(GAP_MEDIAN_FACTOR * self.dt_median_min_max_s.0)
    }

    /// Gives a run built from the kept rows the raw noise floors and intervals, and says
    /// in its treatment what was done.
    pub fn apply(&self, run: &mut Run) {
        for ch in Channel::ALL {
            let i = ch_index(ch);
            if run.y[i].is_some()
                && let Some(s) = self.noise[i]
            {
                run.noise[i] = s.max(noise_floor_min(ch));
            }
        }
        run.treatment.dt_median_min_max_s = self.dt_median_min_max_s;
        let (med, _, _) = self.dt_median_min_max_s;
        run.treatment.notes.push(format!(
            "long log: {} rows decimated {}:1 to {} for the lab (one sample kept every {:.3} s; commands averaged over each kept interval; noise floors and intervals from all rows)",
            self.rows,
            self.factor,
            self.kept,
            med * self.factor as f64
        ));
    }
}

/// A block of raw rows becoming one kept row.
#[derive(Debug, Clone, Copy)]
struct Block {
    /// The kept row (its measurements; its command is replaced by the block's mean).
    first: MeasurementRow,
    /// Rows in the block, the pending one included.
    n: usize,
    /// Σ command × interval over the rows before the pending one.
    cmd_dt: [f64; 3],
    /// Σ interval over the rows before the pending one, s.
    dt: f64,
    /// Whether every command so far equals the first row's.
    same: bool,
    /// The last row, whose interval is not known yet.
    pending: MeasurementRow,
}

fn cmd_of(r: &MeasurementRow) -> [f64; 3] {
    [r.port_pct, r.starboard_pct, r.vertical_pct]
}

impl Block {
    fn start(row: &MeasurementRow) -> Self {
        Self {
            first: *row,
            n: 1,
            cmd_dt: [0.0; 3],
            dt: 0.0,
            same: true,
            pending: *row,
        }
    }

    /// The pending row's command held for `dt`.
    fn settle(&mut self, dt: f64) {
        for (s, c) in self.cmd_dt.iter_mut().zip(cmd_of(&self.pending)) {
            *s += c * dt;
        }
        self.dt += dt;
    }

    /// The kept row: the first row's measurements and the block's mean command.
    fn kept(&self) -> MeasurementRow {
        let mut row = self.first;
        if !self.same && self.dt > 0.0 {
            let [p, s, v] = self.cmd_dt.map(|x| x / self.dt);
            row.port_pct = p;
            row.starboard_pct = s;
            row.vertical_pct = v;
        }
        row
    }
}

/// A log read one row at a time into lab runs (see the module docs).
#[derive(Debug)]
pub struct LogStream {
    label: String,
    factor: usize,
    /// The rows kept (all of them when the factor is 1).
    rows: Vec<MeasurementRow>,
    block: Option<Block>,
    raw_rows: usize,
    last_t: Option<f64>,
    noise: Vec<NoiseAcc>,
    dt_hist: LogHistogram,
    dt_min: f64,
    dt_max: f64,
}

impl LogStream {
    /// A stream for a log `label` expected to have `expected_rows` rows (the plan: see
    /// [`decimation_factor`]).
    pub fn new(label: &str, expected_rows: usize) -> Self {
        let factor = decimation_factor(expected_rows);
        Self {
            label: label.to_string(),
            factor,
            rows: Vec::with_capacity(expected_rows.div_ceil(factor).min(MAX_LAB_ROWS + 1)),
            block: None,
            raw_rows: 0,
            last_t: None,
            noise: if factor > 1 {
                Channel::ALL.iter().map(|c| NoiseAcc::new(*c)).collect()
            } else {
                Vec::new()
            },
            dt_hist: LogHistogram::new(),
            dt_min: f64::INFINITY,
            dt_max: 0.0,
        }
    }

    /// The decimation factor planned (1 = every row kept).
    pub fn factor(&self) -> usize {
        self.factor
    }

    /// Rows read so far.
    pub fn rows_read(&self) -> usize {
        self.raw_rows
    }

    /// The next row (time increasing, as a session's rows are).
    pub fn push(&mut self, row: &MeasurementRow) {
        self.raw_rows += 1;
        if self.factor == 1 {
            self.rows.push(*row);
            return;
        }
        for (acc, ch) in self.noise.iter_mut().zip(Channel::ALL) {
            acc.push(channel_value(row, ch));
        }
        let dt = self.last_t.map(|t| row.time_s - t);
        self.last_t = Some(row.time_s);
        if let Some(d) = dt {
            self.dt_hist.add(d);
            self.dt_min = self.dt_min.min(d);
            self.dt_max = self.dt_max.max(d);
        }
        let (Some(mut b), Some(dt)) = (self.block.take(), dt) else {
            self.block = Some(Block::start(row));
            return;
        };
        if dt > GAP_MIN_S / self.factor as f64 {
            // A long interval: the rows before the pending one are one block, the pending
            // row another, so the interval is kept exactly.
            if b.n > 1 {
                self.rows.push(b.kept());
            }
            let mut last = Block::start(&b.pending);
            last.settle(dt);
            self.rows.push(last.kept());
            self.block = Some(Block::start(row));
            return;
        }
        b.settle(dt);
        if b.n >= self.factor {
            self.rows.push(b.kept());
            self.block = Some(Block::start(row));
            return;
        }
        b.same &= cmd_of(row) == cmd_of(&b.first);
        b.n += 1;
        b.pending = *row;
        self.block = Some(b);
    }

    /// The kept rows as a series (`present`: the optional columns the log has) and, when
    /// the log was decimated, what its raw rows showed.
    pub fn finish_series(mut self, present: [bool; 8]) -> (MeasurementSeries, Option<RawStats>) {
        if let Some(mut b) = self.block.take() {
            // The last row's interval is unknown: weight it like the block's others.
            let w = if b.n > 1 {
                b.dt / (b.n - 1) as f64
            } else {
                1.0
            };
            b.settle(w);
            self.rows.push(b.kept());
        }
        let kept = self.rows.len();
        let series = MeasurementSeries {
            rows: self.rows,
            present,
            warnings: Vec::new(),
        };
        if self.factor == 1 {
            return (series, None);
        }
        let mut noise = [None; N_CHANNELS];
        for (n, acc) in noise.iter_mut().zip(&self.noise) {
            *n = acc.noise();
        }
        let med = self.dt_hist.median().unwrap_or(0.0);
        let stats = RawStats {
            rows: self.raw_rows,
            kept,
            factor: self.factor,
            dt_median_min_max_s: (
                med,
                if self.dt_min.is_finite() {
                    self.dt_min
                } else {
                    0.0
                },
                self.dt_max,
            ),
            noise,
        };
        (series, Some(stats))
    }

    /// The log as runs split at gaps (as [`crate::ingest::series_runs`] does), with the
    /// raw noise floors when decimated.
    pub fn finish(self, present: [bool; 8]) -> Result<Vec<Run>, LabError> {
        self.finish_log(present).runs()
    }

    /// The log read ([`crate::loader::LoadedLog`]: its rows before they become runs).
    pub fn finish_log(self, present: [bool; 8]) -> crate::loader::LoadedLog {
        let label = self.label.clone();
        let (series, raw) = self.finish_series(present);
        crate::loader::LoadedLog::from_stream(&label, series, raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rov_types::measurement::OptionalChannel;

    /// A 50 Hz log: steps of the port thruster every 7 s, a noisy depth and a yaw rate.
    fn row(k: usize, seed: &mut u64) -> MeasurementRow {
        let t = k as f64 * 0.02;
        let mut noise = || {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((*seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
        };
        let mut r = MeasurementRow {
            time_s: t,
            port_pct: if (t / 7.0) as usize % 2 == 1 {
                40.0
            } else {
                0.0
            },
            starboard_pct: 0.0,
            vertical_pct: 10.0,
            depth_m: 2.0 + 0.3 * (t * 0.05).sin() + noise(),
            heading_deg: (t * 7.0) % 360.0,
            pitch_deg: 0.5 * noise(),
            roll_deg: 0.5 * noise(),
            optional: [None; 8],
        };
        r.set(OptionalChannel::YawRateDps, Some(7.0 + 10.0 * noise()));
        r
    }

    #[test]
    fn the_plan_keeps_short_logs_whole() {
        assert_eq!(decimation_factor(0), 1);
        assert_eq!(decimation_factor(MAX_LAB_ROWS), 1);
        assert_eq!(decimation_factor(MAX_LAB_ROWS + 1), 2);
        assert_eq!(decimation_factor(1_440_000), 8);
    }

    #[test]
    fn a_short_log_is_kept_row_for_row() {
        let mut seed = 1;
        let rows: Vec<MeasurementRow> = (0..3000).map(|k| row(k, &mut seed)).collect();
        let mut s = LogStream::new("short", rows.len());
        for r in &rows {
            s.push(r);
        }
        let mut present = [false; 8];
        present[OptionalChannel::YawRateDps as usize] = true;
        let (series, raw) = s.finish_series(present);
        assert!(raw.is_none());
        assert_eq!(series.rows, rows);
    }

    #[test]
    fn histogram_median_is_within_its_bin() {
        let mut h = LogHistogram::new();
        let v: Vec<f64> = (1..=1001).map(|k| k as f64 * 1e-3).collect();
        for x in &v {
            h.add(*x);
        }
        let m = h.median().unwrap();
        assert!((m / 0.501 - 1.0).abs() < 2f64.powi(-8), "{m}");
        let mut z = LogHistogram::new();
        for _ in 0..5 {
            z.add(0.0);
        }
        z.add(1.0);
        assert_eq!(z.median(), Some(0.0));
    }

    #[test]
    fn decimation_keeps_point_samples_mean_commands_raw_noise_and_gaps() {
        let mut seed = 7;
        let mut rows: Vec<MeasurementRow> = (0..20_000).map(|k| row(k, &mut seed)).collect();
        // A 3 s gap after row 10_003 (not a multiple of the factor).
        for r in rows.iter_mut().skip(10_004) {
            r.time_s += 3.0;
        }
        // The planned factor for a long log, forced on a short one for the test.
        let mut s = LogStream::new("long", 8 * MAX_LAB_ROWS);
        assert_eq!(s.factor(), 8);
        for r in &rows {
            s.push(r);
        }
        let mut present = [false; 8];
        present[OptionalChannel::YawRateDps as usize] = true;
        let (series, raw) = s.finish_series(present);
        let raw = raw.unwrap();
        assert_eq!(raw.rows, 20_000);
        assert_eq!(raw.kept, series.rows.len());
        assert!(series.rows.len() < 20_000 / 8 + 3, "{}", series.rows.len());
        // Every kept row is a raw row's measurement, at its time.
        for k in &series.rows {
            let r = rows.iter().find(|r| r.time_s == k.time_s).unwrap();
            assert_eq!(r.depth_m, k.depth_m);
            assert_eq!(r.optional, k.optional);
        }
        // The held command integrates like the raw one (the same impulse per interval).
        for w in series.rows.windows(2) {
            let (a, b) = (w[0].time_s, w[1].time_s);
            let raw_impulse: f64 = rows
                .windows(2)
                .filter(|p| p[0].time_s >= a && p[0].time_s < b)
                .map(|p| p[0].port_pct * (p[1].time_s - p[0].time_s))
                .sum();
            assert!(
                (raw_impulse - w[0].port_pct * (b - a)).abs() < 1e-9,
                "{a}–{b}: {raw_impulse} vs {}",
                w[0].port_pct * (b - a)
            );
        }
        // Constant commands stay bit for bit.
        assert!(series.rows.iter().all(|r| r.vertical_pct == 10.0));
        // The gap is one kept interval of exactly its raw length.
        let gaps: Vec<f64> = series
            .rows
            .windows(2)
            .map(|w| w[1].time_s - w[0].time_s)
            .filter(|d| *d > raw.gap_limit_s())
            .collect();
        assert_eq!(gaps.len(), 1);
        assert!((gaps[0] - 3.02).abs() < 1e-9, "{gaps:?}");
        // The noise floors are the raw ones: uniform noise of width 0.02 (σ = 0.02/√12)
        // on depth; the estimate from kept samples would see the same σ, but the yaw rate
        // (σ = 0.2/√12 ≈ 0.058) is measured from all 20,000 rows.
        let depth = raw.noise[ch_index(Channel::Depth)].unwrap();
        assert!(
            (depth / (0.02 / 12f64.sqrt()) - 1.0).abs() < 0.15,
            "{depth}"
        );
        let r = raw.noise[ch_index(Channel::YawRate)].unwrap();
        assert!((r / (0.2 / 12f64.sqrt()) - 1.0).abs() < 0.15, "{r}");
        // The wrapped heading unwraps before differencing: a steady turn has no noise.
        let h = raw.noise[ch_index(Channel::Heading)].unwrap();
        assert!(h < 1e-6, "{h}");
        assert!((raw.dt_median_min_max_s.0 - 0.02).abs() < 0.02 * 2f64.powi(-8));
        assert!((raw.dt_median_min_max_s.2 - 3.02).abs() < 1e-9);
        // And the runs: split at the gap, with the raw floors and a note.
        let runs = crate::ingest::series_runs_with(&series, "long", None, Some(&raw)).unwrap();
        assert_eq!(runs.len(), 2);
        for run in &runs {
            assert_eq!(run.noise[ch_index(Channel::Depth)], depth.max(0.002));
            assert!(
                run.treatment
                    .notes
                    .iter()
                    .any(|n| n.contains("decimated 8:1")),
                "{:?}",
                run.treatment.notes
            );
        }
    }
}
