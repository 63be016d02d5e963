//! Session benchmarks: recording cost per 50 Hz tick, opening a one-hour file (through its
//! summary, and by a full scan), reading it and exporting it (a model is compared with a
//! session by the model lab's engine: `rov_lab`).
//!
//! Run: `cargo bench -p rov_session -- --warm-up-time 1 --measurement-time 3`
//!
//! Targets: a tick (every topic of one 20 ms tick) < 400 µs (2 % of one core); open a
//! one-hour file through its summary < 50 ms (an 8-hour file must open in < 2 s with
//! everything else the tools do). The one-hour file (50 Hz: raw frames both ways, nav,
//! truth, observer, pilot, autopilot, thrust, the pose topics; status and link stats at
//! 1 Hz; an event every 10 s) is generated once into a temp dir.

#[path = "../tests/it/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use rov_session::{SessionWriter, WriterOptions, export_csv_to, open};

/// Counts the bytes written to it.
#[derive(Default)]
struct Count(u64);

impl std::io::Write for Count {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0 += b.len() as u64;
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

const HOUR_TICKS: u64 = 50 * 3600;

/// CPU time of this process so far (user + system, all threads), s; 10 ms resolution.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<f64> = stat
        .rsplit_once(')')
        .map_or("", |(_, rest)| rest)
        .split_whitespace()
        .map(|f| f.parse().unwrap_or(0.0))
        .collect();
    // utime and stime are fields 14 and 15 of stat(5), in clock ticks (100 per second).
    (fields.get(11).copied().unwrap_or(0.0) + fields.get(12).copied().unwrap_or(0.0)) / 100.0
}

fn bench_record(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("tempdir");
    // CPU time per tick over 5 minutes of session (15 000 ticks), default options.
    {
        let path = dir.path().join("cpu.mcap");
        let ticks: Vec<common::Tick> = (0..15_000).map(common::tick).collect();
        let (cpu0, wall0) = (cpu_s(), Instant::now());
        let mut w = SessionWriter::create(&path, &common::info(), 0).expect("create");
        for tk in &ticks {
            common::write_tick(&mut w, tk).expect("write");
        }
        w.finish().expect("finish");
        eprintln!(
            "recording, default options: {:.1} µs CPU and {:.1} µs wall per 50 Hz tick ({:.2} % of a core)",
            (cpu_s() - cpu0) / 15_000.0 * 1e6,
            wall0.elapsed().as_secs_f64() / 15_000.0 * 1e6,
            (cpu_s() - cpu0) / 300.0 * 100.0
        );
    }
    let mut g = c.benchmark_group("record");
    for (name, opts) in [
        ("tick_50hz_flush_250ms_fsync_1s", WriterOptions::default()),
        (
            "tick_50hz_flush_250ms_no_fsync",
            WriterOptions {
                sync_interval_ns: u64::MAX,
                ..WriterOptions::default()
            },
        ),
    ] {
        let path = dir.path().join(format!("{name}.mcap"));
        let mut w = SessionWriter::create_with(&path, &common::info(), 0, opts).expect("create");
        let ticks: Vec<common::Tick> = (0..1000).map(common::tick).collect();
        let mut k = 0u64;
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut tk = ticks[(k % 1000) as usize].clone();
                tk.t_ns = k * common::TICK_NS;
                k += 1;
                common::write_tick(&mut w, black_box(&tk)).expect("write");
            })
        });
        w.finish().expect("finish");
    }
    g.finish();
}

fn bench_hour(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("hour.mcap");
    let t = Instant::now();
    let opts = WriterOptions {
        sync_interval_ns: u64::MAX,
        ..WriterOptions::default()
    };
    let mut w = SessionWriter::create_with(&path, &common::info(), 0, opts).expect("create");
    for k in 0..HOUR_TICKS {
        common::write_tick(&mut w, &common::tick(k)).expect("write");
    }
    let summary = w.finish().expect("finish");
    let size = std::fs::metadata(&path).expect("stat").len();
    eprintln!(
        "one-hour file: {} messages, {} chunks, {:.1} MB, written in {:.1} s",
        summary.messages,
        summary.chunks,
        size as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    // Opening through the summary, and by a scan (a file without one), wall and CPU.
    for (name, scan) in [("through the summary", false), ("by a full scan", true)] {
        let (cpu0, wall0) = (cpu_s(), Instant::now());
        for _ in 0..3 {
            let s = if scan {
                rov_session::Session::open_scanned(&path)
            } else {
                open(&path)
            };
            black_box(s.expect("open").len());
        }
        eprintln!(
            "open one hour {name}: mean wall {:.1} ms, mean CPU {:.1} ms",
            wall0.elapsed().as_secs_f64() / 3.0 * 1e3,
            (cpu_s() - cpu0) / 3.0 * 1e3
        );
    }
    let session = open(&path).expect("open");
    let t = Instant::now();
    let n = session.messages().count();
    eprintln!(
        "read every message of the one-hour file in time order: {n} in {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let mut out = Count::default();
    let csv = export_csv_to(&session, &mut out).expect("export");
    eprintln!(
        "export of the one-hour file: {} rows x {} extra columns, {:.1} MB of CSV in {:.2} s",
        csv.rows,
        csv.extra_columns.len(),
        out.0 as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    drop(csv);

    let mut g = c.benchmark_group("one_hour");
    g.sample_size(10);
    g.bench_function("open", |b| {
        b.iter(|| black_box(open(&path).expect("open")).len())
    });
    g.bench_function("open_and_decode_nav", |b| {
        b.iter(|| {
            let s = open(&path).expect("open");
            black_box(s.records::<rov_session::NavRecord>().expect("nav").len())
        })
    });
    g.finish();
}

criterion_group!(benches, bench_record, bench_hour);
criterion_main!(benches);
