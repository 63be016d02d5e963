//! Link settings with documented defaults (protocol.md §8 and §12.2, style B1).

use firmware_proto::{DeviceType, NodeId};
use rov_types::conventions::WireConventions;

use crate::error::ConfigError;

/// Settings of the [`Link`](crate::Link). Times are in microseconds of the caller's
/// clock (virtual or wall).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkConfig {
    /// The vehicle's node ID (default 0x01, the Pro 4).
    pub node: NodeId,
    /// Device type a response must carry; `None` accepts any (default the Pro 4, 0x01).
    pub device_type: Option<DeviceType>,
    /// Response timeout for device-specific requests (ping, control + nav), default
    /// 50 ms (protocol.md §8, our choice).
    pub response_timeout_us: u64,
    /// Response timeout for CSR reads, the status block and the config read, default
    /// 100 ms.
    pub dump_timeout_us: u64,
    /// Control cycle in RUNNING, default 20 ms (50 Hz); 0 = back to back (benchmarks).
    pub cycle_period_us: u64,
    /// Probe period in SEARCHING, default 250 ms (protocol.md §12.2).
    pub search_period_us: u64,
    /// Read the status block (0x7A, 14 bytes) as an extra exchange after every N-th
    /// control cycle; 0 = never. Default 10.
    pub status_every: u32,
    /// Read the full register image (M4) in INIT. Default true.
    pub init_dump: bool,
    /// Read the configuration data (0xF7, extended reply) in INIT. Default false.
    pub init_config: bool,
    /// Retries of an INIT read before going back to SEARCHING (default 3).
    pub init_retries: u32,
    /// Retries of an application request ([`Link::request`](crate::Link::request)),
    /// default 2. Control frames are never retried: the next cycle carries a fresh
    /// command.
    pub request_retries: u32,
    /// Consecutive failed exchanges before the link is "degraded" (default 3, B1).
    pub degraded_after_failures: u32,
    /// No valid response for this long → "lost" (T_loss, default 500 ms, B1: within
    /// 200 ms..=3 s and at least 4 control periods).
    pub loss_timeout_us: u64,
    /// The link must have been connected this long before the pilot can arm
    /// (default 1 s, style G4). 0 allows arming as soon as a response arrived.
    pub arm_min_healthy_us: u64,
    /// Number of round trips kept for the latency percentiles (default 1000).
    pub rtt_window: usize,
    /// Inter-byte gap after which a partial frame is abandoned (default 10 ms).
    pub deframer_gap_us: u64,
    /// Emit [`LinkEvent::FrameTx`](crate::LinkEvent::FrameTx) /
    /// [`FrameRx`](crate::LinkEvent::FrameRx) with a copy of every frame (for the session
    /// recorder). Default true.
    pub record_frames: bool,
    /// Capacity of the event queue; older events are dropped and counted beyond it
    /// (default 4096).
    pub event_capacity: usize,
    /// Wire ↔ physics conventions (signs, tare, density).
    pub conventions: WireConventions,
}

impl Default for LinkConfig {
    fn default() -> Self {
        Self {
            node: NodeId::ROV,
            device_type: Some(DeviceType::Pro4Rov),
            response_timeout_us: 50_000,
            dump_timeout_us: 100_000,
            cycle_period_us: 20_000,
            search_period_us: 250_000,
            status_every: 10,
            init_dump: true,
            init_config: false,
            init_retries: 3,
            request_retries: 2,
            degraded_after_failures: 3,
            loss_timeout_us: 500_000,
            arm_min_healthy_us: 1_000_000,
            rtt_window: 1000,
            deframer_gap_us: firmware_proto::DEFAULT_GAP_US,
            record_frames: true,
            event_capacity: 4096,
            conventions: WireConventions::DEFAULT,
        }
    }
}

/// `value` within `min..=max`, or the error naming `field`.
pub(crate) fn check(
    field: &'static str,
    value: u64,
    min: u64,
    max: u64,
) -> Result<(), ConfigError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(ConfigError {
            field,
            value: value.to_string(),
            allowed: format!("{min}..={max}"),
        })
    }
}

impl LinkConfig {
    /// Checks every setting.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.node.is_unicast() {
            return Err(ConfigError {
                field: "node",
                value: self.node.0.to_string(),
                allowed: "0..=127 (unicast)".into(),
            });
        }
        check(
            "response_timeout_us",
            self.response_timeout_us,
            1_000,
            5_000_000,
        )?;
        check("dump_timeout_us", self.dump_timeout_us, 1_000, 5_000_000)?;
        check("cycle_period_us", self.cycle_period_us, 0, 1_000_000)?;
        check("search_period_us", self.search_period_us, 1_000, 10_000_000)?;
        check(
            "degraded_after_failures",
            self.degraded_after_failures.into(),
            1,
            1000,
        )?;
        check("loss_timeout_us", self.loss_timeout_us, 200_000, 3_000_000)?;
        check(
            "loss_timeout_us (>= 4 cycle periods)",
            self.loss_timeout_us,
            self.cycle_period_us.saturating_mul(4),
            u64::MAX,
        )?;
        check("arm_min_healthy_us", self.arm_min_healthy_us, 0, 60_000_000)?;
        check("rtt_window", self.rtt_window as u64, 1, 1_000_000)?;
        check("deframer_gap_us", self.deframer_gap_us, 100, 1_000_000)?;
        check("event_capacity", self.event_capacity as u64, 16, 1 << 20)?;
        self.conventions.validate().map_err(|e| ConfigError {
            field: e.field,
            value: e.value.to_string(),
            allowed: e.allowed.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate() {
        assert_eq!(LinkConfig::default().validate(), Ok(()));
    }

    #[test]
    fn loss_timeout_must_cover_four_periods() {
        let c = LinkConfig {
            cycle_period_us: 100_000,
            loss_timeout_us: 300_000,
            ..LinkConfig::default()
        };
        assert_eq!(
            c.validate().map_err(|e| e.field),
            Err("loss_timeout_us (>= 4 cycle periods)")
        );
    }
}
