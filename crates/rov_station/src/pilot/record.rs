//! What the pilot core hands the runtime to record (and to serve live): one item per
//! session message, stamped in ns since the recording started.

use rov_session::{
    AutopilotRecord, Direction, EventRecord, LinkRecord, NavRecord, ObserverRecord, PilotRecord,
    StatusRecord, ThrustRecord, TruthRecord,
};

/// One item for the recorder; times are ns since the recording started.
#[derive(Debug, Clone)]
pub enum RecordItem {
    /// A raw frame.
    Raw(Direction, u64, Vec<u8>),
    /// `/telemetry/nav`.
    Nav(u64, NavRecord),
    /// `/telemetry/status`.
    Status(u64, StatusRecord),
    /// `/command/thrust`.
    Thrust(u64, ThrustRecord),
    /// `/pilot/input`.
    Pilot(u64, PilotRecord),
    /// `/autopilot/state`.
    Autopilot(u64, AutopilotRecord),
    /// `/observer/state`.
    Observer(u64, ObserverRecord),
    /// `/link/stats`.
    Link(u64, LinkRecord),
    /// `/events`.
    Event(u64, EventRecord),
    /// `/truth/state` (simulated vehicle only).
    Truth(u64, TruthRecord),
    /// `/camera/video`: one H.264 access unit (Annex B) and whether it is a key frame.
    Video(u64, bool, Vec<u8>),
}

impl RecordItem {
    /// Its recording time, ns.
    #[must_use]
    pub const fn t_ns(&self) -> u64 {
        match self {
            Self::Raw(_, t, _)
            | Self::Nav(t, _)
            | Self::Status(t, _)
            | Self::Thrust(t, _)
            | Self::Pilot(t, _)
            | Self::Autopilot(t, _)
            | Self::Observer(t, _)
            | Self::Link(t, _)
            | Self::Event(t, _)
            | Self::Truth(t, _)
            | Self::Video(t, _, _) => *t,
        }
    }
}
