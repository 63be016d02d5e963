//! Runtime tests: GUI isolation (G1), the control watchdog (G2), arming, input liveness,
//! recording and replay through the same pipeline.

use std::time::{Duration, Instant};

use rov_control::{Axis, ModeCommand, PilotInput};

use super::*;
use crate::core::StationCommand;

/// Runtime tests run one at a time: the timing tests measure scheduling, and the other
/// tests would load the two cores meanwhile.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn sim_config() -> RuntimeConfig {
    RuntimeConfig {
        gamepad: false,
        ..RuntimeConfig::default()
    }
}

fn wait_for(h: &StationHandle, what: &str, timeout_s: f64, f: impl Fn(&StationView) -> bool) {
    let t0 = Instant::now();
    loop {
        if f(&h.view()) {
            return;
        }
        assert!(
            t0.elapsed().as_secs_f64() < timeout_s,
            "timed out waiting for {what}: {:#?}",
            h.view()
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn arm_live(h: &StationHandle) {
    wait_for(h, "the link", 10.0, |v| v.link.health == "connected");
    let t0 = Instant::now();
    while !h.view().snapshot.armed {
        assert!(t0.elapsed() < Duration::from_secs(10), "{:#?}", h.view());
        h.send(StationCommand::Arm);
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// G1 GUI isolation: a GUI that stalls for 2 s misses no control tick. A "GUI" thread
/// reads the handle (view, history), blocks for 2 s, reads again; over the stall the
/// tick count is elapsed/period ± 1 and the lateness stays within the G1 bounds
/// (p99 ≤ 2 ms, max ≤ 10 ms). With video on (issue 12): the sim camera renders at
/// 25 fps and a recording encodes it to `/camera/video` meanwhile.
#[test]
fn g1_a_gui_that_stalls_for_2_s_misses_no_control_tick() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_g1_video_{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let rec = dir.join("g1.mcap");
    let h = std::sync::Arc::new(
        Runtime::start(RuntimeConfig {
            video: video::VideoSettings {
                source: "sim".into(),
                ..video::VideoSettings::default()
            },
            ..sim_config()
        })
        .unwrap(),
    );
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    assert!(h.start_recording(&rec));
    wait_for(&h, "the recording", 5.0, |v| v.recording.path.is_some());
    let gui = {
        let h = std::sync::Arc::clone(&h);
        std::thread::spawn(move || {
            let mut history = History::default();
            for _ in 0..20 {
                let _ = h.view();
                h.sync_history(&mut history);
                std::thread::sleep(Duration::from_millis(16));
            }
            let t0 = h.now_us();
            // The stall: the GUI thread is blocked (e.g. a slow file dialog).
            std::thread::sleep(Duration::from_secs(2));
            let t1 = h.now_us();
            let n = h.sync_history(&mut history);
            (t0, t1, n, history.lost())
        })
    };
    let (t0, t1, pulled, lost) = gui.join().unwrap();
    std::thread::sleep(Duration::from_millis(100));
    let period = h.tick_stats().period_us;
    let times: Vec<u64> = h
        .tick_times()
        .into_iter()
        .filter(|&t| t >= t0 && t <= t1)
        .collect();
    let expected = (t1 - t0) as f64 / period as f64;
    assert!(
        (times.len() as f64 - expected).abs() <= 1.0,
        "{} ticks in {} µs, expected {expected:.1}",
        times.len(),
        t1 - t0
    );
    // Period jitter over the stall: each tick against the grid of the first.
    let first = times[0];
    let mut late: Vec<u64> = times
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let grid = first + k as u64 * period;
            t.abs_diff(grid)
        })
        .collect();
    late.sort_unstable();
    let p99 = late[(late.len() * 99).div_ceil(100) - 1];
    let max = *late.last().unwrap();
    let stats = h.tick_stats();
    eprintln!(
        "G1: {} ticks over {:.3} s (expected {expected:.1}); deviation from the grid p99 {} µs, \
         max {} µs; runtime stats {stats:?}",
        times.len(),
        (t1 - t0) as f64 * 1e-6,
        p99,
        max
    );
    // Jitter bounds with room for a loaded 2-core CI machine (other tests run beside
    // this one); a tick later than one period would count as missed.
    assert!(p99 <= 5_000, "p99 {p99} µs");
    assert!(max <= 15_000, "max {max} µs");
    assert_eq!(stats.missed, 0, "{stats:?}");
    assert_eq!(stats.watchdog_trips, 0, "{stats:?}");
    // The GUI got every sample of the stall afterwards.
    assert_eq!(lost, 0);
    assert!(pulled as f64 >= expected - 2.0, "{pulled}");
    // The camera was recorded meanwhile.
    let video = h.video().unwrap().status();
    assert!(video.recording, "{video:?}");
    assert!(h.stop_recording());
    wait_for(&h, "the recording to be saved", 10.0, |v| {
        v.recording.path.is_none() && v.recording.last_file.as_ref() == Some(&rec)
    });
    let session = rov_session::open(&rec).unwrap();
    let frames = session.count("/camera/video");
    assert!(frames >= 50, "{frames} video frames recorded ({video:?})");
    let _ = std::fs::remove_dir_all(&dir);
}

/// G2 control-loop watchdog: the control thread blocked for 0.5 s while armed with full
/// sticks → the watchdog sends neutral within 3 P + P of the last tick, and the
/// CONTROL STALL alarm latches.
#[test]
fn g2_a_blocked_control_tick_sends_neutral_within_four_periods() {
    let _serial = serial();
    let h = Runtime::start(sim_config()).unwrap();
    arm_live(&h);
    for _ in 0..10 {
        h.send(StationCommand::Sticks(PilotInput {
            surge: 1.0,
            yaw: 0.0,
            vertical: 0.0,
        }));
        std::thread::sleep(Duration::from_millis(20));
    }
    h.command(RuntimeCommand::Camera(CameraCommand::Lights(60.0)));
    std::thread::sleep(Duration::from_millis(100));
    h.command(RuntimeCommand::InjectStall(Duration::from_millis(500)));
    std::thread::sleep(Duration::from_millis(800));
    let s = h.tick_stats();
    eprintln!("G2: {s:?}");
    // The neutral frames keep the lights the pilot had on.
    let kept = live::watchdog_block(h.shared.watchdog_kept.load(Ordering::Relaxed));
    assert_eq!(kept.lights_pct, 60, "{kept:?}");
    assert!(rov_driver::failsafe::is_neutral(&kept));
    assert!(s.watchdog_trips >= 1, "{s:?}");
    assert!(
        s.watchdog_frames >= 10,
        "neutral every period while stalled: {s:?}"
    );
    let p = s.period_us;
    assert!(
        s.watchdog_max_gap_us <= 4 * p + p / 4,
        "first neutral frame {} µs after the last tick",
        s.watchdog_max_gap_us
    );
    wait_for(&h, "the stall alarm", 2.0, |v| {
        v.alarms.iter().any(|a| a.kind == AlarmKind::ControlStall)
    });
    h.ack_alarm(Some(AlarmKind::ControlStall));
    wait_for(&h, "the acknowledgement", 2.0, |v| {
        v.alarms.iter().all(|a| a.kind != AlarmKind::ControlStall)
    });
}

/// The watchdog's neutral frame zeroes thrust and both autopilots but keeps the lights
/// and camera of the last frame sent, through the real encoder and decoder.
#[test]
fn watchdog_frame_is_neutral_but_keeps_lights_and_camera() {
    use firmware_proto::{ControlBlock, Frame, NodeId};
    let node = NodeId::ROV;
    let decode =
        |c: live::Chunk| ControlBlock::from_frame(&Frame::parse(c.bytes()).unwrap()).unwrap();

    // Nothing sent yet: all stop.
    assert_eq!(
        decode(live::watchdog_frame(0, node)),
        ControlBlock::ALL_STOP
    );

    let flying = ControlBlock {
        port_pct: 80,
        starboard_pct: -60,
        vertical_pct: 45,
        lights_pct: 75,
        tilt_deg: -35,
        focus_pct: -12,
        camera_control: 0x05,
        camera_buttons: 0x02,
        depth_target_mbar: Some(1300),
        heading_target_deg: Some(270),
    };
    let sent = decode(live::watchdog_frame(live::pack_kept(&flying), node));
    assert!(rov_driver::failsafe::is_neutral(&sent), "{sent:?}");
    assert_eq!(
        (
            sent.lights_pct,
            sent.tilt_deg,
            sent.focus_pct,
            sent.camera_control
        ),
        (75, -35, -12, 0x05)
    );
    // A button press is an event, not a state: it is not repeated.
    assert_eq!(sent.camera_buttons, 0);
    // Lights off stay off (the valid bit, not the value, says something was kept).
    let dark = ControlBlock {
        lights_pct: 0,
        ..flying
    };
    assert_eq!(
        decode(live::watchdog_frame(live::pack_kept(&dark), node)).lights_pct,
        0
    );
}

fn virtual_armed() -> (VirtualStation, StationHandle) {
    let (mut st, h) = VirtualStation::new(sim_config()).unwrap();
    st.advance(2.0).unwrap();
    assert_eq!(h.view().link.health, "connected");
    h.command(RuntimeCommand::ArmButton(true));
    for _ in 0..12 {
        st.advance(0.1).unwrap();
        h.command(RuntimeCommand::ArmButton(true));
    }
    h.command(RuntimeCommand::ArmButton(false));
    st.advance(0.1).unwrap();
    assert!(h.view().snapshot.armed, "{:#?}", h.view());
    (st, h)
}

#[test]
fn holding_the_arm_button_one_second_arms_and_a_short_press_does_not() {
    let _serial = serial();
    let (mut st, h) = VirtualStation::new(sim_config()).unwrap();
    st.advance(2.0).unwrap();
    for _ in 0..5 {
        h.command(RuntimeCommand::ArmButton(true));
        st.advance(0.1).unwrap();
    }
    assert!(
        h.view().pilot.arm_progress > 0.3,
        "{}",
        h.view().pilot.arm_progress
    );
    h.command(RuntimeCommand::ArmButton(false));
    st.advance(1.0).unwrap();
    assert!(!h.view().snapshot.armed);
    assert_eq!(h.view().pilot.arm_progress, 0.0);
    // Held but not refreshed (a frozen GUI): cancelled, and the pilot is told why.
    h.command(RuntimeCommand::ArmButton(true));
    st.advance(1.5).unwrap();
    assert!(!h.view().snapshot.armed);
    assert!(
        h.view()
            .hint
            .as_deref()
            .is_some_and(|s| s.contains("Arming cancelled")),
        "{:?}",
        h.view().hint
    );
    h.command(RuntimeCommand::ArmButton(false));
    st.advance(0.1).unwrap();
    // A GUI refreshing only every 400 ms (a loaded laptop) still arms.
    for _ in 0..4 {
        h.command(RuntimeCommand::ArmButton(true));
        st.advance(0.4).unwrap();
    }
    assert!(h.view().snapshot.armed, "{:?}", h.view().hint);
    h.command(RuntimeCommand::ArmButton(false));
    drop(st);
    let (_st, h) = virtual_armed();
    h.send(StationCommand::Disarm);
    drop(h);
}

#[test]
fn keyboard_sticks_time_out_to_neutral() {
    let _serial = serial();
    let (mut st, h) = virtual_armed();
    h.send(StationCommand::Sticks(PilotInput {
        surge: 1.0,
        yaw: 0.0,
        vertical: 0.0,
    }));
    st.advance(0.1).unwrap();
    let v = h.view();
    assert_eq!(v.pilot.input, "keyboard");
    assert!(v.snapshot.thrust.port_pct > 5.0, "{:?}", v.snapshot.thrust);
    st.advance(1.0).unwrap();
    let v = h.view();
    assert_eq!(v.pilot.input, "none");
    assert_eq!(v.snapshot.thrust.port_pct, 0.0, "{:?}", v.snapshot.thrust);
}

#[test]
fn depth_hold_engages_and_setpoints_step() {
    let _serial = serial();
    let (mut st, h) = virtual_armed();
    h.command(RuntimeCommand::ToggleHold(Axis::Depth));
    st.advance(0.1).unwrap();
    let v = h.view();
    assert_eq!(v.depth.mode, AxisModeView::Hold, "{:?}", v.last_refusal);
    let sp = v.depth.setpoint.unwrap();
    h.send(StationCommand::Mode(ModeCommand::StepDepth {
        delta_m: 0.5,
    }));
    st.advance(10.0).unwrap();
    let v = h.view();
    assert!((v.depth.setpoint.unwrap() - sp - 0.5).abs() < 1e-6);
    assert!(
        (v.snapshot.depth_m.unwrap() - sp - 0.5).abs() < 0.2,
        "{v:#?}"
    );
    // Disarm: holds drop.
    h.send(StationCommand::Disarm);
    st.advance(0.1).unwrap();
    assert_eq!(h.view().depth.mode, AxisModeView::Manual);
}

#[test]
fn record_then_replay_through_the_same_pipeline() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_rt_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("dive.mcap");
    let (mut st, h) = virtual_armed();
    h.start_recording(&path);
    h.command(RuntimeCommand::ToggleHold(Axis::Heading));
    h.command(RuntimeCommand::Camera(CameraCommand::Lights(40.0)));
    st.advance(0.1).unwrap();
    h.send(StationCommand::Mode(ModeCommand::StepHeading {
        delta_deg: 30.0,
    }));
    st.advance(6.0).unwrap();
    let live = h.view();
    assert!(live.recording.path.is_some());
    let truth_at_stop = *st.vehicle().sim().truth();
    h.stop_recording();
    st.advance(0.1).unwrap();
    let v = h.view();
    assert!(v.recording.path.is_none(), "{:?}", v.recording);
    assert!(v.recording.messages > 1000, "{:?}", v.recording);

    let session = rov_session::open(&path).unwrap();
    for t in [
        "/pro4/tx",
        "/pro4/rx",
        "/telemetry/nav",
        "/telemetry/status",
        "/command/thrust",
        "/pilot/input",
        "/autopilot/state",
        "/observer/state",
        "/link/stats",
        "/events",
        "/session/info",
        "/truth/state",
    ] {
        assert!(session.count(t) > 0, "{t}");
    }
    // One truth sample per control tick, and the last one is the vehicle's state then.
    let truth = session.records::<rov_session::TruthRecord>().unwrap();
    assert!(
        truth.len() + 2 >= session.count("/command/thrust"),
        "{} truth vs {} thrust",
        truth.len(),
        session.count("/command/thrust")
    );
    let (_, last) = truth.last().unwrap();
    let eta = truth_at_stop.state.eta;
    assert!((last.depth_m - eta[2]).abs() < 1e-9, "{last:?} vs {eta}");
    assert!(
        (last.heading_deg - eta[5].to_degrees().rem_euclid(360.0)).abs() < 1e-9,
        "{last:?}"
    );
    assert!(last.r_dps.is_finite() && last.u_mps.is_finite());

    let (mut rp, rh) = VirtualReplay::open(&path).unwrap();
    let v0 = rh.view();
    assert!(v0.source.is_replay());
    let r = v0.replay.clone().unwrap();
    assert!((r.duration_s - 6.2).abs() < 0.3, "{r:?}");
    rh.command(RuntimeCommand::Replay(ReplayCommand::Speed(10.0)));
    rh.command(RuntimeCommand::Replay(ReplayCommand::Play));
    let mut hist = History::default();
    for _ in 0..100 {
        rp.advance(0.02);
        rh.sync_history(&mut hist);
    }
    let v = rh.view();
    assert!(!v.replay.as_ref().unwrap().playing, "reached the end");
    assert_eq!(v.camera.lights_pct, 40.0);
    assert_eq!(v.heading.mode, AxisModeView::Hold);
    assert!(
        (v.heading.setpoint.unwrap() - live.heading.setpoint.unwrap()).abs() < 1e-9,
        "the replay shows the recorded setpoint"
    );
    assert!(hist.len() > 200, "{}", hist.len());
    assert!(v.snapshot.armed);
    // Seek back: state and history rebuilt up to the position.
    rh.command(RuntimeCommand::Replay(ReplayCommand::Seek(2.0)));
    rp.advance(0.0);
    rh.sync_history(&mut hist);
    let (_, last) = hist.time_span().unwrap();
    assert!(last <= 2.0 + 1e-9 && last > 1.8, "{last}");
    rh.command(RuntimeCommand::Replay(ReplayCommand::Step));
    rp.advance(0.0);
    assert!(rh.view().replay.unwrap().position_s >= 2.0);
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 25 #12: the replayed dive panel follows the recorded depth (it said "at the
/// surface" at 5 m), at the play-head after playing and after a seek.
#[test]
fn the_replayed_dive_log_follows_the_recorded_depth() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_rt_dive_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("dive.mcap");
    let (mut st, h) = virtual_armed();
    h.start_recording(&path);
    h.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 4.0 }));
    st.advance(20.0).unwrap();
    h.command(RuntimeCommand::Marker);
    st.advance(1.0).unwrap();
    let live = h.view().dive;
    assert!(live.diving && live.max_depth_m > 3.5, "{live:?}");
    h.stop_recording();
    st.advance(0.1).unwrap();
    let (mut rp, rh) = VirtualReplay::open(&path).unwrap();
    assert!(
        !rh.view().dive.diving,
        "at the start the vehicle is not yet diving"
    );
    rh.command(RuntimeCommand::Replay(ReplayCommand::Speed(50.0)));
    rh.command(RuntimeCommand::Replay(ReplayCommand::Play));
    for _ in 0..100 {
        rp.advance(0.02);
    }
    let d = rh.view().dive;
    assert!(d.diving && d.dives == 1, "{d:?}");
    assert!(
        (d.max_depth_m - live.max_depth_m).abs() < 0.1,
        "{d:?} vs {live:?}"
    );
    assert_eq!(d.markers, 1);
    // A seek rebuilds it from the session up to the position.
    rh.command(RuntimeCommand::Replay(ReplayCommand::Seek(15.0)));
    rp.advance(0.0);
    let d = rh.view().dive;
    assert!(d.diving && d.max_depth_m > 3.0 && d.markers == 0, "{d:?}");
    assert!(d.dive_s > 5.0 && d.dive_s < 15.0, "{d:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 25 #11: the simulated vehicle starts floating at the surface, where "zero
/// depth here" passes; under water (1 m, where it used to start) the zero is refused.
#[test]
fn zero_depth_passes_at_the_surface_and_is_refused_a_metre_down() {
    use crate::pilot::dive::{Item, ItemStatus};
    let _serial = serial();
    let (mut st, h) = virtual_armed();
    let d0 = h.view().snapshot.depth_m.unwrap();
    assert!(d0.abs() < 0.3, "starts at the surface: {d0:.2} m");
    h.command(RuntimeCommand::Checklist(ChecklistCommand::ZeroDepth));
    st.advance(0.1).unwrap();
    let item = |h: &StationHandle| {
        let v = h.view();
        let i = v.checklist.item(Item::DepthZero).unwrap();
        (i.status, i.detail.clone())
    };
    assert_eq!(item(&h).0, ItemStatus::Pass, "{:?}", item(&h));
    // Floating, it stays at the surface (it does not rise into the air).
    st.advance(10.0).unwrap();
    let d = h.view().snapshot.depth_m.unwrap();
    assert!((-0.05..0.3).contains(&d), "floating at {d:.2} m");
    h.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 1.0 }));
    st.advance(15.0).unwrap();
    h.command(RuntimeCommand::Checklist(ChecklistCommand::ZeroDepth));
    st.advance(0.1).unwrap();
    let (status, detail) = item(&h);
    assert_eq!(status, ItemStatus::Fail, "{detail}");
    assert!(detail.contains("not at the surface"), "{detail}");
}

#[test]
fn threaded_replay_plays_on_wall_time() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_rt_thr_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("short.mcap");
    let (mut st, h) = virtual_armed();
    h.start_recording(&path);
    st.advance(4.0).unwrap();
    h.stop_recording();
    st.advance(0.1).unwrap();
    let rh = Runtime::replay(&path).unwrap();
    wait_for(&rh, "the replay view", 5.0, |v| v.replay.is_some());
    rh.command(RuntimeCommand::Replay(ReplayCommand::Speed(10.0)));
    rh.command(RuntimeCommand::Replay(ReplayCommand::Play));
    wait_for(&rh, "the end of the replay", 10.0, |v| {
        v.replay
            .as_ref()
            .is_some_and(|r| !r.playing && r.position_s > 3.5)
    });
    let mut hist = History::default();
    rh.sync_history(&mut hist);
    assert!(hist.len() > 100, "{}", hist.len());
    assert!(rh.view().source.is_replay());
    rh.shutdown();
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 15 #8: the simulated vehicle's link is clean by default, and the link light
/// stays green over a quiet dive (no amber flicker from single failed exchanges).
#[test]
fn the_simulated_link_light_stays_green() {
    let _serial = serial();
    let h = Runtime::start(sim_config()).unwrap();
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    std::thread::sleep(Duration::from_millis(1500));
    let mut amber = Vec::new();
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(12) {
        let v = h.view();
        if v.link.quality != Quality::Green {
            amber.push((v.snapshot.time_s, v.link.clone()));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let v = h.view();
    eprintln!("link after 12 s: {:?}", v.link);
    assert!(
        amber.is_empty(),
        "{} non-green samples, first {:?}",
        amber.len(),
        amber.first()
    );
    h.shutdown();
}

/// Records 4 s of the live station with `cfg` into a fresh folder named `tag`, checks
/// every message in file order (no damage, no "earlier than the message before them"
/// warning) and returns how many `/camera/video` units were recorded.
fn live_recording_in_time_order(tag: &str, cfg: RuntimeConfig) -> usize {
    let dir = std::env::temp_dir().join(format!("rov_station_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}.mcap"));
    let h = Runtime::start(cfg).unwrap();
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    h.start_recording(&path);
    std::thread::sleep(Duration::from_secs(4));
    h.shutdown();
    let s = rov_session::open(&path).unwrap();
    assert!(s.len() > 1000, "{}", s.len());
    // Opening reads only the index; the full check reads every message in file order.
    let report = s.check();
    assert!(report.damage.is_none(), "{:?}", report.damage);
    let order: Vec<&String> = report
        .warnings
        .iter()
        .filter(|w| !w.starts_with("/events: "))
        .collect();
    assert!(order.is_empty(), "{order:?}");
    let video = s.count("/camera/video");
    std::fs::remove_dir_all(&dir).ok();
    video
}

/// Issue 15 #4: a recording made by the live station has its messages in time order
/// (no "earlier than the message before them" warning when it is opened).
#[test]
fn a_live_recording_is_in_time_order() {
    let _serial = serial();
    live_recording_in_time_order("order", sim_config());
}

/// Issue 25 #13: with the simulated camera recorded, the video's access units (stamped
/// at capture, delivered after the encoder's latency) are written in time order too.
#[test]
fn a_live_recording_with_video_is_in_time_order() {
    let _serial = serial();
    let mut cfg = sim_config();
    cfg.video = crate::runtime::video::VideoSettings {
        source: "sim".into(),
        ..crate::runtime::video::VideoSettings::default()
    };
    let video = live_recording_in_time_order("order_v", cfg);
    assert!(video > 25, "{video} video units recorded");
}

/// The gamepad map through the runtime with a virtual pad: the centre rule, hold Start
/// to arm, a button press toggles a hold, the shift layer gives a button its second
/// function (record), the mapped axis drives surge.
#[test]
fn a_virtual_pad_is_mapped_like_a_real_one() {
    use crate::pilot::pad::{PadButton, PadState};
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_pad_{}", std::process::id()));
    let cfg = RuntimeConfig {
        recordings_dir: Some(dir.clone()),
        ..sim_config()
    };
    let (mut st, h) = VirtualStation::new(cfg).unwrap();
    st.advance(2.0).unwrap();
    let hold = |st: &mut VirtualStation, s: PadState, secs: f64| {
        let n = (secs / 0.05).round() as usize;
        for _ in 0..n {
            h.command(RuntimeCommand::PadInput(s));
            st.advance(0.05).unwrap();
        }
    };
    let press = |b: &[PadButton]| PadState {
        buttons: b.iter().map(|b| b.bit()).sum(),
        ..PadState::default()
    };
    // A stick deflected at connection does not count until centred.
    let mut deflected = PadState::default();
    deflected.axes[1] = 0.9;
    hold(&mut st, deflected, 0.3);
    assert_eq!(h.view().snapshot.thrust.port_pct, 0.0);
    assert!(matches!(h.view().pilot.pad, PadStatus::WaitingForCentre(_)));
    hold(&mut st, PadState::default(), 0.2);
    hold(&mut st, press(&[PadButton::Start]), 1.3);
    assert!(h.view().snapshot.armed, "{:?}", h.view().last_refusal);
    hold(&mut st, PadState::default(), 0.1);
    hold(&mut st, press(&[PadButton::North]), 0.1);
    hold(&mut st, PadState::default(), 0.1);
    assert_eq!(h.view().depth.mode, AxisModeView::Hold);
    // Shift (left trigger) + North: record.
    assert!(h.view().recording.path.is_none());
    hold(&mut st, press(&[PadButton::LeftTrigger]), 0.1);
    hold(
        &mut st,
        press(&[PadButton::LeftTrigger, PadButton::North]),
        0.1,
    );
    hold(&mut st, PadState::default(), 0.1);
    assert!(h.view().recording.path.is_some(), "shift+north records");
    assert_eq!(
        h.view().depth.mode,
        AxisModeView::Hold,
        "not the unshifted function"
    );
    // The left stick's Y drives surge.
    let mut fwd = PadState::default();
    fwd.axes[1] = 1.0;
    hold(&mut st, fwd, 0.5);
    let v = h.view();
    assert_eq!(v.pilot.input, "gamepad");
    assert!(v.snapshot.thrust.port_pct > 5.0, "{:?}", v.snapshot.thrust);
    h.stop_recording();
    st.advance(0.1).unwrap();
    std::fs::remove_dir_all(&dir).ok();
}

/// The control thread's steady state (the link up, ticking, publishing; the GUI reading)
/// stays off the allocator but for the 0.5 s link statistics; while recording, the
/// records handed to the recorder add theirs. Counted per wake-up of the real control thread with allocation-counter.
#[test]
fn the_control_loop_stays_off_the_allocator_in_steady_state() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_alloc_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let h = Runtime::start(sim_config()).unwrap();
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    std::thread::sleep(Duration::from_secs(2));
    let count = |secs: f64| {
        let a0 = h.shared.test_allocations.load(Ordering::Relaxed);
        let w0 = h.shared.test_wakeups.load(Ordering::Relaxed);
        let t0 = h.tick_stats().ticks;
        let mut history = History::default();
        let t = Instant::now();
        while t.elapsed().as_secs_f64() < secs {
            let _ = h.view();
            h.sync_history(&mut history);
            std::thread::sleep(Duration::from_millis(30));
        }
        (
            h.shared.test_allocations.load(Ordering::Relaxed) - a0,
            h.shared.test_wakeups.load(Ordering::Relaxed) - w0,
            h.tick_stats().ticks - t0,
        )
    };
    let (idle, wakeups, ticks) = count(3.0);
    h.start_recording(&dir.join("alloc.mcap"));
    std::thread::sleep(Duration::from_secs(1));
    let (rec, _, rec_ticks) = count(3.0);
    eprintln!(
        "control thread: {idle} allocations in {wakeups} wake-ups / {ticks} ticks (not recording); \
         {rec} in {rec_ticks} ticks while recording ({:.1} per tick)",
        rec as f64 / rec_ticks.max(1) as f64
    );
    h.shutdown();
    std::fs::remove_dir_all(&dir).ok();
    assert!(ticks > 100);
    // Before this work: 23.7 allocations per tick (rx chunks, tx frames, frame events,
    // the view's strings cloned anew, per-tick text). Now about one per tick remains
    // (see ARCHITECTURE.md); the bound keeps it from growing back.
    let per_tick = idle as f64 / ticks as f64;
    assert!(
        per_tick < 2.0,
        "{per_tick:.2} allocations per tick without recording"
    );
    assert!(
        rec as f64 / rec_ticks as f64 <= 10.0,
        "{rec} allocations in {rec_ticks} ticks while recording"
    );
}

/// Stopping a recording with video never holds up the control loop: the encoder's last
/// units, the summary and the sync run on the recording's finisher thread. The finisher
/// is held at its start (a slow encoder or disk, made deterministic) while the control
/// loop must go on publishing ticks, the view says "being saved", the same file is
/// refused and a new recording starts; once released the file is saved, complete, and
/// holds the video up to the stop. At exit the station waits for a finisher still held.
#[test]
fn stopping_a_recording_with_video_never_holds_up_the_control_loop() {
    use crate::runtime::finisher::test_gate;
    /// Opens the gate however the test ends (a held finisher would hang later tests).
    struct Reopen;
    impl Drop for Reopen {
        fn drop(&mut self) {
            test_gate::open();
        }
    }
    let _serial = serial();
    let _reopen = Reopen;
    let dir = std::env::temp_dir().join(format!("rov_station_finish_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let first = dir.join("first.mcap");
    let second = dir.join("second.mcap");
    let h = Runtime::start(RuntimeConfig {
        video: video::VideoSettings {
            source: "sim".into(),
            ..video::VideoSettings::default()
        },
        ..sim_config()
    })
    .unwrap();
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    assert!(h.start_recording(&first));
    wait_for(&h, "two seconds of recording", 20.0, |v| {
        v.recording.elapsed_s >= 2.0
    });
    assert!(h.video().unwrap().status().recording, "no video encoding");

    test_gate::close();
    assert!(h.stop_recording());
    wait_for(&h, "the stopped recording being saved", 10.0, |v| {
        v.recording.path.is_none() && v.recording.finishing == [first.clone()]
    });
    // The finisher is held: the control loop must keep ticking. 50 ticks = 1 s at 50 Hz;
    // the wait is generous (load), the assertion is on the tick sequence.
    let seq = h.view().seq;
    wait_for(&h, "50 control ticks while the file is saved", 30.0, |v| {
        v.seq >= seq + 50
    });
    let v = h.view();
    assert_eq!(
        v.recording.finishing,
        std::slice::from_ref(&first),
        "{:?}",
        v.recording
    );
    assert_ne!(v.recording.last_file.as_ref(), Some(&first));

    // The file being saved is refused, with the reason; another file records.
    assert!(h.start_recording(&first));
    wait_for(&h, "the refusal", 10.0, |v| {
        v.recording
            .error
            .as_deref()
            .is_some_and(|e| e.contains("still being saved"))
    });
    assert!(h.view().recording.path.is_none());
    assert!(h.start_recording(&second));
    wait_for(&h, "the second recording", 10.0, |v| {
        v.recording.path.as_ref() == Some(&second)
    });

    test_gate::open();
    wait_for(&h, "the first file saved", 20.0, |v| {
        v.recording.finishing.is_empty() && v.recording.last_file.as_ref() == Some(&first)
    });
    assert!(
        h.view()
            .events
            .iter()
            .any(|e| e.contains("recording saved: first.mcap")),
        "{:#?}",
        h.view().events
    );
    let s = rov_session::open(&first).unwrap();
    assert!(s.is_indexed() && s.is_complete(), "{:?}", s.warnings());
    let frames = s.count("/camera/video");
    assert!(frames >= 25, "{frames} video units");
    // The encoder's last units reached the file: the video runs up to the stop.
    let end_nav = s.last_before("/telemetry/nav", u64::MAX).unwrap().t_ns;
    let end_video = s.last_before("/camera/video", u64::MAX).unwrap().t_ns;
    assert!(
        end_video + 500_000_000 >= end_nav,
        "video ends at {end_video} ns, telemetry at {end_nav} ns"
    );

    // Exit with the second recording's finisher held: shutdown waits for it.
    wait_for(&h, "the second recording running", 20.0, |v| {
        v.recording.elapsed_s >= 1.0
    });
    test_gate::close();
    let opened = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let opener = {
        let opened = std::sync::Arc::clone(&opened);
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs(1));
            opened.store(true, std::sync::atomic::Ordering::SeqCst);
            test_gate::open();
        })
    };
    h.shutdown();
    assert!(
        opened.load(std::sync::atomic::Ordering::SeqCst),
        "shutdown returned before the held finisher was released"
    );
    opener.join().unwrap();
    let s = rov_session::open(&second).unwrap();
    assert!(s.is_indexed() && s.is_complete(), "{:?}", s.warnings());
    assert!(s.count("/camera/video") >= 10);
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 23: a fault injected from the Settings page (RuntimeCommand::InjectFault) acts
/// on the simulated vehicle, and the station's own watch raises VEHICLE CHANGED with the
/// cause in words, an event, and nothing before the fault.
#[test]
fn an_injected_compass_fault_raises_vehicle_changed_with_its_cause() {
    let _serial = serial();
    let (mut st, h) = virtual_armed();
    h.send(StationCommand::Mode(ModeCommand::SetDepth { depth_m: 3.0 }));
    h.send(StationCommand::Mode(ModeCommand::SetHeading {
        heading_deg: 90.0,
    }));
    // Under way with turns, so every channel moves (the watch learns its floor in 60 s).
    let fly = |st: &mut VirtualStation, from_s: f64, to_s: f64| {
        let mut t = from_s;
        while t < to_s {
            let surge = if (t / 20.0).floor() as i64 % 2 == 0 {
                0.8
            } else {
                0.5
            };
            h.send(StationCommand::Sticks(PilotInput {
                surge,
                yaw: 0.0,
                vertical: 0.0,
            }));
            if (t % 20.0) < 0.05 {
                h.send(StationCommand::Mode(ModeCommand::StepHeading {
                    delta_deg: 45.0,
                }));
            }
            st.advance(0.05).unwrap();
            t += 0.05;
        }
    };
    fly(&mut st, 0.0, 150.0);
    let v = h.view();
    assert!(v.watch.running, "{:?}", v.watch);
    assert!(v.watch.alerts.is_empty(), "{:?}", v.watch.alerts);
    assert!(!v.alarms.iter().any(|a| a.kind == AlarmKind::VehicleChanged));
    h.command(RuntimeCommand::InjectFault(
        rov_sim::FaultSpec::parse("compass:30@0").unwrap(),
    ));
    fly(&mut st, 150.0, 170.0);
    let v = h.view();
    let alarm = v
        .alarms
        .iter()
        .find(|a| a.kind == AlarmKind::VehicleChanged)
        .expect("VEHICLE CHANGED");
    assert!(alarm.active && !alarm.acknowledged);
    let change = v
        .watch
        .alerts
        .iter()
        .find(|a| a.kind == "change")
        .expect("a change alert");
    assert_eq!(change.channel, "heading");
    assert!(
        change.words.contains("COMPASS OFF +30")
            || change.words.contains("COMPASS OFF +29")
            || change.words.contains("COMPASS OFF +31"),
        "{change:?}"
    );
    assert!(
        v.events
            .iter()
            .any(|e| e.contains("simulated fault injected: compass")),
        "{:?}",
        v.events
    );
    assert!(
        v.events.iter().any(|e| e.contains("COMPASS OFF")),
        "{:?}",
        v.events
    );
    // The vehicle stays changed: acknowledged, it stays listed.
    h.command(RuntimeCommand::AckAlarm(None));
    st.advance(0.1).unwrap();
    let v = h.view();
    assert!(
        v.alarms
            .iter()
            .any(|a| a.kind == AlarmKind::VehicleChanged && a.acknowledged)
    );
}

/// This process's threads: (name, scheduling policy), from `/proc/self/task/*/stat`
/// (field 41, `policy`: 0 normal, 1 FIFO, 2 RR, 3 batch, 5 idle).
fn thread_policies() -> Vec<(String, u32)> {
    let mut out = Vec::new();
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return out;
    };
    for t in tasks.flatten() {
        let name = std::fs::read_to_string(t.path().join("comm")).unwrap_or_default();
        let stat = std::fs::read_to_string(t.path().join("stat")).unwrap_or_default();
        // Fields after the command's closing parenthesis start at field 3 (state).
        let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else {
            continue;
        };
        let policy = rest
            .split_whitespace()
            .nth(41 - 3)
            .and_then(|p| p.parse().ok());
        if let Some(p) = policy {
            out.push((name.trim().to_string(), p));
        }
    }
    out
}

/// A thread inherits its creator's scheduling. The recorder, the camera encoder's
/// threads and the model watch are started by the control thread; at its real-time
/// priority a busy one (the encoder starting, the watch's simulations) held the control
/// loop off: a CONTROL STALL alarm at every start of a recording with video on a loaded
/// machine (issue 25's flights). Only the real-time threads run real-time now. Where the
/// control thread got no real-time priority (unprivileged) the check still holds (no
/// thread is real-time) but proves less; the test says which.
#[cfg(target_os = "linux")]
#[test]
fn threads_started_by_the_control_thread_do_not_inherit_its_real_time_priority() {
    let _serial = serial();
    let dir = std::env::temp_dir().join(format!("rov_station_prio_{}", std::process::id()));
    let mut cfg = sim_config();
    cfg.video = crate::runtime::video::VideoSettings {
        source: "sim".into(),
        ..crate::runtime::video::VideoSettings::default()
    };
    let h = Runtime::start(cfg).unwrap();
    wait_for(&h, "the link", 10.0, |v| v.link.health == "connected");
    assert!(h.start_recording(&dir.join("prio.mcap")));
    wait_for(&h, "the recording", 10.0, |v| v.recording.messages > 200);
    let threads = thread_policies();
    let real_time = [
        "station-control",
        "station-rx",
        "station-tx",
        "station-watchdo",
    ];
    let control_rt = threads
        .iter()
        .any(|(n, p)| n == "station-control" && *p == 1);
    let wrong: Vec<&(String, u32)> = threads
        .iter()
        .filter(|(n, p)| *p == 1 && !real_time.contains(&n.as_str()) && n != "station-vehicle")
        .collect();
    assert!(
        threads.iter().any(|(n, _)| n == "station-recorde"),
        "the recorder runs: {threads:?}"
    );
    println!(
        "control thread real-time: {control_rt}; {} threads; real-time: {:?}",
        threads.len(),
        threads.iter().filter(|(_, p)| *p == 1).collect::<Vec<_>>()
    );
    h.shutdown();
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        wrong.is_empty(),
        "threads at a real-time priority they inherited: {wrong:?}"
    );
}
