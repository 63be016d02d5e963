//! Sessions of the topside station: MCAP recording that survives being killed, reading of
//! complete, truncated and damaged files, recovery, measurement-CSV export and import,
//! sans-IO playback and re-simulation through a vehicle model.
//!
//! * [`record`]: the topics (fixed names), one typed record per JSON topic and its JSON
//!   Schema. Raw Pro 4 frames go on `/pro4/tx` and `/pro4/rx` (encoding `vr-pro4`).
//! * [`writer`]: [`SessionWriter`]; flush and fsync policy and the crash-safety guarantee.
//! * [`reader`]: [`open`] / [`Session`]; truncated and corrupt files, warnings, lazy
//!   per-topic decoding.
//! * [`recover`](mod@recover): [`recover()`] writes `NAME.recovered.mcap`.
//! * [`csv`]: [`export_csv`] and [`import_csv`]; the export timing rule.
//! * [`playback`]: [`Playback`] (play/pause, speed 0.1×–50×, seek, step).
//! * [`resim`]: [`resimulate`], model-versus-measured traces and fits.
//!
//! # Time
//!
//! This crate never reads a clock. Message times are `u64` nanoseconds given by the
//! caller: since the session start (the station's choice) or since the Unix epoch; one
//! base per file. Exports and playback count seconds from the first message.
//!
//! # Files
//!
//! Files are standard MCAP (JSON messages with `jsonschema` schemas), readable by
//! Foxglove, PlotJuggler, the `mcap` CLI and the official Python reader. Reading parses
//! with bounds-checked code of its own (see [`reader`]); writing uses the `mcap` crate.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod csv;
pub mod error;
pub mod playback;
pub mod reader;
pub mod record;
pub mod recover;
pub mod resim;
mod wire;
pub mod writer;

pub use csv::{CsvExport, ImportReport, export_csv, import_csv, measurements};
pub use error::{Result, SessionError};
pub use playback::{MAX_SPEED, MIN_SPEED, Playback};
pub use reader::{Damage, Decoded, MAX_CHUNK_BYTES, MessageRef, Session, TopicSummary, open};
pub use record::{
    AutopilotRecord, Cell, Direction, EventRecord, LinkRecord, LinkState, Mode, NavRecord,
    ObserverRecord, PilotRecord, Record, SessionInfo, Severity, StatusRecord, ThrustRecord, Topic,
    TruthRecord,
};
pub use recover::{RecoveryReport, recover, recovered_path};
pub use resim::{ChannelFit, ResimOptions, Resimulation, resimulate, resimulate_series};
pub use wire::{AttachmentData, ChannelDef, SchemaDef};
pub use writer::{SessionWriter, WriteSummary, WriterOptions};
