//! The readers and the map on small logs: a DataFlash log from the test writer read back
//! value by value, cut short (read to its last good record and said so), a 6-thruster
//! PWM CSV through a map (clamping counted), and a map naming a missing field.

use rov_logs::dataflash::Writer;
use rov_logs::{Format, LogError, LogMap, ReadOptions, read};

fn dataflash_log() -> Vec<u8> {
    let mut w = Writer::new();
    w.declare(130, "BARO", "QBff", &["TimeUS", "I", "Press", "Temp"])
        .unwrap();
    w.declare(131, "RCOU", "QHH", &["TimeUS", "C1", "C2"])
        .unwrap();
    for k in 0..50u32 {
        let t = 1_000_000.0 + 100_000.0 * k as f64;
        w.write(130, &[t, 1.0, 101_325.0 + 100.0 * k as f64, 20.0])
            .unwrap();
        w.write(131, &[t + 5_000.0, 1500.0 + k as f64 * 20.0, 1500.0])
            .unwrap();
    }
    w.into_bytes()
}

#[test]
fn dataflash_round_trip_and_truncation() {
    let bytes = dataflash_log();
    assert_eq!(Format::detect(&bytes), Some(Format::DataFlash));
    let log = read(&bytes, None, "t.BIN", &ReadOptions::default()).unwrap();
    let p = &log.fields["BARO[1].Press"];
    assert_eq!(p.len(), 50);
    assert_eq!(p.v[3], 101_625.0);
    assert!((p.t_s[3] - 1.3).abs() < 1e-12);
    assert_eq!(log.fields["RCOU.C1"].v[2], 1540.0);
    assert!(log.report.truncated.is_none());
    let cut = &bytes[..bytes.len() - 4];
    let log = read(cut, None, "t.BIN", &ReadOptions::default()).unwrap();
    assert_eq!(log.fields["RCOU.C1"].len(), 49);
    assert!(log.report.truncated.is_some());
}

#[test]
fn six_thruster_pwm_csv_through_a_map() {
    let mut csv = String::from("time_s,thr1,thr2,thr3,thr4,thr5,thr6,depth\n");
    for k in 0..30 {
        let pwm = 1500 + 20 * k;
        csv.push_str(&format!(
            "{},{pwm},1500,1500,1500,1500,1100,{}\n",
            k as f64 * 0.1,
            k as f64 * 0.01
        ));
    }
    let mut map = String::from("format = \"csv\"\n[signals]\ndepth_m = { field = \"depth\" }\n");
    for i in 1..=6 {
        map.push_str(&format!(
            "[commands.thr{i}]\nfield = \"thr{i}\"\npwm = [1100, 1500, 1900]\n"
        ));
    }
    let m = LogMap::parse(&map, "six.toml").unwrap();
    let mapped = m.read_apply(csv.as_bytes(), "six.csv").unwrap();
    let table = mapped.lab_table();
    assert_eq!(table.t_s.len(), 30);
    assert_eq!(table.commands.len(), 6);
    assert_eq!(table.commands["thr1"][5], 25.0);
    assert_eq!(table.commands["thr6"][0], -100.0);
    // 1500 + 20k µs exceeds 1900 for k > 20: clamped and counted.
    assert_eq!(mapped.clamped["thr1"], 9);
    let bad = LogMap::parse("[signals]\ndepth_m = { field = \"z\" }\n", "bad.toml").unwrap();
    match bad.read_apply(csv.as_bytes(), "six.csv") {
        Err(LogError::MissingField { field, present, .. }) => {
            assert_eq!(field, "z");
            assert!(present.contains(&"thr1".to_string()));
        }
        other => panic!("{other:?}"),
    }
}

/// Messages of one logger pass, a few ms apart, share a row (`[time] merge_s`, default
/// 10 ms); a slower signal is NaN on the rows it was not measured on (never invented);
/// a command logged in the same pass is held on that row.
#[test]
fn samples_of_one_logger_pass_share_a_row() {
    let mut w = Writer::new();
    w.declare(130, "BARO", "QBff", &["TimeUS", "I", "Press", "Temp"])
        .unwrap();
    w.declare(131, "RCOU", "QH", &["TimeUS", "C1"]).unwrap();
    w.declare(132, "ATT", "Qf", &["TimeUS", "Roll"]).unwrap();
    for k in 0..20u32 {
        let t = 1_000_000.0 + 100_000.0 * k as f64;
        w.write(132, &[t, k as f64]).unwrap();
        w.write(131, &[t + 1_000.0, 1500.0 + 10.0 * k as f64])
            .unwrap();
        if k % 2 == 0 {
            w.write(130, &[t + 3_000.0, 1.0, 101_325.0, 20.0]).unwrap();
        }
    }
    let bytes = w.into_bytes();
    let map_text = "[commands.thr1]\nfield = \"RCOU.C1\"\npwm = [1100, 1500, 1900]\n\
                    [signals]\nroll_deg = { field = \"ATT.Roll\" }\n\
                    depth_m = { pressure_pa = \"BARO[1].Press\" }\n";
    let m = LogMap::parse(map_text, "m.toml").unwrap();
    let table = m.read_apply(&bytes, "t.BIN").unwrap().lab_table();
    assert_eq!(table.t_s.len(), 20, "{:?}", table.t_s);
    assert_eq!(table.signals["roll_deg"][7], 7.0);
    assert_eq!(table.signals["depth_m"][6], 0.0);
    assert!(table.signals["depth_m"][7].is_nan());
    assert_eq!(table.commands["thr1"][7], 17.5);
    // merge_s = 0: every distinct time is its own row.
    let m = LogMap::parse(&format!("[time]\nmerge_s = 0.0\n{map_text}"), "m.toml").unwrap();
    let table = m.read_apply(&bytes, "t.BIN").unwrap().lab_table();
    assert_eq!(table.t_s.len(), 30 - 1, "{:?}", table.t_s);
    let bad = LogMap::parse(&format!("[time]\nmerge_s = 2.0\n{map_text}"), "m.toml");
    assert!(bad.is_err());
}
