//! The station, armed and holding depth and heading through the mock link and the
//! simulated vehicle, fed a telemetry stream with NaNs, infinities, dropouts and outliers
//! (corrupted after decoding, where the wire's checksums no longer protect them): every
//! command that reaches the thrusters is finite and within ±100 %.

use rov_control::{ControlConfig, ModeCommand, ModelSet, PilotInput};
use rov_driver::{Link, LinkConfig, LinkEvent};
use rov_station::{SimApp, SimLink};
use rov_station::{StationCommand, StationCore};
use rov_vehicle::{Vehicle, VehicleConfig};

/// A small deterministic PRNG (xorshift64*), so the stream is reproducible.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

const BAD: [f64; 6] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e300,
    -1e300,
    5e-324,
];

struct Corrupting {
    core: StationCore,
    rng: Rng,
    engaged: bool,
    corrupted: u64,
    dropped: u64,
    ticks: u64,
}

impl SimApp for Corrupting {
    fn on_event(&mut self, link: &mut Link, _v: &Vehicle, event: LinkEvent, _now_us: u64) {
        let event = match event {
            LinkEvent::Telemetry(mut t) if self.engaged => {
                let r = self.rng.unit();
                if r < 0.15 {
                    self.dropped += 1;
                    return; // dropout
                }
                let pick = BAD[(self.rng.next() % BAD.len() as u64) as usize];
                match self.rng.next() % 8 {
                    0 => t.depth_m = pick,
                    1 => t.heading_deg = pick,
                    2 => t.yaw_rate_radps = pick,
                    3 => t.depth_m += 40.0 * (self.rng.unit() - 0.5),
                    4 => t.heading_deg += 170.0,
                    _ => {}
                }
                self.corrupted += 1;
                LinkEvent::Telemetry(t)
            }
            other => other,
        };
        self.core.on_event(link, &event);
    }

    fn on_tick(&mut self, link: &mut Link, _v: &mut Vehicle, now_us: u64) {
        if !self.engaged && link.arm(now_us).is_ok() {
            for m in [
                ModeCommand::SetDepth { depth_m: 4.0 },
                ModeCommand::SetHeading { heading_deg: 45.0 },
            ] {
                self.core
                    .command(link, StationCommand::Mode(m), now_us)
                    .unwrap();
            }
            self.engaged = true;
        }
        if self.engaged {
            let u = |rng: &mut Rng| rng.unit() * 2.0 - 1.0;
            let sticks = PilotInput {
                surge: if self.rng.unit() < 0.02 {
                    f64::NAN
                } else {
                    u(&mut self.rng) * 0.3
                },
                yaw: if self.rng.unit() < 0.02 {
                    f64::NAN
                } else {
                    0.0
                },
                vertical: if self.rng.unit() < 0.02 {
                    f64::NAN
                } else {
                    0.0
                },
            };
            self.core
                .command(link, StationCommand::Sticks(sticks), now_us)
                .unwrap();
        }
        let out = self.core.tick(link, now_us);
        let c = out.command;
        for v in [c.port_pct(), c.starboard_pct(), c.vertical_pct()] {
            assert!(
                v.is_finite() && v.abs() <= 100.0,
                "t = {now_us} us: command {v}"
            );
        }
        self.ticks += 1;
    }
}

#[test]
fn nan_dropouts_and_outliers_never_reach_the_thrusters() {
    let core =
        StationCore::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap();
    let link = Link::new(LinkConfig::default()).unwrap();
    let vehicle = Vehicle::with_model3(VehicleConfig::default(), 7).unwrap();
    let mut sim = SimLink::new(link, vehicle, 20_000);
    let mut app = Corrupting {
        core,
        rng: Rng(0x5EED),
        engaged: false,
        corrupted: 0,
        dropped: 0,
        ticks: 0,
    };
    sim.run_until(120_000_000, &mut app).unwrap();
    assert!(app.engaged, "the station armed and engaged");
    assert!(
        app.corrupted > 3000 && app.dropped > 500,
        "{} corrupted, {} dropped",
        app.corrupted,
        app.dropped
    );
    // What the vehicle received is finite by construction (integers on the wire); check
    // that the plant saw sane thrust and the vehicle is still near the depth target despite
    // the garbage (the observer gates outliers and treats NaN as a missing sample).
    let plant = sim.vehicle.plant_command();
    for v in [plant.port, plant.starboard, plant.vertical] {
        assert!(v.is_finite() && v.abs() <= 100.0);
    }
    let depth = sim.vehicle.depth_m();
    assert!(
        (depth - 4.0).abs() < 0.5,
        "vehicle depth {depth} m near the 4 m target"
    );
}
