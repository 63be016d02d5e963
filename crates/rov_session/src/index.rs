//! What a session knows without reading its messages: the chunks (where, when, which
//! channels), the schemas and channels, and the per-topic counts.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use crate::message::{TopicInfo, TopicSummary};
use crate::record::Topic;
use crate::wire::{ChannelDef, SchemaDef};

/// A chunk record, or a run of top-level message records (other writers' unchunked files).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Chunk,
    Loose,
}

/// One unit of message data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChunkInfo {
    pub kind: Kind,
    /// First byte in the file (the chunk record's opcode).
    pub offset: u64,
    /// Bytes.
    pub len: u64,
    /// Earliest and latest message time, ns.
    pub start_ns: u64,
    pub end_ns: u64,
    /// Range of [`Index::chunk_channels`]: the channels with messages here.
    pub chans: (u32, u32),
    /// Messages, when known (a scan counts them; the summary does not say).
    pub messages: Option<u64>,
}

/// The index of a session; see the module docs.
#[derive(Debug, Default)]
pub(crate) struct Index {
    /// File order.
    pub chunks: Vec<ChunkInfo>,
    /// Chunk indices sorted by (start time, offset).
    pub by_time: Vec<u32>,
    /// Channel ids of every chunk, concatenated.
    pub chunk_channels: Vec<u16>,
    /// Message counts parallel to `chunk_channels` (scans only).
    pub chunk_channel_counts: Vec<u64>,
    pub schemas: BTreeMap<u16, SchemaDef>,
    pub channels: BTreeMap<u16, ChannelDef>,
    /// Topics by first appearance; several channels may share one.
    pub topics: Vec<Arc<TopicInfo>>,
    pub topic_by_name: HashMap<String, usize>,
    pub channel_topic: HashMap<u16, usize>,
    /// Messages per channel.
    pub channel_counts: BTreeMap<u16, u64>,
    /// Earliest and latest message time.
    pub span_ns: Option<(u64, u64)>,
}

impl Index {
    pub(crate) fn channels_of(&self, c: &ChunkInfo) -> &[u16] {
        self.chunk_channels
            .get(c.chans.0 as usize..c.chans.1 as usize)
            .unwrap_or(&[])
    }

    /// Appends a chunk with its channels (and their counts, for a scan).
    pub(crate) fn push_chunk(&mut self, mut c: ChunkInfo, channels: &[(u16, Option<u64>)]) {
        let a = self.chunk_channels.len() as u32;
        for (id, n) in channels {
            self.chunk_channels.push(*id);
            if let Some(n) = n {
                self.chunk_channel_counts.push(*n);
            }
        }
        c.chans = (a, self.chunk_channels.len() as u32);
        self.chunks.push(c);
    }

    /// Registers a channel (its topic created on first use). A channel id seen before with
    /// a different definition keeps the first one; returns whether that happened.
    pub(crate) fn add_channel(&mut self, c: ChannelDef) -> bool {
        if let Some(old) = self.channels.get(&c.id) {
            return *old != c;
        }
        let topic = match self.topic_by_name.get(&c.topic) {
            Some(&i) => i,
            None => {
                let known = Topic::from_name(&c.topic).filter(|t| t.encoding() == c.encoding);
                let schema_name = self.schemas.get(&c.schema_id).map(|s| s.name.clone());
                self.topics.push(Arc::new(TopicInfo {
                    name: c.topic.clone(),
                    encoding: c.encoding.clone(),
                    schema_name,
                    known,
                }));
                let i = self.topics.len() - 1;
                self.topic_by_name.insert(c.topic.clone(), i);
                i
            }
        };
        self.channel_topic.insert(c.id, topic);
        self.channels.insert(c.id, c);
        false
    }

    /// Registers a schema; a redefinition keeps the first one and returns true.
    pub(crate) fn add_schema(&mut self, s: SchemaDef) -> bool {
        match self.schemas.get(&s.id) {
            Some(old) => *old != s,
            None => {
                self.schemas.insert(s.id, s);
                false
            }
        }
    }

    pub(crate) fn topic_of_channel(&self, id: u16) -> Option<&Arc<TopicInfo>> {
        self.channel_topic
            .get(&id)
            .and_then(|&i| self.topics.get(i))
    }

    /// Channel ids of a topic.
    pub(crate) fn channels_of_topic(&self, name: &str) -> Vec<u16> {
        match self.topic_by_name.get(name) {
            Some(&t) => self
                .channel_topic
                .iter()
                .filter(|(_, i)| **i == t)
                .map(|(&c, _)| c)
                .collect(),
            None => Vec::new(),
        }
    }

    /// Sorts the time order and computes the time span.
    pub(crate) fn finish(&mut self) {
        let mut order: Vec<u32> = (0..self.chunks.len() as u32).collect();
        order.sort_by_key(|&i| {
            self.chunks
                .get(i as usize)
                .map_or((u64::MAX, u64::MAX), |c| (c.start_ns, c.offset))
        });
        self.by_time = order;
    }

    /// Messages of a topic.
    pub(crate) fn topic_count(&self, topic: usize) -> u64 {
        self.channel_topic
            .iter()
            .filter(|(_, t)| **t == topic)
            .map(|(c, _)| self.channel_counts.get(c).copied().unwrap_or(0))
            .sum()
    }

    /// The topic summaries, sorted by name. First and last times come from the chunks that
    /// hold the topic (exact for a scanned file; chunk bounds for an indexed one).
    pub(crate) fn topic_summaries(&self) -> Vec<TopicSummary> {
        let mut first = vec![u64::MAX; self.topics.len()];
        let mut last = vec![0u64; self.topics.len()];
        for c in &self.chunks {
            for id in self.channels_of(c) {
                if let Some(&t) = self.channel_topic.get(id) {
                    if let Some(f) = first.get_mut(t) {
                        *f = (*f).min(c.start_ns);
                    }
                    if let Some(l) = last.get_mut(t) {
                        *l = (*l).max(c.end_ns);
                    }
                }
            }
        }
        let mut out: Vec<TopicSummary> = self
            .topics
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let count = self.topic_count(i);
                let f = first.get(i).copied().unwrap_or(u64::MAX);
                TopicSummary {
                    topic: t.name.clone(),
                    encoding: t.encoding.clone(),
                    schema_name: t.schema_name.clone(),
                    known: t.known,
                    count: usize::try_from(count).unwrap_or(usize::MAX),
                    first_ns: if f == u64::MAX { 0 } else { f },
                    last_ns: last.get(i).copied().unwrap_or(0),
                }
            })
            .collect();
        out.sort_by(|a, b| a.topic.cmp(&b.topic));
        out
    }

    /// Warnings about topics that are not known (kept undecoded).
    pub(crate) fn unknown_topic_warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (i, t) in self.topics.iter().enumerate() {
            if t.known.is_some() {
                continue;
            }
            let why = match Topic::from_name(&t.name) {
                Some(k) => format!(
                    "encoding {:?} where {:?} is expected",
                    t.encoding,
                    k.encoding()
                ),
                None => format!("encoding {:?}", t.encoding),
            };
            out.push(format!(
                "unknown topic {} ({} messages, {why}) kept undecoded",
                t.name,
                self.topic_count(i)
            ));
        }
        out
    }
}
