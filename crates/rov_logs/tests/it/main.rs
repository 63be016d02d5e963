//! The integration tests of `rov_logs`, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p rov_logs --test it MODULE::`.

mod dataflash_dfreader;
mod read_and_map;
mod ros_fixtures;
mod tlog;
