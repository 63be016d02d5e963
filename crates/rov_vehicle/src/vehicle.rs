//! The simulated Pro 4 behind the wire protocol (protocol.md §5–7, §12.3). Sans-IO:
//! bytes and timestamps in, timestamped bytes out; time is an argument.

use std::collections::VecDeque;

use firmware_proto::msg::{BootloaderBlock, CONFIG_TEXT_LEN, HardwareConfig, VALID_APP_FLAG};
use firmware_proto::{
    Addressing, ConfigData, DeframeErrorKind, Deframer, DeviceType, Event, Frame, NavReply, NodeId,
    PingReply, csr, encode_response, flags,
};
use rov_dynamics::ThrustPct;
use rov_sim::{SimConfig, SimError, Simulator};
use rov_types::conventions::WireConventions;

use crate::autopilot::{Autopilot, AutopilotConfig};
use crate::faults::{FaultConfig, FaultCounts, RequestCorruptor, fault_reply};
use crate::rng::FaultRng;

/// Line timing: baud-rate pacing of every byte in both directions plus the vehicle's
/// turnaround.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireTiming {
    /// Baud rate (default 115200).
    pub baud: u32,
    /// Bits per byte on the wire (default 10: 8N1).
    pub bits_per_byte: u32,
    /// Delay between the end of a request and the first reply byte, µs (default 1 ms;
    /// our choice, protocol.md §12.3 step 5).
    pub turnaround_us: u64,
    /// Pace bytes at the baud rate (default true). Off: bytes take no time.
    pub paced: bool,
}

impl Default for WireTiming {
    fn default() -> Self {
        Self {
            baud: 115_200,
            bits_per_byte: 10,
            turnaround_us: 1_000,
            paced: true,
        }
    }
}

impl WireTiming {
    /// Time for `n` bytes, µs (rounded to the nearest µs; 86.8 µs per byte at 115200
    /// 8N1).
    #[must_use]
    pub fn bytes_us(&self, n: u64) -> u64 {
        if !self.paced || self.baud == 0 {
            return 0;
        }
        let num = u128::from(n) * u128::from(self.bits_per_byte) * 1_000_000;
        let den = u128::from(self.baud);
        u64::try_from((num + den / 2) / den).unwrap_or(u64::MAX)
    }
}

/// Settings of the simulated vehicle.
#[derive(Debug, Clone)]
pub struct VehicleConfig {
    /// Own node ID (default 0x01).
    pub node: u8,
    /// Line timing.
    pub timing: WireTiming,
    /// Command watchdog: no valid control write for this long → thrusters 0 and the
    /// onboard autopilot off (default 1 s; our choice, the real vehicle's behaviour is
    /// undocumented, protocol.md §12.3 step 6).
    pub watchdog_us: u64,
    /// Wire ↔ physics conventions (the same type the driver uses).
    pub conventions: WireConventions,
    /// The onboard autopilot.
    pub autopilot: AutopilotConfig,
    /// Faults.
    pub faults: FaultConfig,
    /// Tether voltage at no load, V (S2 example 75.52).
    pub tether_v: f64,
    /// Loop resistance of the tether, Ω. The tether carries the vehicle's power at its
    /// own voltage, so its drop is `R·P/(η·V)` for the power `P` drawn; the former model
    /// dropped 2 V per ampere of *12 V* load (10 V at full forward: TETHER VOLTAGE LOW at
    /// the default 66 V warning in normal flight, issue 25). 6 Ω is an estimate (about
    /// 150 m of a small-gauge two-conductor tether); with it the full load of all three
    /// thrusters drops 7 V, 68 V at the vehicle, above the default warning.
    pub tether_loop_resistance_ohm: f64,
    /// Efficiency of the vehicle's tether-to-12 V conversion (an estimate).
    pub power_conversion_efficiency: f64,
    /// 12 V rail voltage, V (S2 example 12.19).
    pub rail_12v_v: f64,
    /// 12 V rail current with thrusters idle, mA (S2 example 385).
    pub rail_idle_ma: f64,
    /// Extra 12 V current at full thrust on one thruster, mA.
    pub rail_ma_per_full_thruster: f64,
    /// The configuration data returned for register 0xF7.
    pub config_data: ConfigData,
}

impl VehicleConfig {
    /// The tether voltage at the vehicle with `rail_ma` of 12 V load, V.
    #[must_use]
    pub fn tether_voltage_v(&self, rail_ma: f64) -> f64 {
        let c = self;
        let power_w = c.rail_12v_v * rail_ma / 1000.0;
        let eta = c.power_conversion_efficiency.clamp(0.1, 1.0);
        let v0 = c.tether_v;
        if !(v0.is_finite() && v0 > 0.0 && power_w.is_finite()) {
            return v0;
        }
        // V = V0 − R·I with I = P/(η·V): the larger root of V² − V0·V + R·P/η = 0; past
        // the tether's maximum power transfer, the voltage halves.
        let rp = c.tether_loop_resistance_ohm.max(0.0) * power_w / eta;
        let disc = v0 * v0 - 4.0 * rp;
        if disc >= 0.0 {
            0.5 * (v0 + disc.sqrt())
        } else {
            0.5 * v0
        }
    }
}

fn text(s: &str) -> [u8; CONFIG_TEXT_LEN] {
    let mut out = [0u8; CONFIG_TEXT_LEN];
    for (d, b) in out.iter_mut().zip(s.bytes()) {
        *d = b;
    }
    out
}

/// The configuration data the simulated vehicle reports.
#[must_use]
pub fn sim_config_data() -> ConfigData {
    let mut serial = [0u8; 16];
    for (d, b) in serial.iter_mut().zip(b"SIM-PRO4".iter()) {
        *d = *b;
    }
    ConfigData {
        device_type: DeviceType::Pro4Rov,
        bootloader: BootloaderBlock {
            version: 1,
            device_type: 1,
            serial,
            reserved: [0; 8],
            valid_app_flag: VALID_APP_FLAG,
        },
        hardware: HardwareConfig {
            structure_version: 1,
            cpu_board: text("rov_vehicle simulated CPU"),
            power_board: text("simulated"),
            depth_board: text("simulated"),
            camera_io_board: text("simulated"),
            camera: text("none"),
            lights: text("none"),
            horizontal_thrusters: text("model3"),
            vertical_thrusters: text("model3"),
        },
    }
}

impl Default for VehicleConfig {
    fn default() -> Self {
        Self {
            node: 0x01,
            timing: WireTiming::default(),
            watchdog_us: 1_000_000,
            conventions: WireConventions::DEFAULT,
            autopilot: AutopilotConfig::default(),
            faults: FaultConfig::default(),
            tether_v: 75.52,
            tether_loop_resistance_ohm: 6.0,
            power_conversion_efficiency: 0.85,
            rail_12v_v: 12.19,
            rail_idle_ma: 385.0,
            rail_ma_per_full_thruster: 2_000.0,
            config_data: sim_config_data(),
        }
    }
}

/// Errors of the simulated vehicle.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VehicleError {
    /// The simulator failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A transport failed (wall-time runner).
    #[error(transparent)]
    Transport(#[from] rov_transport::TransportError),
}

/// Protocol-level tallies of the vehicle (besides the injected faults).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct VehicleCounts {
    /// Requests for our node (unicast).
    pub unicast: u64,
    /// Multicast requests for our group (writes applied, no reply).
    pub multicast: u64,
    /// Broadcast requests (writes applied, no reply).
    pub broadcast: u64,
    /// Requests for other nodes or groups (ignored).
    pub other_node: u64,
    /// Unicast requests with FLAGS 0 (no reply wanted).
    pub no_reply_wanted: u64,
    /// Unicast requests with unimplemented FLAGS 0x06..=0x7F (no reply, our choice).
    pub unimplemented_flags: u64,
    /// Writes to the custom-command register 0xF0 (ignored).
    pub custom_commands: u64,
    /// Reboots (0xDEAD to 0xFE).
    pub reboots: u64,
    /// Control writes that touched the thrust registers.
    pub control_writes: u64,
    /// Times the command watchdog neutralised the thrusters.
    pub watchdog_trips: u64,
    /// Reply bytes put on the wire (garbage included).
    pub tx_bytes: u64,
    /// Request bytes received.
    pub rx_bytes: u64,
}

/// The simulated Pro 4.
#[derive(Debug)]
pub struct Vehicle {
    cfg: VehicleConfig,
    sim: Simulator,
    image: [u8; csr::REGISTER_COUNT],
    rx: Deframer,
    rng: FaultRng,
    corruptor: RequestCorruptor,
    faults: FaultCounts,
    counts: VehicleCounts,
    /// The host → vehicle line is busy until then (request pacing), µs.
    rx_free_us: u64,
    /// The vehicle → host line is busy until then, µs.
    tx_free_us: u64,
    /// Requests received whole: (complete time, frame bytes).
    pending: VecDeque<(u64, Vec<u8>)>,
    /// Scheduled output: (time the byte has fully arrived at the host, byte).
    output: VecDeque<(u64, u8)>,
    last_control_us: Option<u64>,
    watchdog_tripped: bool,
    autopilot: Autopilot,
    boot_us: u64,
    comm_errors: u16,
    scratch: Vec<u8>,
}

fn put_i16(image: &mut [u8; csr::REGISTER_COUNT], addr: u8, v: i16) {
    csr::write_registers(image, addr, &v.to_le_bytes());
}

fn put_u16(image: &mut [u8; csr::REGISTER_COUNT], addr: u8, v: u16) {
    csr::write_registers(image, addr, &v.to_le_bytes());
}

fn get_i16(image: &[u8; csr::REGISTER_COUNT], addr: u8) -> i16 {
    let b = csr::read_registers(image, addr, 2);
    match b {
        [lo, hi] => i16::from_le_bytes([*lo, *hi]),
        _ => 0,
    }
}

fn get_u16(image: &[u8; csr::REGISTER_COUNT], addr: u8) -> u16 {
    get_i16(image, addr) as u16
}

fn sat_i16(x: f64) -> i16 {
    if x.is_nan() {
        0
    } else {
        x.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
    }
}

fn sat_u16(x: f64) -> u16 {
    if x.is_nan() {
        0
    } else {
        x.round().clamp(0.0, f64::from(u16::MAX)) as u16
    }
}

impl Vehicle {
    /// A vehicle around `sim` (at time 0), with the register image of
    /// [`csr::DEFAULT_IMAGE`] filled from the sensors.
    #[must_use]
    pub fn new(cfg: VehicleConfig, sim: Simulator) -> Self {
        let mut v = Self {
            rng: FaultRng::new(cfg.faults.seed),
            autopilot: Autopilot::new(cfg.autopilot),
            sim,
            image: csr::DEFAULT_IMAGE,
            rx: Deframer::vehicle(),
            corruptor: RequestCorruptor::default(),
            faults: FaultCounts::default(),
            counts: VehicleCounts::default(),
            rx_free_us: 0,
            tx_free_us: 0,
            pending: VecDeque::new(),
            output: VecDeque::new(),
            last_control_us: None,
            watchdog_tripped: true,
            boot_us: 0,
            comm_errors: 0,
            scratch: Vec::with_capacity(320),
            cfg,
        };
        v.refresh_telemetry(0);
        v
    }

    /// Model 3, noiseless sensors off (noise on), at rest 1 m deep heading north, with
    /// simulator seed `seed`.
    ///
    /// # Errors
    /// [`VehicleError::Sim`] if the model cannot be loaded.
    pub fn with_model3(cfg: VehicleConfig, seed: u64) -> Result<Self, VehicleError> {
        let sim = Simulator::new(SimConfig::default_model3()?, seed)?;
        Ok(Self::new(cfg, sim))
    }

    // ---- inspection ---------------------------------------------------------------

    /// The register image.
    #[must_use]
    pub const fn registers(&self) -> &[u8; csr::REGISTER_COUNT] {
        &self.image
    }

    /// The simulator.
    #[must_use]
    pub const fn sim(&self) -> &Simulator {
        &self.sim
    }

    /// The simulator, mutable (e.g. to add an external force).
    pub fn sim_mut(&mut self) -> &mut Simulator {
        &mut self.sim
    }

    /// True depth of the vehicle (NED z), m.
    #[must_use]
    pub fn depth_m(&self) -> f64 {
        self.sim.truth().state.eta[2]
    }

    /// True heading, degrees [0, 360).
    #[must_use]
    pub fn heading_deg(&self) -> f64 {
        self.sim.truth().state.eta[5].to_degrees().rem_euclid(360.0)
    }

    /// The thrust command the plant holds now.
    #[must_use]
    pub fn plant_command(&self) -> ThrustPct {
        self.sim.command()
    }

    /// Whether the command watchdog holds the thrusters at 0.
    #[must_use]
    pub const fn watchdog_tripped(&self) -> bool {
        self.watchdog_tripped
    }

    /// The comm error counter (CSR 0x86).
    #[must_use]
    pub const fn comm_errors(&self) -> u16 {
        self.comm_errors
    }

    /// Injected faults so far.
    #[must_use]
    pub const fn fault_counts(&self) -> &FaultCounts {
        &self.faults
    }

    /// Protocol tallies.
    #[must_use]
    pub const fn counts(&self) -> &VehicleCounts {
        &self.counts
    }

    /// The settings.
    #[must_use]
    pub const fn config(&self) -> &VehicleConfig {
        &self.cfg
    }

    /// The fault settings, to change them while running (e.g. add a dead window).
    pub fn faults_mut(&mut self) -> &mut FaultConfig {
        &mut self.cfg.faults
    }

    /// The line timing, to change it while running.
    pub fn timing_mut(&mut self) -> &mut WireTiming {
        &mut self.cfg.timing
    }

    // ---- I/O ------------------------------------------------------------------------

    /// Bytes from the host arriving at `now_us`. On a paced line they take one byte
    /// time each from `max(now, end of the previous byte)`; a request is acted on when
    /// its last byte has arrived (in [`Vehicle::advance_to`]).
    pub fn handle_input(&mut self, bytes: &[u8], now_us: u64) {
        if bytes.is_empty() {
            return;
        }
        self.counts.rx_bytes += bytes.len() as u64;
        let dead = self.cfg.faults.is_dead(now_us);
        self.scratch.clear();
        self.scratch.extend_from_slice(bytes);
        if !dead {
            self.corruptor.process(
                &mut self.scratch,
                self.cfg.faults.corrupt_request,
                &mut self.rng,
                &mut self.faults,
            );
        }
        let start_us = now_us.max(self.rx_free_us);
        let base = self.rx.stream_offset();
        let timing = self.cfg.timing;
        self.rx_free_us = start_us + timing.bytes_us(bytes.len() as u64);
        let mut input: &[u8] = &self.scratch;
        while let Some(event) = self.rx.feed(&mut input, now_us) {
            match event {
                Event::Frame { frame, offset } => {
                    if dead {
                        self.faults.requests_ignored_dead += 1;
                        continue;
                    }
                    let end = (offset + frame.wire_len() as u64).saturating_sub(base);
                    let complete = start_us + timing.bytes_us(end);
                    self.pending
                        .push_back((complete, frame.as_bytes().to_vec()));
                }
                Event::Error(e) => {
                    let counted = matches!(
                        e.kind,
                        DeframeErrorKind::HeaderCheck
                            | DeframeErrorKind::ExtLengthCheck
                            | DeframeErrorKind::Overlong
                            | DeframeErrorKind::TotalCheck
                            | DeframeErrorKind::Stall
                            | DeframeErrorKind::Truncated
                    );
                    if counted && !dead {
                        self.comm_errors = self.comm_errors.wrapping_add(1);
                        put_u16(&mut self.image, csr::COMM_ERRORS, self.comm_errors);
                    }
                }
            }
        }
    }

    /// Moves the reply bytes due by `now_us` into `out`; returns how many.
    pub fn poll_output(&mut self, now_us: u64, out: &mut Vec<u8>) -> usize {
        let mut n = 0;
        while let Some(&(t, b)) = self.output.front() {
            if t > now_us {
                break;
            }
            self.output.pop_front();
            out.push(b);
            n += 1;
        }
        n
    }

    /// When the vehicle next has something to do (a request completes, a byte is due),
    /// µs.
    #[must_use]
    pub fn next_wakeup(&self) -> Option<u64> {
        let a = self.pending.front().map(|p| p.0);
        let b = self.output.front().map(|o| o.0);
        match (a, b) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// When the `n`-th scheduled reply byte (1-based, or the last one if fewer) is due,
    /// µs: lets a wall-time runner write in small batches instead of byte by byte.
    #[must_use]
    pub fn output_due_nth(&self, n: usize) -> Option<u64> {
        self.output
            .get(n.saturating_sub(1))
            .or_else(|| self.output.back())
            .map(|o| o.0)
    }

    /// When the next request completes (its last byte has arrived), µs.
    #[must_use]
    pub fn next_request_due(&self) -> Option<u64> {
        self.pending.front().map(|p| p.0)
    }

    /// Whether reply bytes are scheduled.
    #[must_use]
    pub fn output_pending(&self) -> bool {
        !self.output.is_empty()
    }

    /// Runs the simulator, the watchdog and the onboard autopilot up to `now_us`, and
    /// acts on every request whose last byte has arrived by then, in time order.
    ///
    /// # Errors
    /// [`VehicleError::Sim`] if the simulation fails.
    pub fn advance_to(&mut self, now_us: u64) -> Result<(), VehicleError> {
        loop {
            let step_s = self.sim.step_s();
            let next_step_us = ((self.sim.time_s() + step_s) * 1e6).round() as u64;
            if let Some(&(t, _)) = self.pending.front()
                && t <= now_us
                && t <= next_step_us
            {
                if let Some((t, bytes)) = self.pending.pop_front() {
                    self.process_request(&bytes, t);
                }
                continue;
            }
            if next_step_us <= now_us {
                self.control_step(next_step_us, step_s);
                self.sim.step()?;
                self.refresh_telemetry(next_step_us);
                continue;
            }
            return Ok(());
        }
    }

    // ---- internals --------------------------------------------------------------------

    fn control_step(&mut self, t_us: u64, dt: f64) {
        let conv = self.cfg.conventions;
        let readings = self.sim.sensors();
        let depth_meas = conv.depth_m_from_pressure(readings.pressure_mbar);
        self.autopilot.observe_depth(depth_meas, dt);
        let stale = self
            .last_control_us
            .is_none_or(|l| t_us.saturating_sub(l) > self.cfg.watchdog_us);
        if stale {
            if !self.watchdog_tripped {
                self.counts.watchdog_trips += 1;
                self.watchdog_tripped = true;
            }
            self.autopilot.release_depth();
            self.autopilot.release_heading();
            let _ = self.sim.set_command(ThrustPct::ZERO);
            return;
        }
        self.watchdog_tripped = false;
        let wire = [
            get_i16(&self.image, csr::PORT_THRUST),
            get_i16(&self.image, csr::STARBOARD_THRUST),
            get_i16(&self.image, csr::VERTICAL_THRUST),
        ];
        let pilot = conv.thrust_from_wire(wire);
        let mut cmd = ThrustPct::new(pilot.port_pct, pilot.starboard_pct, pilot.vertical_pct);
        let depth_target = get_u16(&self.image, csr::AUTO_DEPTH_TARGET);
        if depth_target == firmware_proto::msg::TARGET_OFF {
            self.autopilot.release_depth();
        } else {
            let target_m = conv.depth_m_from_pressure(f64::from(depth_target));
            cmd.vertical = self.autopilot.depth_output(target_m, depth_meas, dt);
        }
        let heading_target = get_u16(&self.image, csr::AUTO_HEADING_TARGET);
        if heading_target == firmware_proto::msg::TARGET_OFF {
            self.autopilot.release_heading();
        } else {
            let target = conv.heading_target_to_physics(heading_target);
            let heading = readings.heading_rad.to_degrees().rem_euclid(360.0);
            let rate = readings.gyro_body_radps.z.to_degrees();
            let u = self.autopilot.heading_output(target, heading, rate, dt);
            let mean = 0.5 * (cmd.port + cmd.starboard);
            cmd.port = (mean + u).clamp(-100.0, 100.0);
            cmd.starboard = (mean - u).clamp(-100.0, 100.0);
        }
        let _ = self.sim.set_command(cmd.saturated());
    }

    /// Writes the sensor readings into the telemetry registers.
    fn refresh_telemetry(&mut self, t_us: u64) {
        let conv = self.cfg.conventions;
        let r = self.sim.sensors();
        let img = &mut self.image;
        put_i16(img, csr::PRESSURE, sat_i16(r.pressure_mbar));
        put_i16(
            img,
            csr::HEADING,
            conv.heading_to_wire(r.heading_rad.to_degrees()),
        );
        put_i16(
            img,
            csr::PITCH,
            conv.pitch_to_wire(r.pitch_rad.to_degrees()),
        );
        put_i16(img, csr::ROLL, conv.roll_to_wire(r.roll_rad.to_degrees()));
        let g = r.gyro_body_radps;
        put_i16(img, csr::YAW_ACCEL, sat_i16(g.z * 1000.0));
        put_i16(
            img,
            csr::PITCH_ACCEL,
            sat_i16(conv.pitch_sign() * g.y * 1000.0),
        );
        put_i16(
            img,
            csr::ROLL_ACCEL,
            sat_i16(conv.roll_sign() * g.x * 1000.0),
        );
        let a = r.accel_body_mps2;
        put_i16(img, csr::SURGE_ACCEL, sat_i16(a.x * 1000.0));
        put_i16(img, csr::SWAY_ACCEL, sat_i16(a.y * 1000.0));
        put_i16(img, csr::HEAVE_ACCEL, sat_i16(a.z * 1000.0));
        put_i16(img, csr::MAG_X, r.pro4.mag_x_raw);
        put_i16(img, csr::MAG_Y, r.pro4.mag_y_raw);
        put_i16(img, csr::MAG_Z, r.pro4.mag_z_raw);
        put_i16(img, csr::ATTITUDE_STATUS, r.pro4.attitude_status);
        put_i16(img, csr::WATER_TEMP, r.pro4.water_temperature_centi_c);
        put_u16(img, csr::HUMIDITY, r.pro4.humidity_pct.max(0) as u16);
        csr::write_registers(img, csr::POWER_AVAILABLE, &[r.pro4.power_available_pct]);
        let cmd = self.sim.command();
        let load = (cmd.port.abs() + cmd.starboard.abs() + cmd.vertical.abs()) / 100.0;
        let rail_ma = self.cfg.rail_idle_ma + self.cfg.rail_ma_per_full_thruster * load;
        put_u16(img, csr::RAIL_12V_CURRENT, sat_u16(rail_ma));
        let tether = self.cfg.tether_voltage_v(rail_ma);
        put_u16(img, csr::TETHER_VOLTAGE, sat_u16(tether * 100.0));
        put_u16(
            img,
            csr::RAIL_12V_VOLTAGE,
            sat_u16(self.cfg.rail_12v_v * 100.0),
        );
        put_u16(img, csr::COMM_ERRORS, self.comm_errors);
        let run_s = u32::try_from(t_us.saturating_sub(self.boot_us) / 1_000_000).unwrap_or(0);
        csr::write_registers(img, csr::RUN_TIME, &run_s.to_le_bytes());
    }

    fn nav_reply(&self) -> NavReply {
        let i = &self.image;
        NavReply {
            device_type: DeviceType::Pro4Rov,
            heading_deg_x10: get_i16(i, csr::HEADING),
            pitch_deg_x10: get_i16(i, csr::PITCH),
            roll_deg_x10: get_i16(i, csr::ROLL),
            pressure_mbar: get_i16(i, csr::PRESSURE),
            yaw_accel_raw: get_i16(i, csr::YAW_ACCEL),
            pitch_accel_raw: get_i16(i, csr::PITCH_ACCEL),
            roll_accel_raw: get_i16(i, csr::ROLL_ACCEL),
            surge_accel_raw: get_i16(i, csr::SURGE_ACCEL),
            sway_accel_raw: get_i16(i, csr::SWAY_ACCEL),
            heave_accel_raw: get_i16(i, csr::HEAVE_ACCEL),
            mag_x_raw: get_i16(i, csr::MAG_X),
            mag_y_raw: get_i16(i, csr::MAG_Y),
            mag_z_raw: get_i16(i, csr::MAG_Z),
            attitude_status: get_i16(i, csr::ATTITUDE_STATUS),
            humidity_pct: get_i16(i, csr::HUMIDITY),
            water_temp_c_x100: get_i16(i, csr::WATER_TEMP),
            power_pct: csr::read_registers(i, csr::POWER_AVAILABLE, 1)
                .first()
                .copied()
                .unwrap_or(0),
        }
    }

    fn attitude_block(&self) -> [u8; 8] {
        let i = &self.image;
        let mut out = [0u8; 8];
        for (k, addr) in [csr::HEADING, csr::PITCH, csr::ROLL, csr::PRESSURE]
            .into_iter()
            .enumerate()
        {
            if let Some(dst) = out.get_mut(2 * k..2 * k + 2) {
                dst.copy_from_slice(&get_i16(i, addr).to_le_bytes());
            }
        }
        out
    }

    fn reboot(&mut self, t_us: u64) {
        self.counts.reboots += 1;
        self.image = csr::DEFAULT_IMAGE;
        self.comm_errors = 0;
        self.boot_us = t_us;
        self.last_control_us = None;
        self.autopilot.reset();
        self.pending.clear();
        let _ = self.sim.set_command(ThrustPct::ZERO);
        self.watchdog_tripped = true;
        self.refresh_telemetry(t_us);
    }

    fn process_request(&mut self, bytes: &[u8], t_us: u64) {
        let Ok(frame) = Frame::parse(bytes) else {
            return;
        };
        self.faults.requests += 1;
        let own_group = csr::read_registers(&self.image, csr::GROUP_ID, 1)
            .first()
            .copied()
            .unwrap_or(0)
            & 0x7F;
        let reply_allowed = match frame.node().addressing() {
            Addressing::Unicast(id) if id == self.cfg.node => {
                self.counts.unicast += 1;
                true
            }
            Addressing::Broadcast => {
                self.counts.broadcast += 1;
                false
            }
            Addressing::Multicast { group } if group == own_group => {
                self.counts.multicast += 1;
                false
            }
            _ => {
                self.counts.other_node += 1;
                return;
            }
        };
        // 1. Apply the write first.
        let payload = frame.payload();
        if !payload.is_empty() {
            let addr = frame.addr();
            if addr == csr::CUSTOM_COMMAND {
                self.counts.custom_commands += 1;
            } else if addr == csr::UTILITY {
                if payload == csr::REBOOT_MAGIC {
                    self.reboot(t_us);
                    return;
                }
            } else {
                let n = csr::write_registers(&mut self.image, addr, payload);
                // Writes to telemetry registers are overwritten at the next refresh.
                let end = usize::from(addr) + n;
                if usize::from(addr) <= usize::from(csr::VERTICAL_THRUST) + 1
                    && end > usize::from(csr::PORT_THRUST)
                {
                    self.counts.control_writes += 1;
                    self.last_control_us = Some(t_us);
                }
                // The comm error counter is ours; a write does not reset it.
                put_u16(&mut self.image, csr::COMM_ERRORS, self.comm_errors);
            }
        }
        if !reply_allowed {
            return;
        }
        // 2. Reply.
        let node = NodeId(self.cfg.node);
        let f = frame.flags();
        let mut out = vec![0u8; firmware_proto::MAX_FRAME_LEN];
        let written = match f {
            flags::NONE => {
                self.counts.no_reply_wanted += 1;
                return;
            }
            0x01 | 0x02 => {
                let a = self.attitude_block();
                let reply = PingReply {
                    device_type: DeviceType::Pro4Rov,
                    heading_deg_x10: i16::from_le_bytes([a[0], a[1]]),
                    pitch_deg_x10: i16::from_le_bytes([a[2], a[3]]),
                    roll_deg_x10: i16::from_le_bytes([a[4], a[5]]),
                    pressure_mbar: i16::from_le_bytes([a[6], a[7]]),
                };
                encode_response(
                    node,
                    f,
                    0,
                    DeviceType::Pro4Rov,
                    &reply.to_payload()[1..],
                    &mut out,
                )
            }
            0x03 => {
                let mut data = self.attitude_block().to_vec();
                data.extend_from_slice(&get_i16(&self.image, csr::WATER_TEMP).to_le_bytes());
                encode_response(node, f, 0, DeviceType::Pro4Rov, &data, &mut out)
            }
            0x04 => {
                let mut data = self.attitude_block().to_vec();
                let cpu = csr::read_registers(&self.image, csr::INTERNAL_TEMP_CPU, 1)
                    .first()
                    .copied()
                    .unwrap_or(0);
                data.extend_from_slice(&i16::from(cpu).to_le_bytes());
                data.extend_from_slice(&get_i16(&self.image, csr::HUMIDITY).to_le_bytes());
                encode_response(node, f, 0, DeviceType::Pro4Rov, &data, &mut out)
            }
            flags::NAV => {
                let nav = self.nav_reply();
                encode_response(
                    node,
                    f,
                    0,
                    DeviceType::Pro4Rov,
                    &nav.to_payload()[1..],
                    &mut out,
                )
            }
            0x06..=0x7F => {
                self.counts.unimplemented_flags += 1;
                return;
            }
            _ => {
                let addr = frame.addr();
                if addr == csr::CONFIG_DATA && f == flags::DUMP {
                    self.cfg.config_data.encode_response(node, &mut out)
                } else {
                    let count = if f == flags::DUMP {
                        if addr <= csr::APP_REGION_END {
                            usize::from(csr::APP_REGION_END - addr) + 1
                        } else {
                            csr::REGISTER_COUNT - usize::from(addr)
                        }
                    } else {
                        usize::from(f & 0x7F)
                    };
                    let data = csr::read_registers(&self.image, addr, count).to_vec();
                    encode_response(
                        node,
                        flags::DUMP,
                        addr,
                        DeviceType::Pro4Rov,
                        &data,
                        &mut out,
                    )
                }
            }
        };
        let Ok(n) = written else {
            return;
        };
        out.truncate(n);
        self.schedule_reply(out, t_us);
    }

    fn schedule_reply(&mut self, mut frame: Vec<u8>, ready_us: u64) {
        let Some(faulted) = fault_reply(
            &self.cfg.faults,
            &mut self.rng,
            &mut self.faults,
            &mut frame,
        ) else {
            return;
        };
        let timing = self.cfg.timing;
        let mut t0 =
            (ready_us + timing.turnaround_us + faulted.extra_delay_us).max(self.tx_free_us);
        let mut k: u64 = 0;
        let push = |output: &mut VecDeque<(u64, u8)>, t0: u64, k: &mut u64, b: u8| {
            *k += 1;
            output.push_back((t0 + timing.bytes_us(*k), b));
        };
        for &b in &faulted.garbage {
            push(&mut self.output, t0, &mut k, b);
        }
        let mut rest: &[u8] = &frame;
        for (len, gap) in faulted.pieces {
            let (piece, tail) = rest.split_at(len.min(rest.len()));
            for &b in piece {
                push(&mut self.output, t0, &mut k, b);
            }
            rest = tail;
            if gap > 0 {
                // Restart the byte clock after the gap.
                t0 = t0 + timing.bytes_us(k) + gap;
                k = 0;
            }
        }
        self.tx_free_us = t0 + timing.bytes_us(k);
        self.counts.tx_bytes += (faulted.garbage.len() + frame.len()) as u64;
    }
}
