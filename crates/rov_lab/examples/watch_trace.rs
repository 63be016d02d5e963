//! Prints the model watch's evaluation trace over a measurement CSV (for tuning):
//! `cargo run -p rov_lab --example watch_trace -- FILE.csv [model3]`.
use rov_lab::watch::{Watch, WatchConfig};
use rov_types::measurement::MeasurementSeries;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).ok_or("usage: watch_trace FILE.csv [MODEL]")?;
    let model_name = args.get(2).map_or("model3", String::as_str);
    let text = std::fs::read_to_string(path)?;
    let series = MeasurementSeries::parse_csv(&text, path)?;
    let id: rov_types::ModelId = model_name.parse()?;
    let model = rov_lab::load_model(&id, None)?;
    let mut cfg = WatchConfig::default();
    if let Some(v) = std::env::var("WATCH_THRESHOLD")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cfg.threshold = v;
    }
    if let Some(v) = std::env::var("WATCH_BASELINE_S")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cfg.baseline_s = v;
    }
    if let Some(v) = std::env::var("WATCH_DRIFT")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cfg.drift = v;
    }
    let mut w = Watch::new(model, cfg, series.present);
    w.keep_trace(true);
    let mut shown = false;
    for r in &series.rows {
        if !shown && !w.learning() {
            for (i, n) in w.noise_floors().iter().enumerate() {
                if let Some(n) = n {
                    println!(
                        "BASE {i} mu {:?} s0 {:.4} kappa {:.3} floor {:.4} ratio {:.1}",
                        n.mu,
                        n.s0,
                        n.kappa,
                        n.sensor_floor,
                        n.s0 / n.sensor_floor
                    );
                }
            }
            shown = true;
        }
        for a in w.push(r) {
            println!("WORDS {} at {:.1} s", a.words(), a.t_s);
            println!("ALERT {:?}", a);
        }
    }
    for a in w.finish() {
        println!("ALERT {:?}", a);
    }
    println!("NOISE {:?}", w.noise_floors());
    for t in w.trace() {
        println!(
            "{:7.1} {} z {:7.2} {:7.2} {:7.2} {:7.2} | up {:6.1} {:6.1} {:6.1} {:6.1} | dn {:6.1} {:6.1} {:6.1} {:6.1}",
            t.t_s,
            if t.learning { "L" } else { " " },
            t.z[0],
            t.z[1],
            t.z[2],
            t.z[3],
            t.up[0],
            t.up[1],
            t.up[2],
            t.up[3],
            t.down[0],
            t.down[1],
            t.down[2],
            t.down[3]
        );
    }
    Ok(())
}
