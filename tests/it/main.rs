//! Cross-crate scenarios on virtual time, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p scenarios --test it MODULE::`.

mod driver;

mod depth_hold_chatter;
mod driver_mock_link;
mod driver_pty_link;
mod heading_hold_surging;
mod hold_acceptance;
mod layering;
mod pilot_alarms;
mod pitch_at_speed;
mod sim_seabed;
mod station_bad_input;
