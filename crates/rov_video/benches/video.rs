//! Video benchmarks.
//!
//! Run: `cargo bench -p rov_video --bench video -- --warm-up-time 1 --measurement-time 5`
//!
//! * `simcam/render_640x480`: one frame of the simulator's camera (target ≤ 5 ms on one
//!   core). The pose changes every iteration (a diving turn, lights at 50 %).
//!   `simcam/render_640x480_cpu` reports CPU time instead of wall time (immune to other
//!   work on the machine).
//! * `station_path/test_source_to_slot`: the `test` source (live, 25 fps) → capture →
//!   latest-frame slot, as a consumer polling every 1 ms sees it, from the buffer's time
//!   (criterion reports the mean per frame); the consumer polls, so up to 1 ms of it is the
//!   polling. Printed at the end: p50/p99 of that, and of the latency the station's path
//!   adds (raw frame entering conversion → slot; target p99 ≤ 50 ms).
//! * `encoder/cpu_per_video_second`: CPU time (all threads) to encode one second of
//!   640×480 sim-camera video at 25 fps with the recording settings.
//! * `decoder/frame_640x480`: decoding one access unit for replay.

use std::hint::black_box;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use rov_video::simcam::{CameraModel, CameraPose, SimCamera, SimScene};
use rov_video::stats::percentile;
use rov_video::{
    Capture, CaptureConfig, Decoder, Encoder, EncoderConfig, SourceSpec, TimeSource, VideoFrame,
};

fn pose(i: u64) -> CameraPose {
    let t = i as f64 * 0.04;
    CameraPose::from_degrees(
        0.1 * t,
        0.0,
        1.0 + 0.1 * (t % 40.0),
        1.0,
        -2.0,
        9.0 * t,
        -10.0,
    )
}

fn bench_simcam(c: &mut Criterion) {
    let cam = SimCamera::new(SimScene::default(), CameraModel::default(), true).expect("camera");
    let mut frame = VideoFrame::black(640, 480, 0);
    let mut i = 0u64;
    let mut group = c.benchmark_group("simcam");
    group.bench_function("render_640x480", |b| {
        b.iter(|| {
            i += 1;
            cam.render_into(&pose(i), 50.0, &mut frame);
            black_box(&frame);
        });
    });
    // The same in CPU time (one thread renders): on a loaded machine the wall time above
    // also counts the time the thread waited for a core.
    group.sample_size(10);
    group.bench_function("render_640x480_cpu", |b| {
        b.iter_custom(|iters| {
            let start = process_cpu();
            for _ in 0..iters {
                i += 1;
                cam.render_into(&pose(i), 50.0, &mut frame);
                black_box(&frame);
            }
            process_cpu().saturating_sub(start)
        });
    });
    group.finish();
}

fn bench_station_path(c: &mut Criterion) {
    let clock = TimeSource::monotonic();
    let cap = Capture::start(
        &SourceSpec::Test,
        CaptureConfig {
            clock: clock.clone(),
            ..CaptureConfig::default()
        },
        vec![],
    )
    .expect("test source");
    let slot = cap.slot();
    cap.wait_first_frame(Duration::from_secs(10))
        .expect("first frame");
    let all_ms = Arc::new(Mutex::new(Vec::<f64>::new()));
    let mut last_seq = slot.latest().map(|f| f.seq);
    let mut group = c.benchmark_group("station_path");
    group.sample_size(10);
    group.bench_function("test_source_to_slot", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let deadline = Instant::now() + Duration::from_secs(2);
                loop {
                    if let Some(f) = slot.newer_than(last_seq) {
                        let latency_ns = clock.now_ns().saturating_sub(f.capture_ns);
                        last_seq = Some(f.seq);
                        total += Duration::from_nanos(latency_ns);
                        if let Ok(mut v) = all_ms.lock() {
                            v.push(latency_ns as f64 * 1e-6);
                        }
                        break;
                    }
                    if Instant::now() > deadline {
                        total += Duration::from_secs(2);
                        break;
                    }
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
            total
        });
    });
    group.finish();
    let mut v = all_ms.lock().map(|v| v.clone()).unwrap_or_default();
    v.sort_by(f64::total_cmp);
    let st = cap.stats();
    println!(
        "station_path: {} frames seen by the consumer, buffer time → consumer p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms; \
         added by the station path (raw frame → slot, last 256 frames) p50 {:.2} ms, p99 {:.2} ms; capture fps {:.1}, missed {}",
        v.len(),
        percentile(&v, 0.5).unwrap_or(f64::NAN),
        percentile(&v, 0.99).unwrap_or(f64::NAN),
        v.last().copied().unwrap_or(f64::NAN),
        st.path_latency_p50_ms.unwrap_or(f64::NAN),
        st.path_latency_p99_ms.unwrap_or(f64::NAN),
        st.fps,
        st.frames_missed,
    );
    cap.stop();
}

/// CPU time of the process (user + system, all threads), from /proc (10 ms ticks).
fn process_cpu() -> Duration {
    let text = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after_name = text.rsplit_once(')').map_or("", |(_, r)| r);
    // stat(5): utime and stime are the 14th and 15th fields; after the name, 12th and 13th.
    let ticks: u64 = after_name
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|f| f.parse::<u64>().ok())
        .sum();
    Duration::from_millis(ticks * 10)
}

fn sim_frames(n: u64) -> Vec<Arc<VideoFrame>> {
    let cam = SimCamera::new(SimScene::default(), CameraModel::default(), true).expect("camera");
    (0..n)
        .map(|i| Arc::new(cam.render(&pose(i), 50.0, i * 40_000_000, i)))
        .collect()
}

fn bench_codec(c: &mut Criterion) {
    let frames = sim_frames(125);
    let mut group = c.benchmark_group("encoder");
    group.sample_size(10);
    // One iteration = 5 s of video; the time reported is CPU time per video second.
    group.bench_function("cpu_per_video_second", |b| {
        b.iter_custom(|iters| {
            let mut cpu = Duration::ZERO;
            for _ in 0..iters {
                let start = process_cpu();
                let enc = Encoder::start(EncoderConfig::default(), |au| {
                    black_box(au);
                })
                .expect("encoder");
                for f in &frames {
                    enc.push_blocking(Arc::clone(f)).expect("push");
                }
                enc.finish(Duration::from_secs(60)).expect("finish");
                cpu += process_cpu().saturating_sub(start) / 5;
            }
            cpu
        });
    });
    group.finish();

    let aus = Arc::new(Mutex::new(Vec::new()));
    let out = Arc::clone(&aus);
    let enc = Encoder::start(EncoderConfig::default(), move |au| {
        if let Ok(mut v) = out.lock() {
            v.push(au);
        }
    })
    .expect("encoder");
    for f in &frames {
        enc.push_blocking(Arc::clone(f)).expect("push");
    }
    enc.finish(Duration::from_secs(60)).expect("finish");
    let aus = aus.lock().map(|v| v.clone()).unwrap_or_default();
    let mut dec = Decoder::new(Duration::from_millis(500)).expect("decoder");
    let mut i = 0usize;
    c.bench_function("decoder/frame_640x480", |b| {
        b.iter(|| {
            if i.is_multiple_of(aus.len()) {
                dec.reset().expect("reset");
            }
            if let Some(au) = aus.get(i % aus.len()) {
                black_box(dec.decode(au).expect("decode"));
            }
            i += 1;
        });
    });
}

criterion_group!(benches, bench_simcam, bench_station_path, bench_codec);
criterion_main!(benches);
