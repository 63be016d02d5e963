//! Link throughput over a pseudo-terminal pair (harness = false; prints figures).
//!
//! 1. Mock pacing at 115200 baud, turnaround 0: control + nav exchanges back to back
//!    (23-byte request + 42-byte reply = 5.64 ms on the wire → ≈ 177 exchanges/s).
//! 2. Pacing off: the software's own ceiling over a bare pty.
//!
//! `cargo bench -p scenarios --bench link_pty [-- SECONDS]`

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use rov_driver::{Link, LinkConfig, MonoClock, SerialTransport, run_blocking};
use rov_vehicle::{FaultConfig, RunnerConfig, Vehicle, VehicleConfig, WireTiming, runner};

fn run(paced: bool, seconds: f64) -> (f64, rov_driver::RttSummary, rov_driver::LinkCounters) {
    let (master, mut slave, _) = SerialTransport::pty_pair().expect("pty");
    let cfg = VehicleConfig {
        timing: WireTiming {
            paced,
            turnaround_us: 0,
            ..WireTiming::default()
        },
        faults: FaultConfig::none(),
        ..VehicleConfig::default()
    };
    let vehicle = Vehicle::with_model3(cfg, 1).expect("model");
    let thread = runner::spawn(vehicle, Box::new(master), RunnerConfig::default());
    let link_cfg = LinkConfig {
        cycle_period_us: 0,
        status_every: 0,
        init_dump: false,
        record_frames: false,
        rtt_window: 100_000,
        ..LinkConfig::default()
    };
    let mut link = Link::new(link_cfg).expect("config");
    let clock = MonoClock::new();
    // Warm up until running.
    let mut start: Option<(Instant, u64)> = None;
    let mut window_start_responses = 0;
    run_blocking(
        &mut link,
        &mut slave,
        &clock,
        Duration::from_millis(5),
        |link, _now| {
            while link.poll_event().is_some() {}
            match start {
                None if link.counters().responses >= 20 => {
                    start = Some((Instant::now(), 0));
                    window_start_responses = link.counters().responses;
                    ControlFlow::Continue(())
                }
                Some((t, _)) if t.elapsed().as_secs_f64() >= seconds => ControlFlow::Break(()),
                _ => ControlFlow::Continue(()),
            }
        },
    )
    .expect("link");
    let elapsed = start.map_or(1.0, |(t, _)| t.elapsed().as_secs_f64());
    let c = link.counters();
    let rate = (c.responses - window_start_responses) as f64 / elapsed;
    let rtt = link.rtt();
    drop(slave);
    let _ = thread.stop();
    (rate, rtt, c)
}

fn main() {
    let seconds: f64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5.0);
    let wire_rate = 115_200.0 / 10.0 / 65.0;
    let (rate, rtt, c) = run(true, seconds);
    println!(
        "pty, paced 115200 8N1, turnaround 0: {rate:.1} exchanges/s = {:.1} % of the wire's {wire_rate:.1}/s; \
         RTT p50 {} µs, p99 {} µs, max {} µs (n = {}); failed {}",
        100.0 * rate / wire_rate,
        rtt.p50_us,
        rtt.p99_us,
        rtt.max_us,
        rtt.count,
        c.failed()
    );
    let (rate, rtt, c) = run(false, seconds);
    println!(
        "pty, pacing off: {rate:.0} exchanges/s; RTT p50 {} µs, p99 {} µs, max {} µs (n = {}); failed {}",
        rtt.p50_us,
        rtt.p99_us,
        rtt.max_us,
        rtt.count,
        c.failed()
    );
}
