//! The integration tests of `firmware-proto`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod chunking;
mod common;
mod roundtrip;
mod stress;
mod vectors;
