//! One model engine (issue 14): the same model on the same recorded dive gives the same
//! numbers through `lab compare`, `replay --model` and `sim run`, because all three load
//! the model with one loader and simulate it with the model lab's engine.

use std::path::PathBuf;
use std::process::Command;

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("one_engine_cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn run_json(args: &[&str]) -> serde_json::Value {
    let out = topside().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `replay --model`'s channel name → `lab compare`'s.
fn lab_name(replay_channel: &str) -> &str {
    ["_m", "_deg", "_mps", "_dps"]
        .iter()
        .find_map(|u| replay_channel.strip_suffix(u))
        .unwrap_or(replay_channel)
}

#[test]
fn lab_compare_replay_and_sim_run_give_the_same_numbers_on_a_recorded_dive() {
    let mcap = tmp("dive.mcap");
    let mcap_s = mcap.to_str().unwrap();
    let rec = run_json(&[
        "record",
        "--sim",
        "--fast",
        "--duration-s",
        "40",
        "--video",
        "none",
        "--out",
        mcap_s,
        "--json",
    ]);
    assert_eq!(rec["complete"], true);

    for model in ["model3", "model1"] {
        let lab = run_json(&[
            "lab", "compare", "--model", model, "--data", mcap_s, "--json",
        ]);
        let pooled = &lab["pooled"]["free_run"]["channels"];
        let replay = run_json(&["replay", mcap_s, "--headless", "--model", model]);
        assert_eq!(replay["model"], model);
        assert!(replay["fit_error"].is_null(), "{replay}");
        let fits = replay["fit"].as_array().unwrap();
        let mut compared = 0;
        for f in fits {
            let name = f["channel"].as_str().unwrap();
            let l = &pooled[lab_name(name)];
            if f["predicted"] == false {
                assert!(l.is_null(), "{model} {name}: not predicted, yet {l}");
                assert!(f["rmse"].is_null() && f["fit_pct"].is_null());
                continue;
            }
            // Exactly the same numbers (same JSON text of the same f64).
            assert_eq!(f["rmse"], l["rmse"], "{model} {name}");
            assert_eq!(f["fit_pct"], l["fit_pct"], "{model} {name}");
            assert_eq!(f["samples"], l["n"], "{model} {name}");
            compared += 1;
        }
        // Depth and heading at least (model1 predicts no pitch or roll).
        assert!(compared >= 2, "{model}: {fits:?}");
        let depth = fits.iter().find(|f| f["channel"] == "depth_m").unwrap();
        assert!(depth["rmse"].as_f64().unwrap() > 0.0, "{depth}");
        if model == "model1" {
            let pitch = fits.iter().find(|f| f["channel"] == "pitch_deg").unwrap();
            assert_eq!(pitch["predicted"], false, "{pitch}");
        }
    }

    // `sim run`: the same engine writes the free-run prediction and prints the same fit
    // (the session is one continuous run here, as `lab compare` pooled one run).
    let out_csv = tmp("pred.csv");
    let o = topside()
        .args(["sim", "run", "--model", "model3", "--data", mcap_s, "--out"])
        .arg(&out_csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let lab = run_json(&[
        "lab", "compare", "--model", "model3", "--data", mcap_s, "--json",
    ]);
    let depth_rmse = lab["pooled"]["free_run"]["channels"]["depth"]["rmse"]
        .as_f64()
        .unwrap();
    assert!(
        text.contains(&format!("RMSE {depth_rmse:.4}")),
        "sim run prints depth RMSE {depth_rmse:.4}: {text}"
    );
}

#[test]
fn every_tool_refuses_a_bad_model_the_same_way() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    let base = rov_dynamics::models::default_model_text("model3").unwrap();
    std::fs::write(
        &bad,
        format!("{base}\n[lab]\nbase = \"model3\"\neffects = [\"no-such-effect\"]\n"),
    )
    .unwrap();
    let bad_s = bad.to_str().unwrap();
    let data = tmp("none.csv");
    std::fs::write(&data, "time_s\n").unwrap();
    for args in [
        vec![
            "lab",
            "compare",
            "--model",
            bad_s,
            "--data",
            data.to_str().unwrap(),
        ],
        vec![
            "replay",
            data.to_str().unwrap(),
            "--headless",
            "--model",
            bad_s,
        ],
        vec![
            "sim",
            "run",
            "--model",
            bad_s,
            "--data",
            data.to_str().unwrap(),
            "--out",
            "/dev/null",
        ],
    ] {
        let o = topside().args(&args).output().unwrap();
        assert!(!o.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("bad.toml") && err.contains("no-such-effect"),
            "{args:?}: {err}"
        );
    }
    // A model name that is neither a base nor a .toml file: the model identity's message.
    let o = topside()
        .args(["replay", "x.mcap", "--headless", "--model", "model4"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("model1, model2, model3 or a FILE.toml"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
