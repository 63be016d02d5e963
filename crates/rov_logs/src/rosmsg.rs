//! ROS message definitions (`.msg` text) and a schema-driven decoder for both wire forms:
//! ROS 1 serialization and the CDR of ROS 2. One parser and one walker serve the ROS 1 bag
//! reader and the MCAP reader.
//!
//! A definition is the message's own field lines, then each dependency after a line of
//! `=` signs and `MSG: pkg/Name` (ROS 1's `message_definition`, ROS 2's `ros2msg` schema
//! text alike). Field lines are `TYPE NAME` with `TYPE` a primitive or a message, and an
//! array suffix `[]`, `[N]` or `[<=N]`; `TYPE NAME=VALUE` is a constant (not on the wire);
//! ROS 2's default values (`TYPE NAME VALUE`) and bounded strings (`string<=N`) are read as
//! plain fields. A type name is looked up in full (`pkg/Name`, `pkg/msg/Name` the same),
//! then in the enclosing message's package, then by its last part; `Header` alone is
//! `std_msgs/Header`. `builtin_interfaces/Time` and `Duration` are known without being
//! listed.
//!
//! Why not the `cdr` crate the issue names: it decodes into Rust types fixed at compile
//! time (serde), while a log's types are known only from the schema it carries. Walking
//! the schema is the general path, and the same walk with ROS 1's rules (little-endian,
//! no alignment, `time` as two u32) reads ROS 1 bags.
//!
//! Field paths are `a.b[2].c`. A time (ROS 1 `time`/`duration`, ROS 2
//! `builtin_interfaces/Time`/`Duration`) is one number, seconds (sec + nanosec·1e-9);
//! `bool` is 0/1; strings are not numbers and are never fields.

use std::collections::BTreeMap;

/// A primitive type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prim {
    /// `bool` (one byte).
    Bool,
    /// `int8`.
    I8,
    /// `uint8`, `char`, `byte` in ROS 2 (an octet; in ROS 1 `byte` is `int8`).
    U8,
    /// `int16`.
    I16,
    /// `uint16`.
    U16,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `int64`.
    I64,
    /// `uint64`.
    U64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
    /// `string`.
    Str,
    /// ROS 1 `time` (u32 sec, u32 nsec).
    Time,
    /// ROS 1 `duration` (i32 sec, i32 nsec).
    Duration,
}

impl Prim {
    fn parse(s: &str, ros1: bool) -> Option<Self> {
        Some(match s {
            "byte" if ros1 => Self::I8,
            "bool" => Self::Bool,
            "int8" => Self::I8,
            "uint8" | "byte" | "char" | "octet" => Self::U8,
            "int16" => Self::I16,
            "uint16" => Self::U16,
            "int32" => Self::I32,
            "uint32" => Self::U32,
            "int64" => Self::I64,
            "uint64" => Self::U64,
            "float32" => Self::F32,
            "float64" => Self::F64,
            "string" => Self::Str,
            "time" => Self::Time,
            "duration" => Self::Duration,
            _ => return None,
        })
    }

    /// Size on the wire (strings: their length prefix).
    fn size(self) -> usize {
        match self {
            Self::Bool | Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 | Self::Str => 4,
            Self::I64 | Self::U64 | Self::F64 | Self::Time | Self::Duration => 8,
        }
    }
}

/// A field's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ty {
    /// A primitive.
    Prim(Prim),
    /// A message, by index into [`Schema::defs`].
    Msg(usize),
}

/// Array-ness of a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arr {
    /// One value.
    One,
    /// `[N]`: exactly N values, no length on the wire.
    Fixed(usize),
    /// `[]` or `[<=N]`: a u32 count, then the values.
    Seq,
}

/// One field of a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Name.
    pub name: String,
    /// Type.
    pub ty: Ty,
    /// Array-ness.
    pub arr: Arr,
}

/// One message type.
#[derive(Debug, Clone, PartialEq)]
pub struct MsgDef {
    /// Full name, `pkg/Name`.
    pub name: String,
    /// Fields in wire order.
    pub fields: Vec<Field>,
    /// A time (`builtin_interfaces/Time` or `Duration`): read as seconds.
    pub is_time: bool,
}

/// A message type with every type it uses; `defs[0]` is the message itself.
#[derive(Debug, Clone, PartialEq)]
pub struct Schema {
    /// Message types.
    pub defs: Vec<MsgDef>,
}

/// Why a definition or a message could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MsgError {
    /// The definition names a type it does not define.
    #[error("type `{0}` is not defined")]
    UnknownType(String),
    /// A field line does not parse.
    #[error("bad field line `{0}`")]
    BadLine(String),
    /// The message bytes end before the schema does, or a count exceeds them.
    #[error("message cut short or malformed at byte {0}")]
    Short(usize),
    /// Nesting deeper than [`MAX_DEPTH`] (a type that contains itself).
    #[error("message nesting deeper than {MAX_DEPTH}")]
    TooDeep,
    /// An encapsulation the decoder does not read.
    #[error("unsupported CDR encapsulation {0:#06x}")]
    Encapsulation(u16),
}

/// Deepest nesting the walker follows.
pub const MAX_DEPTH: usize = 32;

/// A decode-everything walk ([`Select::all`], used to list a log's fields) gives array
/// elements up to this index only, so an image's pixels do not become a million fields;
/// a path naming a later element is read like any other.
pub const ALL_MAX_ELEMENTS: usize = 16;

fn normalize(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').filter(|p| !p.is_empty()).collect();
    match parts.as_slice() {
        [pkg, "msg", n] => format!("{pkg}/{n}"),
        _ => parts.join("/"),
    }
}

fn short(name: &str) -> &str {
    name.rsplit('/').next().unwrap_or(name)
}

fn package(name: &str) -> Option<&str> {
    name.rsplit_once('/').map(|(p, _)| p)
}

struct RawDef {
    name: String,
    /// (type token, array, field name)
    fields: Vec<(String, Arr, String)>,
}

fn parse_lines(name: String, text: &str) -> Result<RawDef, MsgError> {
    let mut fields = Vec::new();
    for line in text.lines() {
        let line = match line.find('#') {
            Some(i) => line.get(..i).unwrap_or(""),
            None => line,
        }
        .trim();
        if line.is_empty() {
            continue;
        }
        let Some((ty, rest)) = line.split_once(char::is_whitespace) else {
            return Err(MsgError::BadLine(line.into()));
        };
        let rest = rest.trim_start();
        let name_end = rest
            .find(|c: char| c.is_whitespace() || c == '=')
            .unwrap_or(rest.len());
        let (fname, after) = rest.split_at(name_end);
        if after.trim_start().starts_with('=') {
            continue; // a constant
        }
        if fname.is_empty() || !fname.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(MsgError::BadLine(line.into()));
        }
        let (base, arr) = match ty.split_once('[') {
            Some((b, a)) => {
                let inner = a.trim_end_matches(']').trim();
                let arr = if inner.is_empty() || inner.starts_with("<=") {
                    Arr::Seq
                } else {
                    Arr::Fixed(inner.parse().map_err(|_| MsgError::BadLine(line.into()))?)
                };
                (b, arr)
            }
            None => (ty, Arr::One),
        };
        let base = base.split("<=").next().unwrap_or(base);
        fields.push((base.to_string(), arr, fname.to_string()));
    }
    Ok(RawDef { name, fields })
}

const BUILTIN_TIME: [(&str, &str); 2] = [
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"),
];

impl Schema {
    /// Parses a definition: `name` is the message's own type (`pkg/Name` or `pkg/msg/Name`),
    /// `text` its definition with dependencies; ROS 2's rules (`byte` unsigned).
    pub fn parse(name: &str, text: &str) -> Result<Self, MsgError> {
        Self::parse_with(name, text, false)
    }

    /// As [`Schema::parse`], with ROS 1's rules (`byte` is `int8`).
    pub fn parse_ros1(name: &str, text: &str) -> Result<Self, MsgError> {
        Self::parse_with(name, text, true)
    }

    fn parse_with(name: &str, text: &str, ros1: bool) -> Result<Self, MsgError> {
        let mut raws: Vec<RawDef> = Vec::new();
        let mut cur_name = normalize(name);
        let mut cur_text = String::new();
        let mut lines = text.lines().peekable();
        while let Some(line) = lines.next() {
            let t = line.trim();
            if t.len() >= 3 && t.chars().all(|c| c == '=') {
                raws.push(parse_lines(
                    std::mem::take(&mut cur_name),
                    &std::mem::take(&mut cur_text),
                )?);
                // The next non-empty line names the dependency.
                while let Some(l) = lines.peek() {
                    if l.trim().is_empty() {
                        lines.next();
                    } else {
                        break;
                    }
                }
                if let Some(l) = lines.next() {
                    let l = l.trim();
                    cur_name = normalize(l.strip_prefix("MSG:").unwrap_or(l).trim());
                }
                continue;
            }
            cur_text.push_str(line);
            cur_text.push('\n');
        }
        raws.push(parse_lines(cur_name, &cur_text)?);
        for (n, body) in BUILTIN_TIME {
            if !raws.iter().any(|r| r.name == n) {
                raws.push(parse_lines(n.into(), body)?);
            }
        }
        let mut defs: Vec<MsgDef> = raws
            .iter()
            .map(|r| MsgDef {
                name: r.name.clone(),
                fields: Vec::new(),
                is_time: BUILTIN_TIME.iter().any(|(n, _)| *n == r.name),
            })
            .collect();
        let find = |owner: &str, ty: &str| -> Option<usize> {
            let full = if ty == "Header" {
                "std_msgs/Header".to_string()
            } else {
                normalize(ty)
            };
            let by = |n: &str| raws.iter().position(|r| r.name == n);
            by(&full)
                .or_else(|| {
                    package(owner)
                        .filter(|_| !full.contains('/'))
                        .and_then(|p| by(&format!("{p}/{full}")))
                })
                .or_else(|| raws.iter().position(|r| short(&r.name) == short(&full)))
        };
        for (i, r) in raws.iter().enumerate() {
            let mut fields = Vec::with_capacity(r.fields.len());
            for (ty, arr, fname) in &r.fields {
                let t = match Prim::parse(ty, ros1) {
                    Some(p) => Ty::Prim(p),
                    None => {
                        Ty::Msg(find(&r.name, ty).ok_or_else(|| MsgError::UnknownType(ty.clone()))?)
                    }
                };
                fields.push(Field {
                    name: fname.clone(),
                    ty: t,
                    arr: *arr,
                });
            }
            if let Some(d) = defs.get_mut(i) {
                d.fields = fields;
            }
        }
        Ok(Self { defs })
    }

    /// Whether `path` (`a.b[2].c`) names something of this message: a numeric leaf, a time,
    /// or an element of an unbounded array of them (whose presence depends on the message).
    pub fn has_path(&self, path: &str) -> bool {
        let Some(segs) = parse_path(path) else {
            return false;
        };
        let mut def = 0usize;
        let mut it = segs.iter().peekable();
        while let Some(seg) = it.next() {
            let Seg::Name(n) = seg else {
                return false;
            };
            let Some(f) = self
                .defs
                .get(def)
                .and_then(|d| d.fields.iter().find(|f| f.name == *n))
            else {
                return false;
            };
            if f.arr != Arr::One {
                match it.next() {
                    Some(Seg::Index(i)) => {
                        if let Arr::Fixed(len) = f.arr
                            && *i >= len
                        {
                            return false;
                        }
                    }
                    _ => return false,
                }
            }
            match f.ty {
                Ty::Prim(Prim::Str) => return false,
                Ty::Prim(_) => return it.peek().is_none(),
                Ty::Msg(m) => {
                    if it.peek().is_none() {
                        return self.defs.get(m).is_some_and(|d| d.is_time);
                    }
                    def = m;
                }
            }
        }
        false
    }
}

/// One segment of a field path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Seg {
    /// A field name.
    Name(String),
    /// An array index.
    Index(usize),
}

/// Parses `a.b[2].c` (`None` when malformed).
pub fn parse_path(path: &str) -> Option<Vec<Seg>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => part.split_at(i),
            None => (part, ""),
        };
        if name.is_empty() {
            return None;
        }
        out.push(Seg::Name(name.to_string()));
        while !rest.is_empty() {
            let inner = rest.strip_prefix('[')?;
            let close = inner.find(']')?;
            out.push(Seg::Index(inner.get(..close)?.trim().parse().ok()?));
            rest = inner.get(close + 1..)?;
        }
    }
    (!out.is_empty()).then_some(out)
}

/// Which parts of a message to decode: a tree of wanted paths, each ending in an output
/// slot. `all` decodes every numeric leaf (its path given to the sink by name).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Select {
    /// Decode everything below.
    pub all: bool,
    /// The value here goes to these slots (a path may be both a field and the time).
    pub slots: Vec<usize>,
    names: BTreeMap<String, Select>,
    index: BTreeMap<usize, Select>,
}

impl Select {
    /// Everything.
    pub fn all() -> Self {
        Self {
            all: true,
            ..Default::default()
        }
    }

    /// Adds a wanted path with its output slot (`false` when the path is malformed).
    pub fn add(&mut self, path: &str, slot: usize) -> bool {
        let Some(segs) = parse_path(path) else {
            return false;
        };
        let mut node = self;
        for s in segs {
            node = match s {
                Seg::Name(n) => node.names.entry(n).or_default(),
                Seg::Index(i) => node.index.entry(i).or_default(),
            };
        }
        if !node.slots.contains(&slot) {
            node.slots.push(slot);
        }
        true
    }

    /// Whether nothing is selected.
    pub fn is_empty(&self) -> bool {
        !self.all && self.slots.is_empty() && self.names.is_empty() && self.index.is_empty()
    }
}

/// Where a decoded value goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Key<'a> {
    /// A selected path's slot.
    Slot(usize),
    /// A path, in a decode-everything walk.
    Path(&'a str),
}

/// The wire rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wire {
    /// ROS 1: little-endian, packed, strings without NUL, `time` as two 32-bit integers.
    Ros1,
    /// CDR (ROS 2): the given byte order; primitives aligned to their size up to `max_align`
    /// (8 in classic CDR, 4 in XCDR2), relative to the payload after the 4-byte header.
    Cdr {
        /// Little-endian.
        le: bool,
        /// Largest alignment.
        max_align: usize,
    },
}

struct Cursor<'b> {
    b: &'b [u8],
    pos: usize,
    wire: Wire,
}

impl Cursor<'_> {
    fn align(&mut self, n: usize) -> Result<(), MsgError> {
        if let Wire::Cdr { max_align, .. } = self.wire {
            let a = n.min(max_align).max(1);
            let p = self.pos.div_ceil(a) * a;
            if p > self.b.len() {
                return Err(MsgError::Short(self.pos));
            }
            self.pos = p;
        }
        Ok(())
    }

    fn take(&mut self, n: usize) -> Result<&[u8], MsgError> {
        let end = self.pos.checked_add(n).ok_or(MsgError::Short(self.pos))?;
        let s = self.b.get(self.pos..end).ok_or(MsgError::Short(self.pos))?;
        self.pos = end;
        Ok(s)
    }

    fn arr<const N: usize>(&mut self) -> Result<[u8; N], MsgError> {
        self.align(N)?;
        let at = self.pos;
        let s = self.take(N)?;
        let mut a: [u8; N] = s.try_into().map_err(|_| MsgError::Short(at))?;
        let le = match self.wire {
            Wire::Ros1 => true,
            Wire::Cdr { le, .. } => le,
        };
        if !le {
            a.reverse();
        }
        Ok(a)
    }

    fn u32(&mut self) -> Result<u32, MsgError> {
        Ok(u32::from_le_bytes(self.arr()?))
    }

    fn count(&mut self, elem_min: usize) -> Result<usize, MsgError> {
        let at = self.pos;
        let n = self.u32()? as usize;
        if n.saturating_mul(elem_min.max(1)) > self.b.len().saturating_sub(self.pos) {
            return Err(MsgError::Short(at));
        }
        Ok(n)
    }

    fn prim(&mut self, p: Prim) -> Result<Option<f64>, MsgError> {
        Ok(Some(match p {
            Prim::Bool | Prim::U8 => u8::from_le_bytes(self.arr()?) as f64,
            Prim::I8 => i8::from_le_bytes(self.arr()?) as f64,
            Prim::I16 => i16::from_le_bytes(self.arr()?) as f64,
            Prim::U16 => u16::from_le_bytes(self.arr()?) as f64,
            Prim::I32 => i32::from_le_bytes(self.arr()?) as f64,
            Prim::U32 => u32::from_le_bytes(self.arr()?) as f64,
            Prim::I64 => i64::from_le_bytes(self.arr()?) as f64,
            Prim::U64 => u64::from_le_bytes(self.arr()?) as f64,
            Prim::F32 => f32::from_le_bytes(self.arr()?) as f64,
            Prim::F64 => f64::from_le_bytes(self.arr()?),
            Prim::Time => {
                let s = u32::from_le_bytes(self.arr()?) as f64;
                let ns = u32::from_le_bytes(self.arr()?) as f64;
                s + ns * 1e-9
            }
            Prim::Duration => {
                let s = i32::from_le_bytes(self.arr()?) as f64;
                let ns = i32::from_le_bytes(self.arr()?) as f64;
                s + ns * 1e-9
            }
            Prim::Str => {
                let n = self.count(1)?;
                self.take(n)?;
                return Ok(None);
            }
        }))
    }

    fn skip_prims(&mut self, p: Prim, n: usize) -> Result<(), MsgError> {
        match p {
            Prim::Str => {
                for _ in 0..n {
                    self.prim(p)?;
                }
            }
            Prim::Time | Prim::Duration => {
                self.align(4)?;
                self.take(n.saturating_mul(8))?;
            }
            _ => {
                if n > 0 {
                    self.align(p.size())?;
                    self.take(n.saturating_mul(p.size()))?;
                }
            }
        }
        Ok(())
    }
}

/// Splits a CDR payload into its wire rules and the body after the 4-byte encapsulation
/// header (`00 00` big-endian, `00 01` little-endian, `00 06`/`00 07` XCDR2 plain).
pub fn cdr_body(payload: &[u8]) -> Result<(Wire, &[u8]), MsgError> {
    let (Some(h), Some(body)) = (payload.get(..2), payload.get(4..)) else {
        return Err(MsgError::Short(0));
    };
    let kind = u16::from_be_bytes([h[0], h[1]]);
    let wire = match kind {
        0x0000 => Wire::Cdr {
            le: false,
            max_align: 8,
        },
        0x0001 => Wire::Cdr {
            le: true,
            max_align: 8,
        },
        0x0006 => Wire::Cdr {
            le: false,
            max_align: 4,
        },
        0x0007 => Wire::Cdr {
            le: true,
            max_align: 4,
        },
        k => return Err(MsgError::Encapsulation(k)),
    };
    Ok((wire, body))
}

/// Decodes one message: each selected value (or, with [`Select::all`], every numeric
/// leaf) is given to `sink`. Unselected fields are skipped without being decoded.
pub fn decode(
    schema: &Schema,
    wire: Wire,
    body: &[u8],
    sel: &Select,
    sink: &mut dyn FnMut(Key<'_>, f64),
) -> Result<(), MsgError> {
    let mut c = Cursor {
        b: body,
        pos: 0,
        wire,
    };
    let mut path = String::new();
    walk_msg(schema, 0, &mut c, Some(sel), &mut path, sink, 0)
}

fn emit(sel: &Select, path: &str, v: f64, sink: &mut dyn FnMut(Key<'_>, f64)) {
    for s in &sel.slots {
        sink(Key::Slot(*s), v);
    }
    if sel.all {
        sink(Key::Path(path), v);
    }
}

fn walk_msg(
    schema: &Schema,
    def: usize,
    c: &mut Cursor<'_>,
    sel: Option<&Select>,
    path: &mut String,
    sink: &mut dyn FnMut(Key<'_>, f64),
    depth: usize,
) -> Result<(), MsgError> {
    if depth > MAX_DEPTH {
        return Err(MsgError::TooDeep);
    }
    let Some(d) = schema.defs.get(def) else {
        return Err(MsgError::UnknownType(format!("#{def}")));
    };
    if d.is_time {
        // builtin_interfaces/Time: int32 sec, uint32 nanosec, read as seconds.
        let s = i32::from_le_bytes(c.arr()?) as f64;
        let ns = u32::from_le_bytes(c.arr()?) as f64;
        if let Some(sel) = sel {
            emit(sel, path, s + ns * 1e-9, sink);
            let parts = [("sec", s), ("nanosec", ns)];
            for (n, v) in parts {
                if let Some(sub) = sel.names.get(n) {
                    emit(sub, path, v, sink);
                }
            }
        }
        return Ok(());
    }
    for f in &d.fields {
        let sub = sel.and_then(|s| if s.all { Some(s) } else { s.names.get(&f.name) });
        let len0 = path.len();
        if sub.is_some_and(|s| s.all) {
            if !path.is_empty() {
                path.push('.');
            }
            path.push_str(&f.name);
        }
        let r = walk_field(schema, f, c, sub, path, sink, depth);
        path.truncate(len0);
        r?;
    }
    Ok(())
}

fn walk_one(
    schema: &Schema,
    ty: Ty,
    c: &mut Cursor<'_>,
    sel: Option<&Select>,
    path: &mut String,
    sink: &mut dyn FnMut(Key<'_>, f64),
    depth: usize,
) -> Result<(), MsgError> {
    match ty {
        Ty::Prim(p) => {
            let v = c.prim(p)?;
            if let (Some(sel), Some(v)) = (sel, v) {
                emit(sel, path, v, sink);
            }
            Ok(())
        }
        Ty::Msg(m) => walk_msg(schema, m, c, sel, path, sink, depth + 1),
    }
}

fn min_size(schema: &Schema, ty: Ty) -> usize {
    match ty {
        Ty::Prim(p) => p.size(),
        Ty::Msg(m) => usize::from(schema.defs.get(m).is_some_and(|d| !d.fields.is_empty())),
    }
}

fn walk_field(
    schema: &Schema,
    f: &Field,
    c: &mut Cursor<'_>,
    sel: Option<&Select>,
    path: &mut String,
    sink: &mut dyn FnMut(Key<'_>, f64),
    depth: usize,
) -> Result<(), MsgError> {
    let n = match f.arr {
        Arr::One => return walk_one(schema, f.ty, c, sel, path, sink, depth),
        Arr::Fixed(n) => n,
        Arr::Seq => c.count(min_size(schema, f.ty))?,
    };
    let Some(sel) = sel else {
        // Not wanted: skip whole.
        return match f.ty {
            Ty::Prim(p) => c.skip_prims(p, n),
            Ty::Msg(_) => {
                for _ in 0..n {
                    walk_one(schema, f.ty, c, None, path, sink, depth)?;
                }
                Ok(())
            }
        };
    };
    if !sel.all && sel.index.is_empty() {
        return match f.ty {
            Ty::Prim(p) => c.skip_prims(p, n),
            Ty::Msg(_) => {
                for _ in 0..n {
                    walk_one(schema, f.ty, c, None, path, sink, depth)?;
                }
                Ok(())
            }
        };
    }
    for i in 0..n {
        let sub = if sel.all {
            (i < ALL_MAX_ELEMENTS).then_some(sel)
        } else {
            sel.index.get(&i)
        };
        let len0 = path.len();
        if sub.is_some() && sel.all {
            path.push_str(&format!("[{i}]"));
        }
        let r = walk_one(schema, f.ty, c, sub, path, sink, depth);
        path.truncate(len0);
        r?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect(s: &Schema, wire: Wire, body: &[u8], paths: &[&str]) -> Vec<Option<f64>> {
        let mut sel = Select::default();
        for (i, p) in paths.iter().enumerate() {
            assert!(sel.add(p, i));
        }
        let mut out = vec![None; paths.len()];
        decode(s, wire, body, &sel, &mut |k, v| {
            if let Key::Slot(i) = k {
                out[i] = Some(v);
            }
        })
        .unwrap();
        out
    }

    #[test]
    fn definitions_with_constants_defaults_bounds_and_dependencies() {
        let text = "# comment\nuint8 MODE_A=1\nuint8 MODE_B = 2 # two\nstring<=8 name \"x\"\n\
                    int32[<=4] small\nVec v\nfloat64 k 0.5\nstring S=a#b\n\
                    ===\nMSG: pkg/Vec\nfloat32 x\nfloat64 y\n";
        let s = Schema::parse("pkg/msg/Top", text).unwrap();
        let names: Vec<&str> = s.defs[0].fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["name", "small", "v", "k"]);
        assert_eq!(s.defs[0].fields[1].arr, Arr::Seq);
        assert!(s.has_path("v.y") && s.has_path("small[3]") && s.has_path("k"));
        assert!(!s.has_path("name") && !s.has_path("v.z") && !s.has_path("v"));
        assert!(matches!(
            Schema::parse("a/B", "c/D x\n"),
            Err(MsgError::UnknownType(_))
        ));
    }

    #[test]
    fn cdr_alignment_is_relative_to_the_body_and_xcdr2_aligns_8_byte_types_to_4() {
        let s = Schema::parse("p/M", "uint8 a\nfloat64 b\n").unwrap();
        // Classic CDR: a at 0, b at 8.
        let mut body = vec![7u8, 0, 0, 0, 0, 0, 0, 0];
        body.extend(2.5f64.to_le_bytes());
        let mut payload = vec![0, 1, 0, 0];
        payload.extend(&body);
        let (w, b) = cdr_body(&payload).unwrap();
        assert_eq!(collect(&s, w, b, &["a", "b"]), [Some(7.0), Some(2.5)]);
        // XCDR2 little-endian: b at 4.
        let mut payload = vec![0, 7, 0, 0, 7, 0, 0, 0];
        payload.extend(2.5f64.to_le_bytes());
        let (w, b) = cdr_body(&payload).unwrap();
        assert_eq!(collect(&s, w, b, &["b"]), [Some(2.5)]);
        // Big-endian.
        let mut payload = vec![0, 0, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        payload.extend(2.5f64.to_be_bytes());
        let (w, b) = cdr_body(&payload).unwrap();
        assert_eq!(collect(&s, w, b, &["b"]), [Some(2.5)]);
        assert!(matches!(
            cdr_body(&[0, 2, 0, 0]),
            Err(MsgError::Encapsulation(2))
        ));
    }

    #[test]
    fn hostile_counts_and_self_containing_types_are_errors_not_panics() {
        let s = Schema::parse("p/M", "float64[] d\n").unwrap();
        let body = [0xff, 0xff, 0xff, 0x7f, 1, 2];
        let sel = Select::all();
        assert!(decode(&s, Wire::Ros1, &body, &sel, &mut |_, _| {}).is_err());
        // A long array lists its first ALL_MAX_ELEMENTS elements in a full walk.
        let mut long = 40u32.to_le_bytes().to_vec();
        for k in 0..40 {
            long.extend((k as f64).to_le_bytes());
        }
        let mut names = Vec::new();
        decode(&s, Wire::Ros1, &long, &sel, &mut |k, _| {
            if let Key::Path(p) = k {
                names.push(p.to_string());
            }
        })
        .unwrap();
        assert_eq!(names.len(), ALL_MAX_ELEMENTS);
        assert_eq!(collect(&s, Wire::Ros1, &long, &["d[39]"]), [Some(39.0)]);
        let r = Schema::parse("p/A", "A inner\n").unwrap();
        assert_eq!(
            decode(&r, Wire::Ros1, &[], &sel, &mut |_, _| {}),
            Err(MsgError::TooDeep)
        );
        // `byte`: int8 in ROS 1, an octet in ROS 2.
        let b1 = Schema::parse_ros1("p/B", "byte x\n").unwrap();
        let b2 = Schema::parse("p/B", "byte x\n").unwrap();
        assert_eq!(collect(&b1, Wire::Ros1, &[0xff], &["x"]), [Some(-1.0)]);
        assert_eq!(collect(&b2, Wire::Ros1, &[0xff], &["x"]), [Some(255.0)]);
        // ROS 1 time and a packed layout.
        let t = Schema::parse("p/T", "time stamp\nuint16[2] c\n").unwrap();
        let mut b = 5u32.to_le_bytes().to_vec();
        b.extend(500_000_000u32.to_le_bytes());
        b.extend([1, 0, 2, 0]);
        assert_eq!(
            collect(&t, Wire::Ros1, &b, &["stamp", "c[1]"]),
            [Some(5.5), Some(2.0)]
        );
    }
}
