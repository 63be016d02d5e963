//! The integration tests of `rov_sim`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod faults;
mod reference;
mod simulator;
