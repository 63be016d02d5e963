//! Re-simulation: recorded thrust commands drive a model; fits per channel.

use rov_dynamics::{Channel, InitialConditions, ThrustPct, load_default_model, simulate};
use rov_session::{ResimOptions, import_csv, open, resimulate};
use rov_types::measurement::{MeasurementRow, MeasurementSeries};

/// A dive "measured" by running model3 itself, so model3 must fit it perfectly.
fn model3_dive() -> MeasurementSeries {
    let m3 = load_default_model("model3").unwrap();
    let ic = InitialConditions::at_rest(3.0, 350.0);
    let x0 = m3.initial_state(&ic);
    let inputs: Vec<(f64, ThrustPct)> = (0..1500)
        .map(|k| {
            let t = k as f64 * 0.02;
            let port = if t < 10.0 { 60.0 } else { -20.0 };
            let stbd = if t < 20.0 { 30.0 } else { 70.0 };
            let vert = 40.0 * (0.4 * t).sin();
            (t, ThrustPct::new(port, stbd, vert))
        })
        .collect();
    let out = simulate(m3.as_ref(), &x0, &inputs, ResimOptions::default().dt_max_s).unwrap();
    let rows = inputs
        .iter()
        .zip(&out)
        .map(|((t, c), o)| MeasurementRow {
            time_s: *t,
            port_pct: c.port,
            starboard_pct: c.starboard,
            vertical_pct: c.vertical,
            depth_m: o.depth_m.unwrap(),
            heading_deg: o.heading_deg.unwrap().rem_euclid(360.0),
            pitch_deg: o.pitch_deg.unwrap(),
            roll_deg: o.roll_deg.unwrap(),
            optional: [None; 8],
        })
        .collect();
    MeasurementSeries {
        rows,
        ..MeasurementSeries::default()
    }
}

#[test]
fn model3_reproduces_its_own_dive_and_model1_reports_what_it_does_not_predict() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m3.mcap");
    import_csv(&model3_dive().to_csv(), "m3.csv", &path).unwrap();
    let s = open(&path).unwrap();

    let m3 = load_default_model("model3").unwrap();
    let r = resimulate(&s, m3.as_ref(), &ResimOptions::default()).unwrap();
    assert_eq!(r.model, "model3");
    assert_eq!(r.measured.rows.len(), 1500);
    assert_eq!(r.predicted.rows.len(), 1500);
    assert_eq!(r.fits.len(), 4);
    for f in &r.fits {
        assert!(f.predicted, "{f:?}");
        assert_eq!(f.samples, 1500);
        assert!(f.fit_pct.unwrap() > 99.999, "{f:?}");
        assert!(f.rmse.unwrap() < 1e-6, "{f:?}");
    }
    // Heading crossed north (350° + turning) yet fits: the error is wrapped.
    let h = &r.measured.rows;
    assert!(h.iter().any(|r| r.heading_deg < 10.0) && h.iter().any(|r| r.heading_deg > 340.0));

    let m1 = load_default_model("model1").unwrap();
    let r1 = resimulate(&s, m1.as_ref(), &ResimOptions::default()).unwrap();
    let by = |ch: Channel| r1.fits.iter().find(|f| f.channel == ch).unwrap().clone();
    assert!(by(Channel::Depth).predicted && by(Channel::Depth).rmse.is_some());
    for ch in [Channel::Pitch, Channel::Roll] {
        let f = by(ch);
        assert!(!f.predicted, "{f:?}");
        assert_eq!((f.samples, f.fit_pct, f.rmse), (0, None, None));
    }
    assert!(r1.predicted.rows.iter().all(|r| r.pitch_deg.is_nan()));
    assert!(by(Channel::Depth).fit_pct.unwrap() < 99.999);
}
