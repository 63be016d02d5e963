//! Topics of a ROS log (ROS 1 bag or MCAP) turned into fields: what both readers share.
//!
//! A field is `/topic:path` (`/imu:angular_velocity.z`, `/rc_out:channels[2]`). Its time is
//! chosen by the map's `[time] field`:
//! - `"@log_time"` (or `"/topic:@log_time"`; the default): when the recorder logged the
//!   message (MCAP's `log_time`, a ROS 1 bag's record time);
//! - a path, e.g. `"/imu:header.stamp"` (the topic part may be left out; it names no
//!   topic in particular): that field of every message whose type has it, a stamp read as
//!   seconds (sec + nanosec·1e-9). A topic whose type lacks the path (a `std_msgs/Float64`
//!   has no header) keeps its log time, and the read report says which topics did.
//!
//! Only fields the map names are decoded; a topic the map does not name is not decoded at
//! all. Each field keeps its own times; samples whose time does not increase are skipped
//! and counted, as in the other readers.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crate::rosmsg::{self, Key, Schema, Select, Wire};
use crate::{Log, ReadOptions, ReadReport, Series};

/// The time spelling for the recorder's log time.
pub const LOG_TIME: &str = "@log_time";

const TIME_SLOT: usize = usize::MAX;

/// How a connection's messages are serialized.
#[derive(Debug, Clone, PartialEq)]
pub enum Encoding {
    /// ROS 1 serialization.
    Ros1,
    /// CDR with its encapsulation header (ROS 2).
    Cdr,
    /// Something this crate does not decode (named).
    Other(String),
}

struct Topic {
    topic: String,
    type_name: String,
    /// `Err`: why its messages cannot be decoded.
    schema: Result<Schema, String>,
    encoding: Encoding,
    sel: Select,
    slots: Vec<String>,
    stamp: bool,
    wanted: bool,
}

/// Collects the fields of a ROS log's messages.
pub struct Collector {
    time_path: Option<String>,
    time_scale: f64,
    only: Option<BTreeSet<String>>,
    topics: HashMap<u32, Topic>,
    fields: BTreeMap<String, Series>,
    fallback: BTreeSet<String>,
    scratch: Vec<(usize, f64)>,
    /// What the reader met.
    pub report: ReadReport,
}

impl std::fmt::Debug for Collector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Collector")
            .field("topics", &self.topics.len())
            .finish_non_exhaustive()
    }
}

impl Collector {
    /// A collector for the reader options.
    pub fn new(opts: &ReadOptions) -> Self {
        let time_path = opts.time_field.as_deref().and_then(|f| {
            let p = f.rsplit_once(':').map_or(f, |(_, p)| p).trim();
            (p != LOG_TIME && !p.is_empty()).then(|| p.to_string())
        });
        Self {
            time_path,
            time_scale: opts.time_scale.unwrap_or(1.0),
            only: opts.only.clone(),
            topics: HashMap::new(),
            fields: BTreeMap::new(),
            fallback: BTreeSet::new(),
            scratch: Vec::new(),
            report: ReadReport::default(),
        }
    }

    /// Declares a connection (ROS 1) or channel (MCAP). A second declaration of the same id
    /// is ignored (ROS 1 bags repeat them in their index).
    pub fn connection(
        &mut self,
        id: u32,
        topic: &str,
        type_name: &str,
        definition: &str,
        encoding: Encoding,
    ) {
        if self.topics.contains_key(&id) {
            return;
        }
        let schema = match &encoding {
            Encoding::Other(e) => Err(format!("encoding {e}")),
            Encoding::Ros1 => Schema::parse_ros1(type_name, definition).map_err(|e| e.to_string()),
            Encoding::Cdr => Schema::parse(type_name, definition).map_err(|e| e.to_string()),
        };
        let mut sel = Select::default();
        let mut slots = Vec::new();
        let prefix = format!("{topic}:");
        let mut wanted = false;
        match &self.only {
            None => {
                sel = Select::all();
                wanted = true;
            }
            Some(only) => {
                for name in only.iter().filter(|n| n.starts_with(&prefix)) {
                    let path = name.get(prefix.len()..).unwrap_or("");
                    // A path has no `:` (field names are [A-Za-z0-9_]); this keeps
                    // `/a:b:c` from naming a field of topic `/a`.
                    if !path.contains(':') && sel.add(path, slots.len()) {
                        slots.push(name.clone());
                        wanted = true;
                    }
                }
            }
        }
        let stamp = match (&self.time_path, &schema) {
            (Some(p), Ok(s)) if s.has_path(p) => {
                if !sel.all {
                    sel.add(p, TIME_SLOT);
                }
                true
            }
            _ => false,
        };
        if wanted && self.time_path.is_some() && !stamp {
            self.fallback.insert(topic.to_string());
        }
        self.topics.insert(
            id,
            Topic {
                topic: topic.to_string(),
                type_name: type_name.to_string(),
                schema,
                encoding,
                sel,
                slots,
                stamp,
                wanted,
            },
        );
    }

    /// One message of connection `id`, logged at `log_time_ns`.
    pub fn message(&mut self, id: u32, log_time_ns: u64, data: &[u8]) {
        self.report.records += 1;
        let Some(t) = self.topics.get(&id) else {
            *self
                .report
                .unknown_types
                .entry(format!("(connection {id} never declared)"))
                .or_insert(0) += 1;
            return;
        };
        let schema = match &t.schema {
            Ok(s) => s,
            Err(why) => {
                *self
                    .report
                    .unknown_types
                    .entry(format!("{} ({why})", t.type_name))
                    .or_insert(0) += 1;
                return;
            }
        };
        if !t.wanted {
            return;
        }
        let (wire, body) = match t.encoding {
            Encoding::Ros1 => (Wire::Ros1, data),
            Encoding::Cdr => match rosmsg::cdr_body(data) {
                Ok(x) => x,
                Err(_) => {
                    self.report.bad_records += 1;
                    return;
                }
            },
            Encoding::Other(_) => return,
        };
        let log_t =
            (log_time_ns / 1_000_000_000) as f64 + (log_time_ns % 1_000_000_000) as f64 * 1e-9;
        self.scratch.clear();
        let mut named: Vec<(String, f64)> = Vec::new();
        let mut stamp_t = None;
        let scratch = &mut self.scratch;
        let time_path = self.time_path.as_deref();
        let all = t.sel.all;
        let r = rosmsg::decode(schema, wire, body, &t.sel, &mut |k, v| match k {
            Key::Slot(TIME_SLOT) => stamp_t = Some(v),
            Key::Slot(s) => scratch.push((s, v)),
            Key::Path(p) => {
                if all && Some(p) == time_path {
                    stamp_t = Some(v);
                }
                named.push((p.to_string(), v));
            }
        });
        if r.is_err() {
            self.report.bad_records += 1;
            return;
        }
        let time = if t.stamp { stamp_t } else { Some(log_t) };
        let Some(time) = time.map(|x| x * self.time_scale).filter(|x| x.is_finite()) else {
            self.report.untimed_records += 1;
            return;
        };
        // A NaN or infinite value is no sample (as an empty CSV cell).
        for (s, v) in self.scratch.iter().filter(|(_, v)| v.is_finite()) {
            if let Some(name) = t.slots.get(*s) {
                self.fields.entry(name.clone()).or_default().push(time, *v);
            }
        }
        for (p, v) in named.into_iter().filter(|(_, v)| v.is_finite()) {
            self.fields
                .entry(format!("{}:{p}", t.topic))
                .or_default()
                .push(time, v);
        }
    }

    /// The log: each field's samples with increasing times (others skipped and counted).
    pub fn finish(mut self) -> Log {
        let mut log = Log {
            report: std::mem::take(&mut self.report),
            ..Default::default()
        };
        if !self.fallback.is_empty() {
            let list: Vec<&str> = self.fallback.iter().map(String::as_str).collect();
            log.report.notes.push(format!(
                "topic(s) without `{}` timed by their log time: {}",
                self.time_path.as_deref().unwrap_or(""),
                list.join(", ")
            ));
        }
        for (name, s) in self.fields {
            let mut out = Series::default();
            let mut last = f64::NEG_INFINITY;
            for (t, v) in s.t_s.iter().zip(&s.v) {
                if *t > last {
                    out.push(*t, *v);
                    last = *t;
                } else {
                    log.report.non_increasing += 1;
                }
            }
            log.fields.insert(name, out);
        }
        log
    }
}
