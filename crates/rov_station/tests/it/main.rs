//! The integration tests of `rov_station`, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p rov_station --test it MODULE::`.

mod autopilot_model;
mod model_overlay;
mod serial_reconnect;
mod soak;
mod video;
