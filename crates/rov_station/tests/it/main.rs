//! The integration tests of `rov_station`, one binary (each module was its own test binary;
//! one binary links once). Run one module with `cargo test -p rov_station --test it MODULE::`.

/// The station's integration tests run one at a time. The soak measures the process's
/// resident memory and the reconnect tests count wall-clock control frames: tests of the
/// other modules running beside them in this one test process would disturb both (when
/// each file was its own binary, cargo ran the binaries one after another).
pub(crate) fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    // A test that failed while holding it poisons it; the next test still runs.
    LOCK.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

mod autopilot_model;
mod model_overlay;
mod serial_reconnect;
mod soak;
mod video;
