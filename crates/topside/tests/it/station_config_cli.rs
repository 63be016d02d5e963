//! The station configuration's pilot tables (`[alarms]`, `[station]`) as the binary reads
//! them: a bad value stops `topside record` (and the window) with a message naming the
//! file, the key, the value and the allowed range; good limits reach the station.

use std::path::PathBuf;
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("config")).unwrap();
    d
}

fn record(cwd: &PathBuf) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .args([
            "record",
            "--sim",
            "--fast",
            "--duration-s",
            "2",
            "--out",
            "out.mcap",
            // The file named explicitly: the working directory's config/ is not read
            // (issue 16 packaging: --config, else the user's config dir, else built in).
            "--config",
            "config/station.toml",
        ])
        .current_dir(cwd)
        .output()
        .unwrap()
}

#[test]
fn bad_alarm_and_station_settings_name_file_key_value_and_range() {
    for (toml, key, value, range) in [
        (
            "[alarms]\nhumidity_alarm_pct = 140.0\n",
            "alarms.humidity_alarm_pct",
            "140",
            "0..=100",
        ),
        (
            "[alarms]\ntether_warn_v = 55.0\n",
            "alarms.tether_warn_v",
            "55",
            "at least alarms.tether_alarm_v = 60",
        ),
        (
            "[station]\nbaud = 7\n",
            "station.baud",
            "7",
            "1200..=4000000",
        ),
        (
            "[station]\ntemp_unit = \"kelvin\"\n",
            "station.temp_unit",
            "kelvin",
            "one of c, f",
        ),
        (
            "[alarms]\ndepth_max_m = 3.0\n",
            "alarms.depth_max_m",
            "",
            "depth_warn_m",
        ),
    ] {
        let d = dir("station_config_bad");
        std::fs::write(d.join("config/station.toml"), toml).unwrap();
        let out = record(&d);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{toml} accepted");
        assert!(
            err.contains("config/station.toml")
                && err.contains(key)
                && err.contains(value)
                && err.contains(range),
            "{toml}: {err}"
        );
    }
}

#[test]
fn good_settings_load_and_the_run_records() {
    let d = dir("station_config_good");
    std::fs::write(
        d.join("config/station.toml"),
        "[alarms]\ndepth_warn_m = 1.0\ndepth_alarm_m = 2.0\n[station]\ndepth_unit = \"ft\"\n",
    )
    .unwrap();
    let out = record(&d);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(d.join("out.mcap").is_file());
}
