//! Measurement CSV export and import.

use crate::common::{info, record};
use rov_session::{
    NavRecord, SessionError, SessionWriter, ThrustRecord, WriterOptions, export_csv, import_csv,
    measurements_each, measurements_until, open,
};
use rov_types::measurement::{MeasurementSeries, OptionalChannel};
use std::ops::ControlFlow;

const MS: u64 = 1_000_000;

#[test]
fn export_parses_as_a_measurement_csv_with_every_channel() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    let ticks = record(&path, 250, WriterOptions::default());
    let s = open(&path).unwrap();
    let csv = export_csv(&s).unwrap();
    assert!(csv.warnings.is_empty(), "{:?}", csv.warnings);
    let m = MeasurementSeries::parse_csv(&csv.text, "export.csv").unwrap();
    assert_eq!(m.rows.len(), 250);
    assert_eq!(csv.rows, 250);
    assert!(
        m.rows.windows(2).all(|w| w[1].time_s > w[0].time_s),
        "strictly increasing time"
    );
    for (row, tk) in m.rows.iter().zip(&ticks) {
        assert_eq!(row.time_s, (tk.t_ns + 6 * MS) as f64 / 1e9);
        assert_eq!(row.depth_m, tk.nav.depth_m);
        assert_eq!(row.heading_deg, tk.nav.heading_deg);
        assert_eq!(row.get(OptionalChannel::YawRateDps), tk.nav.yaw_rate_dps);
        assert_eq!(row.get(OptionalChannel::SurgeMps), Some(tk.truth.u_mps));
        assert_eq!(row.get(OptionalChannel::NorthM), Some(tk.truth.north_m));
        // The command sent in this tick (after the nav reply) is in force until the next.
        assert_eq!(row.port_pct, tk.thrust.port_pct);
        assert_eq!(row.vertical_pct, tk.thrust.vertical_pct);
    }
    assert!(m.present.iter().all(|p| *p), "all optional columns present");
    // Every decoded channel is there as topic.field; the measurement reader ignores them.
    for col in [
        "telemetry_status.tether_v",
        "telemetry_nav.pressure_mbar",
        "link_stats.rtt_p99_ms",
        "link_stats.state",
        "pilot_input.armed",
        "pilot_input.buttons",
        "autopilot_state.depth_mode",
        "observer_state.heading_var",
        "events.text",
        "truth_state.r_dps",
        "command_thrust.depth_target_mbar",
    ] {
        assert!(csv.extra_columns.iter().any(|c| c == col), "{col} missing");
    }
    assert!(
        !csv.extra_columns
            .iter()
            .any(|c| c.starts_with("session_info"))
    );
    // The measurement reader says once, per topic, which columns it leaves out.
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    assert!(m.warnings[0].contains(&format!("{} columns", csv.extra_columns.len())));
    assert!(m.warnings[0].contains("ignored"));
    assert!(m.warnings[0].contains("truth_state.*"));
    // Last-value sampling: status is 1 Hz, sampled at every row.
    let header: Vec<&str> = csv.text.lines().next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "telemetry_status.tether_v")
        .unwrap();
    let ev = header.iter().position(|h| *h == "events.kind").unwrap();
    let line = |k: usize| {
        csv.text
            .lines()
            .nth(k + 1)
            .unwrap()
            .split(',')
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(line(0)[col], "", "no status before the first one at 7 ms");
    assert_eq!(line(0)[ev], "");
    assert_eq!(line(1)[col], "340");
    assert_eq!(line(60)[col], (340.0 - 0.01f64).to_string());
    assert_eq!(line(8)[ev], "depth_hold");
}

fn nav_at(w: &mut SessionWriter, t: u64, depth: f64) {
    let nav = NavRecord {
        depth_m: depth,
        heading_deg: 10.0,
        pitch_deg: 0.0,
        roll_deg: 0.0,
        ..NavRecord::default()
    };
    w.write(t, &nav).unwrap();
}

fn thrust_at(w: &mut SessionWriter, t: u64, port: f64) {
    let c = ThrustRecord {
        port_pct: port,
        starboard_pct: 0.0,
        vertical_pct: 0.0,
        ..ThrustRecord::default()
    };
    w.write(t, &c).unwrap();
}

/// A reader that breaks (a cancelled load) ends the pass there: no row after the break
/// is read, and the result says the pass did not finish; one that never breaks gets
/// every row and the same result as `measurements_each`.
#[test]
fn a_streamed_read_stops_when_the_reader_breaks() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dive.mcap");
    record(&path, 250, WriterOptions::default());
    let s = open(&path).unwrap();
    let mut seen = 0usize;
    let done = measurements_until(&s, &mut |_, _| {
        seen += 1;
        if seen == 40 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(done, None);
    assert_eq!(seen, 40, "no row is handed on after the break");
    let mut all = 0usize;
    let whole = measurements_until(&s, &mut |_, _| {
        all += 1;
        ControlFlow::Continue(())
    })
    .unwrap()
    .unwrap();
    assert_eq!((all, whole.rows), (250, 250));
    let each = measurements_each(&s, &mut |_, _| {}).unwrap();
    assert_eq!(each, whole);
}

/// Row k's command is the last one sent before t_{k+1}.
#[test]
fn timing_rule_command_in_force_until_the_next_sample() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("timing.mcap");
    let mut w = SessionWriter::create(&path, &info(), 0).unwrap();
    nav_at(&mut w, 50 * MS, 0.5); // row 0: no command before t_1 → 0 %
    nav_at(&mut w, 100 * MS, 1.0); // row 1
    thrust_at(&mut w, 110 * MS, 150.0); // sent before t_2 → row 1's; clamped to 100
    nav_at(&mut w, 120 * MS, 2.0); // row 2
    thrust_at(&mut w, 125 * MS, 20.0);
    thrust_at(&mut w, 130 * MS, 30.0); // last before t_3 → row 2's command
    nav_at(&mut w, 140 * MS, 3.0); // row 3
    thrust_at(&mut w, 140 * MS, 40.0); // sent at t_3 itself: row 3's command
    nav_at(&mut w, 140 * MS, 3.5); // duplicate time: the later nav wins
    nav_at(&mut w, 160 * MS, 4.0); // row 4 (last): commands before 160 + 20 ms
    thrust_at(&mut w, 175 * MS, -50.0);
    thrust_at(&mut w, 185 * MS, -60.0); // after t_3 + interval: not used
    w.finish().unwrap();
    let s = open(&path).unwrap();
    let csv = export_csv(&s).unwrap();
    let m = MeasurementSeries::parse_csv(&csv.text, "t.csv").unwrap();
    let port: Vec<f64> = m.rows.iter().map(|r| r.port_pct).collect();
    let depth: Vec<f64> = m.rows.iter().map(|r| r.depth_m).collect();
    let times: Vec<f64> = m.rows.iter().map(|r| r.time_s).collect();
    assert_eq!(times, [0.05, 0.1, 0.12, 0.14, 0.16]);
    assert_eq!(depth, [0.5, 1.0, 2.0, 3.5, 4.0]);
    assert_eq!(port, [0.0, 100.0, 30.0, 40.0, -50.0]);
    let all = csv.warnings.join("\n");
    assert!(
        all.contains("1 rows precede the first /command/thrust"),
        "{all}"
    );
    assert!(all.contains("the same time as the one before"), "{all}");
    assert!(all.contains("clamped"), "{all}");
}

#[test]
fn export_needs_nav() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.mcap");
    SessionWriter::create(&path, &info(), 0)
        .unwrap()
        .finish()
        .unwrap();
    let e = export_csv(&open(&path).unwrap()).unwrap_err();
    assert!(matches!(e, SessionError::Unusable(_)));
    assert!(e.to_string().contains("no /telemetry/nav messages"), "{e}");
}

const CSV: &str = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg,yaw_rate_dps,surge_mps,north_m,comment\n\
0,10,-10,30,1.0,359.5,-2,0.5,1.5,0.25,0,x\n\
0.02,10,-10,30,1.0100000000000002,0.3,,0.6,2.0,0.26,0.005,y\n\
0.04,-100,100,0,1.02,1.1,1.5,nan,2.5,0.27,0.0105,z\n\
0.1,55.5,0,-30,1.1,2.2,1.5,0.7,3,0.3,0.02,w\n";

/// Import then export gives back the measurement columns exactly (times to the ns).
#[test]
fn import_then_export_preserves_the_measurement_columns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("imported.mcap");
    let report = import_csv(CSV, "in.csv", &out).unwrap();
    assert_eq!(report.rows, 4);
    assert!(
        report.warnings.iter().any(|w| w.contains("comment")),
        "{:?}",
        report.warnings
    );
    let s = open(&out).unwrap();
    assert!(s.is_complete());
    assert_eq!(s.info().unwrap().vehicle, "import");
    assert_eq!(s.count("/telemetry/nav"), 4);
    assert_eq!(s.count("/command/thrust"), 4);
    assert_eq!(s.count("/truth/state"), 4);
    let back = MeasurementSeries::parse_csv(&export_csv(&s).unwrap().text, "back.csv").unwrap();
    let orig = MeasurementSeries::parse_csv(CSV, "in.csv").unwrap();
    assert_eq!(back.rows.len(), orig.rows.len());
    for (a, b) in back.rows.iter().zip(&orig.rows) {
        assert!(
            (a.time_s - b.time_s).abs() < 1e-9,
            "{} vs {}",
            a.time_s,
            b.time_s
        );
        let bits = |r: &rov_types::MeasurementRow| {
            [
                r.port_pct,
                r.starboard_pct,
                r.vertical_pct,
                r.depth_m,
                r.heading_deg,
                r.pitch_deg,
                r.roll_deg,
            ]
            .map(f64::to_bits)
        };
        assert_eq!(bits(a), bits(b));
        for ch in [
            OptionalChannel::YawRateDps,
            OptionalChannel::SurgeMps,
            OptionalChannel::NorthM,
        ] {
            assert_eq!(
                a.get(ch).map(f64::to_bits),
                b.get(ch).map(f64::to_bits),
                "{ch:?}"
            );
        }
    }
    // Columns the CSV did not have come back absent or NaN, never invented.
    assert!(!back.present[OptionalChannel::PitchRateDps as usize]);
    assert!(back.rows[0].get(OptionalChannel::SwayMps).unwrap().is_nan());
}

#[test]
fn import_rejects_bad_csv_and_shifts_negative_time() {
    let dir = tempfile::tempdir().unwrap();
    let e = import_csv(
        "time_s,depth_m\n0,1\n",
        "bad.csv",
        dir.path().join("a.mcap"),
    )
    .unwrap_err();
    assert!(matches!(e, SessionError::Csv(_)), "{e}");
    assert!(e.to_string().contains("bad.csv"), "{e}");
    let text = "time_s,port_pct,starboard_pct,vertical_pct,depth_m,heading_deg,pitch_deg,roll_deg\n-1,0,0,0,1,0,0,0\n0,0,0,0,2,0,0,0\n";
    let out = dir.path().join("b.mcap");
    let r = import_csv(text, "neg.csv", &out).unwrap();
    assert!(
        r.warnings.iter().any(|w| w.contains("shifted")),
        "{:?}",
        r.warnings
    );
    let m =
        MeasurementSeries::parse_csv(&export_csv(&open(&out).unwrap()).unwrap().text, "x").unwrap();
    assert_eq!(
        m.rows.iter().map(|r| r.time_s).collect::<Vec<_>>(),
        [0.0, 1.0]
    );
}
