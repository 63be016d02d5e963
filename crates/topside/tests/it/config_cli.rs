//! Packaging: the binary runs from any directory with no file beside it (settings and
//! models built in), reads the user's file from the platform's configuration directory,
//! takes `--config PATH`, and refuses a file that exists but does not read or parse,
//! naming it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// An empty home and working directory.
struct Home(PathBuf);

impl Home {
    fn new(name: &str) -> Self {
        let d =
            std::env::temp_dir().join(format!("topside-config-cli-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Self(d)
    }
    fn user_config(&self) -> PathBuf {
        self.0.join(".config/topside/station.toml")
    }
}

impl Drop for Home {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn record(home: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .current_dir(home)
        .env("HOME", home)
        .env_remove("XDG_CONFIG_HOME")
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "3",
            "--out",
            "dive.mcap",
            "--json",
        ])
        .args(extra)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn runs_anywhere_with_built_in_defaults_and_says_so() {
    let h = Home::new("defaults");
    let o = record(&h.0, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("using the built-in defaults"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains(&h.user_config().display().to_string()));
    let s = rov_session_config(&h.0.join("dive.mcap"));
    assert!(
        s.contains("rate_hz = 50.0"),
        "the built-in station.toml is recorded"
    );
}

/// The installed binary's other jobs from an empty directory with an empty home: `hold`
/// with a built-in model, a short recording, and `lab compare` of that recording with a
/// built-in model (nothing read from the checkout).
#[test]
fn hold_record_and_lab_run_from_an_empty_directory() {
    let h = Home::new("jobs");
    let run = |args: &[&str]| -> Output {
        Command::new(env!("CARGO_BIN_EXE_topside"))
            .current_dir(&h.0)
            .env("HOME", &h.0)
            .env_remove("XDG_CONFIG_HOME")
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&[
        "hold",
        "--model",
        "model3",
        "--depth-m",
        "5",
        "--heading-deg",
        "30",
        "--duration-s",
        "10",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        v["depth"]["rmse_m"].as_f64().is_some_and(f64::is_finite),
        "{v}"
    );
    let o = record(&h.0, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "lab",
        "compare",
        "--model",
        "model3",
        "--data",
        "dive.mcap",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["model"], "model3");
    assert!(
        v["pooled"]["shooting"]["channels"]["depth"]["rmse"]
            .as_f64()
            .is_some_and(f64::is_finite),
        "{v}"
    );
}

/// The config text recorded in a session (the `config.toml` attachment).
fn rov_session_config(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    let at = text.find("[control]").expect("config.toml attachment");
    text[at..].chars().take(4000).collect()
}

#[test]
fn the_user_file_and_config_path_are_used_and_bad_files_are_errors() {
    let h = Home::new("user");
    let user = h.user_config();
    std::fs::create_dir_all(user.parent().unwrap()).unwrap();
    std::fs::write(&user, "[control]\nrate_hz = 25.0\n").unwrap();
    let o = record(&h.0, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("settings from {}", user.display())),
        "{}",
        stderr(&o)
    );
    assert!(rov_session_config(&h.0.join("dive.mcap")).contains("rate_hz = 25.0"));

    // A user file that does not parse: an error naming the file and the key, no dive.
    std::fs::write(&user, "[control]\nrate_hz = \"fast\"\n").unwrap();
    let o = record(&h.0, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&user.display().to_string()),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("control.rate_hz"), "{}", stderr(&o));
    // One that cannot be read (a directory in its place).
    std::fs::remove_file(&user).unwrap();
    std::fs::create_dir_all(&user).unwrap();
    let o = record(&h.0, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot read the configuration file"),
        "{}",
        stderr(&o)
    );

    // --config chooses another file, and must name an existing one.
    let other = h.0.join("other.toml");
    std::fs::write(&other, "[control]\nrate_hz = 40.0\n").unwrap();
    let o = record(&h.0, &["--config", other.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(rov_session_config(&h.0.join("dive.mcap")).contains("rate_hz = 40.0"));
    let o = record(&h.0, &["--config", "missing.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.toml"), "{}", stderr(&o));
}
