//! The integration tests of `rov_gui`, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p rov_gui --test it MODULE::`.

mod common;

mod autopilot_model;
mod gui;
mod issue15;
mod issue25;
mod pages;
mod video;
