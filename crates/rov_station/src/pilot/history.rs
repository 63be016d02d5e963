//! Telemetry history for plots.
//!
//! * [`History`]: a columnar store (time as `f64`, values as `f32`), contiguous per column
//!   so a plot can binary-search the time column and scan a slice. The last hour at 50 Hz
//!   (by default) is kept at full rate; older samples are not dropped but folded, in
//!   blocks, into a decimated tier in front of them: a minimum/maximum pair per channel and
//!   per bucket of [`COARSE_BUCKET_S`] (the bucket doubles whenever the tier outgrows half
//!   the capacity). So the "all" plot window of an 8-hour dive shows its whole envelope,
//!   and the store never holds more than 1.5 × capacity samples (≈ 16 MB by default),
//!   however long the station runs.
//! * The runtime does not share its store with the GUI: each tick appends one
//!   [`HistorySample`] to a small shared ring ([`HistoryFeed`]) under a lock held for
//!   a copy only, and the GUI pulls new samples into its own [`History`] once per frame
//!   ([`crate::runtime::StationHandle::sync_history`]). A GUI that stalls longer than
//!   the ring holds loses samples (counted), never ticks.

use std::collections::VecDeque;

/// One plotted sample (one control tick, or one replayed navigation record).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HistorySample {
    /// Station time, s.
    pub t_s: f64,
    /// Measured depth, m (NaN when unknown).
    pub depth_m: f32,
    /// Depth setpoint, m (NaN when not holding).
    pub depth_sp_m: f32,
    /// Observer depth estimate, m.
    pub depth_est_m: f32,
    /// The chosen model's depth prediction, m.
    pub depth_pred_m: f32,
    /// Measured heading, degrees 0..360.
    pub heading_deg: f32,
    /// Heading setpoint, degrees.
    pub heading_sp_deg: f32,
    /// Observer heading estimate, degrees.
    pub heading_est_deg: f32,
    /// The chosen model's heading prediction, degrees.
    pub heading_pred_deg: f32,
    /// Pitch, degrees, nose up.
    pub pitch_deg: f32,
    /// Roll, degrees, starboard down.
    pub roll_deg: f32,
    /// Port thrust command, %.
    pub port_pct: f32,
    /// Starboard thrust command, %.
    pub starboard_pct: f32,
    /// Vertical thrust command, % (positive down).
    pub vertical_pct: f32,
}

/// A value channel of the history.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// [`HistorySample::depth_m`].
    Depth,
    /// [`HistorySample::depth_sp_m`].
    DepthSetpoint,
    /// [`HistorySample::depth_est_m`].
    DepthEstimate,
    /// [`HistorySample::depth_pred_m`].
    DepthPrediction,
    /// [`HistorySample::heading_deg`].
    Heading,
    /// [`HistorySample::heading_sp_deg`].
    HeadingSetpoint,
    /// [`HistorySample::heading_est_deg`].
    HeadingEstimate,
    /// [`HistorySample::heading_pred_deg`].
    HeadingPrediction,
    /// [`HistorySample::pitch_deg`].
    Pitch,
    /// [`HistorySample::roll_deg`].
    Roll,
    /// [`HistorySample::port_pct`].
    Port,
    /// [`HistorySample::starboard_pct`].
    Starboard,
    /// [`HistorySample::vertical_pct`].
    Vertical,
}

impl Channel {
    /// Every channel, in column order.
    pub const ALL: [Channel; 13] = [
        Channel::Depth,
        Channel::DepthSetpoint,
        Channel::DepthEstimate,
        Channel::DepthPrediction,
        Channel::Heading,
        Channel::HeadingSetpoint,
        Channel::HeadingEstimate,
        Channel::HeadingPrediction,
        Channel::Pitch,
        Channel::Roll,
        Channel::Port,
        Channel::Starboard,
        Channel::Vertical,
    ];

    /// Whether the channel is an angle that wraps at 0/360.
    #[must_use]
    pub const fn wraps(self) -> bool {
        matches!(
            self,
            Channel::Heading
                | Channel::HeadingSetpoint
                | Channel::HeadingEstimate
                | Channel::HeadingPrediction
        )
    }

    const fn of(self, s: &HistorySample) -> f32 {
        match self {
            Channel::Depth => s.depth_m,
            Channel::DepthSetpoint => s.depth_sp_m,
            Channel::DepthEstimate => s.depth_est_m,
            Channel::DepthPrediction => s.depth_pred_m,
            Channel::Heading => s.heading_deg,
            Channel::HeadingSetpoint => s.heading_sp_deg,
            Channel::HeadingEstimate => s.heading_est_deg,
            Channel::HeadingPrediction => s.heading_pred_deg,
            Channel::Pitch => s.pitch_deg,
            Channel::Roll => s.roll_deg,
            Channel::Port => s.port_pct,
            Channel::Starboard => s.starboard_pct,
            Channel::Vertical => s.vertical_pct,
        }
    }
}

/// One hour at 50 Hz.
pub const DEFAULT_CAPACITY: usize = 3600 * 50;

/// The first bucket of the decimated tier, s.
pub const COARSE_BUCKET_S: f64 = 1.0;

/// The columnar store; see the module docs.
#[derive(Debug, Clone)]
pub struct History {
    capacity: usize,
    t: Vec<f64>,
    cols: Vec<Vec<f32>>,
    /// Samples `[0, coarse_len)` are the decimated tier.
    coarse_len: usize,
    /// Its bucket, s.
    bucket_s: f64,
    /// Full-rate samples folded into the decimated tier, and lost in transfer.
    dropped: u64,
    lost: u64,
    /// Sequence number of the next sample expected from the feed.
    next_seq: u64,
    epoch: u64,
}

impl Default for History {
    fn default() -> Self {
        Self::with_capacity(DEFAULT_CAPACITY)
    }
}

impl History {
    /// An empty store keeping at most `capacity` samples (at least 16).
    #[must_use]
    pub fn with_capacity(capacity: usize) -> Self {
        let capacity = capacity.max(16);
        Self {
            capacity,
            t: Vec::new(),
            cols: vec![Vec::new(); Channel::ALL.len()],
            coarse_len: 0,
            bucket_s: COARSE_BUCKET_S,
            dropped: 0,
            lost: 0,
            next_seq: 0,
            epoch: 0,
        }
    }

    /// Capacity at full rate, samples.
    #[must_use]
    pub const fn capacity(&self) -> usize {
        self.capacity
    }

    /// Samples of the decimated tier (at the start of the columns).
    #[must_use]
    pub const fn coarse_len(&self) -> usize {
        self.coarse_len
    }

    /// The decimated tier's bucket, s.
    #[must_use]
    pub const fn coarse_bucket_s(&self) -> f64 {
        self.bucket_s
    }

    /// Time of the first full-rate sample, s (`None` when empty).
    #[must_use]
    pub fn full_rate_from_s(&self) -> Option<f64> {
        self.t.get(self.coarse_len).copied()
    }

    /// Number of samples held (both tiers).
    #[must_use]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether it is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Full-rate samples folded into the decimated tier because of the capacity.
    #[must_use]
    pub const fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Samples lost between the runtime and this store (the GUI stalled too long).
    #[must_use]
    pub const fn lost(&self) -> u64 {
        self.lost
    }

    /// Removes everything (keeps the capacity).
    pub fn clear(&mut self) {
        self.t.clear();
        for c in &mut self.cols {
            c.clear();
        }
        self.coarse_len = 0;
        self.bucket_s = COARSE_BUCKET_S;
    }

    /// Appends a sample (times should not decrease; a sample older than the last one is
    /// still appended, plots tolerate it).
    pub fn push(&mut self, s: &HistorySample) {
        if self.t.len() - self.coarse_len >= self.capacity {
            // Fold the oldest eighth of the full-rate samples at once: amortised O(1) per
            // sample, contiguous columns.
            let n = (self.capacity / 8).max(1);
            let end = (self.coarse_len + n).min(self.t.len());
            self.dropped += (end - self.coarse_len) as u64;
            let added = self.fold(self.coarse_len, end, self.bucket_s);
            self.coarse_len += added;
            while self.coarse_len > self.capacity / 2 && self.bucket_s < 1e9 {
                self.bucket_s *= 2.0;
                self.coarse_len = self.fold(0, self.coarse_len, self.bucket_s);
            }
        }
        self.t.push(s.t_s);
        for (c, ch) in self.cols.iter_mut().zip(Channel::ALL) {
            c.push(ch.of(s));
        }
    }

    /// Replaces the samples `[a, b)` by a minimum/maximum pair per channel and per bucket
    /// of `bucket_s` (runs of at most two samples stay as they are); returns the number of
    /// samples that replace them.
    fn fold(&mut self, a: usize, b: usize, bucket_s: f64) -> usize {
        let (Some(ts), true) = (self.t.get(a..b), bucket_s > 0.0) else {
            return 0;
        };
        // Groups of consecutive samples in the same bucket.
        let mut groups: Vec<(usize, usize)> = Vec::new();
        let mut start = 0usize;
        for i in 1..=ts.len() {
            let split = match (ts.get(i), ts.get(start)) {
                (Some(x), Some(s0)) => (x / bucket_s).floor() != (s0 / bucket_s).floor(),
                _ => true,
            };
            if split {
                groups.push((start, i));
                start = i;
            }
        }
        let mut new_t: Vec<f64> = Vec::with_capacity(groups.len() * 2);
        let mut new_cols: Vec<Vec<f32>> =
            vec![Vec::with_capacity(groups.len() * 2); self.cols.len()];
        for &(g0, g1) in &groups {
            let (Some(&ta), Some(&tb)) = (ts.get(g0), ts.get(g1 - 1)) else {
                continue;
            };
            if g1 - g0 <= 2 {
                for i in g0..g1 {
                    new_t.push(ts.get(i).copied().unwrap_or(f64::NAN));
                    for (nc, c) in new_cols.iter_mut().zip(&self.cols) {
                        nc.push(c.get(a + i).copied().unwrap_or(f32::NAN));
                    }
                }
                continue;
            }
            new_t.push(ta);
            new_t.push(tb);
            for (nc, c) in new_cols.iter_mut().zip(&self.cols) {
                let vals = c.get(a + g0..a + g1).unwrap_or(&[]);
                let (lo, hi) = vals
                    .iter()
                    .filter(|x| !x.is_nan())
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| {
                        (lo.min(x), hi.max(x))
                    });
                if lo > hi {
                    nc.push(f32::NAN);
                    nc.push(f32::NAN);
                    continue;
                }
                let first = vals.iter().copied().find(|x| !x.is_nan()).unwrap_or(lo);
                let (x0, x1) = if (first - lo).abs() <= (hi - first).abs() {
                    (lo, hi)
                } else {
                    (hi, lo)
                };
                nc.push(x0);
                nc.push(x1);
            }
        }
        let n = new_t.len();
        self.t.splice(a..b, new_t);
        for (c, nc) in self.cols.iter_mut().zip(new_cols) {
            let e = b.min(c.len());
            c.splice(a.min(e)..e, nc);
        }
        n
    }

    /// The time column, s.
    #[must_use]
    pub fn times(&self) -> &[f64] {
        &self.t
    }

    /// A value column.
    #[must_use]
    pub fn column(&self, ch: Channel) -> &[f32] {
        let i = Channel::ALL.iter().position(|c| *c == ch).unwrap_or(0);
        self.cols.get(i).map_or(&[], Vec::as_slice)
    }

    /// First and last time, s.
    #[must_use]
    pub fn time_span(&self) -> Option<(f64, f64)> {
        Some((*self.t.first()?, *self.t.last()?))
    }

    /// Index range of the samples with `t0 <= t <= t1`.
    #[must_use]
    pub fn range(&self, t0: f64, t1: f64) -> std::ops::Range<usize> {
        let a = self.t.partition_point(|&t| t < t0);
        let b = self.t.partition_point(|&t| t <= t1);
        a..b.max(a)
    }

    /// The sample at index `i`.
    #[must_use]
    pub fn sample(&self, i: usize) -> Option<HistorySample> {
        let t_s = *self.t.get(i)?;
        let v = |ch: Channel| self.column(ch).get(i).copied().unwrap_or(f32::NAN);
        Some(HistorySample {
            t_s,
            depth_m: v(Channel::Depth),
            depth_sp_m: v(Channel::DepthSetpoint),
            depth_est_m: v(Channel::DepthEstimate),
            depth_pred_m: v(Channel::DepthPrediction),
            heading_deg: v(Channel::Heading),
            heading_sp_deg: v(Channel::HeadingSetpoint),
            heading_est_deg: v(Channel::HeadingEstimate),
            heading_pred_deg: v(Channel::HeadingPrediction),
            pitch_deg: v(Channel::Pitch),
            roll_deg: v(Channel::Roll),
            port_pct: v(Channel::Port),
            starboard_pct: v(Channel::Starboard),
            vertical_pct: v(Channel::Vertical),
        })
    }

    /// Approximate heap size, bytes.
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        self.t.capacity() * 8 + self.cols.iter().map(|c| c.capacity() * 4).sum::<usize>()
    }
}

/// Samples the shared ring holds (80 s at 50 Hz).
pub const FEED_CAPACITY: usize = 4096;

/// The shared ring between the runtime (writer) and one reader; see the module docs.
#[derive(Debug)]
pub struct HistoryFeed {
    ring: VecDeque<HistorySample>,
    /// Sequence number of the first sample in the ring.
    first_seq: u64,
    /// Bumped when the writer restarts the history (replay seek, new session).
    epoch: u64,
    /// A complete replacement (replay seek) for the reader to take.
    replacement: Option<History>,
}

impl Default for HistoryFeed {
    fn default() -> Self {
        Self {
            ring: VecDeque::with_capacity(FEED_CAPACITY),
            first_seq: 0,
            epoch: 0,
            replacement: None,
        }
    }
}

impl HistoryFeed {
    /// Appends samples, dropping the oldest beyond the ring's capacity.
    pub fn extend(&mut self, samples: impl IntoIterator<Item = HistorySample>) {
        for s in samples {
            if self.ring.len() >= FEED_CAPACITY {
                self.ring.pop_front();
                self.first_seq += 1;
            }
            self.ring.push_back(s);
        }
    }

    /// Replaces the whole history (the reader takes `history` and continues from the
    /// samples appended after this call).
    pub fn replace(&mut self, history: History) {
        self.epoch += 1;
        self.first_seq += self.ring.len() as u64;
        self.ring.clear();
        self.replacement = Some(history);
    }

    /// Copies what `into` has not seen yet; returns the number of samples added.
    pub fn pull(&mut self, into: &mut History) -> usize {
        if into.epoch != self.epoch {
            match self.replacement.clone() {
                Some(mut h) => {
                    h.epoch = self.epoch;
                    h.next_seq = self.first_seq;
                    h.lost = into.lost;
                    *into = h;
                }
                None => {
                    into.clear();
                    into.epoch = self.epoch;
                    into.next_seq = self.first_seq;
                }
            }
        }
        if into.next_seq < self.first_seq {
            into.lost += self.first_seq - into.next_seq;
            into.next_seq = self.first_seq;
        }
        let skip = usize::try_from(into.next_seq - self.first_seq).unwrap_or(usize::MAX);
        let mut n = 0;
        for s in self.ring.iter().skip(skip) {
            into.push(s);
            n += 1;
        }
        into.next_seq += n as u64;
        n
    }
}

/// Min/max decimation for plotting: at most `2 · buckets` points of `(t, v)` from the
/// index range: each bucket's minimum and maximum (the one nearer the bucket's first
/// value first), placed at the bucket's first and last sample times. Runs of equal values
/// collapse to their end points (setpoints cost a few points). NaN values are skipped; a
/// bucket (or, for short ranges, a sample) with none gives one `[t, NaN]` break marker, so
/// a plot can end the line there (no hold engaged, no data). The inner loop is a plain min/max fold, so one hour
/// of 50 Hz data decimates in well under a millisecond.
#[must_use]
pub fn decimate_min_max(
    t: &[f64],
    v: &[f32],
    range: std::ops::Range<usize>,
    buckets: usize,
) -> Vec<[f64; 2]> {
    let end = range.end.min(t.len()).min(v.len());
    let start = range.start.min(end);
    let (Some(ts), Some(vs)) = (t.get(start..end), v.get(start..end)) else {
        return Vec::new();
    };
    let n = ts.len();
    let buckets = buckets.max(1);
    let mut out: Vec<[f64; 2]> = Vec::with_capacity((2 * buckets).min(n));
    let mut push = |p: [f64; 2]| {
        let len = out.len();
        if p[1].is_nan() {
            // One break marker between runs of data.
            if out.last().is_some_and(|l| !l[1].is_nan()) || len == 0 {
                out.push(p);
            }
            return;
        }
        // Drop the middle of three equal values.
        if len >= 2
            && let (Some(a), Some(b)) = (out.get(len - 2), out.get(len - 1))
            && a[1] == b[1]
            && b[1] == p[1]
        {
            if let Some(last) = out.last_mut() {
                *last = p;
            }
            return;
        }
        out.push(p);
    };
    if n <= 2 * buckets {
        for (&t, &x) in ts.iter().zip(vs) {
            push([
                t,
                if x.is_finite() {
                    f64::from(x)
                } else {
                    f64::NAN
                },
            ]);
        }
        return out;
    }
    for b in 0..buckets {
        let i0 = b * n / buckets;
        let i1 = ((b + 1) * n / buckets).min(n);
        let (Some(bt), Some(bv)) = (ts.get(i0..i1), vs.get(i0..i1)) else {
            continue;
        };
        let (lo, hi) = bv
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        if !(lo.is_finite() && hi.is_finite()) {
            if let Some(&ta) = bt.first() {
                push([ta, f64::NAN]);
            }
            continue;
        }
        let (Some(&ta), Some(&tb)) = (bt.first(), bt.last()) else {
            continue;
        };
        let first = bv.iter().copied().find(|x| x.is_finite()).unwrap_or(lo);
        let (a, z) = if (first - lo).abs() <= (hi - first).abs() {
            (lo, hi)
        } else {
            (hi, lo)
        };
        push([ta, f64::from(a)]);
        push([tb, f64::from(z)]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, depth: f32) -> HistorySample {
        HistorySample {
            t_s: t,
            depth_m: depth,
            ..HistorySample::default()
        }
    }

    #[test]
    fn capacity_folds_old_samples_into_the_decimated_tier() {
        let mut h = History::with_capacity(80);
        for i in 0..200 {
            h.push(&sample(f64::from(i) * 0.1, i as f32));
        }
        assert!(h.len() - h.coarse_len() <= 80);
        assert_eq!(h.times().last(), Some(&(199.0 * 0.1)));
        assert_eq!(h.column(Channel::Depth).len(), h.len());
        assert_eq!(h.dropped() as usize + h.len() - h.coarse_len(), 200);
        // The full-rate part is intact.
        let r = h.range(15.0, 15.95);
        assert_eq!(r.len(), 10);
        // The folded part keeps every second's extremes, in time order.
        let coarse = h.column(Channel::Depth).get(..h.coarse_len()).unwrap();
        assert_eq!(coarse.first(), Some(&0.0));
        assert!(coarse.contains(&9.0) && coarse.contains(&10.0));
        assert!(h.times().windows(2).all(|w| w[0] <= w[1]));
    }

    /// Eight hours at 50 Hz through the default store: bounded, and the whole dive's
    /// envelope is still there.
    #[test]
    fn eight_hours_stay_bounded_with_the_whole_envelope() {
        let mut h = History::default();
        let n = 8 * 3600 * 50;
        let mut peak = 0usize;
        for k in 0..n {
            let t = f64::from(k) * 0.02;
            let mut s = sample(t, (t / 600.0).sin() as f32);
            if k == 1000 {
                s.depth_m = 50.0; // one spike in the first minute
            }
            h.push(&s);
            peak = peak.max(h.len());
        }
        assert!(peak <= DEFAULT_CAPACITY * 3 / 2 + 16, "{peak}");
        assert!(h.heap_bytes() < 32 << 20, "{}", h.heap_bytes());
        assert_eq!(h.time_span(), Some((0.0, f64::from(n - 1) * 0.02)));
        let d = h.column(Channel::Depth);
        assert!(d.contains(&50.0), "the spike survives decimation");
        let full_from = h.full_rate_from_s().unwrap();
        assert!(
            (full_from - (8.0 - 1.0) * 3600.0).abs() < 600.0,
            "{full_from}"
        );
        assert!(h.coarse_bucket_s() >= COARSE_BUCKET_S);
    }

    #[test]
    fn feed_transfers_counts_losses_and_replaces() {
        let mut feed = HistoryFeed::default();
        let mut h = History::default();
        feed.extend((0..10).map(|i| sample(f64::from(i), 0.0)));
        assert_eq!(feed.pull(&mut h), 10);
        assert_eq!(feed.pull(&mut h), 0);
        feed.extend((10..(10 + FEED_CAPACITY as i32 + 5)).map(|i| sample(f64::from(i), 0.0)));
        let n = feed.pull(&mut h);
        assert_eq!(n, FEED_CAPACITY);
        assert_eq!(h.lost(), 5);
        let mut r = History::default();
        r.push(&sample(-1.0, 3.0));
        feed.replace(r);
        feed.extend([sample(100.0, 4.0)]);
        feed.pull(&mut h);
        assert_eq!(h.times(), &[-1.0, 100.0]);
    }

    #[test]
    fn decimation_keeps_extremes() {
        let t: Vec<f64> = (0..10_000).map(f64::from).collect();
        let mut v: Vec<f32> = (0..10_000).map(|i| (i % 7) as f32).collect();
        v[5000] = 100.0;
        v[7000] = -50.0;
        v[100] = f32::NAN;
        let pts: Vec<[f64; 2]> = decimate_min_max(&t, &v, 0..t.len(), 100)
            .into_iter()
            .filter(|p| !p[1].is_nan())
            .collect();
        assert!(pts.len() <= 200);
        assert!(pts.iter().any(|p| p[1] == 100.0));
        assert!(pts.iter().any(|p| p[1] == -50.0));
        assert!(pts.windows(2).all(|w| w[0][0] <= w[1][0]));
        let few = decimate_min_max(&t, &v, 10..20, 100);
        assert_eq!(few.len(), 10);
        let gap = decimate_min_max(&t, &v, 95..105, 100);
        assert_eq!(gap.iter().filter(|p| p[1].is_nan()).count(), 1, "{gap:?}");
        // A constant (setpoint) series collapses to its ends.
        let flat = vec![2.0f32; 10_000];
        let pts = decimate_min_max(&t, &flat, 0..t.len(), 100);
        assert_eq!(pts, vec![[0.0, 2.0], [9999.0, 2.0]]);
    }
}
