//! The station's model watch (issue 23): [`rov_lab::watch::Watch`] fed the rows the
//! session export would write (each navigation reply with the thrust command in force),
//! on a thread of its own in the live station, so its short-window simulations never
//! touch the control tick: the control thread only builds a row and `try_send`s it (a
//! full queue drops the row and counts it; the watch treats the hole as a gap). On
//! virtual time ([`crate::runtime::VirtualStation`]) the same watch runs inline, so a
//! `record --fast` dive gets exactly the alerts a live dive would.

use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::thread::JoinHandle;

use rov_lab::LabModel;
use rov_lab::watch::{Alert, Watch, WatchConfig};
use rov_types::measurement::MeasurementRow;

use crate::runtime::RuntimeError;

/// Rows queued for the watch thread before new ones are dropped (~20 s at 10 Hz nav).
const QUEUE_ROWS: usize = 256;

/// Where the watch runs.
enum Runner {
    /// Not started yet (the first row decides, with what it carries).
    Pending,
    /// On the caller's thread (virtual time).
    Inline(Box<Watch>),
    /// On its own thread.
    Thread {
        rows: SyncSender<MeasurementRow>,
        alerts: Receiver<Alert>,
        join: Option<JoinHandle<()>>,
    },
    /// Could not start (the reason was logged once).
    Failed,
}

/// The station's watch: rows in, alerts out; see the module docs.
pub struct StationWatch {
    model: LabModel,
    cfg: WatchConfig,
    inline: bool,
    queue_rows: usize,
    runner: Runner,
    /// Rows dropped because the watch thread was behind.
    pub dropped_rows: u64,
    /// Rows given to the watch.
    pub rows: u64,
    /// Why it stopped, if it did.
    pub error: Option<String>,
}

impl std::fmt::Debug for StationWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StationWatch")
            .field("inline", &self.inline)
            .field("rows", &self.rows)
            .field("dropped_rows", &self.dropped_rows)
            .finish_non_exhaustive()
    }
}

impl StationWatch {
    /// A watch of `model`; `inline`: run on the caller's thread (virtual time).
    #[must_use]
    pub fn new(model: LabModel, inline: bool) -> Self {
        Self {
            model,
            cfg: WatchConfig::default(),
            inline,
            queue_rows: QUEUE_ROWS,
            runner: Runner::Pending,
            dropped_rows: 0,
            rows: 0,
            error: None,
        }
    }

    /// Runs on the caller's thread from now on (before the first row).
    pub fn set_inline(&mut self) {
        if matches!(self.runner, Runner::Pending) {
            self.inline = true;
        }
    }

    fn start(&mut self, present: [bool; 8]) -> Result<(), RuntimeError> {
        let watch = Watch::new(self.model.clone(), self.cfg, present);
        if self.inline {
            self.runner = Runner::Inline(Box::new(watch));
            return Ok(());
        }
        let (row_tx, row_rx) = std::sync::mpsc::sync_channel::<MeasurementRow>(self.queue_rows);
        let (alert_tx, alert_rx) = std::sync::mpsc::channel::<Alert>();
        let join = crate::runtime::spawn_named("station-watch", move || {
            let mut w = watch;
            while let Ok(row) = row_rx.recv() {
                for a in w.push(&row) {
                    if alert_tx.send(a).is_err() {
                        return;
                    }
                }
            }
        })?;
        self.runner = Runner::Thread {
            rows: row_tx,
            alerts: alert_rx,
            join: Some(join),
        };
        Ok(())
    }

    /// Takes one row (never blocks); returns the alerts that are ready (inline: this
    /// row's; threaded: whatever the thread finished since the last call).
    pub fn push(&mut self, row: MeasurementRow) -> Vec<Alert> {
        if matches!(self.runner, Runner::Pending) {
            let present = std::array::from_fn(|i| row.optional.get(i).is_some_and(Option::is_some));
            if let Err(e) = self.start(present) {
                self.error = Some(format!("the model watch could not start: {e}"));
                self.runner = Runner::Failed;
            }
        }
        self.rows += 1;
        match &mut self.runner {
            Runner::Inline(w) => w.push(&row),
            Runner::Thread { rows, .. } => {
                match rows.try_send(row) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => self.dropped_rows += 1,
                    Err(TrySendError::Disconnected(_)) => {
                        self.error = Some("the model watch's thread stopped".into());
                        self.runner = Runner::Failed;
                    }
                }
                self.poll()
            }
            Runner::Pending | Runner::Failed => Vec::new(),
        }
    }

    /// Alerts the thread has finished (none inline: they come with the row).
    pub fn poll(&mut self) -> Vec<Alert> {
        let mut out = Vec::new();
        if let Runner::Thread { alerts, .. } = &self.runner {
            while let Ok(a) = alerts.try_recv() {
                out.push(a);
            }
        }
        out
    }

    /// Whether the watch is running (it may still be learning its noise floor).
    #[must_use]
    pub fn running(&self) -> bool {
        matches!(self.runner, Runner::Inline(_) | Runner::Thread { .. })
    }
}

impl Drop for StationWatch {
    fn drop(&mut self) {
        if let Runner::Thread { join, .. } = &mut self.runner {
            let j = join.take();
            // Dropping the sender ends the thread's loop.
            self.runner = Runner::Failed;
            if let Some(j) = j {
                crate::runtime::join_or_warn(j);
            }
        }
    }
}

/// The row of one navigation reply with the thrust command in force (the session
/// export's row: [`rov_types::measurement`] columns, body rates in deg/s).
#[must_use]
pub fn nav_row(t_s: f64, thrust_pct: [f64; 3], t: &rov_driver::Telemetry) -> MeasurementRow {
    let mut optional = [None; 8];
    optional[0] = Some(t.yaw_rate_radps.to_degrees());
    optional[1] = Some(t.pitch_rate_radps.to_degrees());
    optional[2] = Some(t.roll_rate_radps.to_degrees());
    MeasurementRow {
        time_s: t_s,
        port_pct: thrust_pct[0],
        starboard_pct: thrust_pct[1],
        vertical_pct: thrust_pct[2],
        depth_m: t.depth_m,
        heading_deg: t.heading_deg,
        pitch_deg: t.pitch_deg,
        roll_deg: t.roll_deg,
        optional,
    }
}

/// 10 Hz rows of the simulated model 3 flown open loop through slow command changes
/// (turning and heaving), with the given `--fault` specs: the watch's test and bench
/// dive, written by the simulator (not by the watch's own model).
///
/// # Errors
/// [`SimulatedRowsError`]: a fault spec that does not parse, or a simulator error.
pub fn simulated_rows(
    n: usize,
    faults: &[&str],
) -> Result<Vec<MeasurementRow>, SimulatedRowsError> {
    use rov_dynamics::ThrustPct;
    let cfg = rov_sim::SimConfig::default_model3()?;
    let mut sim = rov_sim::Simulator::new(cfg, 3)?;
    let specs = faults
        .iter()
        .map(|f| rov_sim::FaultSpec::parse(f))
        .collect::<Result<Vec<_>, _>>()?;
    sim.set_faults(specs);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * 0.1;
        let phase = (t / 7.0).sin();
        let cmd = ThrustPct {
            port: 30.0 + 15.0 * phase,
            starboard: 30.0 - 15.0 * phase,
            vertical: 10.0 * (t / 11.0).cos(),
        };
        sim.set_command(cmd)?;
        sim.advance_to(t)?;
        let s = sim.sensors();
        let mut optional = [None; 8];
        optional[0] = Some(s.gyro_body_radps.z.to_degrees());
        optional[1] = Some(s.gyro_body_radps.y.to_degrees());
        optional[2] = Some(s.gyro_body_radps.x.to_degrees());
        out.push(MeasurementRow {
            time_s: t,
            port_pct: cmd.port,
            starboard_pct: cmd.starboard,
            vertical_pct: cmd.vertical,
            depth_m: s.depth_from_pressure_m,
            heading_deg: s.heading_rad.to_degrees(),
            pitch_deg: s.pitch_rad.to_degrees(),
            roll_deg: s.roll_rad.to_degrees(),
            optional,
        });
    }
    Ok(out)
}

/// Why [`simulated_rows`] could not fly its dive.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimulatedRowsError {
    /// The simulator refused its configuration or a step.
    #[error(transparent)]
    Sim(#[from] rov_sim::SimError),
    /// A `--fault` spec does not parse.
    #[error(transparent)]
    Fault(#[from] rov_sim::fault::FaultSpecError),
}

#[cfg(test)]
mod tests {
    use super::*;
    /// The dive with a 0.8-m depth-sensor jump at 150 s.
    fn rows() -> Vec<MeasurementRow> {
        simulated_rows(2000, &["depth-sensor:jump:0.8@150"]).unwrap()
    }

    fn model3() -> LabModel {
        rov_lab::load_model(
            &rov_types::ModelId::Base(rov_types::BaseModel::Model3),
            None,
        )
        .unwrap()
    }

    #[test]
    fn the_thread_gives_the_alerts_the_inline_watch_gives() {
        let rows = rows();
        let mut inline = StationWatch::new(model3(), true);
        let mut threaded = StationWatch::new(model3(), false);
        // Room for the whole dive: this test offers rows far faster than 10 Hz.
        threaded.queue_rows = 4096;
        let mut a = Vec::new();
        let mut b = Vec::new();
        for r in &rows {
            a.extend(inline.push(*r));
            b.extend(threaded.push(*r));
        }
        // Whatever the thread has not sent yet arrives once it has caught up.
        for _ in 0..3000 {
            b.extend(threaded.poll());
            if b.len() >= a.len() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        assert_eq!(threaded.dropped_rows, 0);
        assert_eq!(a, b);
        let change = a
            .iter()
            .find(|x| x.kind == rov_lab::watch::AlertKind::Change)
            .expect("the depth jump");
        assert_eq!(change.channel, "depth");
        assert_eq!(
            change.causes.first().map(|c| c.cause.as_str()),
            Some("depth-sensor")
        );
        assert!((change.t_s - 150.0).abs() < 1.0, "{change:?}");
    }

    #[test]
    fn a_full_queue_drops_rows_and_never_blocks() {
        let mut w = StationWatch::new(model3(), false);
        for r in rows()
            .iter()
            .cycle()
            .take(20_000)
            .enumerate()
            .map(|(k, r)| {
                let mut r = *r;
                r.time_s = k as f64 * 0.1;
                r
            })
        {
            w.push(r);
        }
        // 20,000 rows offered far faster than the watch simulates: some were dropped,
        // and pushing never waited on the watch.
        assert!(w.dropped_rows > 0, "{w:?}");
        assert_eq!(w.rows, 20_000);
    }
}
