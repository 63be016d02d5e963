//! The integration tests of `rov_lab`, one binary (each module was its own test binary;
//! one binary links once and compiles the shared `common` code once). Run one module
//! with `cargo test -p rov_lab --test it MODULE::`.

mod common;

mod bluerov;
mod bluerov_cv;
mod bluerov_map;
mod calibration_starts;
mod discovered_terms;
mod experiment;
mod hidden_effects;
mod honesty;
mod honesty_probe;
mod independent;
mod lab_api;
mod nulls_and_pairs;
mod plant;
mod probe;
mod real_logs;
mod scale;
mod station_dive;
mod vehicle_check;
mod vehicles;
mod verdict;
