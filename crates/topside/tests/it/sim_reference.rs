//! `topside sim reference` run as a real binary against the Fossen reference files.

use std::path::{Path, PathBuf};
use std::process::Command;

const DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/testdata/fossen_reference"
);

fn out_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("sim_reference_{}_{name}", std::process::id()))
}

fn parse(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
        .collect()
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn cli_reproduces_reference_files() {
    let params = format!("{DIR}/parameters.json");
    for (case, integrator, file) in [
        ("a_heave_restoring", "rk4", "a_heave_restoring_rk4.csv"),
        (
            "b_surge_yaw_coriolis",
            "euler",
            "b_surge_yaw_coriolis_euler.csv",
        ),
    ] {
        let out = out_path(file);
        let o = run(&[
            "sim",
            "reference",
            "--params",
            &params,
            "--case",
            case,
            "--integrator",
            integrator,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let ours = std::fs::read_to_string(&out).unwrap();
        let reference = std::fs::read_to_string(format!("{DIR}/{file}")).unwrap();
        assert_eq!(ours.lines().next(), reference.lines().next(), "header");
        let (a, b) = (parse(&ours), parse(&reference));
        assert_eq!(a.len(), b.len());
        for (ra, rb) in a.iter().zip(&b) {
            assert_eq!(ra.len(), 19);
            for (x, y) in ra.iter().zip(rb) {
                assert!((x - y).abs() <= 1e-6, "{case} {integrator}: {x} vs {y}");
            }
        }
        let _ = std::fs::remove_file(&out);
    }
}

#[test]
fn cli_names_the_missing_case_and_bad_json() {
    let params = format!("{DIR}/parameters.json");
    let out = out_path("missing.csv");
    let o = run(&[
        "sim",
        "reference",
        "--params",
        &params,
        "--case",
        "zz_nope",
        "--integrator",
        "rk4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("cases.zz_nope") && err.contains("a_heave_restoring"),
        "{err}"
    );

    let bad = out_path("bad.json");
    std::fs::write(&bad, "{\"g\": 9.81,").unwrap();
    let o = run(&[
        "sim",
        "reference",
        "--params",
        bad.to_str().unwrap(),
        "--case",
        "a",
        "--integrator",
        "euler",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("not valid JSON") && err.contains("bad.json"),
        "{err}"
    );
    let _ = std::fs::remove_file(&bad);
}
