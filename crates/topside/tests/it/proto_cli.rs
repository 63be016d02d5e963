//! `topside proto` end to end: the real binary on the published vectors.

use std::process::{Command, Output};

fn topside(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_topside"))
        .args(args)
        .output()
        .expect("run topside")
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

const V2: &str = "FD DF 01 01 00 09 2B 01 EE 01 25 00 E2 FF 00 00 D6";
const V3: &str = "FA AF 01 05 00 0F 5E 32 00 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3";
const V6: &str = "FD DF 01 05 00 22 04 01 D2 04 CE FF 19 00 E9 05 00 00 FF FF 02 00 78 00 B0 FF AE D9 76 01 45 FD A1 07 00 00 23 00 F5 05 64 8F";

fn v18() -> String {
    let mut s = String::from(
        "FD DF 01 80 F7 FF AB 25 01 24 01 01 00 01 00 4A 31 34 34 36 31 \
         00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 60 0D F0 0D",
    );
    for _ in 43..303 {
        s.push_str(" 00");
    }
    s.push_str(" ED");
    s
}

const V2_JSON: &str = r#"{"direction":"response","node":1,"flags":1,"addr":0,"len":9,"kind":"ping_reply","fields":{"heading_deg":49.4,"pitch_deg":3.7,"roll_deg":-3.0,"pressure_mbar":0}}"#;
const V3_JSON: &str = r#"{"direction":"request","node":1,"flags":5,"addr":0,"len":15,"kind":"control","fields":{"port_pct":50,"starboard_pct":-50,"vertical_pct":25,"lights_pct":75,"tilt":-30,"focus":0,"camera_control":0,"camera_buttons":0,"depth_target_mbar":null,"heading_target_deg":null}}"#;
const V6_JSON: &str = r#"{"direction":"response","node":1,"flags":5,"addr":0,"len":34,"kind":"nav","fields":{"heading_deg":123.4,"pitch_deg":-5.0,"roll_deg":2.5,"pressure_mbar":1513,"yaw_accel_raw":0,"pitch_accel_raw":-1,"roll_accel_raw":2,"surge_accel_raw":120,"sway_accel_raw":-80,"heave_accel_raw":-9810,"mag_x":374,"mag_y":-699,"mag_z":1953,"attitude_status":0,"humidity_pct":35,"water_temp_c":15.25,"power_pct":100}}"#;
const V18_JSON: &str = r#"{"direction":"response","node":1,"flags":128,"addr":247,"len":293,"kind":"config","fields":{"serial":"J14461","bootloader_version":1,"device_type":1,"valid_app":true,"structure_version":0,"cpu_board":"","power_board":"","depth_board":"","camera_io_board":"","camera":"","lights":"","horizontal_thrusters":"","vertical_thrusters":""}}"#;

#[test]
fn decode_v2_ping_reply() {
    let o = topside(&["proto", "decode", V2]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), format!("{V2_JSON}\n"));
}

#[test]
fn decode_v3_control_lowercase_and_unspaced() {
    let compact = V3.replace(' ', "").to_lowercase();
    let o = topside(&["proto", "decode", &compact]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), format!("{V3_JSON}\n"));
}

#[test]
fn decode_v6_nav_reply() {
    let o = topside(&["proto", "decode", V6]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), format!("{V6_JSON}\n"));
}

#[test]
fn decode_v18_extended_config_reply() {
    let o = topside(&["proto", "decode", &v18()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), format!("{V18_JSON}\n"));
}

#[test]
fn decode_several_frames_per_argument_and_several_arguments() {
    let o = topside(&["proto", "decode", &format!("{V3} {V6}"), V2]);
    assert!(o.status.success());
    assert_eq!(stdout(&o), format!("{V3_JSON}\n{V6_JSON}\n{V2_JSON}\n"));
}

#[test]
fn decode_garbage_then_frame_then_truncated_tail() {
    // Vector C3 (noise, then the nav-only request V5, which is kind raw), then
    // V2 and a cut-off header.
    let input = format!("00 13 FA 00 55 FA AF 01 05 00 00 51 00 {V2} FA AF 01");
    let o = topside(&["proto", "decode", &input]);
    assert!(o.status.success());
    let expected = [
        r#"{"error":"bad sync; 5 bytes skipped","offset":0}"#,
        r#"{"direction":"request","node":1,"flags":5,"addr":0,"len":0,"kind":"raw","fields":{"payload":""}}"#,
        V2_JSON,
        r#"{"error":"truncated frame; 3 bytes skipped","offset":30}"#,
    ];
    assert_eq!(stdout(&o), expected.map(|l| format!("{l}\n")).concat());
}

#[test]
fn decode_other_kinds() {
    let cases = [
        (
            "FA AF 01 01 00 00 55 00",
            r#"{"direction":"request","node":1,"flags":1,"addr":0,"len":0,"kind":"ping","fields":{}}"#,
        ),
        (
            "FA AF 01 8E 7A 00 A0 00",
            r#"{"direction":"request","node":1,"flags":142,"addr":122,"len":0,"kind":"csr_read","fields":{"start":122,"count":14}}"#,
        ),
        (
            "FA AF 01 80 F7 00 23 00",
            r#"{"direction":"request","node":1,"flags":128,"addr":247,"len":0,"kind":"csr_read","fields":{"start":247,"count":null}}"#,
        ),
        (
            "FD DF 01 80 7A 0F D6 01 F5 05 80 1D C3 04 81 01 00 00 31 00 03 00 19",
            r#"{"direction":"response","node":1,"flags":128,"addr":122,"len":15,"kind":"status","fields":{"water_temp_c":15.25,"tether_v":75.52,"rail_12v_v":12.19,"rail_12v_ma":385,"internal_temp_cpu":0,"internal_temp_power":0,"humidity_pct":49,"comm_errors":3}}"#,
        ),
        (
            "FD DF 01 80 68 03 C8 01 D2 04 D7",
            r#"{"direction":"response","node":1,"flags":128,"addr":104,"len":3,"kind":"csr_dump","fields":{"start":104,"count":2,"bytes":"D2 04"}}"#,
        ),
        (
            "FA AF 01 00 FE 02 A8 DE AD 73",
            r#"{"direction":"request","node":1,"flags":0,"addr":254,"len":2,"kind":"reboot","fields":{}}"#,
        ),
        (
            "FA AF 42 00 F0 08 EF 35 49 00 00 00 00 03 00 7F",
            r#"{"direction":"request","node":66,"flags":0,"addr":240,"len":8,"kind":"raw","fields":{"payload":"35 49 00 00 00 00 03 00"}}"#,
        ),
    ];
    for (input, json) in cases {
        let o = topside(&["proto", "decode", input]);
        assert!(o.status.success(), "{input}");
        assert_eq!(stdout(&o), format!("{json}\n"), "{input}");
    }
}

#[test]
fn decode_nothing_valid_exits_1() {
    // C1: flipped payload bit, so the total check fails.
    let o = topside(&[
        "proto",
        "decode",
        "FA AF 01 05 00 0F 5E 32 01 CE FF 19 00 4B E2 00 00 00 FF FF FF FF B3",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stdout(&o),
        "{\"error\":\"total check mismatch; 23 bytes skipped\",\"offset\":0}\n"
    );
    // C6: mixed sync pair.
    let o = topside(&["proto", "decode", "FA DF 01 05 00 00 21 00"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stdout(&o),
        "{\"error\":\"bad sync; 8 bytes skipped\",\"offset\":0}\n"
    );
}

#[test]
fn decode_invalid_hex_is_an_error_line() {
    let o = topside(&["proto", "decode", "FA AF 0G"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stdout(&o),
        "{\"error\":\"invalid hex digit 'G'\",\"offset\":2}\n"
    );
    let o = topside(&["proto", "decode", "FA A", V2]);
    assert_eq!(o.status.code(), Some(0), "the second argument decodes");
    assert_eq!(
        stdout(&o),
        format!("{{\"error\":\"odd number of hex digits\",\"offset\":1}}\n{V2_JSON}\n")
    );
}

#[test]
fn encode_v3() {
    let o = topside(&[
        "proto",
        "encode",
        "control",
        "--port-pct",
        "50",
        "--starboard-pct",
        "-50",
        "--vertical-pct",
        "25",
        "--lights-pct",
        "75",
        "--tilt",
        "-30",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), format!("{V3}\n"));
}

#[test]
fn encode_v4_targets_and_v17_defaults() {
    let o = topside(&[
        "proto",
        "encode",
        "control",
        "--port-pct",
        "100",
        "--starboard-pct",
        "100",
        "--vertical-pct",
        "0",
        "--depth-target-mbar",
        "1513",
        "--heading-target-deg",
        "270",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o),
        "FA AF 01 05 00 0F 5E 64 00 64 00 00 00 00 00 00 00 00 E9 05 0E 01 E3\n"
    );
    let o = topside(&[
        "proto",
        "encode",
        "control",
        "--port-pct",
        "0",
        "--starboard-pct",
        "0",
        "--vertical-pct",
        "0",
    ]);
    assert_eq!(
        stdout(&o),
        "FA AF 01 05 00 0F 5E 00 00 00 00 00 00 00 00 00 00 00 FF FF FF FF 00\n"
    );
}

#[test]
fn encode_then_decode_round_trips() {
    let o = topside(&[
        "proto",
        "encode",
        "control",
        "--port-pct",
        "-100",
        "--starboard-pct",
        "7",
        "--vertical-pct",
        "-41",
        "--focus",
        "-100",
        "--flags",
        "0",
        "--node",
        "66",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let hex = stdout(&o);
    let o = topside(&["proto", "decode", hex.trim()]);
    assert_eq!(
        stdout(&o),
        "{\"direction\":\"request\",\"node\":66,\"flags\":0,\"addr\":0,\"len\":15,\"kind\":\"control\",\"fields\":{\"port_pct\":-100,\"starboard_pct\":7,\"vertical_pct\":-41,\"lights_pct\":0,\"tilt\":0,\"focus\":-100,\"camera_control\":0,\"camera_buttons\":0,\"depth_target_mbar\":null,\"heading_target_deg\":null}}\n"
    );
}

#[test]
fn encode_out_of_range_names_argument_and_range() {
    let base = [
        "proto",
        "encode",
        "control",
        "--port-pct",
        "0",
        "--starboard-pct",
        "0",
    ];
    let cases: [(&[&str], &str, &str); 7] = [
        (&["--vertical-pct", "101"], "--vertical-pct", "-100..=100"),
        (&["--lights-pct", "101"], "--lights-pct", "0..=100"),
        (&["--tilt", "-91"], "--tilt", "-90..=90"),
        (&["--focus", "101"], "--focus", "-100..=100"),
        (
            &["--depth-target-mbar", "65535"],
            "--depth-target-mbar",
            "0..=65534",
        ),
        (
            &["--heading-target-deg", "360"],
            "--heading-target-deg",
            "0..=359",
        ),
        (&["--flags", "256"], "--flags", "0..=255"),
    ];
    for (extra, name, range) in cases {
        let mut args: Vec<&str> = base.iter().chain(extra).copied().collect();
        if name != "--vertical-pct" {
            args.extend(["--vertical-pct", "0"]);
        }
        let o = topside(&args);
        assert_ne!(o.status.code(), Some(0), "{extra:?}");
        assert!(o.stdout.is_empty());
        let err = stderr(&o);
        assert!(
            err.contains(name) && err.contains(range),
            "{extra:?}: {err}"
        );
    }
    let o = topside(&[
        "proto",
        "encode",
        "control",
        "--port-pct",
        "150",
        "--starboard-pct",
        "0",
        "--vertical-pct",
        "0",
        "--node",
        "300",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("--port-pct") && err.contains("-100..=100"),
        "{err}"
    );
}
