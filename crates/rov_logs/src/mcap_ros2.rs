//! MCAP logs: ROS 2 bags (CDR messages with `ros2msg` schemas) and any MCAP whose channels
//! carry CDR or ROS 1 messages with their message definitions.
//!
//! Read streaming with the `mcap` crate's message stream: chunks are decompressed (lz4,
//! zstd) one at a time as the stream reaches them, their CRCs checked. Each channel's
//! schema is parsed once (see [`crate::rosmsg`]) and only the fields the map names are
//! decoded; fields are `/topic:path` and times as [`crate::rostopic`] says.
//!
//! Bad input: a channel whose encoding or schema this crate cannot decode (protobuf,
//! JSON, `ros2idl`, a type the definition does not define) has its messages skipped and
//! counted by type; a message that does not decode is counted bad. A file cut short or
//! corrupted (a record running past the end, a chunk whose CRC fails, a missing end magic)
//! is read to its last good record, reported as truncated with the reason; the messages of
//! a chunk that is cut or corrupt are lost with it (a chunk is one compressed block).

use std::collections::HashSet;

use crate::rostopic::{Collector, Encoding};
use crate::{Log, LogError, ReadOptions};

/// The MCAP magic (start and end of a file).
pub const MAGIC: &[u8] = mcap::MAGIC;

/// Reads an MCAP log.
pub fn read(bytes: &[u8], label: &str, opts: &ReadOptions) -> Result<Log, LogError> {
    let mut stream = mcap::read::RawMessageStream::new_with_options(
        bytes,
        mcap::read::Options::ValidateChunkCrcs.into(),
    )
    .map_err(|e| LogError::Unreadable {
        file: label.into(),
        detail: format!("not an MCAP file: {e}"),
    })?;
    let mut col = Collector::new(opts);
    let mut known: HashSet<u16> = HashSet::new();
    let mut truncated = None;
    // mcap 0.26's linear reader subtracts a record's length from what remains of an
    // uncompressed chunk without checking it (sans_io/linear_reader.rs): a record claiming
    // more than its chunk holds overflows, a panic where overflow checks are on (debug
    // builds). Found by the fuzz target `log_mcap`; until the crate checks it, the read is
    // guarded here and ends as a corrupt file, keeping what was read before.
    let guarded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        loop {
            let msg = match stream.next() {
                None => break,
                Some(Ok(m)) => m,
                Some(Err(e)) => {
                    truncated = Some(format!(
                        "MCAP stream ended after {} message(s): {e}",
                        col.report.records
                    ));
                    break;
                }
            };
            let id = msg.header.channel_id;
            if !known.contains(&id)
                && let Some(ch) = stream.get_channel(id)
            {
                known.insert(id);
                let (name, schema_enc, text) = match &ch.schema {
                    Some(s) => (
                        s.name.clone(),
                        s.encoding.clone(),
                        String::from_utf8_lossy(&s.data).into_owned(),
                    ),
                    None => (String::from("(no schema)"), String::new(), String::new()),
                };
                let enc = match (ch.message_encoding.as_str(), schema_enc.as_str()) {
                    ("cdr", "ros2msg") => Encoding::Cdr,
                    ("ros1", "ros1msg") => Encoding::Ros1,
                    (m, s) => Encoding::Other(format!("{m} with schema {s}")),
                };
                col.connection(u32::from(id), &ch.topic, &name, &text, enc);
            }
            col.message(u32::from(id), msg.header.log_time, &msg.data);
        }
    }));
    if guarded.is_err() {
        truncated = Some(format!(
            "the MCAP reader failed on a malformed record after {} message(s)",
            col.report.records
        ));
    }
    let mut log = col.finish();
    log.report.truncated = truncated;
    Ok(log)
}
