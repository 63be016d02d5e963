//! Pro 4 register map (CSR addresses), protocol.md §6.1, §6.3, §6.4 (source S3
//! "REV 3" unless noted).
//!
//! Multi-byte registers are little endian; signed values are two's complement.
//! A type in brackets gives the register width; the scaling is what the wire
//! value means (`value / 10` degrees and so on).

// ---------------------------------------------------------------------------
// §6.1 Control block and writable settings (host writes)
// ---------------------------------------------------------------------------

/// Start of the 15-byte control block (= [`PORT_THRUST`]).
pub const CONTROL: u8 = 0x00;
/// Length of the control block 0x00–0x0E.
pub const CONTROL_LEN: usize = 15;
/// [i16] Port thruster target, −100..=100 % power; negative is reverse.
pub const PORT_THRUST: u8 = 0x00;
/// [i16] Starboard thruster target, −100..=100 %.
pub const STARBOARD_THRUST: u8 = 0x02;
/// [i16] Vertical thruster target, −100..=100 % (sign convention UNCERTAIN).
pub const VERTICAL_THRUST: u8 = 0x04;
/// [u8] Main lights, 0..=100 % (0 = off).
pub const LIGHTS: u8 = 0x06;
/// [i8] Camera tilt, −90..=90, roughly degrees.
pub const CAMERA_TILT: u8 = 0x07;
/// [i8] Camera focus, −100..=100 % of the focal range.
pub const CAMERA_FOCUS: u8 = 0x08;
/// [u8 bitfield] Camera control state ("bit 1 = camera select"; others: menu).
pub const CAMERA_CONTROL: u8 = 0x09;
/// [u8 bitfield] Camera buttons: bit0 menu, bit1 up, bit2 down, bit3 left,
/// bit4 right, bit5 menu off (see [`crate::msg::camera_button`]).
pub const CAMERA_BUTTONS: u8 = 0x0A;
/// [u16] Auto-depth target, mbar; 0xFFFF = off.
pub const AUTO_DEPTH_TARGET: u8 = 0x0B;
/// [u16] Auto-heading target, whole degrees 0..=359; 0xFFFF = off.
pub const AUTO_HEADING_TARGET: u8 = 0x0D;
/// [u16] Auto-altitude target (REV 1: "not implemented"; Cockpit writes FF FF).
pub const AUTO_ALTITUDE_TARGET: u8 = 0x0F;
/// [u16] Auto-pitch target (REV 1: "not implemented"; Cockpit writes 00 00).
pub const AUTO_PITCH_TARGET: u8 = 0x11;
/// [u8] Power-manager state, 0..=100 (Cockpit writes 100).
pub const POWER_MANAGER_STATE: u8 = 0x13;
/// [u16 × 9] Per-thruster dead band, max limit and slew rate, 0x14–0x25
/// (scaled ×1000 or ×10000).
pub const THRUSTER_TUNING: u8 = 0x14;
/// [u16 × 8] Auto-depth and auto-heading PID P/I/D/K gains ×10000, 0x26–0x35.
pub const AUTOPILOT_GAINS: u8 = 0x26;
/// Power-manager limits 0x46–0x59, including max current (A ×100) and min
/// voltage (V ×100). Non-volatile.
pub const POWER_MANAGER_LIMITS: u8 = 0x46;
/// Length of Cockpit's engine-room write (0x00–0x59).
pub const ENGINE_ROOM_LEN: usize = 0x5A;

// ---------------------------------------------------------------------------
// §6.3 Read-only telemetry (int16 unless noted)
// ---------------------------------------------------------------------------

/// [u8] Total power available, 0..=100 % (power manager).
pub const POWER_AVAILABLE: u8 = 0x5F;
/// [u8] Tether voltage drop measured at startup, V ×10.
pub const TETHER_VOLTAGE_DROP: u8 = 0x60;
/// [u8] Modified horizontal thruster limit (reserved).
pub const MODIFIED_HORIZONTAL_LIMIT: u8 = 0x61;
/// [u8] Attitude sensor type: 0 = KCF node, 1 = VN-100.
pub const ATTITUDE_SENSOR_TYPE: u8 = 0x64;
/// [u8] Pressure sensor type: 0 = standard depth sensor.
pub const PRESSURE_SENSOR_TYPE: u8 = 0x65;
/// [i16] Pressure (depth), mbar (absolute or gauge UNCERTAIN).
pub const PRESSURE: u8 = 0x66;
/// [i16] Heading, degrees ×10; signed (−1800..=1800 seen as well as 0..=3599).
pub const HEADING: u8 = 0x68;
/// [i16] Pitch, degrees ×10.
pub const PITCH: u8 = 0x6A;
/// [i16] Roll, degrees ×10.
pub const ROLL: u8 = 0x6C;
/// [i16] "Yaw acceleration", sensor units (probably gyro rate ×1000).
pub const YAW_ACCEL: u8 = 0x6E;
/// [i16] "Pitch acceleration", sensor units.
pub const PITCH_ACCEL: u8 = 0x70;
/// [i16] "Roll acceleration", sensor units.
pub const ROLL_ACCEL: u8 = 0x72;
/// [i16] Surge acceleration, probably m/s² ×1000.
pub const SURGE_ACCEL: u8 = 0x74;
/// [i16] Sway acceleration, probably m/s² ×1000.
pub const SWAY_ACCEL: u8 = 0x76;
/// [i16] Heave acceleration, probably m/s² ×1000 (about −9040 when level).
pub const HEAVE_ACCEL: u8 = 0x78;
/// [i16] Water temperature, °C ×100. First register of the status block.
pub const WATER_TEMP: u8 = 0x7A;
/// [u16] Tether voltage, V ×100.
pub const TETHER_VOLTAGE: u8 = 0x7C;
/// [u16] 12 V rail voltage, V ×100.
pub const RAIL_12V_VOLTAGE: u8 = 0x7E;
/// [u16] 12 V rail current, mA.
pub const RAIL_12V_CURRENT: u8 = 0x80;
/// [u8] Internal temperature, CPU board (reserved).
pub const INTERNAL_TEMP_CPU: u8 = 0x82;
/// [u8] Internal temperature, power board (reserved).
pub const INTERNAL_TEMP_POWER: u8 = 0x83;
/// [u16] Internal relative humidity, % RH.
pub const HUMIDITY: u8 = 0x84;
/// [u16] Comm error count (wrapping).
pub const COMM_ERRORS: u8 = 0x86;
/// [i16] Max depth (reserved).
pub const MAX_DEPTH: u8 = 0x88;
/// [i16] Max humidity (reserved).
pub const MAX_HUMIDITY: u8 = 0x8A;
/// [u32] Total run time, seconds.
pub const RUN_TIME: u8 = 0x8C;
/// [u16 × 8] Raw ADC channels 0–7, ADC units, 0x90–0x9F.
pub const RAW_ADC: u8 = 0x90;
/// [u16 × 10] Servo direct S1–S9 + timebase, timer ticks, 0xA0–0xB3.
pub const SERVO_DIRECT: u8 = 0xA0;
/// Auto-depth / auto-heading PID error terms and raw output ×10000, 0xB4–0xC3.
pub const AUTOPILOT_TERMS: u8 = 0xB4;
/// [i16] Raw magnetometer X, ADC units.
pub const MAG_X: u8 = 0xC4;
/// [i16] Raw magnetometer Y, ADC units.
pub const MAG_Y: u8 = 0xC6;
/// [i16] Raw magnetometer Z, ADC units.
pub const MAG_Z: u8 = 0xC8;
/// Magnetometer calibration 0xCA–0xE2 (reserved).
pub const MAG_CALIBRATION: u8 = 0xCA;
/// [u16] Attitude sensor status code (0 = OK in the examples), 0xE3–0xE4.
pub const ATTITUDE_STATUS: u8 = 0xE3;
/// [u8] Attitude sensor reset command.
pub const ATTITUDE_RESET: u8 = 0xE5;
/// [u8 × 3] Firmware version copy (S2 example 02 06 06), 0xEB–0xED.
pub const FIRMWARE_VERSION_COPY: u8 = 0xEB;
/// [u16] "Commit control variables to flash", 0xEE–0xEF.
pub const COMMIT_TO_FLASH: u8 = 0xEE;
/// Last address of the application region; a FLAGS 0x80 dump stops here.
pub const APP_REGION_END: u8 = 0xEF;
/// Bytes in the application region 0x00–0xEF (a full dump from 0).
pub const APP_REGION_LEN: usize = 240;

// ---------------------------------------------------------------------------
// §6.4 Special registers 0xF0–0xFF (Pro 4 assignment)
// ---------------------------------------------------------------------------

/// Custom-command register: a write here is a command (e.g. manipulator), not a
/// memory write.
pub const CUSTOM_COMMAND: u8 = 0xF0;
/// [u16] Configuration-data size, 0xF5–0xF6.
pub const CONFIG_SIZE: u8 = 0xF5;
/// Configuration data: read with FLAGS 0x80 and LENGTH 0; the reply is an
/// extended-length [`ConfigData`](crate::ConfigData).
pub const CONFIG_DATA: u8 = 0xF7;
/// [u8 × 3] Firmware (software) version, 0xF8–0xFA.
pub const FIRMWARE_VERSION: u8 = 0xF8;
/// [u8] Node ID, 0..=127.
pub const NODE_ID: u8 = 0xFB;
/// [u8] Group ID, 1..=126.
pub const GROUP_ID: u8 = 0xFC;
/// Unique-ID register: reads return up to 16 bytes; writing 16 ID bytes plus a
/// new node ID sets the node ID.
pub const UNIQUE_ID: u8 = 0xFD;
/// [u16] Utility register (formerly "reboot"), 0xFE–0xFF.
pub const UTILITY: u8 = 0xFE;
/// Bytes written to [`UTILITY`] to reboot: 0xDEAD, LSB first on the wire as
/// `DE AD` (S1, S4, S10).
pub const REBOOT_MAGIC: [u8; 2] = [0xDE, 0xAD];

/// Number of registers in the image (0x00–0xFF).
pub const REGISTER_COUNT: usize = 256;

/// A power-on register image with the defaults seen in S2 (protocol.md §12.3):
/// both autopilot targets off (0xFFFF), power-manager state 100, power
/// available 100 %, attitude sensor VN-100, firmware version 2.6.6 at 0xEB and
/// (assumed) 0xF8, node ID 1. Everything else is 0.
// Evaluated at compile time: an out-of-bounds index would be a build error,
// never a run-time panic.
#[allow(clippy::indexing_slicing)]
pub const DEFAULT_IMAGE: [u8; REGISTER_COUNT] = {
    let mut image = [0u8; REGISTER_COUNT];
    image[AUTO_DEPTH_TARGET as usize] = 0xFF;
    image[AUTO_DEPTH_TARGET as usize + 1] = 0xFF;
    image[AUTO_HEADING_TARGET as usize] = 0xFF;
    image[AUTO_HEADING_TARGET as usize + 1] = 0xFF;
    image[POWER_MANAGER_STATE as usize] = 100;
    image[POWER_AVAILABLE as usize] = 100;
    image[ATTITUDE_SENSOR_TYPE as usize] = 1;
    image[FIRMWARE_VERSION_COPY as usize] = 2;
    image[FIRMWARE_VERSION_COPY as usize + 1] = 6;
    image[FIRMWARE_VERSION_COPY as usize + 2] = 6;
    image[FIRMWARE_VERSION as usize] = 2;
    image[FIRMWARE_VERSION as usize + 1] = 6;
    image[FIRMWARE_VERSION as usize + 2] = 6;
    image[NODE_ID as usize] = 1;
    image
};

/// Applies a request's write to a register image: copies `data` to `addr..`,
/// truncated at the end of the image. Returns the number of bytes written.
///
/// Writes to [`CUSTOM_COMMAND`] and [`UTILITY`] are commands rather than memory
/// writes (protocol.md §12.3); the caller decides whether to store them.
pub fn write_registers(image: &mut [u8; REGISTER_COUNT], addr: u8, data: &[u8]) -> usize {
    let start = usize::from(addr);
    let n = data.len().min(REGISTER_COUNT - start);
    match (image.get_mut(start..start + n), data.get(..n)) {
        (Some(dst), Some(src)) => {
            dst.copy_from_slice(src);
            n
        }
        _ => 0,
    }
}

/// The registers a dump of `count` bytes from `start` returns, truncated at the
/// end of the image.
#[must_use]
pub fn read_registers(image: &[u8; REGISTER_COUNT], start: u8, count: usize) -> &[u8] {
    let start = usize::from(start);
    let end = start.saturating_add(count).min(REGISTER_COUNT);
    image.get(start..end).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_image_matches_s2() {
        assert_eq!(&DEFAULT_IMAGE[0x0B..0x0F], &[0xFF; 4]);
        assert_eq!(DEFAULT_IMAGE[usize::from(POWER_AVAILABLE)], 100);
        assert_eq!(&DEFAULT_IMAGE[0xEB..0xEE], &[2, 6, 6]);
    }

    #[test]
    fn register_writes_and_reads_are_clamped() {
        let mut image = DEFAULT_IMAGE;
        assert_eq!(write_registers(&mut image, 0xFE, &[1, 2, 3]), 2);
        assert_eq!(&image[0xFE..], &[1, 2]);
        assert_eq!(write_registers(&mut image, 0x00, &[7; 15]), 15);
        assert_eq!(read_registers(&image, 0x00, 15), &[7; 15]);
        assert_eq!(read_registers(&image, 0xF0, 100).len(), 16);
        assert_eq!(read_registers(&image, 0x7A, 14).len(), 14);
    }
}
