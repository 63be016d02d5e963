//! ROS 1 bags (format 2.0): a small reader of the record format.
//!
//! Why not the `rosbag` crate the issue names: it opens files only by path through a
//! memory map (this crate reads bytes the caller passes and does no I/O), and it slices
//! the file at the index position its header promises, so a bag cut short — a recording
//! that stopped before its index was written, the commonest damaged bag — panics it
//! instead of being read to its last good record. The record format is small: after the
//! line `#ROSBAG V2.0`, records of `u32 header length, header, u32 data length, data`,
//! the header a list of `u32 length, name=value` fields with `op` its record type. This
//! reader walks them in file order: chunks (op 5; compression `none` or `lz4`, the frame
//! format) hold connection records (op 7: topic, type, `message_definition`) and message
//! records (op 2: connection id, time as u32 sec + u32 nsec); index records (ops 4, 6) and
//! the index's repeated connections are passed over. `bz2` chunks are skipped and counted
//! (no bzip2 decoder in the build).
//!
//! Messages are decoded from each connection's `message_definition` with ROS 1's rules
//! (see [`crate::rosmsg`]); fields are `/topic:path` and times as [`crate::rostopic`] says,
//! the log time being the message record's time.
//!
//! Bad input: a record that runs past the end of the data (a bag cut short) or whose
//! header does not parse ends the read, reported as truncated; the messages of a cut chunk
//! read up to the cut are kept.

use std::collections::BTreeMap;
use std::io::Read;

use crate::rostopic::{Collector, Encoding};
use crate::{Log, LogError, ReadOptions};

/// The first line of a ROS 1 bag (format 2.0).
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

const OP_MSG: u8 = 0x02;
const OP_BAG_HEADER: u8 = 0x03;
const OP_INDEX: u8 = 0x04;
const OP_CHUNK: u8 = 0x05;
const OP_CHUNK_INFO: u8 = 0x06;
const OP_CONNECTION: u8 = 0x07;

fn u32_at(b: &[u8], pos: usize) -> Option<u32> {
    let s: [u8; 4] = b.get(pos..pos.checked_add(4)?)?.try_into().ok()?;
    Some(u32::from_le_bytes(s))
}

/// Parses `u32 length, name=value` fields.
fn fields(h: &[u8]) -> Option<BTreeMap<&str, &[u8]>> {
    let mut out = BTreeMap::new();
    let mut pos = 0usize;
    while pos < h.len() {
        let n = u32_at(h, pos)? as usize;
        let f = h.get(pos + 4..(pos + 4).checked_add(n)?)?;
        let eq = f.iter().position(|c| *c == b'=')?;
        let name = std::str::from_utf8(f.get(..eq)?).ok()?;
        out.insert(name, f.get(eq + 1..)?);
        pos += 4 + n;
    }
    Some(out)
}

enum Rec<'a> {
    Ok {
        header: BTreeMap<&'a str, &'a [u8]>,
        data: &'a [u8],
        next: usize,
    },
    /// Cut short by the end: the header (when whole) and whatever data there is.
    Short(Option<BTreeMap<&'a str, &'a [u8]>>, &'a [u8]),
    Bad(String),
}

fn record(b: &[u8], pos: usize) -> Rec<'_> {
    let Some(hlen) = u32_at(b, pos) else {
        return Rec::Short(None, &[]);
    };
    let hstart = pos + 4;
    let Some(hend) = hstart.checked_add(hlen as usize).filter(|e| *e <= b.len()) else {
        return Rec::Short(None, &[]);
    };
    let Some(header) = b.get(hstart..hend).and_then(fields) else {
        return Rec::Bad(format!("record header at byte {pos} does not parse"));
    };
    let Some(dlen) = u32_at(b, hend) else {
        return Rec::Short(Some(header), &[]);
    };
    let dstart = hend + 4;
    match dstart
        .checked_add(dlen as usize)
        .and_then(|e| b.get(dstart..e).map(|d| (d, e)))
    {
        Some((data, next)) => Rec::Ok { header, data, next },
        None => Rec::Short(Some(header), b.get(dstart..).unwrap_or(&[])),
    }
}

fn op(h: &BTreeMap<&str, &[u8]>) -> Option<u8> {
    h.get("op").and_then(|v| v.first()).copied()
}

fn text(v: Option<&&[u8]>) -> String {
    v.map(|b| String::from_utf8_lossy(b).into_owned())
        .unwrap_or_default()
}

/// Reads a ROS 1 bag.
pub fn read(bytes: &[u8], label: &str, opts: &ReadOptions) -> Result<Log, LogError> {
    let Some(body) = bytes.strip_prefix(MAGIC) else {
        return Err(LogError::Unreadable {
            file: label.into(),
            detail: "not a ROS 1 bag (no `#ROSBAG V2.0` line)".into(),
        });
    };
    let mut col = Collector::new(opts);
    let mut unsupported: BTreeMap<String, usize> = BTreeMap::new();
    let off = MAGIC.len();
    let mut pos = 0usize;
    let mut truncated = None;
    while pos < body.len() {
        match record(body, pos) {
            Rec::Ok { header, data, next } => {
                match op(&header) {
                    Some(OP_CHUNK) => {
                        if let Err(why) = chunk(&mut col, &header, data, false) {
                            *unsupported.entry(why).or_insert(0) += 1;
                        }
                    }
                    Some(OP_BAG_HEADER | OP_INDEX | OP_CHUNK_INFO) => {}
                    Some(o @ (OP_MSG | OP_CONNECTION)) => inner(&mut col, o, &header, data),
                    _ => col.report.bad_records += 1,
                }
                pos = next;
            }
            Rec::Short(header, data) => {
                let mut said = format!(
                    "record at byte {} cut short by the end of the data",
                    pos + off
                );
                if let Some(h) = header.filter(|h| op(h) == Some(OP_CHUNK)) {
                    let before = col.report.records;
                    if chunk(&mut col, &h, data, true).is_ok() {
                        said.push_str(&format!(
                            " (a chunk; its {} message(s) before the cut kept)",
                            col.report.records - before
                        ));
                    }
                }
                truncated = Some(said);
                break;
            }
            Rec::Bad(why) => {
                truncated = Some(format!("corrupt: {why} (file byte {})", pos + off));
                break;
            }
        }
    }
    let mut log = col.finish();
    for (why, n) in unsupported {
        *log.report
            .unknown_types
            .entry(format!("chunk ({why})"))
            .or_insert(0) += n;
    }
    log.report.truncated = truncated;
    Ok(log)
}

/// One message or connection record.
fn inner(col: &mut Collector, o: u8, header: &BTreeMap<&str, &[u8]>, data: &[u8]) {
    let Some(conn) = header.get("conn").and_then(|v| u32_at(v, 0)) else {
        col.report.bad_records += 1;
        return;
    };
    if o == OP_CONNECTION {
        let topic = text(header.get("topic"));
        let Some(c) = fields(data) else {
            col.report.bad_records += 1;
            return;
        };
        let ty = text(c.get("type"));
        let def = text(c.get("message_definition"));
        col.connection(conn, &topic, &ty, &def, Encoding::Ros1);
        return;
    }
    let time_ns = header.get("time").and_then(|v| {
        let s = u32_at(v, 0)? as u64;
        let ns = u32_at(v, 4)? as u64;
        Some(s * 1_000_000_000 + ns)
    });
    match time_ns {
        Some(t) => col.message(conn, t, data),
        None => col.report.bad_records += 1,
    }
}

/// A chunk's records; `cut`: the data ends early (read what is whole).
fn chunk(
    col: &mut Collector,
    header: &BTreeMap<&str, &[u8]>,
    data: &[u8],
    cut: bool,
) -> Result<(), String> {
    let comp = text(header.get("compression"));
    let owned;
    let records: &[u8] = match comp.as_str() {
        "none" => data,
        "lz4" => {
            let size = header.get("size").and_then(|v| u32_at(v, 0)).unwrap_or(0) as usize;
            let mut out = Vec::with_capacity(size.min(64 << 20));
            let r = lz4::Decoder::new(data).and_then(|mut d| d.read_to_end(&mut out));
            if r.is_err() && !cut {
                col.report.bad_records += 1;
            }
            owned = out;
            &owned
        }
        other => return Err(format!("compression {other}")),
    };
    let mut pos = 0usize;
    while pos < records.len() {
        match record(records, pos) {
            Rec::Ok { header, data, next } => {
                match op(&header) {
                    Some(o @ (OP_MSG | OP_CONNECTION)) => inner(col, o, &header, data),
                    _ => col.report.bad_records += 1,
                }
                pos = next;
            }
            Rec::Short(..) | Rec::Bad(_) => {
                if !cut {
                    col.report.bad_records += 1;
                }
                break;
            }
        }
    }
    Ok(())
}
