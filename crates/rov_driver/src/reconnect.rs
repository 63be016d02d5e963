//! The re-connection policy after the port vanished: when to try again and where to
//! look. Sans-IO and clock-free, like the [`Link`](crate::Link): the caller passes the
//! time and the list of ports it can see, opens and probes the candidates it is given,
//! and reports back. The station runtime drives it on the wall clock; the tests on
//! virtual time.
//!
//! # Schedule (style B7: "retry with backoff, 250 ms → 2 s")
//!
//! The first attempt runs `initial_backoff_us` (250 ms) after the loss: a device that has
//! just vanished is not back at once, and a USB adapter takes about a second to
//! re-enumerate. After each failed attempt the wait doubles, up to `max_backoff_us`
//! (2 s): attempts at +0.25 s, then 0.5 s, 1 s, 2 s, 2 s, … after the end of the previous
//! one. No jitter: one station talks to one vehicle, there is no crowd to spread out.
//!
//! # Candidates, in order
//!
//! 1. the port's stable `/dev/serial/by-id/…` name, if it had one when it was opened
//!    (the same USB adapter, found again wherever the kernel numbered it this time);
//! 2. the path where the port was last found, if it differs from the configured one;
//! 3. the configured path (a fixed name such as `/dev/ttyUSB0`, or a udev or socat
//!    symlink that may be re-pointed);
//! 4. if `scan_other_ports` is on, every other port the system lists, in name order.
//!
//! Every candidate must answer a probe before the link takes it, so "the same vehicle"
//! means: a Pro 4 at the configured node answering on the same adapter (by-id), at the
//! same name, or, failing both, on the first other port that answers.

use std::collections::BTreeMap;
use std::fmt;

use crate::config::check;
use crate::error::ConfigError;

/// Settings of the re-connection policy. Times in µs of the caller's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReconnectConfig {
    /// Wait before the first attempt, and the first backoff step (default 250 ms).
    pub initial_backoff_us: u64,
    /// Longest wait between attempts (default 2 s).
    pub max_backoff_us: u64,
    /// Also probe every other listed port (default true).
    pub scan_other_ports: bool,
    /// How long a candidate has to answer the probe (default 200 ms; for the caller).
    pub probe_timeout_us: u64,
    /// A summary of the attempts is due this often during a long outage (default 60 s).
    pub summary_every_us: u64,
}

impl Default for ReconnectConfig {
    fn default() -> Self {
        Self {
            initial_backoff_us: 250_000,
            max_backoff_us: 2_000_000,
            scan_other_ports: true,
            probe_timeout_us: 200_000,
            summary_every_us: 60_000_000,
        }
    }
}

impl ReconnectConfig {
    /// Checks every setting.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check(
            "reconnect.initial_backoff_us",
            self.initial_backoff_us,
            10_000,
            10_000_000,
        )?;
        check(
            "reconnect.max_backoff_us",
            self.max_backoff_us,
            self.initial_backoff_us,
            60_000_000,
        )?;
        check(
            "reconnect.probe_timeout_us",
            self.probe_timeout_us,
            10_000,
            5_000_000,
        )?;
        check(
            "reconnect.summary_every_us",
            self.summary_every_us,
            100_000,
            3_600_000_000,
        )
    }

    /// The wait after the `failed`-th failed attempt (1-based): initial × 2^failed,
    /// at most the maximum.
    #[must_use]
    pub fn backoff_after(&self, failed: u32) -> u64 {
        let factor = 1u64.checked_shl(failed.min(63)).unwrap_or(u64::MAX);
        self.initial_backoff_us
            .saturating_mul(factor)
            .min(self.max_backoff_us)
    }
}

/// Why a path is on the candidate list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CandidateSource {
    /// The port's stable by-id name.
    ById,
    /// Where the port was last found (differs from the configured path).
    LastPath,
    /// The configured path.
    Configured,
    /// Another port the system lists.
    Scan,
}

impl CandidateSource {
    /// Short name.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::ById => "by-id",
            Self::LastPath => "last path",
            Self::Configured => "configured path",
            Self::Scan => "scan",
        }
    }
}

/// A port to open and probe.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Candidate {
    /// Its path.
    pub path: String,
    /// Why it is tried.
    pub source: CandidateSource,
}

/// Where the re-connection stands, for displays.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReconnectStatus {
    /// When the port was lost, µs.
    pub lost_us: u64,
    /// Why.
    pub reason: String,
    /// The attempt running or next (1-based).
    pub attempt: u32,
    /// When the next attempt starts, µs; `None` while one is running.
    pub next_attempt_us: Option<u64>,
    /// Where the port was last open.
    pub last_path: String,
}

impl ReconnectStatus {
    /// "reconnecting (attempt n, next in t s)" at `now_us`, or "(attempt n, probing)"
    /// while it runs.
    #[must_use]
    pub fn describe(&self, now_us: u64) -> String {
        match self.next_attempt_us {
            Some(t) => format!(
                "reconnecting (attempt {}, next in {:.1} s)",
                self.attempt,
                t.saturating_sub(now_us) as f64 * 1e-6
            ),
            None => format!("reconnecting (attempt {}, probing)", self.attempt),
        }
    }
}

/// What an outage looked like: for the session's events.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutageSummary {
    /// When the port was lost, µs.
    pub lost_us: u64,
    /// How long it has lasted (or lasted), µs.
    pub duration_us: u64,
    /// Why the port was lost.
    pub reason: String,
    /// Attempts made (each one a pass over the candidates).
    pub attempts: u32,
    /// Failed candidates by path and reason, with counts, most frequent first.
    pub failures: Vec<(String, u32)>,
}

impl OutageSummary {
    /// "3 attempts: /dev/ttyUSB0: not present ×2; /dev/ttyUSB1: no answer ×1".
    #[must_use]
    pub fn attempts_text(&self) -> String {
        let mut out = format!(
            "{} attempt{}",
            self.attempts,
            if self.attempts == 1 { "" } else { "s" }
        );
        for (k, (what, n)) in self.failures.iter().enumerate() {
            out.push_str(if k == 0 { ": " } else { "; " });
            out.push_str(&format!("{what} ×{n}"));
        }
        out
    }
}

impl fmt::Display for OutageSummary {
    /// "lost 1.75 s ago (reason); 3 attempts: ...".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "lost {:.2} s ago ({}); {}",
            self.duration_us as f64 * 1e-6,
            self.reason,
            self.attempts_text()
        )
    }
}

/// Distinct failure kinds kept for the summary; the rest are counted as "other".
const MAX_FAILURE_KINDS: usize = 16;

#[derive(Debug, Clone)]
struct Outage {
    lost_us: u64,
    reason: String,
    attempts: u32,
    /// `None` while an attempt runs.
    next_attempt_us: Option<u64>,
    failures: BTreeMap<String, u32>,
    next_summary_us: u64,
}

/// The policy. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Reconnect {
    cfg: ReconnectConfig,
    configured: String,
    last_path: String,
    by_id: Option<String>,
    outage: Option<Outage>,
}

impl Reconnect {
    /// The port at `configured` is open, with its by-id name if it has one.
    ///
    /// # Errors
    /// [`ConfigError`] if a setting is out of range.
    pub fn new(
        cfg: ReconnectConfig,
        configured: &str,
        by_id: Option<String>,
    ) -> Result<Self, ConfigError> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            configured: configured.to_string(),
            last_path: configured.to_string(),
            by_id,
            outage: None,
        })
    }

    /// The settings.
    #[must_use]
    pub const fn config(&self) -> &ReconnectConfig {
        &self.cfg
    }

    /// The by-id name remembered for the port.
    #[must_use]
    pub fn by_id(&self) -> Option<&str> {
        self.by_id.as_deref()
    }

    /// Where the port was last open.
    #[must_use]
    pub fn last_path(&self) -> &str {
        &self.last_path
    }

    /// Whether the port is lost and being looked for.
    #[must_use]
    pub const fn is_reconnecting(&self) -> bool {
        self.outage.is_some()
    }

    /// The port was lost at `now_us` for `reason`. The first attempt is due after the
    /// initial backoff. A second call during the same outage changes nothing.
    pub fn lost(&mut self, now_us: u64, reason: &str) {
        if self.outage.is_some() {
            return;
        }
        self.outage = Some(Outage {
            lost_us: now_us,
            reason: reason.to_string(),
            attempts: 0,
            next_attempt_us: Some(now_us.saturating_add(self.cfg.initial_backoff_us)),
            failures: BTreeMap::new(),
            next_summary_us: now_us.saturating_add(self.cfg.summary_every_us),
        });
    }

    /// When the next attempt is due, µs (`None` when connected or while one runs).
    #[must_use]
    pub fn next_attempt_us(&self) -> Option<u64> {
        self.outage.as_ref().and_then(|o| o.next_attempt_us)
    }

    /// Starts an attempt if one is due at `now_us`: the candidates to open and probe, in
    /// order (see the module docs). `available` is what the system lists now. Report
    /// each failure with [`Reconnect::candidate_failed`], then either
    /// [`Reconnect::reconnected`] or [`Reconnect::attempt_failed`].
    pub fn start_attempt(&mut self, now_us: u64, available: &[String]) -> Option<Vec<Candidate>> {
        let o = self.outage.as_mut()?;
        if o.next_attempt_us.is_none_or(|t| now_us < t) {
            return None;
        }
        o.attempts = o.attempts.saturating_add(1);
        o.next_attempt_us = None;
        let mut out: Vec<Candidate> = Vec::new();
        let mut push = |path: &str, source| {
            if !path.is_empty() && !out.iter().any(|c| c.path == path) {
                out.push(Candidate {
                    path: path.to_string(),
                    source,
                });
            }
        };
        if let Some(b) = &self.by_id {
            push(b, CandidateSource::ById);
        }
        push(&self.last_path, CandidateSource::LastPath);
        push(&self.configured, CandidateSource::Configured);
        if self.cfg.scan_other_ports {
            let mut others: Vec<&String> = available.iter().collect();
            others.sort();
            for p in others {
                push(p, CandidateSource::Scan);
            }
        }
        // The last path is only "last" when it differs from the configured one.
        for c in &mut out {
            if c.source == CandidateSource::LastPath && c.path == self.configured {
                c.source = CandidateSource::Configured;
            }
        }
        Some(out)
    }

    /// A candidate of the running attempt failed (did not open, did not answer).
    pub fn candidate_failed(&mut self, candidate: &Candidate, why: &str) {
        let Some(o) = self.outage.as_mut() else {
            return;
        };
        let key = format!("{}: {why}", candidate.path);
        if o.failures.len() < MAX_FAILURE_KINDS || o.failures.contains_key(&key) {
            *o.failures.entry(key).or_insert(0) += 1;
        } else {
            *o.failures.entry("other".to_string()).or_insert(0) += 1;
        }
    }

    /// The running attempt found nothing; the next one is due after the backoff.
    pub fn attempt_failed(&mut self, now_us: u64) {
        let Some(o) = self.outage.as_mut() else {
            return;
        };
        let wait = self.cfg.backoff_after(o.attempts);
        o.next_attempt_us = Some(now_us.saturating_add(wait));
    }

    /// The vehicle answered on `path` at `now_us`; `by_id` is that port's by-id name if
    /// it has one (the old one is kept when the new port has none). Ends the outage and
    /// returns its summary (`None` if there was no outage).
    pub fn reconnected(
        &mut self,
        now_us: u64,
        path: &str,
        by_id: Option<String>,
    ) -> Option<OutageSummary> {
        let summary = self.summary(now_us);
        self.outage = None;
        path.clone_into(&mut self.last_path);
        if by_id.is_some() {
            self.by_id = by_id;
        }
        summary
    }

    /// The summary of the outage so far.
    #[must_use]
    pub fn summary(&self, now_us: u64) -> Option<OutageSummary> {
        let o = self.outage.as_ref()?;
        let mut failures: Vec<(String, u32)> =
            o.failures.iter().map(|(k, n)| (k.clone(), *n)).collect();
        failures.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        Some(OutageSummary {
            lost_us: o.lost_us,
            duration_us: now_us.saturating_sub(o.lost_us),
            reason: o.reason.clone(),
            attempts: o.attempts,
            failures,
        })
    }

    /// A summary if one is due at `now_us` (every `summary_every_us` of an outage).
    pub fn due_summary(&mut self, now_us: u64) -> Option<OutageSummary> {
        let every = self.cfg.summary_every_us;
        let o = self.outage.as_mut()?;
        if now_us < o.next_summary_us {
            return None;
        }
        o.next_summary_us = now_us.saturating_add(every);
        self.summary(now_us)
    }

    /// Where the re-connection stands (`None` when connected).
    #[must_use]
    pub fn status(&self) -> Option<ReconnectStatus> {
        let o = self.outage.as_ref()?;
        Some(ReconnectStatus {
            lost_us: o.lost_us,
            reason: o.reason.clone(),
            attempt: if o.next_attempt_us.is_some() {
                o.attempts.saturating_add(1)
            } else {
                o.attempts
            },
            next_attempt_us: o.next_attempt_us,
            last_path: self.last_path.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1000;

    fn ports(p: &[&str]) -> Vec<String> {
        p.iter().map(|s| (*s).to_string()).collect()
    }

    fn paths(c: &[Candidate]) -> Vec<(&str, CandidateSource)> {
        c.iter().map(|c| (c.path.as_str(), c.source)).collect()
    }

    /// The B7 schedule on virtual time: first attempt 250 ms after the loss, then
    /// waits of 0.5, 1, 2, 2, 2 s after each failed attempt; never early.
    #[test]
    fn backoff_schedule_250_ms_to_2_s() {
        let mut r = Reconnect::new(ReconnectConfig::default(), "/dev/ttyUSB0", None).unwrap();
        assert_eq!(r.next_attempt_us(), None);
        r.lost(1_000 * MS, "port gone (EIO)");
        let mut starts = Vec::new();
        let mut t = 1_000 * MS;
        while starts.len() < 7 {
            // Each attempt takes 30 ms of probing.
            if let Some(c) = r.start_attempt(t, &[]) {
                starts.push(t - 1_000 * MS);
                assert_eq!(r.next_attempt_us(), None);
                assert!(r.start_attempt(t, &[]).is_none(), "one attempt at a time");
                for cand in &c {
                    r.candidate_failed(cand, "not present");
                }
                t += 30 * MS;
                r.attempt_failed(t);
            } else {
                t += MS;
            }
        }
        // Start times relative to the loss: 250, +30+500, +30+1000, +30+2000, ...
        assert_eq!(
            starts,
            vec![
                250 * MS,
                780 * MS,
                1_810 * MS,
                3_840 * MS,
                5_870 * MS,
                7_900 * MS,
                9_930 * MS
            ]
        );
        let c = ReconnectConfig::default();
        assert_eq!(
            (1..=6).map(|k| c.backoff_after(k)).collect::<Vec<_>>(),
            vec![
                500 * MS,
                1000 * MS,
                2000 * MS,
                2000 * MS,
                2000 * MS,
                2000 * MS
            ]
        );
        assert_eq!(c.backoff_after(u32::MAX), 2000 * MS);
    }

    #[test]
    fn candidate_order_by_id_then_paths_then_scan() {
        let by_id = "/dev/serial/by-id/usb-FTDI_FT232R_A50285BI-if00-port0";
        let mut r = Reconnect::new(
            ReconnectConfig::default(),
            "/dev/ttyUSB0",
            Some(by_id.into()),
        )
        .unwrap();
        r.lost(0, "port gone (EIO)");
        let c = r
            .start_attempt(
                250 * MS,
                &ports(&["/dev/ttyUSB1", "/dev/ttyACM0", "/dev/ttyUSB0"]),
            )
            .unwrap();
        assert_eq!(
            paths(&c),
            vec![
                (by_id, CandidateSource::ById),
                ("/dev/ttyUSB0", CandidateSource::Configured),
                ("/dev/ttyACM0", CandidateSource::Scan),
                ("/dev/ttyUSB1", CandidateSource::Scan),
            ]
        );
        // Found by the scan at another path: that path comes before the configured
        // one next time, after the by-id name.
        let s = r.reconnected(400 * MS, "/dev/ttyUSB1", None).unwrap();
        assert_eq!(s.attempts, 1);
        assert!(!r.is_reconnecting());
        r.lost(10_000 * MS, "port gone (EIO)");
        let c = r
            .start_attempt(10_250 * MS, &ports(&["/dev/ttyUSB1"]))
            .unwrap();
        assert_eq!(
            paths(&c),
            vec![
                (by_id, CandidateSource::ById),
                ("/dev/ttyUSB1", CandidateSource::LastPath),
                ("/dev/ttyUSB0", CandidateSource::Configured),
            ]
        );
    }

    #[test]
    fn no_scan_when_switched_off() {
        let cfg = ReconnectConfig {
            scan_other_ports: false,
            ..ReconnectConfig::default()
        };
        let mut r = Reconnect::new(cfg, "/tmp/ttyV0", None).unwrap();
        r.lost(0, "hang-up");
        let c = r
            .start_attempt(250 * MS, &ports(&["/dev/ttyUSB3"]))
            .unwrap();
        assert_eq!(paths(&c), vec![("/tmp/ttyV0", CandidateSource::Configured)]);
    }

    #[test]
    fn status_and_summaries() {
        let cfg = ReconnectConfig {
            summary_every_us: 10_000 * MS,
            ..ReconnectConfig::default()
        };
        let mut r = Reconnect::new(cfg, "/dev/ttyUSB0", None).unwrap();
        assert_eq!(r.status(), None);
        r.lost(2_000 * MS, "port gone (EIO): Input/output error");
        r.lost(2_100 * MS, "ignored: same outage");
        let s = r.status().unwrap();
        assert_eq!((s.attempt, s.next_attempt_us), (1, Some(2_250 * MS)));
        assert_eq!(s.reason, "port gone (EIO): Input/output error");
        assert_eq!(
            s.describe(2_000 * MS),
            "reconnecting (attempt 1, next in 0.2 s)"
        );
        let mut t = 2_000 * MS;
        let mut summaries = Vec::new();
        while t < 23_000 * MS {
            if let Some(c) = r.start_attempt(t, &ports(&["/dev/ttyUSB1"])) {
                assert_eq!(
                    r.status().unwrap().describe(t),
                    format!(
                        "reconnecting (attempt {}, probing)",
                        r.status().unwrap().attempt
                    )
                );
                r.candidate_failed(&c[0], "not present");
                r.candidate_failed(&c[1], "no answer");
                r.attempt_failed(t);
            }
            if let Some(s) = r.due_summary(t) {
                summaries.push(s);
            }
            t += 10 * MS;
        }
        // Summaries at 10 s and 20 s into the outage.
        assert_eq!(
            summaries.iter().map(|s| s.duration_us).collect::<Vec<_>>(),
            vec![10_000 * MS, 20_000 * MS]
        );
        let s = r.reconnected(23_000 * MS, "/dev/ttyUSB0", None).unwrap();
        // 250 ms, +500, +1 s, +2 s, … : attempts at 0.25, 0.75, 1.75, 3.75, 5.75, …, 19.75.
        assert_eq!(s.attempts, 12);
        assert_eq!(s.duration_us, 21_000 * MS);
        assert_eq!(
            s.failures,
            vec![
                ("/dev/ttyUSB0: not present".to_string(), 12),
                ("/dev/ttyUSB1: no answer".to_string(), 12)
            ]
        );
        assert_eq!(
            s.to_string(),
            "lost 21.00 s ago (port gone (EIO): Input/output error); 12 attempts: \
             /dev/ttyUSB0: not present ×12; /dev/ttyUSB1: no answer ×12"
        );
        assert_eq!(r.status(), None);
        assert_eq!(r.reconnected(23_000 * MS, "/dev/ttyUSB0", None), None);
    }

    #[test]
    fn failure_kinds_are_bounded() {
        let mut r = Reconnect::new(ReconnectConfig::default(), "/dev/ttyUSB0", None).unwrap();
        r.lost(0, "EOF");
        let c = Candidate {
            path: "x".into(),
            source: CandidateSource::Scan,
        };
        for k in 0..100 {
            r.candidate_failed(&c, &format!("reason {k}"));
        }
        let s = r.summary(0).unwrap();
        assert_eq!(s.failures.len(), MAX_FAILURE_KINDS + 1);
        assert_eq!(
            s.failures[0],
            ("other".to_string(), 100 - MAX_FAILURE_KINDS as u32)
        );
    }

    #[test]
    fn settings_are_checked() {
        let bad = ReconnectConfig {
            max_backoff_us: 100_000,
            ..ReconnectConfig::default()
        };
        assert_eq!(
            Reconnect::new(bad, "p", None)
                .map(|_| ())
                .unwrap_err()
                .field,
            "reconnect.max_backoff_us"
        );
        assert!(ReconnectConfig::default().validate().is_ok());
    }
}
