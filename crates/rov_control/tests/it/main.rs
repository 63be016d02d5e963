//! The integration tests of `rov_control`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod closed_loop_6dof;
mod closed_loop_axis;
mod common;
mod config_file;
mod observer;
mod pipeline;
