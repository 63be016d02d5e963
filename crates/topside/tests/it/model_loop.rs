//! Issue 14's loop through the real binary: a vehicle with hidden effects → two recorded
//! dives → `lab diagnose` names the effects → `lab add --save` → `hold --model` with the
//! learned file tracks the survey profile better than the published model. Plus the bad
//! input of `--model`/`--vehicle`/`[autopilot] model`, refused before anything runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("topside-model-loop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn topside(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(args)
        .env(
            "XDG_CONFIG_HOME",
            std::env::temp_dir().join("topside-model-loop-noconfig"),
        )
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> Output {
    let out = topside(args);
    assert!(
        out.status.success(),
        "topside {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn json(args: &[&str]) -> serde_json::Value {
    serde_json::from_slice(&ok(args).stdout).unwrap()
}

/// model3 as shipped with `[lab]` effects appended: a saved extended model.
fn model3_with(lab: &str) -> String {
    let base = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/models/model3.toml"),
    )
    .unwrap();
    format!("{base}\n{lab}")
}

/// The truth: reverse vertical thrust at half the forward thrust and a 0.4 s lag on
/// every thruster; both hurt depth and heading hold.
const TRUTH_LAB: &str = r#"[lab]
base = "model3"
effects = ["thrust-asymmetry", "thruster-lag"]
[lab.params]
reverse_ratio_vertical = { value = 0.5, unit = "-", source = "scenario truth" }
lag_time_constant_s = { value = 0.4, unit = "s", source = "scenario truth" }
"#;

/// Station settings for the recorded dives: the simulated vehicle rests on the seabed its
/// camera shows (6 m by default), and these dives hold 8 m with stick steps about it, so
/// the water is made deeper than any excursion (30 m): the lab's data is open-water flight,
/// never bottom contact, which no model here describes.
fn deep_water_config(name: &str) -> PathBuf {
    let p = tmp(&format!("{name}-station.toml"));
    std::fs::write(&p, "[video]\nsim_seabed_depth_m = 30.0\n").unwrap();
    p
}

/// A pilot script: hold 8 m, then manual stick steps of both signs on the vertical and
/// yaw sticks (pairs of opposite steps, so the depth stays near 8 m), from a small LCG.
fn stick_script(seed: u64, duration_s: f64) -> String {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((x >> 33) as f64) / f64::from(1u32 << 31)
    };
    let mut s = String::from(
        "[[command]]\nt_s = 1.0\narm = true\n[[command]]\nt_s = 2.0\ndepth_m = 8.0\n\
         [[command]]\nt_s = 30.0\nmanual = \"depth\"\n",
    );
    let mut t = 31.0;
    let mut cmd = |t: f64, yaw: f64, vertical: f64| {
        s.push_str(&format!(
            "[[command]]\nt_s = {t:.2}\nsticks = {{ surge = 0.0, yaw = {yaw:.2}, vertical = {vertical:.2} }}\n"
        ));
    };
    while t < duration_s - 12.0 {
        let a = [0.3, 0.45, 0.6, 0.8][(next() * 4.0) as usize % 4];
        let sign = if next() < 0.5 { 1.0 } else { -1.0 };
        let yaw = [0.0, 0.0, 0.5, -0.5][(next() * 4.0) as usize % 4];
        let d = 2.0 + 1.5 * next();
        for s in [sign, -sign] {
            cmd(t, yaw * s, a * s);
            t += d;
            cmd(t, 0.0, 0.0);
            t += 1.5 + 1.5 * next();
        }
        let y = [0.3, 0.5, 0.7][(next() * 3.0) as usize % 3];
        let d = 1.5 + 1.5 * next();
        for s in [1.0, -1.0] {
            cmd(t, y * s, 0.0);
            t += d;
            cmd(t, 0.0, 0.0);
            t += 1.5 + next();
        }
    }
    s.push_str(&format!(
        "[[command]]\nt_s = {:.2}\ndisarm = true\n",
        duration_s - 1.0
    ));
    s
}

fn tracking(vehicle: &str, model: &str) -> (f64, f64) {
    let v = json(&[
        "hold",
        "--vehicle",
        vehicle,
        "--model",
        model,
        "--depth-m",
        "5",
        "--heading-deg",
        "0",
        "--duration-s",
        "0",
        "--profile",
        "survey",
        "--json",
    ]);
    let t = &v["tracking_rmse"];
    (
        t["depth_m"].as_f64().unwrap(),
        t["heading_deg"].as_f64().unwrap(),
    )
}

#[test]
fn dive_lab_model_autopilot_loop_cuts_the_tracking_error() {
    let truth = tmp("truth.toml");
    std::fs::write(&truth, model3_with(TRUTH_LAB)).unwrap();
    let truth_s = truth.to_str().unwrap();

    // Two dives of the hidden-effect vehicle through the whole station.
    let config = deep_water_config("truth");
    let mut sessions = Vec::new();
    for (seed, duration_s) in [(11u64, 240.0), (22, 180.0)] {
        let script = tmp(&format!("dive{seed}.toml"));
        std::fs::write(&script, stick_script(seed, duration_s)).unwrap();
        let out = tmp(&format!("dive{seed}.mcap"));
        let r = json(&[
            "record",
            "--sim",
            "--config",
            config.to_str().unwrap(),
            "--vehicle",
            truth_s,
            "--fast",
            "--video",
            "none",
            "--script",
            script.to_str().unwrap(),
            "--seed",
            &seed.to_string(),
            "--duration-s",
            &duration_s.to_string(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(r["complete"], true, "{r}");
        sessions.push(out.to_str().unwrap().to_string());
    }
    let (train, val) = (sessions[0].as_str(), sessions[1].as_str());

    // The lab names both effects, first.
    let d = json(&[
        "lab",
        "diagnose",
        "--model",
        "model3",
        "--data",
        train,
        "--validate",
        val,
        "--json",
    ]);
    let findings = d["findings"].as_array().unwrap();
    for f in findings.iter().take(4) {
        eprintln!("finding {} significant {}", f["effect"], f["significant"]);
    }
    let named: Vec<&str> = findings
        .iter()
        .take(2)
        .filter_map(|f| f["effect"].as_str())
        .collect();
    assert!(
        named.contains(&"thrust-asymmetry") && named.contains(&"thruster-lag"),
        "{named:?}"
    );
    assert!(findings.iter().take(2).all(|f| f["significant"] == true));

    // Add them and save the learned model.
    let learned = tmp("learned.toml");
    ok(&[
        "lab",
        "add",
        "--model",
        "model3",
        "--effects",
        "thrust-asymmetry,thruster-lag",
        "--data",
        train,
        "--validate",
        val,
        "--save",
        learned.to_str().unwrap(),
    ]);

    // The learned model flies the survey profile on the truth vehicle.
    let (d3, h3) = tracking(truth_s, "model3");
    let (dl, hl) = tracking(truth_s, learned.to_str().unwrap());
    let cut = |a: f64, b: f64| 100.0 * (1.0 - b / a);
    eprintln!(
        "tracking RMSE model3 {d3:.4} m / {h3:.3} deg, learned {dl:.4} m / {hl:.3} deg \
         (cut {:.0} % / {:.0} %)",
        cut(d3, dl),
        cut(h3, hl)
    );
    // Both channels are hurt by the effects here; the issue asks ≥ 30 % on the hurt
    // channel and no channel more than 5 % worse.
    assert!(cut(d3, dl).max(cut(h3, hl)) >= 30.0);
    assert!(dl <= 1.05 * d3 && hl <= 1.05 * h3);
    assert!(cut(d3, dl) >= 30.0 && cut(h3, hl) >= 30.0);
    // Only this test's files: the other tests of this process share the folder.
    for f in [truth, learned]
        .into_iter()
        .chain(sessions.iter().map(PathBuf::from))
    {
        let _ = std::fs::remove_file(f);
    }
}

#[test]
fn a_bad_model_file_is_refused_naming_file_key_value_and_range() {
    let bad = tmp("bad-lag.toml");
    std::fs::write(
        &bad,
        model3_with(
            "[lab]\nbase = \"model3\"\neffects = [\"thruster-lag\"]\n[lab.params]\n\
             lag_time_constant_s = { value = 9.0, unit = \"s\", source = \"typo\" }\n",
        ),
    )
    .unwrap();
    let unknown = tmp("bad-effect.toml");
    std::fs::write(
        &unknown,
        model3_with("[lab]\nbase = \"model3\"\neffects = [\"warp-drive\"]\n"),
    )
    .unwrap();
    let (bad_s, unknown_s) = (bad.to_str().unwrap(), unknown.to_str().unwrap());
    let base = ["--depth-m", "5", "--heading-deg", "0", "--duration-s", "5"];
    for (args, needles) in [
        (
            [&["hold", "--model", bad_s][..], &base[..]].concat(),
            vec![
                bad_s,
                "lab.params.lag_time_constant_s",
                "9",
                "allowed 0..=2",
            ],
        ),
        (
            [
                &["hold", "--model", "model3", "--vehicle", unknown_s][..],
                &base[..],
            ]
            .concat(),
            vec![unknown_s, "lab.effects", "warp-drive"],
        ),
        (
            vec![
                "record",
                "--sim",
                "--fast",
                "--duration-s",
                "5",
                "--video",
                "none",
                "--out",
                "/nonexistent/never.mcap",
                "--model",
                bad_s,
            ],
            vec![bad_s, "lag_time_constant_s"],
        ),
    ] {
        let out = topside(&args);
        assert!(!out.status.success(), "{args:?} must fail");
        let err = String::from_utf8_lossy(&out.stderr);
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} missing in {err}");
        }
    }
    // A vehicle file that is fine loads as the autopilot's model and as the vehicle.
    let truth = tmp("ok.toml");
    std::fs::write(&truth, model3_with(TRUTH_LAB)).unwrap();
    let t = truth.to_str().unwrap();
    ok(&[&["hold", "--model", t, "--vehicle", t][..], &base[..]].concat());
}

#[test]
fn station_toml_names_the_autopilot_model_and_a_bad_value_is_refused() {
    let dir = tmp("cfg");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("learned.toml"), model3_with(TRUTH_LAB)).unwrap();
    let good = dir.join("station.toml");
    std::fs::write(&good, "[autopilot]\nmodel = \"learned.toml\"\n").unwrap();
    let script = dir.join("s.toml");
    std::fs::write(
        &script,
        "[[command]]\nt_s = 1.0\narm = true\n[[command]]\nt_s = 2.0\ndepth_m = 3.0\n",
    )
    .unwrap();
    let session = dir.join("s.mcap");
    let csv = dir.join("s.csv");
    ok(&[
        "--config",
        good.to_str().unwrap(),
        "record",
        "--sim",
        "--fast",
        "--video",
        "none",
        "--duration-s",
        "6",
        "--script",
        script.to_str().unwrap(),
        "--out",
        session.to_str().unwrap(),
    ]);
    ok(&[
        "export",
        session.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    // The recorded autopilot state names the file the autopilot used (relative to the
    // settings file's folder).
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.contains("learned.toml"), "the model label is recorded");

    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[autopilot]\nmodel = \"model9\"\n").unwrap();
    let out = topside(&[
        "--config",
        bad.to_str().unwrap(),
        "record",
        "--sim",
        "--fast",
        "--video",
        "none",
        "--duration-s",
        "2",
        "--out",
        session.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    for n in [
        bad.to_str().unwrap(),
        "autopilot.model",
        "model9",
        "model1, model2, model3",
    ] {
        assert!(err.contains(n), "{n:?} missing in {err}");
    }
}

#[test]
fn model2_calibrated_on_a_model3_dive_closes_the_heading_feedforward_shortfall() {
    // Dives of the shipped (model3) vehicle; model2 calibrated by the lab on them.
    let config = deep_water_config("m2");
    let mut sessions = Vec::new();
    for (seed, duration_s) in [(31u64, 240.0), (32, 180.0)] {
        let script = tmp(&format!("m2dive{seed}.toml"));
        std::fs::write(&script, stick_script(seed, duration_s)).unwrap();
        let out = tmp(&format!("m2dive{seed}.mcap"));
        ok(&[
            "record",
            "--sim",
            "--config",
            config.to_str().unwrap(),
            "--fast",
            "--video",
            "none",
            "--script",
            script.to_str().unwrap(),
            "--seed",
            &seed.to_string(),
            "--duration-s",
            &duration_s.to_string(),
            "--out",
            out.to_str().unwrap(),
        ]);
        sessions.push(out.to_str().unwrap().to_string());
    }
    // `lab add` needs an effect: net buoyancy is one model2 already contains (a refit).
    let cal = tmp("model2-calibrated.toml");
    ok(&[
        "lab",
        "add",
        "--model",
        "model2",
        "--effects",
        "net-buoyancy",
        "--data",
        &sessions[0],
        "--validate",
        &sessions[1],
        "--save",
        cal.to_str().unwrap(),
    ]);
    let hold = |extra: &[&str]| {
        let v = json(
            &[
                &[
                    "hold",
                    "--depth-m",
                    "5",
                    "--heading-deg",
                    "0",
                    "--duration-s",
                    "0",
                ][..],
                &["--profile", "survey", "--json"][..],
                extra,
            ]
            .concat(),
        );
        let t = &v["tracking_rmse"];
        (
            t["depth_m"].as_f64().unwrap(),
            t["heading_deg"].as_f64().unwrap(),
        )
    };
    let (d0, h0) = hold(&["--model", "model3", "--no-feedforward"]);
    let (d2, h2) = hold(&["--model", "model2"]);
    let (d3, h3) = hold(&["--model", "model3"]);
    let (dc, hc) = hold(&["--model", cal.to_str().unwrap()]);
    let cut = |a: f64, b: f64| 100.0 * (1.0 - b / a);
    eprintln!(
        "tracking cut vs no feedforward (depth / heading): model2 {:.0} / {:.0} %, model3 \
         {:.0} / {:.0} %, model2 calibrated {:.0} / {:.0} %",
        cut(d0, d2),
        cut(h0, h2),
        cut(d0, d3),
        cut(h0, h3),
        cut(d0, dc),
        cut(h0, hc)
    );
    // The shipped model2 misses the heading feedforward; calibrated, it does as well as
    // model3 on both channels.
    assert!(cut(h0, h2) < 10.0);
    assert!(cut(d0, dc) >= 30.0 && cut(h0, hc) >= 30.0);
    assert!(cut(h0, hc) >= cut(h0, h3), "{hc} vs model3 {h3}");
}
