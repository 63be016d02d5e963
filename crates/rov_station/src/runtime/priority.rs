//! Thread priorities for the real-time threads (control, link rx/tx, watchdog).
//!
//! Each thread asks for the best the operating system grants without special set-up:
//! first real-time `SCHED_FIFO` (granted to root, to `CAP_SYS_NICE`, or within
//! `RLIMIT_RTPRIO`, e.g. a user in an `audio`/`realtime` group), then the lowest nice
//! value allowed (`RLIMIT_NICE`), else the normal priority. What each thread got is
//! published in the view (health panel) and in `topside record --json`. Through the
//! `thread-priority` crate (pthread_setschedparam / setpriority), as the workspace has
//! no unsafe code of its own.

use serde::Serialize;
use thread_priority::{
    RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue, ThreadSchedulePolicy,
};

/// What a thread got.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub enum Granted {
    /// Real-time FIFO at this priority (1..99).
    RealTime(u8),
    /// Normal scheduling with this nice value (−20..0).
    Nice(i8),
    /// Normal scheduling at the default priority (nothing better was allowed).
    Normal,
}

impl std::fmt::Display for Granted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Granted::RealTime(p) => write!(f, "real-time FIFO {p}"),
            Granted::Nice(n) => write!(f, "nice {n}"),
            Granted::Normal => write!(f, "normal (no rights to raise)"),
        }
    }
}

/// Real-time priorities: the watchdog above the control thread (it must run when the
/// control thread is stuck), the link threads just below.
pub const RT_WATCHDOG: u8 = 62;
/// Control thread.
pub const RT_CONTROL: u8 = 60;
/// Link rx/tx threads.
pub const RT_LINK: u8 = 58;

/// Puts the calling thread back to normal scheduling (`SCHED_OTHER`, nice 0). A thread
/// inherits its creator's scheduling, so a thread created from a real-time thread (the
/// recorder, a finisher, the camera encoder's start and the GStreamer threads it creates,
/// the model watch, all started by the control thread) would run at the control
/// thread's own real-time priority and, being busy, hold it off (seen as a CONTROL STALL
/// alarm when a recording with video started). Every thread the runtime spawns calls
/// this first; the real-time ones raise themselves after. Lowering needs no rights; if
/// the system refuses anyway, the thread keeps what it inherited and says so.
pub fn normal_current() {
    let id = thread_priority::thread_native_id();
    let normal = ThreadPriorityValue::try_from(50u8).map(ThreadPriority::Crossplatform);
    let lowered = normal.ok().is_some_and(|p| {
        thread_priority::set_thread_priority_and_policy(
            id,
            p,
            ThreadSchedulePolicy::Normal(thread_priority::NormalThreadSchedulePolicy::Other),
        )
        .is_ok()
    });
    if !lowered {
        tracing::warn!(
            "thread {:?} kept its creator's scheduling (could not return to normal)",
            std::thread::current().name()
        );
    }
}

/// Raises the calling thread: real-time `rt` if allowed, else the lowest nice allowed.
#[must_use]
pub fn raise_current(rt: u8) -> Granted {
    let id = thread_priority::thread_native_id();
    if let Ok(p) = ThreadPriorityValue::try_from(rt)
        && thread_priority::set_thread_priority_and_policy(
            id,
            ThreadPriority::Crossplatform(p),
            ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
        )
        .is_ok()
    {
        return Granted::RealTime(rt);
    }
    // Crossplatform 100 maps to nice −20, 50 to nice 0 (normal policy).
    for (cross, nice) in [(100u8, -20i8), (87, -15), (75, -10), (62, -5), (55, -2)] {
        if let Ok(p) = ThreadPriorityValue::try_from(cross)
            && thread_priority::set_thread_priority_and_policy(
                id,
                ThreadPriority::Crossplatform(p),
                ThreadSchedulePolicy::Normal(thread_priority::NormalThreadSchedulePolicy::Other),
            )
            .is_ok()
        {
            return Granted::Nice(nice);
        }
    }
    Granted::Normal
}
