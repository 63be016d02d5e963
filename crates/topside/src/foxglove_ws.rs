//! `--foxglove-ws ADDR:PORT` and `[foxglove]`: starting the live Foxglove server for the
//! window and for `topside record` (see `rov_station::runtime::foxglove_live`).

use rov_station::runtime::foxglove_live::{ConfiguredLiveError, LiveServer};
use rov_station::runtime::settings::FoxgloveSettings;

/// Where to serve: the flag wins; else `[foxglove]` when enabled. The settings are
/// updated to what is served (the Settings tab shows it).
pub fn wanted(flag: Option<&str>, settings: &mut FoxgloveSettings) -> Option<String> {
    if let Some(a) = flag {
        settings.ws = a.trim().to_string();
        settings.enabled = true;
    }
    settings.serve_on().map(str::to_string)
}

/// Starts the server on `addr` and says where on stderr; the error names the address
/// (and `[foxglove] ws` of `config_label` when the address came from there).
pub fn start(
    addr: &str,
    from_flag: bool,
    config_label: &str,
) -> Result<LiveServer, ConfiguredLiveError> {
    match LiveServer::start(addr) {
        Ok(s) => {
            eprintln!(
                "Foxglove live: serving {} (in Foxglove: Open connection -> Foxglove WebSocket -> {})",
                s.status().url(),
                s.status().url()
            );
            Ok(s)
        }
        Err(source) => Err(ConfiguredLiveError {
            origin: if from_flag {
                "--foxglove-ws".to_string()
            } else {
                format!("[foxglove] ws in {config_label}")
            },
            source,
        }),
    }
}
