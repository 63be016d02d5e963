//! Runners that move bytes between a transport and a [`Link`] on the wall clock: a
//! blocking loop ([`run_blocking`], always built) and a tokio task (`spawn`, feature
//! `tokio`).

use std::ops::ControlFlow;
use std::time::Duration;

use crate::error::TransportError;
use crate::link::Link;
use crate::transport::Transport;

#[cfg(feature = "tokio")]
mod task;
#[cfg(feature = "tokio")]
pub use task::{LinkHandle, LinkSnapshot, RunnerOptions, spawn};

pub use rov_transport::MonoClock;

/// Drives `link` over `transport` until `on_iteration` breaks or the transport fails.
/// `on_iteration` runs after every wake-up (bytes, timeout or `max_wait`) with the link
/// and the time; it drains events and sets commands.
///
/// # Errors
/// [`TransportError`] from the transport.
pub fn run_blocking<T: Transport + ?Sized>(
    link: &mut Link,
    transport: &mut T,
    clock: &MonoClock,
    max_wait: Duration,
    mut on_iteration: impl FnMut(&mut Link, u64) -> ControlFlow<()>,
) -> Result<(), TransportError> {
    let mut buf = vec![0u8; 4096];
    let max_wait_us = u64::try_from(max_wait.as_micros()).unwrap_or(u64::MAX);
    loop {
        let mut now = clock.now_us();
        if link.next_timeout().is_some_and(|t| t <= now) {
            // A deadline passed while this thread was away (preempted, or busy in
            // `on_iteration`): take the bytes the OS already holds first, so a reply that
            // arrived meanwhile is not judged a stalled frame or a timeout.
            let n = transport.recv(&mut buf, Duration::ZERO)?;
            if n > 0 {
                now = clock.now_us();
                link.handle_input(buf.get(..n).unwrap_or_default(), now);
            }
        }
        link.handle_timeout(now);
        while let Some(frame) = link.poll_transmit(now) {
            transport.send(frame)?;
        }
        if on_iteration(link, now).is_break() {
            return Ok(());
        }
        let now = clock.now_us();
        let wait_us = link
            .next_timeout()
            .map_or(max_wait_us, |t| t.saturating_sub(now))
            .min(max_wait_us);
        let n = transport.recv(&mut buf, Duration::from_micros(wait_us))?;
        if n > 0 {
            link.handle_input(buf.get(..n).unwrap_or_default(), clock.now_us());
        }
    }
}
