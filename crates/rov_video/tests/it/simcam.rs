//! The simulator's camera: it moves exactly as the vehicle does (landmarks appear where
//! the camera model projects them, for any yaw, pitch, roll, tilt and depth), it is
//! deterministic, and the lights extend the view. The built-in 20-s dive of
//! `topside record --sim` flown through the station is in `rov_station`'s video test
//! (this crate sits below the station).

use nalgebra::Vector3;
use rov_video::VideoFrame;
use rov_video::simcam::{CameraModel, CameraPose, Landmark, SimCamera, SimScene};

fn camera(scene: SimScene) -> SimCamera {
    SimCamera::new(scene, CameraModel::default(), false).unwrap()
}

fn channel_diff(a: [u8; 4], b: [u8; 4]) -> u8 {
    (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap()
}

/// Landmarks within `range_m` of the camera whose centre is well inside the picture.
fn visible(
    cam: &SimCamera,
    pose: &CameraPose,
    depth_m: f64,
    range_m: f64,
) -> Vec<(Landmark, f64, f64)> {
    cam.landmarks_near(pose.north_m, pose.east_m, range_m)
        .into_iter()
        .filter_map(|l| {
            let (u, v) = cam.project(pose, Vector3::new(l.north_m, l.east_m, depth_m))?;
            (u > 20.0 && u < 620.0 && v > 40.0 && v < 460.0).then_some((l, u, v))
        })
        .collect()
}

#[test]
fn landmarks_appear_where_the_camera_model_projects_them() {
    let scene = SimScene::default();
    let with = camera(scene.clone());
    let without = camera(SimScene {
        landmark_density: 0.0,
        ..scene.clone()
    });
    let mut checked = 0;
    let mut poses_with_landmarks = 0;
    // Positions and attitudes of all kinds; yaw and tilt aim near a landmark (offset by a
    // few degrees) so that every picture has one to check.
    for (i, (n, e, d, roll, pitch, yaw_offset, tilt_offset)) in [
        (0.0, 0.0, 4.5, 0.0, 0.0, 0.0, 0.0),
        (3.0, -2.0, 4.0, 0.0, 0.0, 8.0, 5.0),
        (10.0, 7.0, 5.0, 0.0, 0.0, -12.0, -5.0),
        (-4.0, 5.0, 4.5, 15.0, -10.0, 5.0, 8.0),
        (1.0, 1.0, 5.2, -20.0, 10.0, -5.0, -10.0),
        (2.0, -6.0, 3.5, 5.0, -25.0, 15.0, 3.0),
        (-8.0, -8.0, 4.0, 0.0, 5.0, -20.0, -8.0),
        (6.0, 12.0, 5.0, -10.0, 0.0, 10.0, 10.0),
    ]
    .into_iter()
    .enumerate()
    {
        let target = with
            .landmarks_near(n, e, 6.0)
            .into_iter()
            .find(|l| (l.north_m - n).hypot(l.east_m - e) > 1.5)
            .unwrap();
        let yaw = (target.east_m - e).atan2(target.north_m - n).to_degrees() + yaw_offset;
        let range = (target.north_m - n).hypot(target.east_m - e);
        let depression = (scene.seabed_depth_m - d).atan2(range).to_degrees();
        let tilt = -depression - pitch + tilt_offset;
        let pose = CameraPose::from_degrees(n, e, d, roll, pitch, yaw, tilt);
        let a = with.render(&pose, 100.0, 0, 0);
        let b = without.render(&pose, 100.0, 0, 0);
        let seen = visible(&with, &pose, scene.seabed_depth_m, 6.0);
        poses_with_landmarks += usize::from(!seen.is_empty());
        for (l, u, v) in seen {
            let (x, y) = (u as u32, v as u32);
            let d = channel_diff(a.pixel(x, y).unwrap(), b.pixel(x, y).unwrap());
            assert!(
                d > 25,
                "pose {i}: landmark at ({u:.1}, {v:.1}) not drawn there (diff {d}), {l:?}"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 10 && poses_with_landmarks == 8,
        "{checked} landmarks in {poses_with_landmarks} poses"
    );
}

#[test]
fn turning_diving_and_pitching_move_the_picture_as_the_vehicle_moves() {
    let cam = camera(SimScene::default());
    let f = f64::from(640u32) * 0.5 / (75.0f64.to_radians() * 0.5).tan();
    // A point far ahead at the camera's depth: the horizon of the camera.
    let at = |pose: &CameraPose, bearing_deg: f64| {
        let b = bearing_deg.to_radians();
        let p = Vector3::new(
            pose.north_m + 1000.0 * b.cos(),
            pose.east_m + 1000.0 * b.sin(),
            pose.down_m,
        );
        cam.project(pose, p)
    };
    let level = CameraPose::from_degrees(0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0);
    let (u0, v0) = at(&level, 0.0).unwrap();
    assert!((u0 - 320.0).abs() < 1e-6 && (v0 - 240.0).abs() < 1e-6);
    // Yaw 30° to starboard: what was ahead moves left by f·tan 30°.
    let yawed = CameraPose::from_degrees(0.0, 0.0, 3.0, 0.0, 0.0, 30.0, 0.0);
    let (u, _) = at(&yawed, 0.0).unwrap();
    assert!((u - (320.0 - f * 30f64.to_radians().tan())).abs() < 1e-6);
    // Pitch up 10° (or tilt the camera up 10°): the horizon moves down by f·tan 10°.
    for pose in [
        CameraPose::from_degrees(0.0, 0.0, 3.0, 0.0, 10.0, 0.0, 0.0),
        CameraPose::from_degrees(0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 10.0),
    ] {
        let (_, v) = at(&pose, 0.0).unwrap();
        assert!(
            (v - (240.0 + f * 10f64.to_radians().tan())).abs() < 1e-6,
            "{v}"
        );
    }
    // A full turn is the same picture; a quarter turn a different one.
    let down = CameraPose::from_degrees(0.0, 0.0, 4.0, 0.0, 0.0, 0.0, -30.0);
    let a = cam.render(&down, 0.0, 0, 0);
    let full = cam.render(
        &CameraPose {
            yaw_rad: std::f64::consts::TAU,
            ..down
        },
        0.0,
        0,
        0,
    );
    let quarter = cam.render(
        &CameraPose {
            yaw_rad: std::f64::consts::FRAC_PI_2,
            ..down
        },
        0.0,
        0,
        0,
    );
    assert!(a.mean_abs_diff(&full).unwrap() < 0.05);
    assert!(a.mean_abs_diff(&quarter).unwrap() > 2.0);
    // Diving towards a landmark seen 45° down ahead: it grows in the picture as the
    // projection says (area within 40 % of π r²).
    let scene = SimScene::default();
    let flat = camera(SimScene {
        landmark_density: 0.0,
        ..scene.clone()
    });
    let l = cam.landmarks_near(0.0, 0.0, 10.0)[0];
    let mut areas = Vec::new();
    for depth in [2.0, 3.0, 4.0, 5.0, 5.5] {
        let h = scene.seabed_depth_m - depth;
        let pose = CameraPose::from_degrees(l.north_m - h, l.east_m, depth, 0.0, 0.0, 0.0, -45.0);
        let centre = Vector3::new(l.north_m, l.east_m, scene.seabed_depth_m);
        let (u, v) = cam.project(&pose, centre).unwrap();
        assert!((u - 320.0).abs() < 1.0 && (v - 240.0).abs() < 1.0);
        let (ue, _) = cam
            .project(&pose, centre + Vector3::new(0.0, l.radius_m, 0.0))
            .unwrap();
        let r_px = ue - u;
        let a = cam.render(&pose, 100.0, 0, 0);
        let b = flat.render(&pose, 100.0, 0, 0);
        let reach = (r_px * 2.0).ceil() as i64;
        let mut n = 0usize;
        for y in (v as i64 - reach).max(0)..(v as i64 + reach).min(480) {
            for x in (u as i64 - reach).max(0)..(u as i64 + reach).min(640) {
                let inside_disc = ((x as f64 + 0.5 - u).powi(2) + (y as f64 + 0.5 - v).powi(2))
                    .sqrt()
                    < r_px * 0.9;
                let drawn = channel_diff(
                    a.pixel(x as u32, y as u32).unwrap(),
                    b.pixel(x as u32, y as u32).unwrap(),
                ) > 20;
                n += usize::from(inside_disc && drawn);
            }
        }
        // The disc is an ellipse (seen at 45°): area π r · r sin 45°, r along the view.
        let expected =
            std::f64::consts::PI * (r_px * 0.9).powi(2) * std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (n as f64) > 0.6 * expected,
            "depth {depth}: {n} px drawn, ~{expected:.0} expected"
        );
        areas.push(n);
    }
    assert!(
        areas.windows(2).all(|w| w[1] > w[0]),
        "landmark area by depth {areas:?}"
    );
}

#[test]
fn deterministic_for_a_seed() {
    let pose = CameraPose::from_degrees(4.0, -3.0, 4.0, 2.0, -5.0, 70.0, -20.0);
    let a = camera(SimScene::default()).render(&pose, 30.0, 7, 0);
    let b = camera(SimScene::default()).render(&pose, 30.0, 7, 0);
    assert_eq!(a, b);
    let c = camera(SimScene {
        seed: 2,
        ..SimScene::default()
    })
    .render(&pose, 30.0, 7, 0);
    assert!(a.mean_abs_diff(&c).unwrap() > 0.5);
}

#[test]
fn lights_extend_the_view() {
    let scene = SimScene::default();
    let with = camera(scene.clone());
    let without = camera(SimScene {
        landmark_density: 0.0,
        ..scene.clone()
    });
    let pose = CameraPose::from_degrees(0.0, 0.0, 4.0, 0.0, 0.0, 0.0, -15.0);
    // Contrast of every landmark 5–9 m away, lights off and on.
    let contrast = |lights: f64| -> f64 {
        let a = with.render(&pose, lights, 0, 0);
        let b = without.render(&pose, lights, 0, 0);
        let far: Vec<(Landmark, f64, f64)> = visible(&with, &pose, scene.seabed_depth_m, 9.0)
            .into_iter()
            .filter(|(l, _, _)| l.north_m.hypot(l.east_m) > 5.0)
            .collect();
        assert!(!far.is_empty());
        far.iter()
            .map(|(_, u, v)| {
                f64::from(channel_diff(
                    a.pixel(*u as u32, *v as u32).unwrap(),
                    b.pixel(*u as u32, *v as u32).unwrap(),
                ))
            })
            .sum::<f64>()
            / far.len() as f64
    };
    let off = contrast(0.0);
    let on = contrast(100.0);
    assert!(
        on > 2.0 * off,
        "far landmarks: contrast {off:.1} lights off, {on:.1} on"
    );
}

#[test]
fn bad_settings_are_refused_and_a_bad_pose_is_black() {
    let e = SimCamera::new(
        SimScene {
            seabed_depth_m: f64::NAN,
            ..SimScene::default()
        },
        CameraModel::default(),
        false,
    )
    .unwrap_err();
    assert!(e.to_string().contains("`seabed_depth_m` = NaN"), "{e}");
    let e = SimCamera::new(
        SimScene::default(),
        CameraModel {
            hfov_deg: 200.0,
            ..CameraModel::default()
        },
        false,
    )
    .unwrap_err();
    assert!(e.to_string().contains("`hfov_deg` = 200"), "{e}");
    let cam = camera(SimScene::default());
    let f = cam.render(
        &CameraPose {
            yaw_rad: f64::INFINITY,
            ..CameraPose::default()
        },
        0.0,
        0,
        0,
    );
    assert_eq!(
        f,
        VideoFrame {
            capture_ns: 0,
            seq: 0,
            ..VideoFrame::black(640, 480, 0)
        }
    );
    // Above the surface or below the seabed: clamped, still a picture.
    for d in [-5.0, 50.0] {
        let f = cam.render(
            &CameraPose {
                down_m: d,
                ..CameraPose::default()
            },
            f64::NAN,
            0,
            0,
        );
        assert!(
            f.rgba
                .chunks_exact(4)
                .any(|p| p[0] > 0 || p[1] > 0 || p[2] > 0)
        );
    }
}

#[test]
fn the_picture_follows_depth_down_to_the_seabed() {
    // Level and tilted down, from mid-water to resting on the default 6 m seabed (the
    // simulated vehicle's body origin stops 0.11 m above it, rov_sim::Seabed): every
    // 0.2 m deeper is a different picture, also in the last half metre.
    let scene = SimScene::default();
    let cam = camera(scene.clone());
    let resting = scene.seabed_depth_m - 0.11;
    for tilt in [0.0, -30.0] {
        let mut depths: Vec<f64> = (0..=12).map(|k| 3.5 + 0.2 * f64::from(k)).collect();
        depths.retain(|d| *d < resting);
        depths.push(resting);
        let frames: Vec<VideoFrame> = depths
            .iter()
            .map(|&d| {
                let pose = CameraPose::from_degrees(1.0, 2.0, d, 0.0, 0.0, 20.0, tilt);
                cam.render(&pose, 50.0, 0, 0)
            })
            .collect();
        for (w, d) in frames.windows(2).zip(depths.windows(2)) {
            let change = w[0].mean_abs_diff(&w[1]).unwrap();
            assert!(
                change > 0.5,
                "tilt {tilt}: {:.2} → {:.2} m changes the picture by {change:.2}/255",
                d[0],
                d[1]
            );
        }
    }
}
