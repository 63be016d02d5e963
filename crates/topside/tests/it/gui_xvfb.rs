//! The real `topside` binary under Xvfb: the station window opens on the simulated
//! vehicle, takes a screenshot of itself after a few seconds (hidden `--screenshot` and
//! `--screenshot-after-s` options), saves it as PNG and exits 0. The PNG must have the
//! window's size, not be blank, and show the simulator's camera in the Fly view (the
//! default video source with the simulated vehicle: not the horizon instrument's flat
//! sky, a picture of water and seabed) with the dark instrument background and the green
//! SAFE / link colours; the recording holds the camera's video. The layout test runs
//! with `--video none` (the instrument layout). `--vehicle FILE` puts the file's model
//! behind the window's simulated Pro 4 (a heavy vehicle sinks where model3 does not).
//!
//! Needs `xvfb-run` (installed by `scripts/setup.sh`); without it the test fails and
//! says so.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn xvfb_run() -> PathBuf {
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join("xvfb-run"))
            .find(|p| p.is_file())
    });
    found.unwrap_or_else(|| {
        panic!("xvfb-run is not installed: run scripts/setup.sh (it installs xvfb and the Vulkan/GL CPU drivers)")
    })
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Counts pixels within `tol` of a colour.
fn count(px: &[u8], rgb: [u8; 3], tol: i32) -> usize {
    px.chunks_exact(4)
        .filter(|p| (0..3).all(|i| (i32::from(p[i]) - i32::from(rgb[i])).abs() <= tol))
        .count()
}

#[test]
fn the_station_window_renders_under_xvfb_and_screenshots_itself() {
    let xvfb = xvfb_run();
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("station_xvfb.png");
    let _ = std::fs::remove_file(&out);
    let rec_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("station_xvfb_recordings");
    let _ = std::fs::remove_dir_all(&rec_dir);
    let mut child = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1280x800x24"])
        .arg(env!("CARGO_BIN_EXE_topside"))
        .arg("--screenshot")
        .arg(&out)
        .args(["--screenshot-after-s", "5"])
        .arg("--recordings")
        .arg(&rec_dir)
        .current_dir(workspace_root())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start xvfb-run");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("topside did not exit within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(status.success(), "topside failed ({status}):\n{stderr}");
    assert!(out.is_file(), "no screenshot written:\n{stderr}");

    // Every session is recorded from the start: one MCAP file with the dive's telemetry.
    let files: Vec<PathBuf> = std::fs::read_dir(&rec_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let session = rov_session::open(&files[0]).unwrap();
    assert!(session.len() > 100, "{} messages", session.len());
    assert!(session.count("/telemetry/nav") > 50);
    // Closing the window finishes the file (footer written, nothing to recover).
    assert!(session.is_complete(), "{:?}", session.warnings());

    let (w, h, px) = rov_gui::screenshot::load_png(&out).unwrap();
    assert_eq!((w, h), (1280, 800), "window size");
    // Not blank: many distinct colours.
    let mut colours: Vec<[u8; 3]> = px.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() > 200,
        "only {} colours: blank window?",
        colours.len()
    );
    let n = (w * h) as usize;
    // The camera, not the instrument layout, fills the Fly view: the horizon
    // instrument's flat sky colour hardly appears; the water and seabed of the sim camera
    // (dark blue-green, green above red) fill the centre.
    let sky = count(&px, [40, 110, 190], 6);
    assert!(
        sky < n / 200,
        "instrument sky pixels {sky}: is the camera shown?"
    );
    let centre: Vec<&[u8]> = px
        .chunks_exact(4)
        .enumerate()
        .filter(|(i, _)| {
            let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
            (200..700).contains(&x) && (250..600).contains(&y)
        })
        .map(|(_, p)| p)
        .collect();
    let watery = centre.iter().filter(|p| p[1] > p[0] && p[2] > p[0]).count();
    assert!(
        watery > centre.len() / 2,
        "centre not water/seabed: {watery} of {}",
        centre.len()
    );
    // The recording holds the camera (25 fps nominal; under Xvfb the CPU-rendered
    // window and the shared cores cost the sim camera frames, counted, never the
    // control loop).
    let video = session.count("/camera/video");
    assert!(
        video as f64 > 5.0 * session.duration_s(),
        "{video} video frames in {:.1} s",
        session.duration_s()
    );
    // The HUD over the picture (the yellow vehicle symbol of the horizon line) and the
    // green of SAFE / a connected link.
    let yellow = px
        .chunks_exact(4)
        .filter(|p| p[0] > 200 && p[1] > 180 && p[2] < 90)
        .count();
    assert!(yellow > 100, "HUD vehicle symbol: {yellow} yellow pixels");
    assert!(
        count(&px, [40, 180, 70], 30) > 50,
        "green status (SAFE, link connected)"
    );
    eprintln!(
        "screenshot {} ({w}x{h}, {} colours, sky {sky}, {video} video frames)",
        out.display(),
        colours.len()
    );
}

/// The real window at the smallest and the largest size a pilot uses: the screenshot
/// has the window's size, and the layout report written with it (the same frame's
/// clipped controls, see rov_gui::layout) lists no control cut off; the Fly tab's main
/// view fills the space beside the side panel. The PNGs stay in the test output.
#[test]
fn the_window_fits_at_1024x600_and_1920x1080_under_xvfb() {
    let xvfb = xvfb_run();
    for (w, h) in [(1024u32, 600u32), (1920, 1080)] {
        let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("station_{w}x{h}.png"));
        let report = out.with_extension("layout.json");
        let _ = std::fs::remove_file(&out);
        let _ = std::fs::remove_file(&report);
        let rec_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("station_{w}_rec"));
        let output = Command::new(&xvfb)
            .args(["-a", "-s", &format!("-screen 0 {w}x{h}x24")])
            .arg(env!("CARGO_BIN_EXE_topside"))
            .arg("--screenshot")
            .arg(&out)
            .args(["--screenshot-after-s", "4"])
            .args(["--window-size", &format!("{w}x{h}")])
            .args(["--video", "none"])
            .arg("--recordings")
            .arg(&rec_dir)
            .current_dir(workspace_root())
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("run xvfb-run");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            output.status.success(),
            "{w}x{h}: topside failed:\n{stderr}"
        );
        let (pw, ph, px) = rov_gui::screenshot::load_png(&out).unwrap();
        assert_eq!((pw, ph), (w, h), "window size");
        let n = (w * h) as usize;
        assert!(
            count(&px, [40, 110, 190], 6) > n / 50,
            "{w}x{h}: no horizon sky"
        );
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        // The simulated vehicle's link stays green also while the window renders (its
        // thread has the link's priority). A single failed exchange can still happen when
        // the test machine is loaded (CI at load average 10 saw one); green needs fewer
        // than 3 in 5 s, so allow up to 2 here and fail on anything the pilot would see.
        assert_eq!(j["link_quality"], "Green", "{w}x{h}: {j}");
        assert!(
            j["link_errors"].as_u64().is_some_and(|e| e <= 2),
            "{w}x{h}: {j}"
        );
        let clipped = j["clipped"].as_array().unwrap();
        assert!(
            clipped.is_empty(),
            "{w}x{h}: controls cut off: {clipped:#?}"
        );
        let main = j["main_view"].as_array().unwrap();
        let mw = main[2].as_f64().unwrap() - main[0].as_f64().unwrap();
        let mh = main[3].as_f64().unwrap() - main[1].as_f64().unwrap();
        assert!(
            mw > 0.6 * f64::from(w) && mh > f64::from(h) - 200.0,
            "{w}x{h}: main view {main:?}"
        );
        eprintln!(
            "{w}x{h}: {} (main view {mw}x{mh}, no clipped control)",
            out.display()
        );
        let _ = std::fs::remove_dir_all(&rec_dir);
    }
}

/// How far the truth sank over a session (last − first `/truth/state` depth), m.
fn truth_sink_m(path: &Path) -> f64 {
    let s = rov_session::open(path).unwrap();
    let truth = s.records::<rov_session::TruthRecord>().unwrap();
    assert!(truth.len() > 50, "{} truth records", truth.len());
    truth.last().unwrap().1.depth_m - truth[0].1.depth_m
}

/// The window's `--vehicle FILE`: the simulated Pro 4 behind the window flies the given
/// model file. The file is model3 with 0.3 L less displaced volume (W − B = 2.9 N,
/// heavy); model3 as shipped is neutral (ρV = m). The window runs 4 s disarmed under
/// Xvfb and records: the heavy vehicle sinks (truth and the measured depth the window
/// shows), where the shipped model3 on the same simulator (`record --sim`, disarmed)
/// stays at the surface.
#[test]
fn the_window_flies_the_vehicle_file_given_with_vehicle() {
    let xvfb = xvfb_run();
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("station_vehicle");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let model3 =
        std::fs::read_to_string(workspace_root().join("config/models/model3.toml")).unwrap();
    let neutral = "volume_m3 = { value = 6.1e-3,";
    assert!(model3.contains(neutral), "model3.toml's volume line moved");
    let heavy = tmp.join("heavy.toml");
    std::fs::write(
        &heavy,
        model3.replace(neutral, "volume_m3 = { value = 5.8e-3,"),
    )
    .unwrap();
    let out = tmp.join("window.png");
    let rec_dir = tmp.join("rec");
    let output = Command::new(&xvfb)
        .args(["-a", "-s", "-screen 0 1024x600x24"])
        .arg(env!("CARGO_BIN_EXE_topside"))
        .arg("--vehicle")
        .arg(&heavy)
        .arg("--screenshot")
        .arg(&out)
        .args(["--screenshot-after-s", "4"])
        .args(["--window-size", "1024x600"])
        .args(["--video", "none"])
        .arg("--recordings")
        .arg(&rec_dir)
        .current_dir(workspace_root())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("run xvfb-run");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "topside failed:\n{stderr}");
    assert!(out.is_file(), "no screenshot:\n{stderr}");
    let files: Vec<PathBuf> = std::fs::read_dir(&rec_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let window_sink_m = truth_sink_m(&files[0]);
    let s = rov_session::open(&files[0]).unwrap();
    let nav = s.records::<rov_session::NavRecord>().unwrap();
    let measured_sink_m = nav.last().unwrap().1.depth_m - nav[0].1.depth_m;

    // The shipped model3 on the same simulated vehicle, without a window, also left
    // disarmed (a script that only switches the lights off: no built-in dive).
    let script = tmp.join("idle.toml");
    std::fs::write(&script, "[[command]]\nt_s = 1.0\nlights_pct = 0.0\n").unwrap();
    let base = tmp.join("base.mcap");
    let o = Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(["record", "--sim", "--fast", "--duration-s", "4"])
        .args(["--video", "none", "--script"])
        .arg(&script)
        .arg("--out")
        .arg(&base)
        .current_dir(workspace_root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let base_sink_m = truth_sink_m(&base);
    eprintln!(
        "--vehicle heavy.toml: sank {window_sink_m:.2} m (measured {measured_sink_m:.2} m) \
         in the window's run; model3 as shipped: {base_sink_m:.3} m"
    );
    assert!(base_sink_m.abs() < 0.1, "model3 moved {base_sink_m} m");
    assert!(
        window_sink_m > 0.3,
        "the heavy vehicle file did not sink: {window_sink_m} m"
    );
    assert!(measured_sink_m > 0.2, "measured sink {measured_sink_m} m");
    let _ = std::fs::remove_dir_all(&tmp);
}
