//! MAVLink telemetry logs (`.tlog`), as QGroundControl, Mission Planner and pymavlink's
//! `mavlogfile` write them: records of an 8-byte big-endian timestamp (µs since the UNIX
//! epoch, the ground station's clock when the frame arrived) followed by one MAVLink v1
//! (`FE`) or v2 (`FD`) frame. Frames are checked (CRC with the message's CRC-extra) and
//! decoded with the `mavlink` crate's generated ardupilotmega dialect (which includes
//! `common`), extension fields included.
//!
//! Fields are named `MESSAGE.field` with the MAVLink XML names (`ATTITUDE.roll`,
//! `SERVO_OUTPUT_RAW.servo3_raw`, `SCALED_PRESSURE2.press_abs`, `HEARTBEAT.type`); an
//! array field gives `MESSAGE.field[i]`. Values are as sent (radians, hPa, µs, …: the
//! map converts units). Enumeration fields (e.g. `HEARTBEAT.system_status`) and text are
//! not numeric series and are left out; bitmask fields (e.g. `HEARTBEAT.base_mode`) are
//! their integer value. Messages from every sender (system and component) are merged.
//!
//! Time, per message: by default (or with the map's `[time] field = "tlog.timestamp_us"`,
//! [`TIMESTAMP_FIELD`]) the record's timestamp, scaled by 1e-6 unless the map gives a
//! scale. A map may instead name a message field, e.g. `"ATTITUDE.time_boot_ms"`: then
//! every message's own field of that name (the part after the dot) is its time, scaled by
//! 1e-3 for a name ending `_ms`, 1e-6 for `_us`/`_usec`, otherwise 1 (or the map's
//! `scale`); a message without that field is skipped and counted as untimed. Each field
//! keeps its own timestamps; samples whose time does not increase are dropped and counted.
//!
//! Bad input: a frame whose CRC does not match is skipped and counted as a bad record; a
//! frame whose message id the dialect does not know (no CRC-extra, so it cannot be
//! checked) is skipped and counted under `msgid N`; a frame that decodes to an invalid
//! enumeration value is a bad record; bytes that do not start a record are skipped until
//! the next record whose frame checks, and counted; a record cut short by the end of the
//! data ends the read, reported as truncated. The reader walks the bytes once and keeps
//! only the samples of the fields it is asked for.

use std::collections::HashMap;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavlinkVersion, Message};

use crate::{Log, LogError, ReadOptions, Series};

/// The map's name for a record's own timestamp (µs since the UNIX epoch).
pub const TIMESTAMP_FIELD: &str = "tlog.timestamp_us";

/// Bytes of the record timestamp before each frame.
pub const TIMESTAMP_LEN: usize = 8;
/// Start byte of a MAVLink v1 frame.
pub const STX_V1: u8 = 0xFE;
/// Start byte of a MAVLink v2 frame.
pub const STX_V2: u8 = 0xFD;

/// A v1 frame's bytes around its payload: STX, len, seq, sys, comp, msgid; CRC.
const V1_OVERHEAD: usize = 6 + 2;
/// A v2 frame's bytes around its payload: STX, len, incompat, compat, seq, sys, comp,
/// msgid (3); CRC.
const V2_OVERHEAD: usize = 10 + 2;
/// A v2 signature's length (present when incompat flag bit 0 is set).
const V2_SIGNATURE: usize = 13;

/// What is at one byte offset of a tlog.
#[derive(Debug)]
enum At<'a> {
    /// A record whose frame checks: timestamp, version, message id, payload, length.
    Good {
        stamp_us: u64,
        version: MavlinkVersion,
        id: u32,
        payload: &'a [u8],
        len: usize,
    },
    /// A frame of a message id the dialect does not know.
    Unknown { id: u32, len: usize },
    /// A frame whose CRC does not match.
    BadCrc { len: usize },
    /// Not the start of a record (no frame start byte after 8 bytes).
    NotARecord,
    /// A record whose frame start byte is there but which the data ends inside.
    Short { have: usize, need: Option<usize> },
}

fn record_at(bytes: &[u8], pos: usize) -> At<'_> {
    let rest = bytes.get(pos..).unwrap_or_default();
    let short = |need: Option<usize>| At::Short {
        have: rest.len(),
        need,
    };
    let Some(&stx) = rest.get(TIMESTAMP_LEN) else {
        return short(None);
    };
    let frame = rest.get(TIMESTAMP_LEN..).unwrap_or_default();
    let (overhead, header) = match stx {
        STX_V1 => (V1_OVERHEAD, 6),
        STX_V2 => (V2_OVERHEAD, 10),
        _ => return At::NotARecord,
    };
    let Some(head) = frame.get(..header) else {
        return short(None);
    };
    let payload_len = head.get(1).copied().unwrap_or(0) as usize;
    let signed = stx == STX_V2 && head.get(2).is_some_and(|f| f & 0x01 != 0);
    let frame_len = payload_len + overhead + if signed { V2_SIGNATURE } else { 0 };
    let len = TIMESTAMP_LEN + frame_len;
    let Some(frame) = frame.get(..frame_len) else {
        return short(Some(len));
    };
    let (version, id) = if stx == STX_V1 {
        (
            MavlinkVersion::V1,
            u32::from(head.get(5).copied().unwrap_or(0)),
        )
    } else {
        let b = |i: usize| u32::from(head.get(i).copied().unwrap_or(0));
        (MavlinkVersion::V2, b(7) | (b(8) << 8) | (b(9) << 16))
    };
    if MavMessage::default_message_from_id(id).is_none() {
        return At::Unknown { id, len };
    }
    let crc_end = header + payload_len;
    let (Some(covered), Some(crc)) = (frame.get(1..crc_end), frame.get(crc_end..crc_end + 2))
    else {
        return At::BadCrc { len };
    };
    let sent = u16::from_le_bytes([
        crc.first().copied().unwrap_or(0),
        crc.get(1).copied().unwrap_or(0),
    ]);
    if mavlink::calculate_crc(covered, MavMessage::extra_crc(id)) != sent {
        return At::BadCrc { len };
    }
    let mut stamp = [0u8; TIMESTAMP_LEN];
    stamp.copy_from_slice(rest.get(..TIMESTAMP_LEN).unwrap_or(&[0; TIMESTAMP_LEN]));
    At::Good {
        stamp_us: u64::from_be_bytes(stamp),
        version,
        id,
        payload: frame.get(header..crc_end).unwrap_or_default(),
        len,
    }
}

/// Whether the bytes start like a tlog: a record whose frame checks, possibly after one
/// record of a message id the dialect does not know.
pub fn looks_like(bytes: &[u8]) -> bool {
    match record_at(bytes, 0) {
        At::Good { .. } => true,
        At::Unknown { len, .. } => matches!(record_at(bytes, len), At::Good { .. }),
        _ => false,
    }
}

/// How each message is timed.
enum Clock {
    /// The record timestamp times a scale.
    Record(f64),
    /// A message field of this name times a scale.
    Field(String, f64),
}

fn clock(opts: &ReadOptions) -> Clock {
    match opts.time_field.as_deref() {
        None => Clock::Record(opts.time_scale.unwrap_or(1e-6)),
        Some(f) if f == TIMESTAMP_FIELD => Clock::Record(opts.time_scale.unwrap_or(1e-6)),
        Some(f) => {
            let name = f.rsplit('.').next().unwrap_or(f).to_string();
            let scale = opts.time_scale.unwrap_or(if name.ends_with("_ms") {
                1e-3
            } else if name.ends_with("_us") || name.ends_with("_usec") {
                1e-6
            } else {
                1.0
            });
            Clock::Field(name, scale)
        }
    }
}

/// Reads a tlog.
pub fn read(bytes: &[u8], label: &str, opts: &ReadOptions) -> Result<Log, LogError> {
    let mut log = Log::default();
    let clock = clock(opts);
    let mut series: Vec<(String, Series)> = Vec::new();
    let mut slots: HashMap<(u32, &'static str, Option<usize>), Option<usize>> = HashMap::new();
    let mut values: Vec<Value> = Vec::with_capacity(64);
    let mut pos = 0usize;
    let n = bytes.len();
    while pos < n {
        match record_at(bytes, pos) {
            At::Good {
                stamp_us,
                version,
                id,
                payload,
                len,
            } => {
                pos += len;
                let msg = match MavMessage::parse(version, id, payload) {
                    Ok(m) => m,
                    Err(_) => {
                        log.report.bad_records += 1;
                        continue;
                    }
                };
                log.report.records += 1;
                values.clear();
                collect(&msg, &mut values);
                let t = match &clock {
                    Clock::Record(s) => Some(stamp_us as f64 * s),
                    Clock::Field(name, s) => values
                        .iter()
                        .find(|v| v.index.is_none() && field_name(v.field) == name)
                        .map(|v| v.v * s),
                };
                let Some(t) = t.filter(|t| t.is_finite()) else {
                    log.report.untimed_records += 1;
                    continue;
                };
                let msg_name = msg.message_name();
                for v in &values {
                    // Each (message, field, index) is named and looked up once.
                    let slot = *slots.entry((id, v.field, v.index)).or_insert_with(|| {
                        let name = match v.index {
                            None => format!("{msg_name}.{}", field_name(v.field)),
                            Some(i) => format!("{msg_name}.{}[{i}]", field_name(v.field)),
                        };
                        opts.wants(&name).then(|| {
                            series.push((name, Series::default()));
                            series.len() - 1
                        })
                    });
                    if let Some((_, s)) = slot.and_then(|k| series.get_mut(k)) {
                        s.push(t, v.v);
                    }
                }
            }
            At::Unknown { id, len } => {
                *log.report
                    .unknown_types
                    .entry(format!("msgid {id}"))
                    .or_insert(0) += 1;
                pos += len;
            }
            At::BadCrc { len } => {
                log.report.bad_records += 1;
                // A corrupted payload leaves the next record where the length says; a
                // corrupted length does not: then resynchronise byte by byte.
                if pos + len >= n || matches!(record_at(bytes, pos + len), At::Good { .. }) {
                    pos += len;
                } else {
                    pos = resync(bytes, pos + 1, &mut log);
                }
            }
            At::NotARecord => pos = resync(bytes, pos, &mut log),
            At::Short { have, need } => {
                log.report.truncated = Some(match need {
                    Some(need) => format!(
                        "record at byte {pos} cut short by the end of the data ({have} of {need} bytes)"
                    ),
                    None => format!("{have} byte(s) at the end, too few for a record"),
                });
                break;
            }
        }
    }
    if let Clock::Field(name, _) = &clock
        && log.report.records > 0
        && log.report.untimed_records == log.report.records
    {
        return Err(LogError::Unreadable {
            file: label.into(),
            detail: format!(
                "no message has the time field `{name}` (the map's [time] field); name a field of the messages read (e.g. `ATTITUDE.time_boot_ms`) or `{TIMESTAMP_FIELD}` for the record timestamps"
            ),
        });
    }
    // A field whose time steps back keeps its increasing samples only.
    for (name, s) in series {
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
    Ok(log)
}

/// The next offset at or after `from` where a record's frame checks (or the end of the
/// data, or a record the data ends inside), counting the bytes skipped.
fn resync(bytes: &[u8], from: usize, log: &mut Log) -> usize {
    let n = bytes.len();
    let mut p = from;
    while p < n {
        match record_at(bytes, p) {
            At::Good { .. } => break,
            // A last record cut short: let the main loop report it, unless its start byte
            // is just a corrupt byte among others (then it is skipped like them).
            At::Short { need: Some(_), .. } if p + TIMESTAMP_LEN < n => break,
            _ => p += 1,
        }
    }
    let p = p.min(n);
    log.report.skipped_bytes += p - from.min(p);
    p
}

/// The rust name of a field, back to its MAVLink XML name (`mavtype` is `type`).
fn field_name(rust: &str) -> &str {
    if rust == "mavtype" { "type" } else { rust }
}

/// One numeric value of a decoded message.
#[derive(Debug, Clone, Copy)]
struct Value {
    field: &'static str,
    index: Option<usize>,
    v: f64,
}

/// Every numeric field of a decoded message, in declaration order.
fn collect(msg: &MavMessage, out: &mut Vec<Value>) {
    // The collector never fails; an error would only lose this message's values.
    let _ = serde::Serialize::serialize(msg, fields::Top { out });
}

mod fields {
    //! A serde serializer that collects a decoded message's numeric fields by name: the
    //! generated messages serialize as a struct (the dialect's enum is internally tagged);
    //! each field is a number, a sequence of numbers (an array), a string (text: skipped)
    //! or a tagged unit enum (a struct with one string: skipped). Bitmasks serialize as
    //! their integer because the serializer says it is not human-readable.

    use serde::ser::{self, Serialize};

    use super::Value;

    /// The serializer's error (never produced by the collector itself).
    #[derive(Debug)]
    pub struct Error;

    impl std::fmt::Display for Error {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("not a MAVLink message")
        }
    }

    impl std::error::Error for Error {}

    impl ser::Error for Error {
        fn custom<T: std::fmt::Display>(_: T) -> Self {
            Error
        }
    }

    /// The message itself: only a struct is expected.
    pub struct Top<'a> {
        pub out: &'a mut Vec<Value>,
    }

    /// One field (or one element of an array field).
    struct Leaf<'a> {
        out: &'a mut Vec<Value>,
        field: &'static str,
        index: Option<usize>,
    }

    /// Compound values: the message's fields, an array's elements, or ignored.
    pub struct Compound<'a> {
        out: Option<&'a mut Vec<Value>>,
        field: &'static str,
        next: usize,
    }

    impl Compound<'_> {
        fn ignored() -> Self {
            Compound {
                out: None,
                field: "",
                next: 0,
            }
        }
    }

    macro_rules! skip_rest {
        () => {
            fn serialize_str(self, _: &str) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_char(self, _: char) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_bytes(self, _: &[u8]) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_none(self) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<(), Error> {
                v.serialize(self)
            }
            fn serialize_unit(self) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_unit_struct(self, _: &'static str) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_unit_variant(
                self,
                _: &'static str,
                _: u32,
                _: &'static str,
            ) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_newtype_struct<T: ?Sized + Serialize>(
                self,
                _: &'static str,
                v: &T,
            ) -> Result<(), Error> {
                v.serialize(self)
            }
            fn serialize_newtype_variant<T: ?Sized + Serialize>(
                self,
                _: &'static str,
                _: u32,
                _: &'static str,
                _: &T,
            ) -> Result<(), Error> {
                Ok(())
            }
            fn serialize_tuple_struct(
                self,
                _: &'static str,
                _: usize,
            ) -> Result<Compound<'a>, Error> {
                Ok(Compound::ignored())
            }
            fn serialize_tuple_variant(
                self,
                _: &'static str,
                _: u32,
                _: &'static str,
                _: usize,
            ) -> Result<Compound<'a>, Error> {
                Ok(Compound::ignored())
            }
            fn serialize_map(self, _: Option<usize>) -> Result<Compound<'a>, Error> {
                Ok(Compound::ignored())
            }
            fn serialize_struct_variant(
                self,
                _: &'static str,
                _: u32,
                _: &'static str,
                _: usize,
            ) -> Result<Compound<'a>, Error> {
                Ok(Compound::ignored())
            }
            fn is_human_readable(&self) -> bool {
                false
            }
        };
    }

    macro_rules! numbers {
        ($($name:ident: $t:ty),*) => {
            $(fn $name(self, v: $t) -> Result<(), Error> {
                self.number(v as f64)
            })*
        };
    }

    impl Top<'_> {
        fn number(self, _: f64) -> Result<(), Error> {
            Ok(())
        }
    }

    impl<'a> ser::Serializer for Top<'a> {
        type Ok = ();
        type Error = Error;
        type SerializeSeq = Compound<'a>;
        type SerializeTuple = Compound<'a>;
        type SerializeTupleStruct = Compound<'a>;
        type SerializeTupleVariant = Compound<'a>;
        type SerializeMap = Compound<'a>;
        type SerializeStruct = Compound<'a>;
        type SerializeStructVariant = Compound<'a>;

        numbers!(serialize_i8: i8, serialize_i16: i16, serialize_i32: i32, serialize_i64: i64,
            serialize_u8: u8, serialize_u16: u16, serialize_u32: u32, serialize_u64: u64,
            serialize_f32: f32, serialize_f64: f64);
        fn serialize_bool(self, v: bool) -> Result<(), Error> {
            self.number(f64::from(u8::from(v)))
        }
        skip_rest!();

        fn serialize_seq(self, _: Option<usize>) -> Result<Compound<'a>, Error> {
            Ok(Compound::ignored())
        }
        fn serialize_tuple(self, _: usize) -> Result<Compound<'a>, Error> {
            Ok(Compound::ignored())
        }
        fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Error> {
            Ok(Compound {
                out: Some(self.out),
                field: "",
                next: 0,
            })
        }
    }

    impl Leaf<'_> {
        fn number(self, v: f64) -> Result<(), Error> {
            self.out.push(Value {
                field: self.field,
                index: self.index,
                v,
            });
            Ok(())
        }
    }

    impl<'a> ser::Serializer for Leaf<'a> {
        type Ok = ();
        type Error = Error;
        type SerializeSeq = Compound<'a>;
        type SerializeTuple = Compound<'a>;
        type SerializeTupleStruct = Compound<'a>;
        type SerializeTupleVariant = Compound<'a>;
        type SerializeMap = Compound<'a>;
        type SerializeStruct = Compound<'a>;
        type SerializeStructVariant = Compound<'a>;

        numbers!(serialize_i8: i8, serialize_i16: i16, serialize_i32: i32, serialize_i64: i64,
            serialize_u8: u8, serialize_u16: u16, serialize_u32: u32, serialize_u64: u64,
            serialize_f32: f32, serialize_f64: f64);
        fn serialize_bool(self, v: bool) -> Result<(), Error> {
            self.number(f64::from(u8::from(v)))
        }
        skip_rest!();

        fn serialize_seq(self, _: Option<usize>) -> Result<Compound<'a>, Error> {
            self.array()
        }
        fn serialize_tuple(self, _: usize) -> Result<Compound<'a>, Error> {
            self.array()
        }
        // A tagged unit enum: its one field is the variant's name, not a number.
        fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Error> {
            Ok(Compound::ignored())
        }
    }

    impl<'a> Leaf<'a> {
        fn array(self) -> Result<Compound<'a>, Error> {
            // An array inside an array is not a MAVLink field: ignored.
            if self.index.is_some() {
                return Ok(Compound::ignored());
            }
            Ok(Compound {
                out: Some(self.out),
                field: self.field,
                next: 0,
            })
        }
    }

    impl Compound<'_> {
        fn element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Error> {
            let index = self.next;
            self.next += 1;
            match self.out.as_deref_mut() {
                Some(out) => v.serialize(Leaf {
                    out,
                    field: self.field,
                    index: Some(index),
                }),
                None => Ok(()),
            }
        }
    }

    impl ser::SerializeStruct for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: ?Sized + Serialize>(
            &mut self,
            key: &'static str,
            v: &T,
        ) -> Result<(), Error> {
            match self.out.as_deref_mut() {
                Some(out) => v.serialize(Leaf {
                    out,
                    field: key,
                    index: None,
                }),
                None => Ok(()),
            }
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeSeq for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Error> {
            self.element(v)
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeTuple for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Error> {
            self.element(v)
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeTupleStruct for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: ?Sized + Serialize>(&mut self, _: &T) -> Result<(), Error> {
            Ok(())
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeTupleVariant for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: ?Sized + Serialize>(&mut self, _: &T) -> Result<(), Error> {
            Ok(())
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeMap for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_key<T: ?Sized + Serialize>(&mut self, _: &T) -> Result<(), Error> {
            Ok(())
        }
        fn serialize_value<T: ?Sized + Serialize>(&mut self, _: &T) -> Result<(), Error> {
            Ok(())
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }

    impl ser::SerializeStructVariant for Compound<'_> {
        type Ok = ();
        type Error = Error;
        fn serialize_field<T: ?Sized + Serialize>(
            &mut self,
            _: &'static str,
            _: &T,
        ) -> Result<(), Error> {
            Ok(())
        }
        fn end(self) -> Result<(), Error> {
            Ok(())
        }
    }
}
