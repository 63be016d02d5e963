//! The replay's model overlay is the model lab's engine (issue 14, one model engine): the
//! prediction the Plots and Replay tabs draw equals, sample for sample, what
//! `rov_lab::engine::predict_series` computes from the same session and model.

use rov_dynamics::{InitialConditions, ThrustPct, load_default_model, simulate};
use rov_station::runtime::replay::HORIZON_S;
use rov_station::runtime::{History, ReplayCommand, RuntimeCommand, VirtualReplay};
use rov_types::measurement::{MeasurementRow, MeasurementSeries};
use rov_types::model_id::{BaseModel, ModelId};

/// 30 s of a dive "measured" by model3 itself (50 Hz), crossing north.
fn model3_dive() -> MeasurementSeries {
    let m3 = load_default_model("model3").unwrap();
    let x0 = m3.initial_state(&InitialConditions::at_rest(3.0, 350.0));
    let inputs: Vec<(f64, ThrustPct)> = (0..1500)
        .map(|k| {
            let t = f64::from(k) * 0.02;
            let port = if t < 10.0 { 60.0 } else { -20.0 };
            let stbd = if t < 20.0 { 30.0 } else { 70.0 };
            (t, ThrustPct::new(port, stbd, 40.0 * (0.4 * t).sin()))
        })
        .collect();
    let out = simulate(m3.as_ref(), &x0, &inputs, 0.02).unwrap();
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
fn the_replay_overlay_is_the_lab_engines_prediction() {
    let _alone = crate::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m3.mcap");
    rov_session::import_csv(&model3_dive().to_csv(), "m3.csv", &path).unwrap();

    // What the engine predicts for this session (no autopilot record: model3).
    let session = rov_session::open(&path).unwrap();
    let (series, times_ns, _) = rov_session::measurements(&session).unwrap();
    let model = rov_lab::load_model(&ModelId::Base(BaseModel::Model3), None).unwrap();
    let expected = rov_lab::engine::predict_series(&model, &series, "m3", HORIZON_S).unwrap();
    let start_ns = session.start_ns().unwrap_or(0);
    let offset_s = (times_ns[0] - start_ns) as f64 * 1e-9 - series.rows[0].time_s;
    assert_eq!(expected.time_s.len(), series.rows.len());

    // The replay, played to the end.
    let (mut rp, rh) = VirtualReplay::open(&path).unwrap();
    rh.command(RuntimeCommand::Replay(ReplayCommand::Speed(50.0)));
    rh.command(RuntimeCommand::Replay(ReplayCommand::Play));
    let mut hist = History::default();
    let mut last_view = None;
    for _ in 0..200 {
        rp.advance(0.02);
        rh.sync_history(&mut hist);
        let v = rh.view();
        if let Some(p) = v.prediction {
            last_view = Some(p);
        }
    }
    assert!(hist.len() >= 1400, "{}", hist.len());
    let mut checked = 0;
    for i in 0..hist.len() {
        let s = hist.sample(i).unwrap();
        let (d, h) = expected.at(s.t_s - offset_s, 0.5).unwrap();
        // The history stores f32: the same numbers, rounded alike.
        assert_eq!(s.depth_pred_m, d as f32, "t = {}", s.t_s);
        assert_eq!(s.heading_pred_deg, h as f32, "t = {}", s.t_s);
        checked += 1;
    }
    assert!(checked >= 1400);
    // The view's own (f64) prediction at the end is the engine's last sample.
    let n = expected.time_s.len() - 1;
    assert_eq!(
        last_view,
        Some((expected.depth_m[n], expected.heading_deg[n]))
    );
    // model3 on its own dive: the overlay follows the measurement closely (every 10 s it
    // restarts from the measurement; in between the lab's integration differs from the
    // generator's by far less than the motion).
    let worst = series
        .rows
        .iter()
        .zip(&expected.depth_m)
        .map(|(r, d)| (r.depth_m - d).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.05, "depth off by {worst} m");
}
