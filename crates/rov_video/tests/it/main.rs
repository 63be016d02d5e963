//! The integration tests of `rov_video`, one binary (each module was
//! its own test binary; one binary links once). Run one module with
//! `cargo test -p CRATE --test it MODULE::`.

mod capture;
mod codec;
mod common;
mod export;
mod feed;
mod simcam;
