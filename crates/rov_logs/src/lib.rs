//! Real vehicle logs read as they are, and the log map that names what they mean.
//!
//! A reader turns a log (bytes the caller passes: this crate opens no file and reads no
//! clock) into a [`Log`]: every numeric field as its own timestamped series, named as the
//! map names it (a CSV column; `MSG.Field` in an ArduSub DataFlash log; `MESSAGE.field` in
//! a MAVLink tlog; `/topic:path` in a ROS 1 bag or an MCAP file such as a ROS 2 bag). A
//! log map
//! ([`map::LogMap`], TOML) says which fields are the lab's canonical signals and the
//! vehicle's command channels and how to convert them; [`map::LogMap::apply`] gives the
//! mapped series and [`map::MappedLog::lab_table`] the lab's table: one row per
//! measurement time, commands held from their last sample (zero-order hold),
//! measurements never invented.
//!
//! Bad input never panics: a record that does not parse is skipped and counted, unknown
//! message types are counted by name, and a log truncated or corrupted mid-record is read
//! to its last good record and says so in its [`ReadReport`].

#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod csv;
pub mod dataflash;
pub mod map;
pub mod mcap_ros2;
pub mod ros1;
pub mod rosmsg;
pub mod rostopic;
pub mod tlog;

use std::collections::BTreeMap;

pub use map::{LogMap, MappedLog};

/// Log formats this crate reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// CSV or TSV text with a header row (the delimiter is detected).
    Csv,
    /// ArduPilot/ArduSub DataFlash binary log (`.BIN`).
    DataFlash,
    /// MAVLink telemetry log (`.tlog`): timestamped MAVLink v1/v2 frames.
    Tlog,
    /// ROS 1 bag (`#ROSBAG V2.0`).
    Ros1,
    /// MCAP: a ROS 2 bag (CDR messages) or any MCAP with ROS 1 or CDR messages.
    Mcap,
}

impl Format {
    /// Every format, as the map's `format` key spells it.
    pub const NAMES: [&'static str; 5] = ["csv", "dataflash", "tlog", "ros1", "mcap"];

    /// Parses the map's `format` value.
    pub fn parse(s: &str) -> Option<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "csv" | "tsv" => Some(Self::Csv),
            "dataflash" | "bin" => Some(Self::DataFlash),
            "tlog" | "mavlink" => Some(Self::Tlog),
            "ros1" | "bag" | "rosbag" => Some(Self::Ros1),
            "mcap" | "ros2" => Some(Self::Mcap),
            _ => None,
        }
    }

    /// The map's spelling.
    pub fn name(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::DataFlash => "dataflash",
            Self::Tlog => "tlog",
            Self::Ros1 => "ros1",
            Self::Mcap => "mcap",
        }
    }

    /// Detects the format from the first bytes of a log: a DataFlash log starts with its
    /// record head `A3 95` and an FMT record (type 128); a ROS 1 bag with `#ROSBAG V2.0`,
    /// an MCAP file with its magic `89 M C A P 30 0D 0A`; a tlog with a timestamp and a
    /// MAVLink frame whose CRC checks ([`tlog::looks_like`]); text is taken as CSV/TSV.
    pub fn detect(bytes: &[u8]) -> Option<Self> {
        if bytes.len() >= 3
            && bytes[..3] == [dataflash::HEAD1, dataflash::HEAD2, dataflash::FMT_TYPE]
        {
            return Some(Self::DataFlash);
        }
        if bytes.starts_with(ros1::MAGIC) {
            return Some(Self::Ros1);
        }
        if bytes.starts_with(mcap_ros2::MAGIC) {
            return Some(Self::Mcap);
        }
        if tlog::looks_like(bytes) {
            return Some(Self::Tlog);
        }
        let head = &bytes[..bytes.len().min(4096)];
        let text = head
            .iter()
            .all(|b| b.is_ascii_graphic() || b.is_ascii_whitespace() || *b >= 0x80);
        (text && !head.is_empty()).then_some(Self::Csv)
    }
}

/// One field's samples: times (s, the log's own clock) and values, in log order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// Values (the log's units).
    pub v: Vec<f64>,
}

impl Series {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    fn push(&mut self, t: f64, v: f64) {
        self.t_s.push(t);
        self.v.push(v);
    }
}

/// What a reader met on its way through a log.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadReport {
    /// Records (rows, messages) read.
    pub records: usize,
    /// Records skipped because they did not parse (bad numbers, bad lengths), counted.
    pub bad_records: usize,
    /// Records without a usable time (skipped), counted.
    pub untimed_records: usize,
    /// Records whose time did not increase (skipped), counted.
    pub non_increasing: usize,
    /// Message types the reader cannot decode, with how many records each.
    pub unknown_types: BTreeMap<String, usize>,
    /// Bytes skipped while resynchronising after corruption.
    pub skipped_bytes: usize,
    /// Where the log ended early (truncated or corrupted mid-record), in words.
    pub truncated: Option<String>,
    /// Other things a reader says about how it read the log (e.g. which time it used).
    pub notes: Vec<String>,
}

impl ReadReport {
    /// The report in words (empty when the log read cleanly).
    pub fn sentences(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.bad_records > 0 {
            out.push(format!(
                "{} record(s) did not parse and were skipped",
                self.bad_records
            ));
        }
        if self.untimed_records > 0 {
            out.push(format!(
                "{} record(s) without a usable time were skipped",
                self.untimed_records
            ));
        }
        if self.non_increasing > 0 {
            out.push(format!(
                "{} record(s) whose time did not increase were skipped",
                self.non_increasing
            ));
        }
        if !self.unknown_types.is_empty() {
            let list: Vec<String> = self
                .unknown_types
                .iter()
                .map(|(k, n)| format!("{k} ×{n}"))
                .collect();
            out.push(format!(
                "unknown message types skipped: {}",
                list.join(", ")
            ));
        }
        if self.skipped_bytes > 0 {
            out.push(format!(
                "{} corrupt byte(s) skipped while resynchronising",
                self.skipped_bytes
            ));
        }
        if let Some(t) = &self.truncated {
            out.push(format!("read to the last good record: {t}"));
        }
        out.extend(self.notes.iter().cloned());
        out
    }
}

/// A log read as it is: every numeric field with its own timestamps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Log {
    /// Fields by name (a CSV column; `MSG.Field`).
    pub fields: BTreeMap<String, Series>,
    /// What the reader met.
    pub report: ReadReport,
}

impl Log {
    /// The field names, sorted.
    pub fn names(&self) -> Vec<&str> {
        self.fields.keys().map(String::as_str).collect()
    }
}

/// How to read time and which fields to keep.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReadOptions {
    /// The time field: a CSV column; for DataFlash the name of the time field every
    /// message carries (`TimeUS`; a map's `"RCOU.TimeUS"` names it by its field part).
    /// For a tlog, `tlog.timestamp_us` (the record's timestamp) or `MESSAGE.field` (each
    /// message's own field of that name, see [`tlog`]).
    /// `None`: CSV takes the first column named `time_s`, `time`, `t` or `timestamp`;
    /// DataFlash takes `TimeUS` (µs) then `TimeMS` (ms); a tlog its record timestamps.
    /// ROS 1 bags and MCAP:
    /// `@log_time` (the default) or a message path such as `/imu:header.stamp`
    /// (see [`rostopic`]).
    pub time_field: Option<String>,
    /// Factor from the time field's unit to seconds (`None`: 1 for CSV; 1e-6 for
    /// `TimeUS`, 1e-3 for `TimeMS`; for a tlog 1e-6 for the record timestamp or a field
    /// ending `_us`/`_usec`, 1e-3 for one ending `_ms`).
    pub time_scale: Option<f64>,
    /// Keep only these fields (`None`: all).
    pub only: Option<std::collections::BTreeSet<String>>,
}

impl ReadOptions {
    fn wants(&self, name: &str) -> bool {
        self.only.as_ref().is_none_or(|s| s.contains(name))
    }
}

/// Errors of reading a log or applying a map.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum LogError {
    /// The log cannot be read at all.
    #[error("{file}: {detail}")]
    Unreadable {
        /// The log's label.
        file: String,
        /// What is wrong.
        detail: String,
    },
    /// A map key has a bad value.
    #[error("{file}: key `{key}` = {value}: {detail}")]
    Map {
        /// The map file's label.
        file: String,
        /// The key (dotted path).
        key: String,
        /// The value as written.
        value: String,
        /// What is wrong and what is allowed.
        detail: String,
    },
    /// The map names a field the log lacks.
    #[error(
        "{file}: key `{key}` names field `{field}`, which the log {log} lacks; fields present: {}",
        present.join(", ")
    )]
    MissingField {
        /// The map file's label.
        file: String,
        /// The map key.
        key: String,
        /// The missing field.
        field: String,
        /// The log's label.
        log: String,
        /// The fields the log has.
        present: Vec<String>,
    },
}

/// Reads a log of the given (or detected) format.
pub fn read(
    bytes: &[u8],
    format: Option<Format>,
    label: &str,
    opts: &ReadOptions,
) -> Result<Log, LogError> {
    let format = match format.or_else(|| Format::detect(bytes)) {
        Some(f) => f,
        None => {
            return Err(LogError::Unreadable {
                file: label.into(),
                detail: format!(
                    "format not recognised from its first bytes; name it with the map's `format` key ({})",
                    Format::NAMES.join(" | ")
                ),
            });
        }
    };
    match format {
        Format::Csv => csv::read(bytes, label, opts),
        Format::DataFlash => dataflash::read(bytes, label, opts),
        Format::Tlog => tlog::read(bytes, label, opts),
        Format::Ros1 => ros1::read(bytes, label, opts),
        Format::Mcap => mcap_ros2::read(bytes, label, opts),
    }
}
