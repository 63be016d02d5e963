//! The integration tests of `topside`, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p topside --test it MODULE::`.

mod config_cli;
mod foxglove_live;
mod gui_xvfb;
mod hold_cli;
mod lab_cli;
mod log_map_cli;
mod long_session;
mod model_loop;
mod one_engine_cli;
mod proto_cli;
mod record_cli;
mod session_cli;
mod sim_paper;
mod sim_reference;
mod station_config_cli;
mod vehicle_cli;
mod video_cli;
mod watch_cli;
