//! One UI frame (egui pass + tessellation, i.e. all the CPU work before the GPU) with one
//! hour of 20 Hz telemetry loaded (72 000 samples × 13 channels), on the Plots tab
//! showing the whole hour, the Plots tab showing the last 2 minutes, and the Fly tab.
//! Budget: ≤ 8 ms of CPU per frame.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};

use criterion::{Criterion, criterion_group, criterion_main};
use rov_gui::{AutodetectResult, Backend, StationApp, Tab};
use rov_station::runtime::{
    AxisModeView, AxisView, Connection, History, HistorySample, RuntimeError, StationHandle,
    StationView,
};

struct NoBackend;

impl Backend for NoBackend {
    fn connect(&mut self, _c: &Connection) -> Result<StationHandle, RuntimeError> {
        Err(RuntimeError::Transport(
            rov_driver::TransportError::Unsupported("no station in the bench".into()),
        ))
    }
    fn open_replay(&mut self, _p: &Path) -> Result<StationHandle, RuntimeError> {
        Err(RuntimeError::Transport(
            rov_driver::TransportError::Unsupported("no replay in the bench".into()),
        ))
    }
    fn ports(&mut self) -> Vec<String> {
        Vec::new()
    }
    fn autodetect(&mut self, _p: Vec<String>) -> Receiver<AutodetectResult> {
        channel().1
    }
    fn recording_path(&mut self) -> PathBuf {
        PathBuf::from("bench.mcap")
    }

    fn recordings_dir(&self) -> PathBuf {
        PathBuf::from(".")
    }
}

/// One hour at 20 Hz of a vehicle doing depth and heading steps, with noise.
fn hour_at_20hz() -> History {
    let mut h = History::default();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for k in 0..72_000u32 {
        let t = f64::from(k) * 0.05;
        let sp_d = 5.0 + 2.0 * ((t / 120.0).floor() % 3.0);
        let sp_h = (90.0 * (t / 300.0).floor()).rem_euclid(360.0);
        let d = sp_d - 0.3 * (-(t % 120.0) / 8.0).exp() + 0.01 * noise();
        let hd = (sp_h - 20.0 * (-(t % 300.0) / 10.0).exp() + 0.5 * noise()).rem_euclid(360.0);
        h.push(&HistorySample {
            t_s: t,
            depth_m: d as f32,
            depth_sp_m: sp_d as f32,
            depth_est_m: (d + 0.005) as f32,
            depth_pred_m: (d + 0.05 * (t / 10.0).sin()) as f32,
            heading_deg: hd as f32,
            heading_sp_deg: sp_h as f32,
            heading_est_deg: hd as f32,
            heading_pred_deg: ((hd + 2.0) % 360.0) as f32,
            pitch_deg: (0.5 * noise()) as f32,
            roll_deg: (0.5 * noise()) as f32,
            port_pct: (20.0 * noise()) as f32,
            starboard_pct: (20.0 * noise()) as f32,
            vertical_pct: (30.0 * noise()) as f32,
        });
    }
    h
}

fn app(tab: Tab, window_s: f64) -> StationApp {
    let history = hour_at_20hz();
    let last = history.sample(history.len() - 1).unwrap();
    let mut view = StationView::default();
    view.snapshot.depth_m = Some(f64::from(last.depth_m));
    view.snapshot.heading_deg = Some(f64::from(last.heading_deg));
    view.snapshot.pitch_deg = Some(1.0);
    view.snapshot.roll_deg = Some(-2.0);
    view.snapshot.time_s = last.t_s;
    view.snapshot.armed = true;
    view.depth = AxisView {
        mode: AxisModeView::Hold,
        overridden: false,
        setpoint: Some(f64::from(last.depth_sp_m)),
    };
    view.heading = AxisView {
        mode: AxisModeView::Hold,
        overridden: false,
        setpoint: Some(f64::from(last.heading_sp_deg)),
    };
    view.link.health = "connected".into();
    let mut a = StationApp::new(Box::new(NoBackend), None);
    a.show_offline(view, history);
    a.set_tab(tab);
    a.set_plot_window(window_s);
    a
}

fn frame(c: &mut Criterion) {
    let mut g = c.benchmark_group("frame");
    for (name, tab, window) in [
        ("plots_1h_of_20hz_whole_hour", Tab::Plots, 3600.0),
        ("plots_1h_of_20hz_last_2min", Tab::Plots, 120.0),
        ("fly_1h_of_20hz", Tab::Fly, 120.0),
    ] {
        let mut app = app(tab, window);
        let ctx = egui::Context::default();
        let input = || egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1280.0, 800.0),
            )),
            ..egui::RawInput::default()
        };
        // Warm up (fonts, layout caches).
        for _ in 0..3 {
            let out = ctx.run_ui(input(), |ui| app.ui(ui));
            let _ = ctx.tessellate(out.shapes.clone(), out.pixels_per_point);
            out.drop_without_applying_deltas();
        }
        g.bench_function(name, |b| {
            b.iter(|| {
                let out = ctx.run_ui(input(), |ui| app.ui(ui));
                let prims = ctx.tessellate(out.shapes.clone(), out.pixels_per_point);
                out.drop_without_applying_deltas();
                prims.len()
            });
        });
    }
    // The decimation alone (all ten plotted series over the whole hour, 1200 columns).
    let h = hour_at_20hz();
    g.bench_function("decimate_10_series_whole_hour", |b| {
        b.iter(|| {
            let mut n = 0;
            for (_, series) in rov_gui::plots::PLOTS {
                for s in series {
                    n += rov_gui::plots::series_points(&h, s.channel, 0.0, 3600.0, 1200, Some(0.0))
                        .len();
                }
            }
            n
        });
    });
    g.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
