//! ArduPilot/ArduSub DataFlash logs (`.BIN`): a reader, and a small writer for test files.
//!
//! The format is self-describing. Every record is `A3 95`, a message type byte and a
//! payload whose layout an FMT record (type 128) declared earlier: the type, the record's
//! whole length, a 4-character name, a format string (one character per field) and the
//! comma-separated column names. Fields are little-endian; the format characters and the
//! scalings applied are those of ArduPilot's `LogStructure.h` (and of pymavlink's
//! `DFReader`, which the tests compare against): `b B h H i I q Q f d M` as they are, `g`
//! (IEEE half float), `c C e E` /100, `L` (latitude/longitude) /1e7; the text fields
//! `n N Z` and the array `a` are skipped (not numbers). `M` (flight mode) is read as
//! ArduPilot writes it, `uint8_t` (DFReader reads it as `int8`; modes are below 128).
//!
//! Each message's time is its `TimeUS` field (µs, or the field [`ReadOptions::time_field`]
//! names); a message without one is skipped and counted. A message with an instance column
//! `I` gives its fields twice: `MSG.Field` (every instance) and `MSG[i].Field` (instance
//! `i`, e.g. `BARO[1].Press`, ArduSub's external pressure sensor).
//!
//! Corruption: bytes that are not a record head are skipped and counted until the next
//! head; a record of a type no FMT declared is counted under `type N` and skipped the same
//! way; a record cut short by the end of the data ends the read, reported as truncated.

use std::collections::BTreeMap;

use crate::{Log, LogError, ReadOptions, Series};

/// First byte of every record.
pub const HEAD1: u8 = 0xA3;
/// Second byte of every record.
pub const HEAD2: u8 = 0x95;
/// Message type of the FMT record.
pub const FMT_TYPE: u8 = 128;
/// Length of an FMT record (head, type, then type, length, name 4, format 16, columns 64).
pub const FMT_LEN: usize = 89;

/// Size in bytes of one field of a format character, or `None` for an unknown character.
pub fn field_size(c: u8) -> Option<usize> {
    Some(match c {
        b'b' | b'B' | b'M' => 1,
        b'h' | b'H' | b'c' | b'C' | b'g' => 2,
        b'i' | b'I' | b'f' | b'e' | b'E' | b'L' | b'n' => 4,
        b'q' | b'Q' | b'd' => 8,
        b'N' => 16,
        b'Z' | b'a' => 64,
        _ => return None,
    })
}

/// An IEEE 754 half-precision float (binary16) as f64.
pub fn half_to_f64(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1F);
    let frac = f64::from(h & 0x03FF);
    sign * match exp {
        0 => frac * 2f64.powi(-24),
        31 if frac == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        e => (1.0 + frac / 1024.0) * 2f64.powi(e - 15),
    }
}

/// The nearest half-precision float to `x` (round to nearest, ties to even), for the
/// writer.
pub fn f64_to_half(x: f64) -> u16 {
    if x.is_nan() {
        return 0x7E00;
    }
    let sign: u16 = if x.is_sign_negative() { 0x8000 } else { 0 };
    let a = x.abs();
    if a >= 65520.0 {
        return sign | 0x7C00;
    }
    // Units of the last place: 2^-24 below 2^-14 (subnormals), else 2^(e-10).
    let e = if a < 2f64.powi(-14) {
        -14
    } else {
        a.log2().floor() as i32
    };
    let ulp = 2f64.powi(e - 10);
    let q = a / ulp;
    let mut m = q.round();
    if (q - q.trunc() - 0.5).abs() == 0.0 && m % 2.0 != 0.0 {
        m -= 1.0;
    }
    let v = m * ulp;
    // Re-derive the fields from the rounded value (rounding may carry into the exponent).
    if v < 2f64.powi(-14) {
        return sign | (v / 2f64.powi(-24)) as u16;
    }
    if v >= 65520.0 {
        return sign | 0x7C00;
    }
    let e = v.log2().floor() as i32;
    let frac = (v / 2f64.powi(e) - 1.0) * 1024.0;
    sign | (((e + 15) as u16) << 10) | (frac as u16)
}

/// Decodes one numeric field (`None` for text and arrays, or too few bytes).
pub fn decode_field(c: u8, b: &[u8]) -> Option<f64> {
    fn arr<const N: usize>(b: &[u8]) -> Option<[u8; N]> {
        b.get(..N)?.try_into().ok()
    }
    Some(match c {
        b'b' => i8::from_le_bytes(arr(b)?) as f64,
        b'B' | b'M' => u8::from_le_bytes(arr(b)?) as f64,
        b'h' => i16::from_le_bytes(arr(b)?) as f64,
        b'H' => u16::from_le_bytes(arr(b)?) as f64,
        // Scaled types divide by 100 or 1e7 (exact divisors, one rounding), as DFReader
        // does: multiplying by 0.01 would round twice and differ in the last bit.
        b'c' => i16::from_le_bytes(arr(b)?) as f64 / 100.0,
        b'C' => u16::from_le_bytes(arr(b)?) as f64 / 100.0,
        b'g' => half_to_f64(u16::from_le_bytes(arr(b)?)),
        b'i' => i32::from_le_bytes(arr(b)?) as f64,
        b'I' => u32::from_le_bytes(arr(b)?) as f64,
        b'e' => i32::from_le_bytes(arr(b)?) as f64 / 100.0,
        b'E' => u32::from_le_bytes(arr(b)?) as f64 / 100.0,
        b'L' => i32::from_le_bytes(arr(b)?) as f64 / 1e7,
        b'f' => f32::from_le_bytes(arr(b)?) as f64,
        b'd' => f64::from_le_bytes(arr(b)?),
        b'q' => i64::from_le_bytes(arr(b)?) as f64,
        b'Q' => u64::from_le_bytes(arr(b)?) as f64,
        _ => return None,
    })
}

/// A message type an FMT record declared.
#[derive(Debug, Clone, PartialEq)]
pub struct MsgFormat {
    /// Name (up to 4 characters).
    pub name: String,
    /// Whole record length, bytes (head and type included).
    pub length: usize,
    /// Format characters.
    pub format: Vec<u8>,
    /// Column names.
    pub columns: Vec<String>,
}

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|c| *c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(b.get(..end).unwrap_or(b))
        .trim()
        .to_string()
}

fn parse_fmt(p: &[u8]) -> Option<(u8, MsgFormat)> {
    let ty = *p.first()?;
    let length = *p.get(1)? as usize;
    let name = text(p.get(2..6)?);
    let format = text(p.get(6..22)?).into_bytes();
    let columns: Vec<String> = text(p.get(22..86)?)
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let body: usize = format
        .iter()
        .map(|c| field_size(*c))
        .sum::<Option<usize>>()?;
    if body + 3 != length || columns.len() != format.len() || name.is_empty() {
        return None;
    }
    Some((
        ty,
        MsgFormat {
            name,
            length,
            format,
            columns,
        },
    ))
}

/// Reads a DataFlash log.
pub fn read(bytes: &[u8], label: &str, opts: &ReadOptions) -> Result<Log, LogError> {
    let _ = label;
    let mut log = Log::default();
    let mut formats: BTreeMap<u8, MsgFormat> = BTreeMap::new();
    let time_name = opts
        .time_field
        .as_deref()
        .map(|f| f.rsplit('.').next().unwrap_or(f).to_string());
    let mut fields: BTreeMap<String, Series> = BTreeMap::new();
    let mut pos = 0usize;
    let n = bytes.len();
    while pos < n {
        if bytes.get(pos..pos + 2) != Some(&[HEAD1, HEAD2][..]) {
            if pos + 2 > n {
                log.report.truncated = Some(format!("{} stray byte(s) at the end", n - pos));
                break;
            }
            log.report.skipped_bytes += 1;
            pos += 1;
            continue;
        }
        let Some(&ty) = bytes.get(pos + 2) else {
            log.report.truncated = Some(format!("record head at byte {pos} without its type"));
            break;
        };
        if ty == FMT_TYPE {
            let Some(p) = bytes.get(pos + 3..pos + FMT_LEN) else {
                log.report.truncated = Some(format!(
                    "FMT record at byte {pos} cut short by the end of the data"
                ));
                break;
            };
            match parse_fmt(p) {
                Some((t, f)) => {
                    formats.insert(t, f);
                    log.report.records += 1;
                    pos += FMT_LEN;
                }
                None => {
                    log.report.bad_records += 1;
                    pos += 2;
                    log.report.skipped_bytes += 2;
                }
            }
            continue;
        }
        let Some(fmt) = formats.get(&ty) else {
            *log.report
                .unknown_types
                .entry(format!("type {ty}"))
                .or_insert(0) += 1;
            pos += 3;
            log.report.skipped_bytes += 3;
            continue;
        };
        let Some(p) = bytes.get(pos + 3..pos + fmt.length) else {
            log.report.truncated = Some(format!(
                "{} record at byte {pos} cut short by the end of the data ({} of {} bytes)",
                fmt.name,
                n - pos,
                fmt.length
            ));
            break;
        };
        log.report.records += 1;
        pos += fmt.length;
        // Decode the numeric fields.
        let mut off = 0usize;
        let mut vals: Vec<(&str, f64)> = Vec::with_capacity(fmt.format.len());
        for (c, col) in fmt.format.iter().zip(&fmt.columns) {
            let size = field_size(*c).unwrap_or(0);
            if let Some(v) = p.get(off..off + size).and_then(|b| decode_field(*c, b)) {
                vals.push((col.as_str(), v));
            }
            off += size;
        }
        let time = match &time_name {
            Some(tn) => vals.iter().find(|(c, _)| c == tn).map(|(_, v)| {
                *v * opts
                    .time_scale
                    .unwrap_or(if tn == "TimeMS" { 1e-3 } else { 1e-6 })
            }),
            None => vals
                .iter()
                .find(|(c, _)| *c == "TimeUS")
                .map(|(_, v)| v * opts.time_scale.unwrap_or(1e-6))
                .or_else(|| {
                    vals.iter()
                        .find(|(c, _)| *c == "TimeMS")
                        .map(|(_, v)| v * opts.time_scale.unwrap_or(1e-3))
                }),
        };
        let Some(t) = time.filter(|t| t.is_finite()) else {
            log.report.untimed_records += 1;
            continue;
        };
        let instance = vals.iter().find(|(c, _)| *c == "I").map(|(_, v)| *v as i64);
        for (col, v) in &vals {
            let plain = format!("{}.{col}", fmt.name);
            if opts.wants(&plain) {
                fields.entry(plain).or_default().push(t, *v);
            }
            if let Some(i) = instance {
                let inst = format!("{}[{i}].{col}", fmt.name);
                if opts.wants(&inst) {
                    fields.entry(inst).or_default().push(t, *v);
                }
            }
        }
    }
    // A field whose time steps back keeps its increasing samples only.
    for (name, s) in fields {
        let mut out = Series::default();
        let mut last = f64::NEG_INFINITY;
        for (t, v) in s.t_s.iter().zip(&s.v) {
            if *t > last {
                out.push(*t, *v);
                last = *t;
            } else if !name.contains('[') {
                log.report.non_increasing += 1;
            }
        }
        log.fields.insert(name, out);
    }
    Ok(log)
}

/// A small DataFlash writer, for making test logs (not a logger).
#[derive(Debug, Default)]
pub struct Writer {
    out: Vec<u8>,
    formats: BTreeMap<u8, MsgFormat>,
}

/// Errors of the test writer.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WriteError {
    /// A format is malformed (unknown character, too long, columns and format differ).
    #[error("message {0}: bad format")]
    BadFormat(String),
    /// A message of a type not declared, or with the wrong number of values.
    #[error("message type {0}: not declared or wrong number of values")]
    BadMessage(u8),
}

impl Writer {
    /// An empty log (the FMT record's own FMT is written first, as ArduPilot does).
    pub fn new() -> Self {
        let mut w = Self::default();
        // The FMT self-description cannot fail.
        let _ = w.declare(
            FMT_TYPE,
            "FMT",
            "BBnNZ",
            &["Type", "Length", "Name", "Format", "Columns"],
        );
        w
    }

    /// Declares a message type (writes its FMT record).
    pub fn declare(
        &mut self,
        ty: u8,
        name: &str,
        format: &str,
        columns: &[&str],
    ) -> Result<(), WriteError> {
        let body: Option<usize> = format.bytes().map(field_size).sum();
        let bad = || WriteError::BadFormat(name.to_string());
        let body = body.ok_or_else(bad)?;
        let cols = columns.join(",");
        if name.len() > 4 || format.len() > 16 || cols.len() > 64 || columns.len() != format.len() {
            return Err(bad());
        }
        let length = body + 3;
        let length_u8 = u8::try_from(length).map_err(|_| bad())?;
        self.out.extend([HEAD1, HEAD2, FMT_TYPE, ty, length_u8]);
        let pad = |s: &str, n: usize, out: &mut Vec<u8>| {
            let mut b = s.as_bytes().to_vec();
            b.resize(n, 0);
            out.extend(b);
        };
        pad(name, 4, &mut self.out);
        pad(format, 16, &mut self.out);
        pad(&cols, 64, &mut self.out);
        self.formats.insert(
            ty,
            MsgFormat {
                name: name.into(),
                length,
                format: format.as_bytes().to_vec(),
                columns: columns.iter().map(|s| s.to_string()).collect(),
            },
        );
        Ok(())
    }

    /// Writes one message; `values` in column order (text fields take a value too, written
    /// as an empty string). Scaled types take the scaled value (`c`: 12.34 → 1234).
    pub fn write(&mut self, ty: u8, values: &[f64]) -> Result<(), WriteError> {
        let fmt = self.formats.get(&ty).ok_or(WriteError::BadMessage(ty))?;
        if values.len() != fmt.format.len() {
            return Err(WriteError::BadMessage(ty));
        }
        self.out.extend([HEAD1, HEAD2, ty]);
        for (c, v) in fmt.format.iter().zip(values) {
            let r = |s: f64| (v / s).round();
            match c {
                b'b' => self.out.extend((*v as i8).to_le_bytes()),
                b'B' | b'M' => self.out.extend((*v as u8).to_le_bytes()),
                b'h' => self.out.extend((*v as i16).to_le_bytes()),
                b'H' => self.out.extend((*v as u16).to_le_bytes()),
                b'g' => self.out.extend(f64_to_half(*v).to_le_bytes()),
                b'c' => self.out.extend((r(0.01) as i16).to_le_bytes()),
                b'C' => self.out.extend((r(0.01) as u16).to_le_bytes()),
                b'i' => self.out.extend((*v as i32).to_le_bytes()),
                b'I' => self.out.extend((*v as u32).to_le_bytes()),
                b'e' => self.out.extend((r(0.01) as i32).to_le_bytes()),
                b'E' => self.out.extend((r(0.01) as u32).to_le_bytes()),
                b'L' => self.out.extend((r(1e-7) as i32).to_le_bytes()),
                b'f' => self.out.extend((*v as f32).to_le_bytes()),
                b'd' => self.out.extend(v.to_le_bytes()),
                b'q' => self.out.extend((*v as i64).to_le_bytes()),
                b'Q' => self.out.extend((*v as u64).to_le_bytes()),
                other => {
                    let size = field_size(*other).unwrap_or(0);
                    self.out.extend(std::iter::repeat_n(0u8, size));
                }
            }
        }
        Ok(())
    }

    /// The log's bytes.
    pub fn into_bytes(self) -> Vec<u8> {
        self.out
    }
}
