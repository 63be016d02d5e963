//! Reading messages: [`Messages`], a stream in time order (or file order) over the chunks
//! a read needs.
//!
//! * Only chunks that hold a wanted channel and overlap the wanted time range are read
//!   (the index says which), each decompressed once when the stream reaches it.
//! * Memory is a few chunks: a stream of more than a megabyte of chunks decodes ahead on a
//!   worker thread through a bounded queue ([`PREFETCH`] chunks), and chunks whose time
//!   ranges overlap are merged (equal times keep file order).
//! * A chunk that turns out bad (CRC, decompression, framing, a message on an undefined
//!   channel) ends the stream after the messages of the good chunks already open;
//!   [`Messages::damage`] says where, and the session remembers it
//!   ([`crate::Session::damage`]). Nothing after it is returned and nothing is skipped
//!   silently.
//! * [`Messages::report`] gives what a complete read learns beyond the index: messages out
//!   of time order in the file (sorted here), gaps in a topic.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, sync_channel};
use std::thread::JoinHandle;

use crate::chunk::{self, ChannelFilter, Decoded, Decompressors, Loc};
use crate::index::Kind;
use crate::io::read_vec;
use crate::message::{Damage, Message, Payload};
use crate::session::Inner;

/// Chunks decoded ahead of the reader.
pub const PREFETCH: usize = 4;

/// Reads of fewer compressed bytes than this decode on the reader's thread.
const WORKER_MIN_BYTES: u64 = 1 << 20;

/// What to read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadOptions {
    /// Topics to read (`None`: every topic).
    pub topics: Option<Vec<String>>,
    /// Earliest message time, ns (inclusive).
    pub start_ns: u64,
    /// Latest message time, ns (inclusive).
    pub end_ns: u64,
    /// File order instead of time order (what recovery copies).
    pub file_order: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            topics: None,
            start_ns: 0,
            end_ns: u64::MAX,
            file_order: false,
        }
    }
}

impl ReadOptions {
    /// Every message, in time order.
    pub fn all() -> Self {
        Self::default()
    }

    /// The messages of these topics, in time order.
    pub fn topics<S: AsRef<str>>(topics: &[S]) -> Self {
        Self {
            topics: Some(topics.iter().map(|t| t.as_ref().to_string()).collect()),
            ..Self::default()
        }
    }

    /// Restricts the read to `start_ns ..= end_ns`.
    pub fn between(mut self, start_ns: u64, end_ns: u64) -> Self {
        self.start_ns = start_ns;
        self.end_ns = end_ns;
        self
    }
}

/// What a read learned: messages returned, damage found, and warnings (messages out of
/// time order, gaps). Only a read of every message of a topic can see its gaps.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadReport {
    /// Messages returned.
    pub messages: u64,
    /// Damage found by the read, or found when the file was opened.
    pub damage: Option<Damage>,
    /// What loaded but looks wrong.
    pub warnings: Vec<String>,
}

type ChunkResult = (u32, Result<Decoded, String>);

/// Where decoded chunks come from: decoded on demand, or by a worker thread ahead.
enum Supply {
    Inline {
        dec: Decompressors,
    },
    Worker {
        rx: Receiver<ChunkResult>,
        join: Option<JoinHandle<()>>,
    },
    Done,
}

/// A decoded chunk being read.
struct Open {
    offset: u64,
    d: Decoded,
    cursor: usize,
}

impl Open {
    fn head(&self) -> Option<&Loc> {
        self.d.locs.get(self.cursor)
    }
}

/// A stream of messages; see the module docs.
pub struct Messages {
    inner: Arc<Inner>,
    filter: ChannelFilter,
    opts: ReadOptions,
    /// Chunks to read, in order.
    plan: Vec<u32>,
    /// Next plan entry to take from the supply.
    next: usize,
    supply: Supply,
    open: Vec<Open>,
    yielded: u64,
    damage: Option<Damage>,
    stats: ReadStats,
}

impl std::fmt::Debug for Messages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("opts", &self.opts)
            .field("chunks", &self.plan.len())
            .field("next", &self.next)
            .field("yielded", &self.yielded)
            .field("damage", &self.damage)
            .finish_non_exhaustive()
    }
}

/// Decodes one chunk of the plan.
pub(crate) fn decode_chunk_at(
    inner: &Inner,
    ci: u32,
    filter: &ChannelFilter,
    time_order: bool,
    dec: &mut Decompressors,
) -> Result<Decoded, String> {
    let c = inner.index.chunks.get(ci as usize).ok_or("no such chunk")?;
    let bytes = read_vec(inner.src.as_ref(), c.offset, c.len)
        .map_err(|e| format!("read failed: {e}"))?
        .ok_or("the index points past the end of the file")?;
    let mut d = match c.kind {
        Kind::Chunk => chunk::decode_chunk_record(bytes, filter, false, dec)?,
        Kind::Loose => chunk::decode_loose_run(bytes, filter)?,
    };
    if let Some(l) = d
        .locs
        .iter()
        .find(|l| inner.index.topic_of_channel(l.channel_id).is_none())
    {
        return Err(format!("message on undefined channel {}", l.channel_id));
    }
    // What the index says about a chunk decides which reads open it and when: a chunk
    // whose messages fall outside its indexed time range, or on a channel its index does
    // not list, would be returned out of order or missed, so it is damage.
    if let Some((a, b)) = d.span_ns
        && (a < c.start_ns || b > c.end_ns)
    {
        return Err(format!(
            "the chunk's messages span {a}..{b} ns but its index says {}..{} ns",
            c.start_ns, c.end_ns
        ));
    }
    let listed = inner.index.channels_of(c);
    if let Some((id, _)) = d.per_channel.iter().find(|(id, _)| !listed.contains(id)) {
        return Err(format!(
            "the chunk holds messages on channel {id}, which its index does not list"
        ));
    }
    if time_order {
        d.sort_by_time();
    }
    Ok(d)
}

impl Messages {
    pub(crate) fn new(inner: Arc<Inner>, opts: ReadOptions) -> Self {
        let filter = match &opts.topics {
            None => ChannelFilter::ALL,
            Some(names) => ChannelFilter::only(
                names
                    .iter()
                    .flat_map(|n| inner.index.channels_of_topic(n))
                    .collect(),
            ),
        };
        let ix = &inner.index;
        let order: Box<dyn Iterator<Item = u32>> = if opts.file_order {
            Box::new(0..ix.chunks.len() as u32)
        } else {
            Box::new(ix.by_time.iter().copied())
        };
        let no_topics = matches!(&opts.topics, Some(t) if t.is_empty());
        let plan: Vec<u32> = order
            .filter(|&i| {
                ix.chunks.get(i as usize).is_some_and(|c| {
                    c.messages != Some(0)
                        && c.end_ns >= opts.start_ns
                        && c.start_ns <= opts.end_ns
                        && filter.wants_any(ix.channels_of(c))
                })
            })
            .filter(|_| !no_topics && opts.start_ns <= opts.end_ns)
            .collect();
        // A worker thread pays off only for reads of more than a few chunks' worth.
        let planned_bytes: u64 = plan
            .iter()
            .filter_map(|&i| ix.chunks.get(i as usize))
            .map(|c| c.len)
            .sum();
        let supply = if plan.len() > 2 && planned_bytes > WORKER_MIN_BYTES {
            spawn_worker(
                Arc::clone(&inner),
                plan.clone(),
                filter.clone(),
                !opts.file_order,
            )
        } else {
            Supply::Inline {
                dec: Decompressors::default(),
            }
        };
        Self {
            inner,
            filter,
            opts,
            plan,
            next: 0,
            supply,
            open: Vec::new(),
            yielded: 0,
            damage: None,
            stats: ReadStats::default(),
        }
    }

    /// Damage this read found (it stopped there).
    pub fn damage(&self) -> Option<&Damage> {
        self.damage.as_ref()
    }

    /// Messages returned so far.
    pub fn count(&self) -> u64 {
        self.yielded
    }

    /// What the read learned so far (complete once the stream has ended).
    pub fn report(&self) -> ReadReport {
        let warnings = self.stats.warnings();
        ReadReport {
            messages: self.yielded,
            damage: self
                .damage
                .clone()
                .or_else(|| self.inner.open_damage.clone()),
            warnings,
        }
    }

    /// Claimed start time of the next chunk to open.
    fn next_start(&self) -> Option<u64> {
        if matches!(self.supply, Supply::Done) {
            return None;
        }
        let ci = *self.plan.get(self.next)?;
        self.inner.index.chunks.get(ci as usize).map(|c| c.start_ns)
    }

    /// Takes the next chunk of the plan; false at the end or on damage.
    fn load_next(&mut self) -> bool {
        let Some(&ci) = self.plan.get(self.next) else {
            self.supply = Supply::Done;
            return false;
        };
        let res = match &mut self.supply {
            Supply::Done => return false,
            Supply::Inline { dec } => Some((
                ci,
                decode_chunk_at(&self.inner, ci, &self.filter, !self.opts.file_order, dec),
            )),
            Supply::Worker { rx, .. } => rx.recv().ok(),
        };
        self.next += 1;
        let offset = self
            .inner
            .index
            .chunks
            .get(ci as usize)
            .map_or(0, |c| c.offset);
        match res {
            Some((got, Ok(d))) if got == ci => {
                self.stats.chunk(&d);
                if !d.locs.is_empty() {
                    self.open.push(Open {
                        offset,
                        d,
                        cursor: 0,
                    });
                }
                true
            }
            Some((_, Err(detail))) => {
                self.fail(offset, detail);
                false
            }
            _ => {
                self.fail(offset, "the chunk decoder stopped".into());
                false
            }
        }
    }

    fn fail(&mut self, at_byte: u64, detail: String) {
        let d = Damage::Corrupt {
            at_byte,
            detail,
            messages_recovered: self.yielded,
        };
        self.inner.note_damage(&d);
        self.damage = Some(d);
        self.supply = Supply::Done;
    }

    /// The open chunk holding the next message (time order: earliest, then lowest offset).
    fn pick(&self) -> Option<usize> {
        if self.opts.file_order {
            return self.open.iter().position(|o| o.head().is_some());
        }
        self.open
            .iter()
            .enumerate()
            .filter_map(|(i, o)| o.head().map(|l| (l.t_ns, o.offset, i)))
            .min()
            .map(|(_, _, i)| i)
    }

    fn make(&self, o: &Open, l: &Loc) -> Option<Message> {
        let topic = Arc::clone(self.inner.index.topic_of_channel(l.channel_id)?);
        Some(Message {
            t_ns: l.t_ns,
            sequence: l.sequence,
            channel_id: l.channel_id,
            topic,
            data: Payload::new(Arc::clone(&o.d.buf), l.start as usize, l.len as usize),
        })
    }
}

impl Iterator for Messages {
    type Item = Message;

    fn next(&mut self) -> Option<Message> {
        loop {
            // Open every chunk that may hold a message before the earliest one open.
            while let Some(start) = self.next_start() {
                let head = self
                    .pick()
                    .and_then(|i| self.open.get(i))
                    .and_then(|o| o.head());
                let need = match head {
                    None => true,
                    Some(h) => !self.opts.file_order && start <= h.t_ns,
                };
                if !need || !self.load_next() {
                    break;
                }
            }
            let i = self.pick()?;
            let o = self.open.get_mut(i)?;
            let l = *o.head()?;
            o.cursor += 1;
            let msg = self.open.get(i).and_then(|o| self.make(o, &l));
            if self.open.get(i).is_some_and(|o| o.head().is_none()) {
                self.open.swap_remove(i);
            }
            if l.t_ns < self.opts.start_ns || l.t_ns > self.opts.end_ns {
                continue;
            }
            let msg = msg?;
            self.yielded += 1;
            self.stats.message(&msg);
            return Some(msg);
        }
    }
}

impl Drop for Messages {
    fn drop(&mut self) {
        // Dropping the receiver first stops the worker at its next send.
        if let Supply::Worker { rx, join } = std::mem::replace(&mut self.supply, Supply::Done) {
            drop(rx);
            if let Some(j) = join {
                let _ = j.join();
            }
        }
    }
}

fn spawn_worker(
    inner: Arc<Inner>,
    plan: Vec<u32>,
    filter: ChannelFilter,
    time_order: bool,
) -> Supply {
    let (tx, rx) = sync_channel::<ChunkResult>(PREFETCH);
    let spawned = std::thread::Builder::new()
        .name("session-read".into())
        .spawn(move || {
            let mut dec = Decompressors::default();
            for ci in plan {
                let r = decode_chunk_at(&inner, ci, &filter, time_order, &mut dec);
                let stop = r.is_err();
                if tx.send((ci, r)).is_err() || stop {
                    break;
                }
            }
        });
    match spawned {
        Ok(join) => Supply::Worker {
            rx,
            join: Some(join),
        },
        // No thread to spare: decode on the reader's thread.
        Err(_) => Supply::Inline {
            dec: Decompressors::default(),
        },
    }
}

/// Log-spaced bins per octave of the interval histogram (median to within ~4 %).
const BINS_PER_OCTAVE: f64 = 8.0;
/// Intervals above this are gap candidates, ns.
const GAP_FLOOR_NS: u64 = 1_000_000_000;
/// At most this many gap candidates are kept per topic (the count stays exact).
const MAX_GAP_CANDIDATES: usize = 4096;

/// Per-topic interval statistics of a read.
#[derive(Debug, Default, Clone)]
struct TopicStats {
    count: u64,
    last_t: Option<u64>,
    hist: Vec<u64>,
    /// (interval, time before it) of intervals > 1 s.
    candidates: Vec<(u64, u64)>,
    over_floor: u64,
}

/// What a read counts for its report.
#[derive(Debug, Default)]
struct ReadStats {
    /// By topic name (few topics: a small map).
    topics: Vec<(String, TopicStats)>,
    inversions: u64,
    worst_inversion_ns: u64,
}

impl ReadStats {
    fn chunk(&mut self, d: &Decoded) {
        self.inversions += d.inversions;
        self.worst_inversion_ns = self.worst_inversion_ns.max(d.worst_inversion_ns);
    }

    fn message(&mut self, m: &Message) {
        let name = m.topic();
        let ts = match self.topics.iter_mut().position(|(n, _)| n == name) {
            Some(i) => self.topics.get_mut(i).map(|(_, s)| s),
            None => {
                self.topics.push((name.to_string(), TopicStats::default()));
                self.topics.last_mut().map(|(_, s)| s)
            }
        };
        let Some(ts) = ts else {
            return;
        };
        ts.count += 1;
        if let Some(p) = ts.last_t {
            let dt = m.t_ns.saturating_sub(p);
            let bin = ((dt as f64 + 1.0).log2() * BINS_PER_OCTAVE) as usize;
            if ts.hist.len() <= bin {
                ts.hist.resize(bin + 1, 0);
            }
            if let Some(h) = ts.hist.get_mut(bin) {
                *h += 1;
            }
            if dt > GAP_FLOOR_NS {
                ts.over_floor += 1;
                if ts.candidates.len() < MAX_GAP_CANDIDATES {
                    ts.candidates.push((dt, p));
                }
            }
        }
        ts.last_t = Some(m.t_ns);
    }

    fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.inversions > 0 {
            out.push(format!(
                "{} messages are earlier than the message before them in the file \
                 (by up to {:.3} s); messages sorted by time",
                self.inversions,
                self.worst_inversion_ns as f64 * 1e-9
            ));
        }
        let mut topics: Vec<&(String, TopicStats)> = self.topics.iter().collect();
        topics.sort_by(|a, b| a.0.cmp(&b.0));
        for (name, ts) in topics {
            // Gaps: an interval longer than 1 s and 10× the topic's median interval.
            if ts.count < 3 {
                continue;
            }
            let n: u64 = ts.hist.iter().sum();
            let mut acc = 0u64;
            let mut median = 0u64;
            for (b, &k) in ts.hist.iter().enumerate() {
                acc += k;
                if acc * 2 > n {
                    median = (2f64.powf((b as f64 + 0.5) / BINS_PER_OCTAVE) - 1.0) as u64;
                    break;
                }
            }
            let limit = median.saturating_mul(10).max(GAP_FLOOR_NS);
            let big: Vec<&(u64, u64)> =
                ts.candidates.iter().filter(|(dt, _)| *dt > limit).collect();
            if let Some(&&(longest, at)) = big.iter().max_by_key(|(dt, _)| *dt) {
                let more = if ts.over_floor as usize > ts.candidates.len() {
                    " (at least)"
                } else {
                    ""
                };
                out.push(format!(
                    "{name}: {}{more} gap(s) longer than {:.3} s; the longest is {:.3} s after t = {:.3} s",
                    big.len(),
                    limit as f64 * 1e-9,
                    longest as f64 * 1e-9,
                    at as f64 * 1e-9
                ));
            }
        }
        out
    }
}
