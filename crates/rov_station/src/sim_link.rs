//! The virtual-time harness: a [`rov_driver::Link`] and a [`Vehicle`] joined by an
//! in-memory, timestamped byte pipe, stepped event by event on virtual time (no
//! sleeping, fully deterministic for given seeds).
//!
//! Frames the link hands out reach the vehicle at that instant (the vehicle's line
//! model then takes one byte time per byte); reply bytes reach the link at the times the
//! vehicle scheduled them. An application ([`SimApp`]) sees every link event and a
//! periodic tick (e.g. a 50 Hz control loop).

use rov_driver::{Link, LinkEvent};

use rov_vehicle::{Vehicle, VehicleError};

/// The application side of the harness.
pub trait SimApp {
    /// Every link event, as soon as it is produced.
    fn on_event(&mut self, _link: &mut Link, _vehicle: &Vehicle, _event: LinkEvent, _now_us: u64) {}

    /// Every tick period (from time 0).
    fn on_tick(&mut self, _link: &mut Link, _vehicle: &mut Vehicle, _now_us: u64) {}
}

/// No application.
impl SimApp for () {}

/// Counters of the harness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimLinkStats {
    /// Frames from the link to the vehicle.
    pub host_frames: u64,
    /// Bytes from the link to the vehicle.
    pub host_bytes: u64,
    /// Deliveries of vehicle bytes to the link (chunks).
    pub vehicle_chunks: u64,
    /// Bytes from the vehicle to the link.
    pub vehicle_bytes: u64,
    /// Harness iterations.
    pub iterations: u64,
}

/// A link and a simulated vehicle on virtual time.
#[derive(Debug)]
pub struct SimLink {
    /// The topside link.
    pub link: Link,
    /// The simulated vehicle.
    pub vehicle: Vehicle,
    now_us: u64,
    tick_period_us: u64,
    next_tick_us: u64,
    out: Vec<u8>,
    stats: SimLinkStats,
}

impl SimLink {
    /// Joins `link` and `vehicle` at time 0; the application ticks every
    /// `tick_period_us` (0: never).
    #[must_use]
    pub fn new(link: Link, vehicle: Vehicle, tick_period_us: u64) -> Self {
        Self {
            link,
            vehicle,
            now_us: 0,
            tick_period_us,
            next_tick_us: 0,
            out: Vec::with_capacity(512),
            stats: SimLinkStats::default(),
        }
    }

    /// Virtual time now, µs.
    #[must_use]
    pub const fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Counters.
    #[must_use]
    pub const fn stats(&self) -> &SimLinkStats {
        &self.stats
    }

    /// Runs until virtual time `t_end_us` (inclusive).
    ///
    /// # Errors
    /// [`VehicleError`] if the simulation fails.
    pub fn run_until(&mut self, t_end_us: u64, app: &mut impl SimApp) -> Result<(), VehicleError> {
        loop {
            let now = self.now_us;
            self.stats.iterations += 1;
            self.vehicle.advance_to(now)?;
            self.out.clear();
            if self.vehicle.poll_output(now, &mut self.out) > 0 {
                self.stats.vehicle_chunks += 1;
                self.stats.vehicle_bytes += self.out.len() as u64;
                self.link.handle_input(&self.out, now);
            }
            self.link.handle_timeout(now);
            if self.tick_period_us > 0 && now >= self.next_tick_us {
                app.on_tick(&mut self.link, &mut self.vehicle, now);
                self.next_tick_us += self.tick_period_us;
            }
            while let Some(frame) = self.link.poll_transmit(now) {
                self.stats.host_frames += 1;
                self.stats.host_bytes += frame.len() as u64;
                self.vehicle.handle_input(frame, now);
            }
            while let Some(event) = self.link.poll_event() {
                app.on_event(&mut self.link, &self.vehicle, event, now);
            }
            if now >= t_end_us {
                return Ok(());
            }
            let mut next = t_end_us;
            for t in [self.link.next_timeout(), self.vehicle.next_wakeup()]
                .into_iter()
                .flatten()
            {
                next = next.min(t);
            }
            if self.tick_period_us > 0 {
                next = next.min(self.next_tick_us);
            }
            self.now_us = next.max(now + 1).min(t_end_us.max(now + 1));
        }
    }
}
