//! The DataFlash reader checked against pymavlink's `DFReader` on the same file.
//!
//! `tests/fixtures/writer.BIN` is written by the crate's own writer from [`fixture`]
//! (deterministic: integer patterns, no clock, no transcendental functions), and
//! `dfreader_bin.json` is what `pymavlink.DFReader.DFReader_binary` read from it
//! (`scripts/fixtures/dump_dataflash.py`). The tests check that the writer still writes
//! the committed bytes exactly, and that our reader's values equal DFReader's value by
//! value, for every numeric format character the reader decodes (`b B h H i I q Q f d M
//! g`, and the scaled `c C e E L`).
//!
//! After changing [`fixture`]: `ROV_LOGS_WRITE_FIXTURES=1 cargo test -p rov_logs --test
//! dataflash_dfreader`, then run the dump script and commit both files.

use std::collections::BTreeMap;

use rov_logs::dataflash::Writer;
use rov_logs::{Format, ReadOptions, Series, read};
use serde_json::Value;

const BIN: &[u8] = include_bytes!("../fixtures/writer.BIN");
const JSON: &str = include_str!("../fixtures/dfreader_bin.json");

/// A triangle wave of integers: 0, 1, …, half, …, 1, 0, -1, … (period 4·half).
fn tri(k: i64, half: i64) -> i64 {
    let p = k.rem_euclid(4 * half);
    if p <= half {
        p
    } else if p <= 3 * half {
        2 * half - p
    } else {
        p - 4 * half
    }
}

/// The log: ArduSub-like messages (formats as ArduPilot's LogStructure.h declares them),
/// and one message with every numeric type.
fn fixture() -> Vec<u8> {
    let mut w = Writer::new();
    w.declare(129, "PARM", "QNf", &["TimeUS", "Name", "Value"])
        .unwrap();
    w.declare(
        130,
        "BARO",
        "QBfffcfIffB",
        &[
            "TimeUS", "I", "Alt", "AltAMSL", "Press", "Temp", "CRt", "SMS", "Offset", "GndTemp",
            "Health",
        ],
    )
    .unwrap();
    w.declare(
        131,
        "RCOU",
        "QHHHHHHHH",
        &["TimeUS", "C1", "C2", "C3", "C4", "C5", "C6", "C7", "C8"],
    )
    .unwrap();
    w.declare(
        132,
        "ATT",
        "QccccCCCCB",
        &[
            "TimeUS", "DesRoll", "Roll", "DesPitch", "Pitch", "DesYaw", "Yaw", "ErrRP", "ErrYaw",
            "AEKF",
        ],
    )
    .unwrap();
    w.declare(
        133,
        "GPS",
        "QBBIHBcLLeffffB",
        &[
            "TimeUS", "I", "Status", "GMS", "GWk", "NSats", "HDop", "Lat", "Lng", "Alt", "Spd",
            "GCrs", "VZ", "Yaw", "U",
        ],
    )
    .unwrap();
    w.declare(134, "MODE", "QMBB", &["TimeUS", "Mode", "ModeNum", "Rsn"])
        .unwrap();
    w.declare(
        135,
        "TYPS",
        "QbBhHiIqfdgcCeE",
        &[
            "TimeUS", "b", "B", "h", "H", "i", "I", "q", "f", "d", "g", "c", "C", "e", "E",
        ],
    )
    .unwrap();
    w.declare(136, "MSG", "QZ", &["TimeUS", "Message"]).unwrap();
    w.write(129, &[1_000.0, 0.0, 1.5]).unwrap();
    w.write(136, &[2_000.0, 0.0]).unwrap();
    w.write(134, &[3_000.0, 19.0, 19.0, 1.0]).unwrap();
    for k in 0..120i64 {
        let t = 10_000_000.0 + 20_000.0 * k as f64;
        let a = tri(k, 15) as f64;
        let b = tri(k + 7, 11) as f64;
        for inst in 0..2 {
            let press = 101_325.0 + 1_000.0 * inst as f64 + 97.5 * a;
            w.write(
                130,
                &[
                    t + 100.0 * inst as f64,
                    inst as f64,
                    -0.125 * a,
                    10.0 - 0.125 * a,
                    press,
                    21.37 + 0.01 * b,
                    0.03125 * b,
                    (t / 1000.0).floor(),
                    0.0,
                    20.5,
                    1.0,
                ],
            )
            .unwrap();
        }
        let pwm = |i: i64| 1500.0 + (25 * tri(k + 3 * i, 16)) as f64;
        let mut rc = vec![t + 500.0];
        rc.extend((0..8).map(pwm));
        w.write(131, &rc).unwrap();
        w.write(
            132,
            &[
                t + 700.0,
                1.5 * a,
                1.25 * a + 0.03,
                -2.0 * b,
                -1.75 * b - 0.07,
                123.45 + a,
                122.99 + b,
                0.02,
                0.11,
                1.0,
            ],
        )
        .unwrap();
        if k % 5 == 0 {
            w.write(
                133,
                &[
                    t + 900.0,
                    0.0,
                    6.0,
                    (t / 1000.0).floor(),
                    2340.0,
                    14.0,
                    0.79,
                    -33.8688197 + 1e-6 * a,
                    151.2092955 - 2e-6 * b,
                    -1.23 + 0.01 * a,
                    0.15,
                    271.5,
                    -0.01,
                    0.0,
                    1.0,
                ],
            )
            .unwrap();
        }
        if k % 10 == 0 {
            w.write(
                135,
                &[
                    t + 1_100.0,
                    -100.0 - b,
                    200.0 + b,
                    -30_000.0 + 7.0 * a,
                    60_000.0 + 3.0 * b,
                    -2_000_000_000.0 + 12_345.0 * a,
                    4_000_000_000.0 + 54_321.0 * b,
                    -9_007_199_254_740_000.0 + 1_000.0 * a,
                    0.1 + 0.01 * a,
                    1.0 / 3.0 + a,
                    0.5 + 0.25 * b,
                    -300.0 + 0.5 * a,
                    600.0 - 0.25 * b,
                    -20_000_000.0 + 0.37 * a,
                    40_000_000.0 - 0.41 * b,
                ],
            )
            .unwrap();
        }
        if k == 60 {
            w.write(134, &[t + 1_300.0, 0.0, 0.0, 2.0]).unwrap();
        }
    }
    w.into_bytes()
}

#[test]
fn writer_still_writes_the_committed_bytes() {
    let bytes = fixture();
    if std::env::var_os("ROV_LOGS_WRITE_FIXTURES").is_some() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/writer.BIN");
        std::fs::write(path, &bytes).unwrap();
        return;
    }
    assert_eq!(bytes.len(), BIN.len());
    assert!(
        bytes == BIN,
        "the writer's bytes changed: regenerate (module docs)"
    );
}

/// Text fields DFReader decodes and the reader leaves out (not numbers).
const TEXT_FIELDS: [&str; 2] = ["PARM.Name", "MSG.Message"];

#[test]
fn reader_equals_dfreader_value_by_value() {
    assert_eq!(Format::detect(BIN), Some(Format::DataFlash));
    let log = read(BIN, None, "writer.BIN", &ReadOptions::default()).unwrap();
    assert!(log.report.sentences().is_empty(), "{:?}", log.report);
    let doc: Value = serde_json::from_str(JSON).unwrap();
    // DFReader's messages as series: `MSG.Field`, and `MSG[i].Field` for instances.
    let mut want: BTreeMap<String, Series> = BTreeMap::new();
    let mut text = std::collections::BTreeSet::new();
    let msgs = doc["messages"].as_array().unwrap();
    for m in msgs {
        let ty = m["type"].as_str().unwrap();
        let f = m["fields"].as_object().unwrap();
        let t = f["TimeUS"].as_f64().unwrap() * 1e-6;
        let inst = f.get("I").and_then(Value::as_i64);
        for (name, v) in f {
            let Some(x) = v.as_f64() else {
                text.insert(format!("{ty}.{name}"));
                continue;
            };
            let mut names = vec![format!("{ty}.{name}")];
            if let Some(i) = inst {
                names.push(format!("{ty}[{i}].{name}"));
            }
            for n in names {
                let s = want.entry(n).or_default();
                s.t_s.push(t);
                s.v.push(x);
            }
        }
    }
    assert_eq!(text, TEXT_FIELDS.iter().map(|s| s.to_string()).collect());
    assert_eq!(
        log.report.records,
        msgs.len() + doc["fmt_records"].as_u64().unwrap() as usize
    );
    assert_eq!(
        log.fields.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>()
    );
    let mut compared = 0;
    for (name, w) in &want {
        let g = &log.fields[name];
        assert_eq!(g.len(), w.len(), "{name}");
        for k in 0..w.len() {
            assert_eq!(g.t_s[k], w.t_s[k], "{name}[{k}] time");
            assert_eq!(
                g.v[k], w.v[k],
                "{name}[{k}]: ours {} DFReader {}",
                g.v[k], w.v[k]
            );
            compared += 1;
        }
    }
    assert!(compared > 5_000, "{compared}");
    // Every format character the reader decodes is in the log.
    let chars: std::collections::BTreeSet<char> = doc["formats"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|f| f.as_str().unwrap().chars())
        .collect();
    for c in "bBhHiIqQfdMgcCeEL".chars() {
        assert!(chars.contains(&c), "format character {c} not exercised");
    }
}

#[test]
fn half_floats_round_trip() {
    use rov_logs::dataflash::{f64_to_half, half_to_f64};
    for x in [
        0.0,
        0.5,
        -0.25,
        1.0,
        1.5,
        65504.0,
        -2.0f64.powi(-24),
        3.140625,
    ] {
        assert_eq!(half_to_f64(f64_to_half(x)), x, "{x}");
    }
    assert_eq!(f64_to_half(1.0), 0x3C00);
    assert_eq!(f64_to_half(-2.0), 0xC000);
    assert!(half_to_f64(f64_to_half(1e6)).is_infinite());
    // Ties to even: 1 + 2^-11 lies halfway between 1 and 1 + 2^-10.
    assert_eq!(f64_to_half(1.0 + 2f64.powi(-11)), 0x3C00);
}
