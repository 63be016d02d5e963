//! The integration tests of `rov_session`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod common;
mod csv;
mod damage;
mod foxglove;
mod playback;
mod roundtrip;
mod sigkill;
mod warnings;
