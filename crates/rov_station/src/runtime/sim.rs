//! [`VirtualStation`]: the live engine on virtual time (the simulated Pro 4 through
//! `rov_station::SimLink`), stepped by the caller. Deterministic for a given seed and
//! command sequence: GUI snapshot tests and benchmarks use it behind an ordinary
//! [`StationHandle`].

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, TryRecvError};

use crate::sim_link::{SimApp, SimLink};
use rov_control::ModelSet;
use rov_driver::{Link, LinkEvent, MonoClock};
use rov_vehicle::{Vehicle, VehicleConfig};

use crate::pilot::view::Source;
use crate::runtime::host::{Followup, Host};
use crate::runtime::{
    RuntimeCommand, RuntimeConfig, RuntimeError, Shared, StationHandle, command_channel, lock,
};

struct App {
    host: Host,
    video: Arc<crate::runtime::video::StationVideo>,
    cmds: Receiver<RuntimeCommand>,
    shared: Arc<Shared>,
    stopped: bool,
}

impl SimApp for App {
    fn on_event(&mut self, link: &mut Link, _vehicle: &Vehicle, event: LinkEvent, now_us: u64) {
        self.host.on_event(link, &event, now_us);
    }

    fn on_tick(&mut self, link: &mut Link, vehicle: &mut Vehicle, now_us: u64) {
        loop {
            match self.cmds.try_recv() {
                Ok(c) => {
                    if self.host.apply(link, c, now_us) == Followup::Shutdown {
                        self.stopped = true;
                    }
                }
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    self.stopped = true;
                    break;
                }
            }
        }
        self.host.tick(link, now_us);
        self.host.record_truth(link, vehicle.sim().truth(), now_us);
        let (lights_pct, tilt_deg) = link.last_control_sent().map_or((0.0, 0.0), |(_, c)| {
            (f64::from(c.lights_pct), f64::from(c.tilt_deg))
        });
        self.video
            .virtual_tick(vehicle.sim().truth(), lights_pct, tilt_deg, now_us);
        let stats = {
            let mut t = lock(&self.shared.ticks);
            t.record(now_us, now_us);
            t.stats()
        };
        self.shared.last_tick_us.store(now_us, Ordering::Relaxed);
        self.host.publish(Some(stats));
    }
}

/// The simulated Pro 4 of a configuration (model 3, or the model of `sim_vehicle`; its
/// seed, link faults and vehicle faults), for the live runtime and the virtual station
/// alike. It starts
/// floating at the surface ([`rov_sim::WaterSurface`]: the pre-dive "zero depth" is then
/// done where it should be; it started 1 m deep, which the zeroing accepted as the
/// surface) and rests on the seabed the simulated camera shows (`[video]
/// sim_seabed_depth_m`, also when no camera runs): the vehicle meets the bottom it sees
/// ([`rov_sim::Seabed`]).
pub(crate) fn sim_vehicle(cfg: &RuntimeConfig) -> Result<Vehicle, rov_vehicle::VehicleError> {
    let vcfg = VehicleConfig {
        faults: cfg.sim_faults.clone(),
        ..VehicleConfig::default()
    };
    let mut sc = match &cfg.sim_vehicle {
        Some(v) => rov_sim::SimConfig::with_model(v.model.clone()),
        None => rov_sim::SimConfig::default_model3()?,
    };
    sc.seabed = Some(rov_sim::Seabed::at_depth(cfg.video.sim_seabed_depth_m));
    let surface = rov_sim::WaterSurface::default();
    sc.initial = rov_dynamics::models::InitialConditions::at_rest(surface.floating_depth_m(), 0.0);
    sc.surface = Some(surface);
    let mut sim = rov_sim::Simulator::new(sc, cfg.sim_seed)?;
    sim.set_faults(cfg.vehicle_faults.clone());
    Ok(Vehicle::new(vcfg, sim))
}

/// The live engine on virtual time; see the module docs.
pub struct VirtualStation {
    sim: SimLink,
    app: App,
    /// Faults the Settings page injects (taken before each advance).
    faults: rov_vehicle::runner::FaultInbox,
}

impl std::fmt::Debug for VirtualStation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VirtualStation")
            .field("now_us", &self.sim.now_us())
            .finish_non_exhaustive()
    }
}

impl VirtualStation {
    /// A station on the simulated Pro 4 at virtual time 0, and its handle. The
    /// connection setting is ignored (always the simulator); no threads are started
    /// (no gamepad, no watchdog: the caller is the clock).
    ///
    /// # Errors
    /// [`RuntimeError`] if the configuration is refused or the models do not load.
    pub fn new(cfg: RuntimeConfig) -> Result<(Self, StationHandle), RuntimeError> {
        Self::with_models(cfg, ModelSet::load_default()?)
    }

    /// [`VirtualStation::new`] with given models.
    ///
    /// # Errors
    /// [`RuntimeError`] if the configuration is refused.
    pub fn with_models(
        cfg: RuntimeConfig,
        models: ModelSet,
    ) -> Result<(Self, StationHandle), RuntimeError> {
        let mut cfg = cfg;
        cfg.record_blocking = true;
        let period_us = cfg.period_us();
        let shared = Arc::new(Shared::new(period_us, MonoClock::new()));
        let (tx, rx) = command_channel();
        let mut link_cfg = cfg.link;
        // Raw frames are recorded only while a recording runs (the engine switches them).
        link_cfg.record_frames = false;
        let link = Link::new(link_cfg)?;
        let vehicle = sim_vehicle(&cfg)?;
        let video = Arc::new(crate::runtime::video::StationVideo::virtual_sim(&cfg.video));
        let mut host = Host::new(cfg, models, Arc::clone(&shared), Source::Sim)?;
        host.attach_video(Arc::clone(&video));
        host.watch_inline();
        let inbox = rov_vehicle::runner::FaultInbox::default();
        host.attach_fault_inbox(Arc::clone(&inbox));
        let app = App {
            host,
            video: Arc::clone(&video),
            cmds: rx,
            shared: Arc::clone(&shared),
            stopped: false,
        };
        let sim = SimLink::new(link, vehicle, period_us);
        Ok((
            Self {
                sim,
                app,
                faults: inbox,
            },
            StationHandle::new(shared, tx, Vec::new()).with_video(video),
        ))
    }

    /// Virtual time now, µs.
    #[must_use]
    pub fn now_us(&self) -> u64 {
        self.sim.now_us()
    }

    /// Runs until virtual time `t_us`; commands sent through the handle are applied at
    /// the next tick.
    ///
    /// # Errors
    /// [`RuntimeError::Vehicle`] if the simulation fails.
    pub fn advance_to(&mut self, t_us: u64) -> Result<(), RuntimeError> {
        if self.app.stopped || t_us <= self.sim.now_us() {
            return Ok(());
        }
        rov_vehicle::runner::take_faults(&mut self.sim.vehicle, &self.faults);
        self.sim.run_until(t_us, &mut self.app)?;
        Ok(())
    }

    /// Runs for `dt_s` seconds of virtual time.
    ///
    /// # Errors
    /// [`RuntimeError::Vehicle`] if the simulation fails.
    pub fn advance(&mut self, dt_s: f64) -> Result<(), RuntimeError> {
        let dt_us = if dt_s.is_finite() && dt_s > 0.0 {
            (dt_s * 1e6).round() as u64
        } else {
            0
        };
        self.advance_to(self.sim.now_us().saturating_add(dt_us))
    }

    /// The simulated vehicle (truth, for tests).
    #[must_use]
    pub fn vehicle(&self) -> &Vehicle {
        &self.sim.vehicle
    }

    /// The simulated vehicle, mutable (fault injection in tests).
    pub fn vehicle_mut(&mut self) -> &mut Vehicle {
        &mut self.sim.vehicle
    }

    /// Finishes a recording in progress.
    pub fn finish(&mut self) {
        let now = self.sim.now_us();
        self.app.host.finish(&mut self.sim.link, now);
        self.app.host.publish(None);
    }
}
