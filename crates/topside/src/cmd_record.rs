//! `topside record --sim --duration-s T --out FILE.mcap [--script FILE.toml] [--fast]`:
//! records a headless dive of the simulated Pro 4 through the full station (link, control
//! loop, failsafes, recorder), exactly what the window records.
//!
//! * Real time by default: the live runtime (its own 50 Hz thread and the in-process
//!   simulated vehicle), like a dive flown from the window.
//! * `--fast`: the same engine on virtual time as fast as the machine goes
//!   (`VirtualStation`); the recorder waits for the disk instead of dropping messages.
//! * `--foxglove-ws ADDR:PORT` (or `[foxglove] enabled = true` in the settings): the dive
//!   is also served live to Foxglove while it is flown (`rov_station::runtime::
//!   foxglove_live`); stderr says where. A bad address is a warning naming it, and the
//!   dive is recorded without the server.
//!
//! # Pilot script
//! A TOML file with a list of timed commands, applied when the dive's clock reaches
//! `t_s` (seconds from the start of the recording):
//!
//! ```toml
//! [[command]]
//! t_s = 1.0
//! arm = true                 # arm (retried for up to 5 s while the link settles)
//!
//! [[command]]
//! t_s = 2.0
//! depth_m = 3.0              # go to and hold this depth (m, 0..300)
//! heading_deg = 90.0         # go to and hold this heading (degrees, any value)
//!
//! [[command]]
//! t_s = 20.0
//! sticks = { surge = 0.4, yaw = 0.0, vertical = 0.0 }   # −1..1, held until the next `sticks`
//!
//! [[command]]
//! t_s = 30.0
//! sticks = { surge = 0.0, yaw = 0.0, vertical = 0.0 }
//! step_depth_m = 1.0         # move the depth setpoint (m, ±50)
//! step_heading_deg = -45.0   # move the heading setpoint (degrees, ±360)
//!
//! [[command]]
//! t_s = 40.0
//! manual = "heading"         # release a hold ("depth" or "heading")
//! hold = "depth"             # hold the current value ("depth" or "heading")
//! lights_pct = 50.0          # lights (0..100)
//!
//! [[command]]
//! t_s = 58.0
//! disarm = true
//! ```
//!
//! One entry may carry several commands; they apply in the order arm, holds, setpoints,
//! sticks, lights, disarm. Sticks are re-sent every tick while set (the station treats a
//! stick stream that stops as released). Without `--script` a built-in dive is flown:
//! arm at 1 s, hold 3 m and 090° at 2 s, cruise forward at 40 % from 15 s to 25 s, step to
//! 5 m and 180° at 30 s, disarm 1 s before the end (commands past the end are skipped).
//! A bad script names the entry, the key, the value and the allowed range.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use clap::Args;
use rov_control::{Axis, ModeCommand, PilotInput};
use rov_station::StationCommand;
use rov_station::runtime::foxglove_live::LiveServer;
use rov_station::runtime::{
    CameraCommand, Runtime, RuntimeCommand, RuntimeConfig, StationHandle, VirtualStation,
};
use serde::Deserialize;

/// Arm retries: the link refuses to arm until it has been healthy for a moment.
const ARM_RETRY_S: f64 = 5.0;
const ARM_RETRY_PERIOD_S: f64 = 0.25;
/// Scheduler step, s (the control rate).
const STEP_S: f64 = 0.02;

/// `topside record --sim --duration-s T --out FILE.mcap [--script FILE.toml] [--fast]`
#[derive(Debug, Args)]
pub struct RecordArgs {
    /// Record the built-in simulated vehicle (the only source for headless recording; a
    /// real vehicle is recorded by the station window).
    #[arg(long)]
    sim: bool,
    /// Length of the dive, s.
    #[arg(long)]
    duration_s: f64,
    /// Output session file.
    #[arg(long)]
    out: PathBuf,
    /// Scripted pilot: a TOML list of timed commands (see `topside record --help`).
    #[arg(long)]
    script: Option<PathBuf>,
    /// Run on virtual time as fast as possible instead of real time.
    #[arg(long)]
    fast: bool,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// The camera recorded on /camera/video: sim (the simulator's camera, also on
    /// virtual time with --fast), test (a GStreamer test pattern, real time only) or
    /// none.
    #[arg(long, value_name = "SOURCE", default_value = "sim")]
    video: String,
    /// Serve the dive live to Foxglove on ADDR:PORT while it is flown (port 0: any free
    /// port; stderr says which).
    #[arg(long, value_name = "ADDR:PORT")]
    foxglove_ws: Option<String>,
    /// The autopilot's model: model1, model2, model3 or FILE.toml (overrides
    /// `[autopilot] model`).
    #[arg(long, value_name = "MODEL|FILE.toml", value_parser = crate::parse_model_id)]
    model: Option<rov_types::ModelId>,
    /// The simulated vehicle's dynamics: any model file (e.g. `lab add --save` output),
    /// effects included, behind the same wire protocol and sensors. Default: model3.
    #[arg(long, value_name = "FILE.toml")]
    vehicle: Option<PathBuf>,
    /// Inject a fault into the simulated vehicle (repeatable): KIND[:TARGET][:SIZE]@T_S,
    /// e.g. `thrust-loss:port:0.4@300` (see `topside --help`); T_S counts from the start
    /// of the recording.
    #[arg(long = "fault", value_name = "SPEC", value_parser = crate::parse_fault)]
    faults: Vec<rov_sim::FaultSpec>,
}

/// Stick positions in a script.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sticks {
    #[serde(default)]
    surge: f64,
    #[serde(default)]
    yaw: f64,
    #[serde(default)]
    vertical: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum AxisName {
    Depth,
    Heading,
}

impl From<AxisName> for Axis {
    fn from(a: AxisName) -> Self {
        match a {
            AxisName::Depth => Axis::Depth,
            AxisName::Heading => Axis::Heading,
        }
    }
}

/// One timed entry of a pilot script.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    t_s: f64,
    #[serde(default)]
    arm: bool,
    #[serde(default)]
    disarm: bool,
    hold: Option<AxisName>,
    manual: Option<AxisName>,
    depth_m: Option<f64>,
    heading_deg: Option<f64>,
    step_depth_m: Option<f64>,
    step_heading_deg: Option<f64>,
    sticks: Option<Sticks>,
    lights_pct: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScriptFile {
    #[serde(default)]
    command: Vec<Entry>,
}

/// A validated pilot script, sorted by time.
#[derive(Debug, Clone)]
struct Script {
    entries: Vec<Entry>,
}

fn check_range(
    what: &str,
    i: usize,
    key: &str,
    v: Option<f64>,
    lo: f64,
    hi: f64,
) -> anyhow::Result<()> {
    if let Some(x) = v
        && !(x.is_finite() && (lo..=hi).contains(&x))
    {
        bail!("{what}: command #{i}: `{key}` = {x} is outside the allowed range {lo}..{hi}");
    }
    Ok(())
}

impl Script {
    fn parse(text: &str, what: &str) -> anyhow::Result<Self> {
        let file: ScriptFile = toml::from_str(text).map_err(|e| anyhow::anyhow!("{what}: {e}"))?;
        for (i, e) in file.command.iter().enumerate() {
            let i = i + 1;
            check_range(what, i, "t_s", Some(e.t_s), 0.0, 1e7)?;
            check_range(what, i, "depth_m", e.depth_m, 0.0, 300.0)?;
            check_range(what, i, "heading_deg", e.heading_deg, -1e4, 1e4)?;
            check_range(what, i, "step_depth_m", e.step_depth_m, -50.0, 50.0)?;
            check_range(
                what,
                i,
                "step_heading_deg",
                e.step_heading_deg,
                -360.0,
                360.0,
            )?;
            check_range(what, i, "lights_pct", e.lights_pct, 0.0, 100.0)?;
            if let Some(s) = e.sticks {
                check_range(what, i, "sticks.surge", Some(s.surge), -1.0, 1.0)?;
                check_range(what, i, "sticks.yaw", Some(s.yaw), -1.0, 1.0)?;
                check_range(what, i, "sticks.vertical", Some(s.vertical), -1.0, 1.0)?;
            }
            if e.arm && e.disarm {
                bail!("{what}: command #{i}: `arm` and `disarm` are both true");
            }
        }
        let mut entries = file.command;
        entries.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        Ok(Self { entries })
    }

    /// The built-in dive (see the module docs).
    fn builtin(duration_s: f64) -> Self {
        let text = format!(
            r#"
            [[command]]
            t_s = 1.0
            arm = true
            [[command]]
            t_s = 2.0
            depth_m = 3.0
            heading_deg = 90.0
            [[command]]
            t_s = 15.0
            sticks = {{ surge = 0.4 }}
            [[command]]
            t_s = 25.0
            sticks = {{ surge = 0.0 }}
            [[command]]
            t_s = 30.0
            depth_m = 5.0
            heading_deg = 180.0
            [[command]]
            t_s = {end}
            disarm = true
            "#,
            end = (duration_s - 1.0).max(1.5)
        );
        Self::parse(&text, "built-in script").unwrap_or(Self {
            entries: Vec::new(),
        })
    }
}

/// Where commands go: the live runtime or the virtual station, through the same handle.
struct Pilot<'a> {
    handle: &'a StationHandle,
    script: Script,
    next: usize,
    sticks: Option<PilotInput>,
    arm_until_s: Option<f64>,
    last_arm_s: f64,
    refused_arm: bool,
}

impl<'a> Pilot<'a> {
    fn new(handle: &'a StationHandle, script: Script) -> Self {
        Self {
            handle,
            script,
            next: 0,
            sticks: None,
            arm_until_s: None,
            last_arm_s: f64::NEG_INFINITY,
            refused_arm: false,
        }
    }

    fn station(&self, c: StationCommand) {
        self.handle.send(c);
    }

    fn mode(&self, m: ModeCommand) {
        self.station(StationCommand::Mode(m));
    }

    /// Applies what is due at `t_s` (seconds since the start).
    fn step(&mut self, t_s: f64) {
        while let Some(e) = self.script.entries.get(self.next) {
            if e.t_s > t_s {
                break;
            }
            let e = e.clone();
            self.next += 1;
            if e.arm {
                self.arm_until_s = Some(t_s + ARM_RETRY_S);
                self.last_arm_s = f64::NEG_INFINITY;
            }
            if let Some(a) = e.manual {
                self.mode(ModeCommand::Disengage(a.into()));
            }
            if let Some(a) = e.hold {
                self.mode(ModeCommand::Engage(a.into()));
            }
            if let Some(depth_m) = e.depth_m {
                self.mode(ModeCommand::SetDepth { depth_m });
            }
            if let Some(heading_deg) = e.heading_deg {
                self.mode(ModeCommand::SetHeading { heading_deg });
            }
            if let Some(delta_m) = e.step_depth_m {
                self.mode(ModeCommand::StepDepth { delta_m });
            }
            if let Some(delta_deg) = e.step_heading_deg {
                self.mode(ModeCommand::StepHeading { delta_deg });
            }
            if let Some(s) = e.sticks {
                let p = PilotInput {
                    surge: s.surge,
                    yaw: s.yaw,
                    vertical: s.vertical,
                };
                self.sticks = (p != PilotInput::default()).then_some(p);
                self.station(StationCommand::Sticks(p));
            }
            if let Some(pct) = e.lights_pct {
                self.handle
                    .command(RuntimeCommand::Camera(CameraCommand::Lights(pct)));
            }
            if e.disarm {
                self.arm_until_s = None;
                self.sticks = None;
                self.station(StationCommand::Disarm);
            }
        }
        // Arm, retried while the link settles.
        if let Some(until) = self.arm_until_s {
            if self.handle.snapshot().armed {
                self.arm_until_s = None;
            } else if t_s > until {
                self.arm_until_s = None;
                self.refused_arm = true;
            } else if t_s - self.last_arm_s >= ARM_RETRY_PERIOD_S {
                self.last_arm_s = t_s;
                self.station(StationCommand::Arm);
            }
        }
        if let Some(p) = self.sticks {
            self.station(StationCommand::Sticks(p));
        }
    }
}

/// The runtime settings (the camera source from --video), and the live Foxglove server
/// when asked for (a bad address is a warning: the dive is recorded without it).
fn runtime_config(
    args: &RecordArgs,
    config: Option<&std::path::Path>,
) -> anyhow::Result<(RuntimeConfig, Option<LiveServer>)> {
    let (cfg, mut foxglove, label) = crate::cmd_station::config_and_foxglove(None, config)?;
    let live =
        crate::foxglove_ws::wanted(args.foxglove_ws.as_deref(), &mut foxglove).and_then(|addr| {
            match crate::foxglove_ws::start(&addr, args.foxglove_ws.is_some(), &label) {
                Ok(s) => Some(s),
                Err(e) => {
                    eprintln!("warning: {e}; recording without the live server");
                    None
                }
            }
        });
    let mut cfg = RuntimeConfig {
        gamepad: false,
        sim_seed: args.seed,
        ..cfg
    };
    crate::cmd_station::apply_models(&mut cfg, args.model.as_ref(), args.vehicle.as_deref())?;
    cfg.video.source.clone_from(&args.video);
    cfg.vehicle_faults.clone_from(&args.faults);
    Ok((cfg, live))
}

/// The camera's figures for the summary; a source that did not start is said on stderr.
fn video_json(handle: &StationHandle) -> serde_json::Value {
    let Some(v) = handle.video() else {
        return serde_json::Value::Null;
    };
    let s = v.status();
    if let Some(e) = &s.error {
        eprintln!("warning: {e}; recorded without video");
    }
    serde_json::json!({
        "source": s.source,
        "error": s.error,
        "frames": s.stats.as_ref().map(|x| x.frames),
        "fps": s.stats.as_ref().map(|x| x.fps),
        "encoder_dropped": s.record_dropped,
    })
}

/// Gives the station a tap on the live server (before anything is recorded).
fn serve_live(live: Option<&LiveServer>, handle: &StationHandle) {
    if let Some(tap) = live.and_then(|l| l.tap(handle.now_us())) {
        handle.command(RuntimeCommand::FoxgloveLive(Some(tap)));
    }
}

/// Runs `topside record`.
pub fn run(args: RecordArgs, config: Option<&std::path::Path>) -> anyhow::Result<ExitCode> {
    if !args.sim {
        bail!(
            "headless recording needs --sim (the built-in simulated vehicle); a real Pro 4 is recorded by the station window (`topside --port PATH`)"
        );
    }
    if !(args.duration_s.is_finite() && args.duration_s > 0.0 && args.duration_s <= 86_400.0) {
        bail!(
            "--duration-s {} is outside the allowed range (0, 86400] s",
            args.duration_s
        );
    }
    let script = match &args.script {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            Script::parse(&text, &p.display().to_string())?
        }
        None => Script::builtin(args.duration_s),
    };
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    if !["sim", "test", "none"].contains(&args.video.as_str()) {
        bail!(
            "--video {}: headless recording takes sim, test or none",
            args.video
        );
    }
    if args.fast && args.video == "test" {
        bail!("--video test runs on wall time; with --fast (virtual time) use --video sim or none");
    }
    let (cfg, live) = runtime_config(&args, config)?;
    // The watch compares the dive with the autopilot's own model.
    let watch_model = args
        .model
        .clone()
        .unwrap_or(rov_types::ModelId::Base(cfg.control.feedforward_model));
    let wall = Instant::now();
    let (refused_arm, control, video) = if args.fast {
        record_fast(cfg, &args, script, live.as_ref())?
    } else {
        record_real_time(cfg, &args, script, live.as_ref())?
    };
    let wall_s = wall.elapsed().as_secs_f64();
    let live_json = live.as_ref().map_or(serde_json::Value::Null, |l| {
        let st = l.status();
        eprintln!(
            "Foxglove live: {} messages sent, {} records dropped",
            st.sent, st.dropped
        );
        serde_json::json!({
            "url": st.url(),
            "sent": st.sent,
            "dropped": st.dropped,
            "failed": st.failed,
        })
    });
    drop(live);
    let watch = watch_json(&args.out, &watch_model);
    summarize(&args, wall_s, refused_arm, control, video, live_json, watch)
}

/// The model watch over the recorded dive (`lab watch` on the session: the rows the
/// station's own watch is fed), as `{"model", "alerts": [...]}`; an error is a warning
/// and `null`.
fn watch_json(out: &std::path::Path, model: &rov_types::ModelId) -> serde_json::Value {
    let run = || -> anyhow::Result<serde_json::Value> {
        let lab_model = crate::cmd_lab::load_model_id(model, "--model")?;
        let (alerts, stats) = crate::cmd_lab_watch::watch_file(out, lab_model, None)?;
        let mut j =
            rov_lab::watch::watch_json(&alerts, &stats, &rov_lab::watch::WatchConfig::default());
        if let Some(o) = j.as_object_mut() {
            o.insert("model".into(), serde_json::Value::from(model.to_string()));
        }
        Ok(j)
    };
    match run() {
        Ok(j) => j,
        Err(e) => {
            eprintln!(
                "warning: the model watch could not run over {}: {e:#}",
                out.display()
            );
            serde_json::Value::Null
        }
    }
}

type Outcome = (bool, serde_json::Value, serde_json::Value);

fn record_fast(
    cfg: RuntimeConfig,
    args: &RecordArgs,
    script: Script,
    live: Option<&LiveServer>,
) -> anyhow::Result<Outcome> {
    let (mut station, handle) = VirtualStation::new(cfg).context("starting the station")?;
    serve_live(live, &handle);
    handle.start_recording(&args.out);
    let mut pilot = Pilot::new(&handle, script);
    let steps = (args.duration_s / STEP_S).ceil() as u64;
    let t0_us = station.now_us();
    for k in 0..=steps {
        let t_s = (k as f64 * STEP_S).min(args.duration_s);
        pilot.step(t_s);
        station
            .advance_to(t0_us + (t_s * 1e6).round() as u64)
            .context("simulating")?;
    }
    // Neutral and disarmed at the end, then the file is finished.
    handle.send(StationCommand::Disarm);
    station.advance(STEP_S).context("simulating")?;
    station.finish();
    let refused = pilot.refused_arm;
    drop(pilot);
    let video = video_json(&handle);
    handle.shutdown();
    Ok((refused, serde_json::Value::Null, video))
}

/// The control loop's timing of a real-time run: ticks, missed ticks (started 20 ms or
/// more late, or skipped), the 99th percentile of the lateness (actual start minus
/// scheduled start) and the priority the control thread got.
fn control_json(handle: &StationHandle) -> serde_json::Value {
    let t = handle.tick_stats();
    let priority = handle
        .priorities()
        .into_iter()
        .find(|(n, _)| n == "station-control")
        .map_or_else(String::new, |(_, g)| g.to_string());
    serde_json::json!({
        "ticks": t.ticks,
        "missed": t.missed,
        "late_p99_ms": t.p99_late_us as f64 * 1e-3,
        "late_max_ms": t.max_late_us as f64 * 1e-3,
        "priority": priority,
    })
}

fn record_real_time(
    cfg: RuntimeConfig,
    args: &RecordArgs,
    script: Script,
    live: Option<&LiveServer>,
) -> anyhow::Result<Outcome> {
    let handle = Runtime::start(cfg).context("starting the station")?;
    serve_live(live, &handle);
    handle.start_recording(&args.out);
    let mut pilot = Pilot::new(&handle, script);
    let t0 = Instant::now();
    loop {
        let t_s = t0.elapsed().as_secs_f64();
        if t_s >= args.duration_s {
            break;
        }
        pilot.step(t_s);
        if !handle.is_running() {
            bail!("the station stopped during the recording");
        }
        std::thread::sleep(Duration::from_secs_f64(STEP_S));
    }
    handle.send(StationCommand::Disarm);
    std::thread::sleep(Duration::from_secs_f64(2.0 * STEP_S));
    let refused = pilot.refused_arm;
    drop(pilot);
    let control = control_json(&handle);
    let video = video_json(&handle);
    // Shutting down finishes the recording (footer written) before the threads stop.
    handle.shutdown();
    Ok((refused, control, video))
}

/// Prints what was recorded, from the file's summary section (its statistics and index:
/// no message is read back, whatever the length of the dive).
fn summarize(
    args: &RecordArgs,
    wall_s: f64,
    refused_arm: bool,
    control: serde_json::Value,
    video: serde_json::Value,
    foxglove: serde_json::Value,
    watch: serde_json::Value,
) -> anyhow::Result<ExitCode> {
    let session = rov_session::open(&args.out)
        .with_context(|| format!("reading back {}", args.out.display()))?;
    let topics: serde_json::Map<String, serde_json::Value> = session
        .topics()
        .iter()
        .map(|t| (t.topic.clone(), serde_json::Value::from(t.count)))
        .collect();
    if refused_arm {
        eprintln!("warning: the vehicle did not arm within {ARM_RETRY_S} s of the script's `arm`");
    }
    for w in session.warnings() {
        eprintln!("warning: {w}");
    }
    if args.json {
        let j = serde_json::json!({
            "out": args.out.display().to_string(),
            "mode": if args.fast { "fast" } else { "real_time" },
            "duration_s": session.duration_s(),
            "wall_s": wall_s,
            "messages": session.len(),
            "complete": session.is_complete(),
            "armed_as_scripted": !refused_arm,
            "topics": topics,
            "control": control,
            "video": video,
            "foxglove": foxglove,
            "watch": watch,
        });
        println!("{j}");
    } else {
        println!(
            "recorded {} ({}): {:.1} s of session time in {:.1} s, {} messages{}",
            args.out.display(),
            if args.fast { "fast" } else { "real time" },
            session.duration_s(),
            wall_s,
            session.len(),
            if session.is_complete() {
                ""
            } else {
                " (file not finished!)"
            }
        );
        for (t, n) in &topics {
            println!("  {t:<22} {n}");
        }
        if let Some(alerts) = watch.get("alerts").and_then(|a| a.as_array()) {
            println!(
                "model watch: {} alert(s){}",
                alerts.len(),
                if alerts.is_empty() {
                    ""
                } else {
                    " (topside lab watch FILE for the causes)"
                }
            );
        }
    }
    Ok(if session.is_complete() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
