//! [`recover`]: rewrite a damaged (or any) session file as a complete one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Result, SessionError, io_err};
use crate::mcap_file::{McapFile, McapOptions};
use crate::message::Damage;
use crate::session::Session;

/// What [`recover`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveryReport {
    /// The input file (never modified).
    pub input: PathBuf,
    /// The file written: `NAME.recovered.mcap` beside the input.
    pub output: PathBuf,
    /// Size of the input, bytes.
    pub input_bytes: u64,
    /// Bytes of the input up to the end of the last good record.
    pub good_bytes: u64,
    /// Bytes after the last good record (lost; 0 for an intact file).
    pub lost_bytes: u64,
    /// Messages copied.
    pub messages_recovered: u64,
    /// The latest message time recovered, ns.
    pub last_good_t_ns: Option<u64>,
    /// The damage found, `None` when the input was complete.
    pub damage: Option<Damage>,
    /// The reader's warnings.
    pub warnings: Vec<String>,
}

impl std::fmt::Display for RecoveryReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.damage {
            None => writeln!(
                f,
                "{}: complete and intact; copied anyway",
                self.input.display()
            )?,
            Some(d) => writeln!(f, "{}: {d}", self.input.display())?,
        }
        writeln!(
            f,
            "recovered {} messages{} into {}",
            self.messages_recovered,
            match self.last_good_t_ns {
                Some(t) => format!(" (last good message at t = {:.3} s)", t as f64 * 1e-9),
                None => String::new(),
            },
            self.output.display()
        )?;
        write!(
            f,
            "lost {} of {} bytes after the last good record",
            self.lost_bytes, self.input_bytes
        )
    }
}

/// `dive.mcap` → `dive.recovered.mcap` (any other name gets `.recovered.mcap` appended).
pub fn recovered_path(input: &Path) -> PathBuf {
    let name = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name.strip_suffix(".mcap").unwrap_or(&name);
    input.with_file_name(format!("{stem}.recovered.mcap"))
}

/// Reads `input` as far as it is intact (every record, by a scan: damage anywhere is
/// found) and writes everything up to the last good record to [`recovered_path`]`(input)`
/// as a complete MCAP file (with summary and indexes), every channel kept (video too).
/// The input is never modified; the output is written to a temporary name and renamed.
/// Memory stays bounded: both passes stream.
pub fn recover(input: impl AsRef<Path>) -> Result<RecoveryReport> {
    let input = input.as_ref();
    let session = Session::open_scanned(input)?;
    let output = recovered_path(input);
    if output == input {
        return Err(SessionError::Unusable(format!(
            "{}: the recovered file would overwrite the input",
            input.display()
        )));
    }
    let copied = write_copy(&session, &output)?;
    let input_bytes = session.file_len();
    let damage = session.damage();
    let good_bytes = damage.as_ref().map_or(input_bytes, Damage::at_byte);
    Ok(RecoveryReport {
        input: input.to_path_buf(),
        output,
        input_bytes,
        good_bytes,
        lost_bytes: input_bytes.saturating_sub(good_bytes),
        messages_recovered: copied,
        last_good_t_ns: session.end_ns(),
        damage,
        warnings: session.warnings().to_vec(),
    })
}

/// Writes every schema, channel, attachment, metadata record and message (in file order)
/// of `session` to a complete MCAP file at `output`; returns the messages copied.
pub fn write_copy(session: &Session, output: &Path) -> Result<u64> {
    let tmp = output.with_extension("mcap.partial");
    let werr = io_err(output, "write");
    let mut w = McapFile::create(
        &tmp,
        McapOptions {
            compress: true,
            chunk_size: 512 * 1024,
            library: format!("topside rov_session {} recover", env!("CARGO_PKG_VERSION")),
        },
    )
    .map_err(io_err(&tmp, "create"))?;
    let copy = |w: &mut McapFile| -> std::io::Result<u64> {
        for a in session.attachments() {
            w.attach(a.log_time, a.create_time, &a.name, &a.media_type, &a.data)?;
        }
        for (name, map) in session.metadata() {
            w.write_metadata(name, map)?;
        }
        let mut schema_ids = BTreeMap::new();
        for (id, s) in session.schemas() {
            schema_ids.insert(*id, w.add_schema(&s.name, &s.encoding, &s.data)?);
        }
        let mut channel_ids = BTreeMap::new();
        for (id, c) in session.channels() {
            let schema = if c.schema_id == 0 {
                0
            } else {
                schema_ids.get(&c.schema_id).copied().unwrap_or(0)
            };
            channel_ids.insert(
                *id,
                w.add_channel(schema, &c.topic, &c.encoding, &c.metadata)?,
            );
        }
        let mut copied = 0u64;
        for m in session.messages_in_file_order() {
            let Some(&channel_id) = channel_ids.get(&m.channel_id) else {
                continue;
            };
            w.write_message(channel_id, m.sequence, m.t_ns, m.t_ns, m.data())?;
            copied += 1;
        }
        w.finish()?;
        Ok(copied)
    };
    let copied = copy(&mut w).map_err(werr)?;
    let file = w.into_file().map_err(io_err(&tmp, "flush"))?;
    file.sync_all().map_err(io_err(&tmp, "fsync"))?;
    drop(file);
    std::fs::rename(&tmp, output).map_err(io_err(output, "rename the finished file to"))?;
    Ok(copied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovered_names() {
        assert_eq!(
            recovered_path(Path::new("/a/dive.mcap")),
            Path::new("/a/dive.recovered.mcap")
        );
        assert_eq!(
            recovered_path(Path::new("x")),
            Path::new("x.recovered.mcap")
        );
        assert_eq!(
            recovered_path(Path::new("d/x.recovered.mcap")),
            Path::new("d/x.recovered.recovered.mcap")
        );
    }
}
