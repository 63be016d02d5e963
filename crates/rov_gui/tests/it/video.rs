//! The camera in the Fly tab (issue 12): the simulator's camera fills the main view with
//! the HUD (tapes, horizon line, thrust bars, status strip) over it; a 90° turn shows a
//! different scene; V switches to the instrument-only layout; the link panel shows the
//! video's rate. Snapshots: `video_fly_sim_camera`, `video_fly_after_yaw_90`.

use crate::common;

use common::{FRAME_S, config, rig_config};
use egui::vec2;
use rov_station::runtime::RuntimeConfig;
use rov_station::runtime::video::VideoSettings;

fn mean_abs_diff(a: &image::RgbaImage, b: &image::RgbaImage, rect: egui::Rect) -> f64 {
    let (mut sum, mut n) = (0u64, 0u64);
    for y in rect.min.y as u32..(rect.max.y as u32).min(a.height()) {
        for x in rect.min.x as u32..(rect.max.x as u32).min(a.width()) {
            let (p, q) = (a.get_pixel(x, y).0, b.get_pixel(x, y).0);
            sum += (0..3).map(|i| u64::from(p[i].abs_diff(q[i]))).sum::<u64>();
            n += 3;
        }
    }
    sum as f64 / n.max(1) as f64
}

#[test]
fn the_fly_tab_shows_the_sim_camera_under_the_hud_and_a_turn_changes_the_scene() {
    let mut r = rig_config(
        "video_fly.mcap",
        vec2(1280.0, 800.0),
        RuntimeConfig {
            video: VideoSettings {
                source: "sim".into(),
                ..VideoSettings::default()
            },
            ..config()
        },
    );
    r.run(2.0);
    let main = r.harness.state().main_view_rect().unwrap();
    // The camera, not the instrument layout: the link panel reports the video.
    assert!(
        r.has_label_containing("25.0 fps"),
        "{:?}",
        r.labels_containing("fps")
    );
    // Dive 4 m on depth hold (the seabed at 6 m comes into view).
    r.arm();
    r.click_nth("OFF", 0);
    for _ in 0..4 {
        r.click_nth("+1", 0);
    }
    r.run(15.0);
    let depth = r.view().snapshot.depth_m.unwrap();
    assert!((3.5..5.5).contains(&depth), "depth {depth}");
    r.harness.event(egui::Event::PointerGone);
    r.harness.step();
    let before = r.harness.render().unwrap();
    // The horizon instrument's flat sky colour hardly appears: the picture is the camera.
    let sky = common::count_colour(&before, main, [40, 110, 190], 4);
    assert!(
        sky < 2000,
        "instrument sky pixels {sky}: is the camera shown?"
    );
    r.snapshot("video_fly_sim_camera");

    // Turn 90° on heading hold.
    r.click_nth("OFF", 0);
    let h0 = r.view().snapshot.heading_deg.unwrap();
    for _ in 0..9 {
        r.click_nth("+10", 0);
    }
    r.run(20.0);
    let h1 = r.view().snapshot.heading_deg.unwrap();
    let turned = (h1 - h0).rem_euclid(360.0);
    assert!(
        (80.0..100.0).contains(&turned),
        "turned {turned}° ({h0} → {h1})"
    );
    r.harness.event(egui::Event::PointerGone);
    r.harness.step();
    let after = r.harness.render().unwrap();
    // The picture's lower band (the seabed, below the horizon line, between the depth
    // tape and the thrust bars).
    let picture = egui::Rect::from_min_max(
        egui::pos2(main.min.x + 150.0, main.center().y + 20.0),
        egui::pos2(main.max.x - 170.0, main.max.y - 40.0),
    );
    let d = mean_abs_diff(&before, &after, picture);
    eprintln!("picture change after the turn: {d:.1}/255 (heading {h0:.0} → {h1:.0})");
    assert!(d > 4.0, "the scene did not change: {d:.1}/255");
    r.snapshot("video_fly_after_yaw_90");

    // V: the instrument-only layout (the horizon's sky fills the centre again).
    r.harness.key_press(egui::Key::V);
    r.run(FRAME_S);
    r.harness.event(egui::Event::PointerGone);
    r.harness.step();
    let img = r.harness.render().unwrap();
    let sky = common::count_colour(&img, main, [40, 110, 190], 6);
    assert!(sky > 20_000, "instrument-only layout: sky pixels {sky}");
}

/// The Model lab shows the camera frame at a chosen time of a session it loaded: a
/// 20-s virtual dive recorded with the sim camera, loaded in the lab; the frame shown is
/// the recording's (decoded on a worker), captured at the slider's time.
#[test]
fn the_model_lab_shows_the_camera_frame_of_a_session() {
    use rov_station::runtime::VirtualStation;
    let path = common::tmp("lab_video.mcap");
    let _ = std::fs::remove_file(&path);
    {
        let (mut st, h) = VirtualStation::new(RuntimeConfig {
            video: VideoSettings {
                source: "sim".into(),
                ..VideoSettings::default()
            },
            ..config()
        })
        .unwrap();
        h.start_recording(&path);
        st.advance(20.0).unwrap();
        st.finish();
    }
    let mut r = rig_config("lab_video_rig.mcap", vec2(1280.0, 800.0), config());
    r.harness.state_mut().set_tab(rov_gui::Tab::Lab);
    r.run(FRAME_S);
    r.type_into("Data (CSV or MCAP)", &path.display().to_string());
    r.click("Load");
    let t0 = std::time::Instant::now();
    while !r.has_label_containing("frame captured at") {
        assert!(
            t0.elapsed().as_secs() < 60,
            "no camera frame in the lab: {:?} {:?}",
            r.harness.state().lab().error,
            r.labels_containing("camera")
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
        r.harness.step();
    }
    let label = r.labels_containing("frame captured at");
    assert!(
        label.iter().any(|l| l.contains("frame captured at 0.0")),
        "{label:?}"
    );
}
