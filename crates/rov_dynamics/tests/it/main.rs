//! The integration tests of `rov_dynamics`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod bad_params;
mod extension;
mod models;
mod quaternion;
