//! Sessions of the topside station: MCAP recording that survives being killed, reading of
//! complete, truncated and damaged files in bounded memory, recovery, measurement-CSV
//! export and import and playback (a model is compared with a session by the model lab's
//! engine, `rov_lab::engine`, not here).
//!
//! * [`record`]: the topics (fixed names), one typed record per JSON topic and its JSON
//!   Schema. Raw Pro 4 frames go on `/pro4/tx` and `/pro4/rx` (encoding `vr-pro4`).
//! * [`foxglove`]: Foxglove's standard schemas: the vehicle pose (`/tf`, `/vehicle/pose`,
//!   `/vehicle/track`) and camera video (`/camera/video`), NED → ENU.
//! * [`writer`]: [`SessionWriter`]; flush and fsync policy and the crash-safety guarantee.
//! * [`session`]: [`open`] / [`Session`]: opening through the summary (no message read) or
//!   by a scan (damaged files); damage and warnings.
//! * [`stream`]: [`Messages`], reads in time (or file) order, chunk by chunk.
//! * [`video`]: video frames in a time range, the key frame at or before a time.
//! * [`recover`](mod@recover): [`recover()`] writes `NAME.recovered.mcap`.
//! * [`csv`]: [`export_csv_to`] (streaming) and [`import_csv`]; the export timing rule.
//! * [`playback`]: [`Playback`] (play/pause, speed 0.1×–50×, seek, step).
//!
//! # Pure parts and I/O
//!
//! The records, the wire format ([`wire`](mod@wire) framing, [`chunk`](mod@chunk)
//! decoding, the Foxglove messages) and the CSV layout take bytes and return values. The
//! file system is touched in three places only: [`io`] (the reader's [`io::Source`]: a file
//! or bytes in memory, read at an offset), [`writer`] and [`recover`](mod@recover)
//! (creating files). Everything between — opening, streams, playback, export — reads
//! through a `Source`, so it runs the same on a file and on bytes in memory (tests, the
//! fuzz target).
//!
//! # Time
//!
//! This crate never reads a clock. Message times are `u64` nanoseconds given by the
//! caller: since the session start (the station's choice) or since the Unix epoch; one
//! base per file. Exports and playback count seconds from the first message.
//!
//! # Files
//!
//! Files are standard MCAP (JSON messages with `jsonschema` schemas, protobuf messages
//! with Foxglove's schemas), readable by Foxglove, PlotJuggler, the `mcap` CLI and the
//! official Python reader. Reading parses with bounds-checked code of its own
//! ([`wire`](mod@wire)); writing streams records of its own too, so its memory does not
//! grow with the recording ([`mcap_file`](mod@mcap_file)).
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

mod chunk;
pub mod csv;
mod encode;
pub mod error;
pub mod foxglove;
mod index;
pub mod io;
mod mcap_file;
mod message;
mod open;
pub mod playback;
pub mod record;
pub mod recover;
pub mod session;
pub mod stream;
pub mod video;
mod wire;
pub mod writer;

pub use chunk::MAX_CHUNK_BYTES;
pub use csv::{
    CsvExport, CsvSummary, ImportReport, MeasurementsStreamed, export_csv, export_csv_to,
    import_csv, import_series, measurements, measurements_each, measurements_until,
};
pub use error::{Result, SessionError};
pub use message::{Damage, Decoded, Message, MessageRef, Payload, TopicSummary};
pub use playback::{MAX_SPEED, MIN_SPEED, Playback};
pub use record::{
    AutopilotRecord, Cell, Direction, EventRecord, LinkRecord, LinkState, Mode, NavRecord,
    ObserverRecord, PilotRecord, Record, SessionInfo, Severity, StatusRecord, ThrustRecord, Topic,
    TruthRecord, encode_json,
};
pub use recover::{RecoveryReport, recover, recovered_path};
pub use session::{Session, open};
pub use stream::{Messages, ReadOptions, ReadReport};
pub use video::{VideoFrames, VideoStats};
pub use wire::{AttachmentData, ChannelDef, SchemaDef};
pub use writer::{SessionWriter, WriteSummary, WriterOptions};
