//! Messages as a read returns them, decoding by topic, and the damage a read can find.

use std::sync::Arc;

use serde::de::DeserializeOwned;

use crate::error::{Result, SessionError};
use crate::record::{
    AutopilotRecord, Direction, EventRecord, JSON_ENCODING, LinkRecord, NavRecord, ObserverRecord,
    PilotRecord, Record, SessionInfo, StatusRecord, ThrustRecord, Topic, TruthRecord,
};

/// How a file is damaged.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Damage {
    /// The file ends inside a record, or without its footer.
    Truncated {
        /// Offset of the first byte that is not part of a complete record.
        at_byte: u64,
        /// Messages read before it.
        messages_recovered: u64,
    },
    /// A complete record is invalid; reading stopped there.
    Corrupt {
        /// Offset of the bad record.
        at_byte: u64,
        /// What is wrong.
        detail: String,
        /// Messages read before it (by the read that found it).
        messages_recovered: u64,
    },
}

impl Damage {
    /// Offset of the first byte not recovered.
    pub fn at_byte(&self) -> u64 {
        match self {
            Damage::Truncated { at_byte, .. } | Damage::Corrupt { at_byte, .. } => *at_byte,
        }
    }

    /// Messages recovered before the damage.
    pub fn messages_recovered(&self) -> u64 {
        match self {
            Damage::Truncated {
                messages_recovered, ..
            }
            | Damage::Corrupt {
                messages_recovered, ..
            } => *messages_recovered,
        }
    }
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Damage::Truncated {
                at_byte,
                messages_recovered,
            } => write!(
                f,
                "truncated: the file ends inside a record or without its footer at byte {at_byte}; \
                 {messages_recovered} messages before it recovered"
            ),
            Damage::Corrupt {
                at_byte,
                detail,
                messages_recovered,
            } => write!(
                f,
                "corrupt record at byte {at_byte} ({detail}); reading stopped there; \
                 {messages_recovered} messages before it recovered"
            ),
        }
    }
}

/// What a session knows about one topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TopicInfo {
    pub name: String,
    pub encoding: String,
    pub schema_name: Option<String>,
    pub known: Option<Topic>,
}

/// A topic's summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSummary {
    /// Topic name.
    pub topic: String,
    /// Message encoding.
    pub encoding: String,
    /// Schema name, if any.
    pub schema_name: Option<String>,
    /// The known topic, or `None` for an unknown topic (kept undecoded).
    pub known: Option<Topic>,
    /// Messages.
    pub count: usize,
    /// First message time, ns (from the indexes; 0 without messages).
    pub first_ns: u64,
    /// Last message time, ns.
    pub last_ns: u64,
}

/// Bytes of one message: a range of a shared, decoded chunk (cloning is cheap).
#[derive(Clone)]
pub struct Payload {
    buf: Arc<[u8]>,
    start: usize,
    len: usize,
}

impl Payload {
    pub(crate) fn new(buf: Arc<[u8]>, start: usize, len: usize) -> Self {
        Self { buf, start, len }
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        self.buf
            .get(self.start..self.start.saturating_add(self.len))
            .unwrap_or(&[])
    }
}

impl std::fmt::Debug for Payload {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Payload({} bytes)", self.len)
    }
}

/// A message returned by a read (owned; its bytes share the decoded chunk).
#[derive(Clone)]
pub struct Message {
    /// Log time, ns (the writer's time base).
    pub t_ns: u64,
    /// Sequence number within its channel.
    pub sequence: u32,
    /// MCAP channel id.
    pub channel_id: u16,
    pub(crate) topic: Arc<TopicInfo>,
    pub(crate) data: Payload,
}

impl std::fmt::Debug for Message {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Message")
            .field("t_ns", &self.t_ns)
            .field("topic", &self.topic.name)
            .field("sequence", &self.sequence)
            .field("bytes", &self.data.len)
            .finish()
    }
}

impl Message {
    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.topic.name
    }

    /// The known topic, if it is one with the expected encoding.
    pub fn known(&self) -> Option<Topic> {
        self.topic.known
    }

    /// Message encoding.
    pub fn encoding(&self) -> &str {
        &self.topic.encoding
    }

    /// The message bytes (JSON text, a raw frame, protobuf, ...).
    pub fn data(&self) -> &[u8] {
        self.data.as_slice()
    }

    /// The payload (shares the decoded chunk).
    pub fn payload(&self) -> &Payload {
        &self.data
    }

    /// A borrowed view.
    pub fn as_ref(&self) -> MessageRef<'_> {
        MessageRef {
            t_ns: self.t_ns,
            sequence: self.sequence,
            channel_id: self.channel_id,
            topic: &self.topic.name,
            known: self.topic.known,
            encoding: &self.topic.encoding,
            data: self.data.as_slice(),
        }
    }

    /// Decodes the message as a record type (its topic must be `T::TOPIC`).
    pub fn decode<T: Record>(&self) -> Result<T> {
        self.as_ref().decode()
    }

    /// Decodes the message by its topic.
    pub fn decode_any(&self) -> Result<Decoded<'_>> {
        self.as_ref().decode_any()
    }

    /// Checks that the message decodes completely by its topic (records, Foxglove
    /// messages, video access units).
    pub fn validate(&self) -> Result<()> {
        self.as_ref().validate()
    }
}

/// A message, borrowed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageRef<'a> {
    /// Log time, ns (the writer's time base).
    pub t_ns: u64,
    /// Sequence number within its channel.
    pub sequence: u32,
    /// MCAP channel id.
    pub channel_id: u16,
    /// Topic name.
    pub topic: &'a str,
    /// The known topic, if it is one with the expected encoding.
    pub known: Option<Topic>,
    /// Message encoding.
    pub encoding: &'a str,
    /// The message bytes.
    pub data: &'a [u8],
}

/// A message decoded by its topic.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Decoded<'a> {
    /// `/telemetry/nav`.
    Nav(NavRecord),
    /// `/telemetry/status`.
    Status(StatusRecord),
    /// `/command/thrust`.
    Thrust(ThrustRecord),
    /// `/pilot/input`.
    Pilot(PilotRecord),
    /// `/autopilot/state`.
    Autopilot(AutopilotRecord),
    /// `/observer/state`.
    Observer(ObserverRecord),
    /// `/link/stats`.
    Link(LinkRecord),
    /// `/events`.
    Event(EventRecord),
    /// `/truth/state`.
    Truth(TruthRecord),
    /// `/session/info`.
    Info(SessionInfo),
    /// A raw frame.
    Raw {
        /// Direction.
        direction: Direction,
        /// The frame.
        frame: &'a [u8],
    },
    /// A Foxglove protobuf message (pose, transform, track, video): decode it with
    /// [`crate::foxglove`].
    Foxglove(Topic, &'a [u8]),
    /// An unknown topic with JSON messages.
    UnknownJson(serde_json::Value),
    /// An unknown topic with another encoding.
    UnknownBytes(&'a [u8]),
}

impl<'a> MessageRef<'a> {
    /// Decodes the message as a record type (its topic must be `T::TOPIC`).
    pub fn decode<T: Record>(&self) -> Result<T> {
        if self.known != Some(T::TOPIC) {
            return Err(SessionError::Decode {
                topic: self.topic.to_string(),
                sequence: self.sequence,
                t_ns: self.t_ns,
                detail: format!("not a {} message", T::TOPIC.name()),
            });
        }
        self.json()
    }

    pub(crate) fn json<T: DeserializeOwned>(&self) -> Result<T> {
        serde_json::from_slice(self.data).map_err(|e| SessionError::Decode {
            topic: self.topic.to_string(),
            sequence: self.sequence,
            t_ns: self.t_ns,
            detail: e.to_string(),
        })
    }

    /// Checks that the message decodes completely by its topic (records, Foxglove
    /// messages, video access units).
    pub fn validate(&self) -> Result<()> {
        if let Decoded::Foxglove(topic, data) = self.decode_any()? {
            crate::foxglove::validate(topic, self.t_ns, data).map_err(|detail| {
                SessionError::Decode {
                    topic: self.topic.to_string(),
                    sequence: self.sequence,
                    t_ns: self.t_ns,
                    detail,
                }
            })?;
        }
        Ok(())
    }

    /// Decodes the message by its topic; unknown topics come back as JSON or bytes.
    pub fn decode_any(&self) -> Result<Decoded<'a>> {
        Ok(match self.known {
            Some(Topic::Pro4Tx) => Decoded::Raw {
                direction: Direction::Tx,
                frame: self.data,
            },
            Some(Topic::Pro4Rx) => Decoded::Raw {
                direction: Direction::Rx,
                frame: self.data,
            },
            Some(Topic::Nav) => Decoded::Nav(self.json()?),
            Some(Topic::Status) => Decoded::Status(self.json()?),
            Some(Topic::Thrust) => Decoded::Thrust(self.json()?),
            Some(Topic::Pilot) => Decoded::Pilot(self.json()?),
            Some(Topic::Autopilot) => Decoded::Autopilot(self.json()?),
            Some(Topic::Observer) => Decoded::Observer(self.json()?),
            Some(Topic::Link) => Decoded::Link(self.json()?),
            Some(Topic::Events) => Decoded::Event(self.json()?),
            Some(Topic::Truth) => Decoded::Truth(self.json()?),
            Some(Topic::SessionInfo) => Decoded::Info(self.json()?),
            Some(t @ (Topic::Transform | Topic::Pose | Topic::Track | Topic::Video)) => {
                Decoded::Foxglove(t, self.data)
            }
            None if self.encoding == JSON_ENCODING => Decoded::UnknownJson(self.json()?),
            None => Decoded::UnknownBytes(self.data),
        })
    }
}
