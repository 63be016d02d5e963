//! The live Foxglove server: the station's channels over the Foxglove WebSocket protocol
//! (`foxglove.websocket.v1`) while flying, so Foxglove (or Lichtblick) connects to a
//! running station with "Open connection → Foxglove WebSocket → ws://ADDR:PORT".
//!
//! # Data flow
//!
//! ```text
//! control thread ── Engine::record ──┬─► recorder queue (when recording)
//!                                    └─► LiveTap::send: try_send of a copy into a
//!                                        bounded queue (QUEUE_CAPACITY, drops counted)
//!                                           │
//!                      station-foxglove-feed thread: rov_session's encodings
//!                      (encode_json, PoseTopics) → foxglove RawChannel::log
//!                                           │
//!                      station-foxglove tokio runtime (1 worker): the SDK's
//!                      WebSocket server, per-client bounded queues
//! ```
//!
//! The protocol is the official SDK's (`foxglove` crate, feature `websocket`, no TLS):
//! handshake, advertisement, subscriptions, per-client back-pressure (a slow client's
//! oldest messages are dropped by the SDK) are its code, not ours. The control thread
//! only makes a `try_send`; the tokio runtime lives in the [`LiveServer`] (its own
//! threads, named `station-foxglove`) and nothing on the control path touches it.
//!
//! # Channels and time
//!
//! Every JSON topic of a session (`/telemetry/nav`, `/telemetry/status`,
//! `/command/thrust`, `/pilot/input`, `/autopilot/state`, `/observer/state`,
//! `/link/stats`, `/events`, `/truth/state` with the simulator) with its JSON Schema, and
//! the pose topics (`/tf`, `/vehicle/pose`, `/vehicle/track`) with Foxglove's protobuf
//! schemas: the same schemas, encodings and derivation as in a recorded session
//! ([`rov_session::foxglove::channel_schema`], [`rov_session::encode_json`],
//! [`rov_session::foxglove::PoseTopics`]). `/camera/video` (`foxglove.CompressedVideo`,
//! H.264) while the station records video: the encoder's thread offers each access unit
//! through the recording's [`crate::runtime::recorder::VideoTap`] (a tap attached when the
//! recording starts; a server started during a recording serves video from the next
//! one), never through the control thread. The raw frames (`/pro4/tx`, `/pro4/rx`,
//! encoding `vr-pro4`) are recorded only: no Foxglove panel reads them.
//!
//! Log times are Unix nanoseconds: a [`LiveTap`] maps the station's clock to the wall
//! clock once, when it is made ([`LiveServer::tap`]), so messages keep the station's
//! spacing.
//!
//! The server outlives a station: the window keeps it across re-connections and gives
//! every new station a tap ([`crate::runtime::RuntimeCommand::FoxgloveLive`]).

use std::net::{SocketAddr, ToSocketAddrs};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;
use std::time::{SystemTime, UNIX_EPOCH};

use foxglove::{Context, PartialMetadata, RawChannel, Schema, WebSocketServer};
use rov_session::foxglove::{PoseTopics, channel_schema};
use rov_session::{Record, Topic, WriterOptions, encode_json};

use crate::runtime::recorder::RecordItem;

/// Queue capacity between the control thread and the feeder, items (about 1.5 s of
/// everything at 50 Hz, like the recorder's).
pub const QUEUE_CAPACITY: usize = 4096;

/// Messages a slow client may have waiting before the SDK drops its oldest, per client.
pub const CLIENT_BACKLOG: usize = 1024;

/// Whether a topic is served live: every topic of a session except the raw frames (no
/// Foxglove panel reads them) and `/session/info` (one message at a recording's start).
/// `/camera/video` carries units only while the station records video (the encoder runs
/// for the recording; its tap offers each unit here too).
#[must_use]
pub const fn is_served(topic: Topic) -> bool {
    !topic.is_raw() && !matches!(topic, Topic::SessionInfo)
}

/// Why the live server did not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The address does not parse or resolve.
    #[error("Foxglove live address {addr:?}: {reason} (expected ADDR:PORT, e.g. 127.0.0.1:8765)")]
    Address {
        /// The address as given.
        addr: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The address cannot be listened on (in use, not an address of this machine, …).
    #[error("Foxglove live server cannot listen on {addr}: {reason}")]
    Bind {
        /// The address as given.
        addr: String,
        /// The system's reason.
        reason: String,
    },
    /// A thread or the tokio runtime could not start.
    #[error("Foxglove live server cannot start: {0}")]
    Start(String),
}

/// A live server that did not start, with where its address came from (the
/// `--foxglove-ws` flag, or `[foxglove] ws` of a named file).
#[derive(Debug, thiserror::Error)]
#[error("{origin}: {source}")]
pub struct ConfiguredLiveError {
    /// Where the address was given, e.g. `--foxglove-ws`.
    pub origin: String,
    /// Why the server did not start.
    #[source]
    pub source: LiveError,
}

/// Parses `ADDR:PORT` (an IP address, `[v6]:port`, or a host name that resolves).
///
/// # Errors
/// [`LiveError::Address`] naming the address.
pub fn parse_addr(addr: &str) -> Result<SocketAddr, LiveError> {
    let bad = |reason: String| LiveError::Address {
        addr: addr.to_string(),
        reason,
    };
    let text = addr.trim();
    if let Ok(a) = text.parse::<SocketAddr>() {
        return Ok(a);
    }
    let Some((host, port)) = text.rsplit_once(':') else {
        return Err(bad("no port".into()));
    };
    if host.is_empty() {
        return Err(bad("no host".into()));
    }
    if port.parse::<u16>().is_err() {
        return Err(bad(format!("port {port:?} is not a number in 0..65535")));
    }
    let mut found = text
        .to_socket_addrs()
        .map_err(|e| bad(format!("does not resolve: {e}")))?;
    found
        .next()
        .ok_or_else(|| bad("resolves to no address".into()))
}

#[derive(Debug, Default)]
struct Counters {
    queued: AtomicU64,
    dropped: AtomicU64,
    sent: AtomicU64,
    failed: AtomicU64,
}

/// The server's state for a status line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveStatus {
    /// The address listened on (the port chosen when 0 was asked).
    pub addr: SocketAddr,
    /// Clients connected now.
    pub clients: usize,
    /// Records queued by the stations.
    pub queued: u64,
    /// Records dropped because the feeder's queue was full.
    pub dropped: u64,
    /// Messages logged to the channels (each goes to every subscribed client).
    pub sent: u64,
    /// Records that did not encode (skipped, counted).
    pub failed: u64,
}

impl LiveStatus {
    /// The URL to give Foxglove.
    #[must_use]
    pub fn url(&self) -> String {
        format!("ws://{}", self.addr)
    }
}

/// A running live server; see the module docs. Dropping it stops it (clients are
/// disconnected, the threads end).
pub struct LiveServer {
    addr: SocketAddr,
    tx: Option<SyncSender<(u64, RecordItem)>>,
    counters: Arc<Counters>,
    server: Option<foxglove::WebSocketServerHandle>,
    feeder: Option<JoinHandle<()>>,
    runtime: Option<tokio::runtime::Runtime>,
    /// The channels' and the server's context (the SDK holds it weakly: it lives here).
    _context: Arc<Context>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl LiveServer {
    /// Listens on `addr` (`ADDR:PORT`; port 0 picks a free one) and starts the feeder
    /// thread and the server's runtime.
    ///
    /// # Errors
    /// [`LiveError`] naming the address: unparsable, in use, or not of this machine.
    pub fn start(addr: &str) -> Result<Self, LiveError> {
        let sock = parse_addr(addr)?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("station-foxglove")
            .enable_all()
            .build()
            .map_err(|e| LiveError::Start(format!("tokio runtime: {e}")))?;
        let ctx = Context::new();
        let channels = advertise(&ctx)?;
        let host = match sock {
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        };
        let server = WebSocketServer::new()
            .name(format!("topside {}", env!("CARGO_PKG_VERSION")))
            .context(&ctx)
            .bind(host, sock.port())
            .message_backlog_size(CLIENT_BACKLOG)
            .tokio_runtime(runtime.handle())
            .start_blocking()
            .map_err(|e| LiveError::Bind {
                addr: addr.trim().to_string(),
                reason: match e {
                    foxglove::FoxgloveError::Bind(io) => io.to_string(),
                    other => other.to_string(),
                },
            })?;
        let local = SocketAddr::new(sock.ip(), server.port());
        let (tx, rx) = sync_channel(QUEUE_CAPACITY);
        let counters = Arc::new(Counters::default());
        let c = Arc::clone(&counters);
        let feeder = std::thread::Builder::new()
            .name("station-foxglove-feed".into())
            .spawn(move || {
                // May be started by the control thread: not at its real-time priority.
                crate::runtime::priority::normal_current();
                feed(&rx, &channels, &c);
            })
            .map_err(|e| LiveError::Start(format!("feeder thread: {e}")))?;
        Ok(Self {
            addr: local,
            tx: Some(tx),
            counters,
            server: Some(server),
            feeder: Some(feeder),
            runtime: Some(runtime),
            _context: ctx,
        })
    }

    /// The address listened on.
    #[must_use]
    pub const fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// A tap for a station whose clock reads `station_now_us` now: its records get log
    /// times on the wall clock (Unix ns) with the station's spacing.
    #[must_use]
    pub fn tap(&self, station_now_us: u64) -> Option<LiveTap> {
        let unix_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        Some(LiveTap {
            tx: self.tx.clone()?,
            counters: Arc::clone(&self.counters),
            base_ns: unix_ns.saturating_sub(station_now_us.saturating_mul(1000)),
        })
    }

    /// Clients and counters now.
    #[must_use]
    pub fn status(&self) -> LiveStatus {
        let c = &self.counters;
        LiveStatus {
            addr: self.addr,
            clients: self.server.as_ref().map_or(0, |s| s.client_count()),
            queued: c.queued.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            sent: c.sent.load(Ordering::Relaxed),
            failed: c.failed.load(Ordering::Relaxed),
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        // The feeder ends when every sender is gone: ours here, the stations' when their
        // taps are dropped (a station that still holds one keeps feeding a closed
        // server's channels, harmlessly, until it is told otherwise or stops).
        self.tx = None;
        if let Some(s) = self.server.take() {
            s.stop().wait_blocking();
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_timeout(std::time::Duration::from_secs(1));
        }
        if let Some(f) = self.feeder.take()
            && f.is_finished()
        {
            crate::runtime::join_or_warn(f);
        }
    }
}

/// A station's end of the live server's queue: cheap to clone, never blocks.
#[derive(Clone)]
pub struct LiveTap {
    tx: SyncSender<(u64, RecordItem)>,
    counters: Arc<Counters>,
    base_ns: u64,
}

impl std::fmt::Debug for LiveTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveTap")
            .field("base_ns", &self.base_ns)
            .finish_non_exhaustive()
    }
}

impl PartialEq for LiveTap {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.counters, &other.counters) && self.base_ns == other.base_ns
    }
}

impl LiveTap {
    /// Queues a copy of a record the station made at `now_us` (its clock); a full queue
    /// drops it (counted). Raw frames are not served.
    pub fn send(&self, now_us: u64, item: &RecordItem) {
        if matches!(item, RecordItem::Raw(..)) {
            return;
        }
        let t_ns = self.base_ns.saturating_add(now_us.saturating_mul(1000));
        let counter = match self.tx.try_send((t_ns, item.clone())) {
            Ok(()) => &self.counters.queued,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => &self.counters.dropped,
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// Records dropped so far (queue full).
    #[must_use]
    pub fn dropped(&self) -> u64 {
        self.counters.dropped.load(Ordering::Relaxed)
    }
}

/// One channel per served topic, indexed by [`Topic::index`].
type Channels = [Option<Arc<RawChannel>>; Topic::ALL.len()];

fn advertise(ctx: &Arc<Context>) -> Result<Channels, LiveError> {
    let mut channels: Channels = Default::default();
    for topic in Topic::ALL.into_iter().filter(|t| is_served(*t)) {
        let s = channel_schema(topic);
        let schema = (!s.name.is_empty()).then(|| Schema::new(s.name, s.encoding, s.data));
        let ch = ctx
            .channel_builder(topic.name())
            .message_encoding(s.message_encoding)
            .schema(schema)
            .build_raw()
            .map_err(|e| LiveError::Start(format!("channel {}: {e}", topic.name())))?;
        if let Some(slot) = channels.get_mut(topic.index()) {
            *slot = Some(ch);
        }
    }
    Ok(channels)
}

/// The feeder's state: the channels, the pose derivation and a scratch buffer.
struct Feed<'a> {
    channels: &'a Channels,
    counters: &'a Counters,
    poses: PoseTopics,
    buf: Vec<u8>,
    max_bytes: usize,
}

impl Feed<'_> {
    fn log(&self, topic: Topic, t_ns: u64, bytes: &[u8]) {
        if let Some(Some(ch)) = self.channels.get(topic.index()) {
            ch.log_with_meta(bytes, PartialMetadata::with_log_time(t_ns));
            self.counters.sent.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn subscribed(&self, topic: Topic) -> bool {
        matches!(self.channels.get(topic.index()), Some(Some(ch)) if ch.has_sinks())
    }

    /// A JSON record, encoded only when a client listens.
    fn json<T: Record>(&mut self, t_ns: u64, r: &T) {
        if !self.subscribed(T::TOPIC) {
            return;
        }
        match encode_json(r, self.max_bytes, &mut self.buf) {
            Ok(()) => self.log(T::TOPIC, t_ns, &self.buf),
            Err(_) => {
                self.counters.failed.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn item(&mut self, t_ns: u64, item: &RecordItem) {
        match item {
            // Raw frames: no Foxglove panel reads them.
            RecordItem::Raw(..) => {}
            // Camera video (from the encoder's thread while recording): the recorded
            // message, foxglove.CompressedVideo, checked as the writer checks it.
            RecordItem::Video(_, key_frame, au) => {
                if self.subscribed(Topic::Video)
                    && rov_session::foxglove::check_access_unit(au, *key_frame).is_ok()
                {
                    let m = rov_session::foxglove::video_message(t_ns, au);
                    self.log(Topic::Video, t_ns, &rov_session::foxglove::encode(&m));
                }
            }
            RecordItem::Nav(_, r) => {
                self.json(t_ns, r);
                if let Some(m) = self.poses.nav(t_ns, r) {
                    self.log(Topic::Transform, t_ns, &m.transform);
                    self.log(Topic::Pose, t_ns, &m.pose_in_frame);
                    if let Some(track) = &m.track {
                        self.log(Topic::Track, t_ns, track);
                    }
                }
            }
            RecordItem::Truth(_, r) => {
                self.poses.truth(t_ns, r);
                self.json(t_ns, r);
            }
            RecordItem::Status(_, r) => self.json(t_ns, r),
            RecordItem::Thrust(_, r) => self.json(t_ns, r),
            RecordItem::Pilot(_, r) => self.json(t_ns, r),
            RecordItem::Autopilot(_, r) => self.json(t_ns, r),
            RecordItem::Observer(_, r) => self.json(t_ns, r),
            RecordItem::Link(_, r) => self.json(t_ns, r),
            RecordItem::Event(_, r) => self.json(t_ns, r),
        }
    }
}

fn feed(rx: &Receiver<(u64, RecordItem)>, channels: &Channels, counters: &Counters) {
    let opts = WriterOptions::default();
    let mut f = Feed {
        channels,
        counters,
        poses: PoseTopics::new(opts.pose_interval_ns),
        buf: Vec::with_capacity(4096),
        max_bytes: opts.max_message_bytes,
    };
    while let Ok((t_ns, item)) = rx.recv() {
        f.item(t_ns, &item);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_or_are_named_in_the_error() {
        assert_eq!(
            parse_addr("127.0.0.1:8765").unwrap(),
            "127.0.0.1:8765".parse().unwrap()
        );
        assert_eq!(parse_addr("[::1]:0").unwrap().port(), 0);
        assert!(parse_addr("localhost:8765").is_ok());
        for bad in [
            "nonsense",
            "127.0.0.1",
            "127.0.0.1:99999",
            ":8765",
            "no.such.host.invalid:1",
        ] {
            let e = parse_addr(bad).unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
    }

    #[test]
    fn an_address_in_use_is_a_clear_error() {
        let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = taken.local_addr().unwrap().to_string();
        let e = LiveServer::start(&addr).unwrap_err();
        assert!(matches!(e, LiveError::Bind { .. }), "{e:?}");
        let text = e.to_string();
        assert!(text.contains(&addr) && text.contains("in use"), "{text}");
    }

    #[test]
    fn a_server_starts_on_a_free_port_and_stops() {
        // The nine JSON telemetry topics, the three pose topics and the camera video.
        let served: Vec<&str> = Topic::ALL
            .into_iter()
            .filter(|t| is_served(*t))
            .map(Topic::name)
            .collect();
        assert_eq!(served.len(), 13, "{served:?}");
        assert!(served.contains(&"/tf") && !served.contains(&"/pro4/rx"));
        let s = LiveServer::start("127.0.0.1:0").unwrap();
        let st = s.status();
        assert_ne!(st.addr.port(), 0);
        assert_eq!(st.clients, 0);
        let tap = s.tap(5_000_000).unwrap();
        tap.send(
            5_000_000,
            &RecordItem::Nav(0, rov_session::NavRecord::default()),
        );
        drop(s);
        // The server is gone: the port is free again.
        std::net::TcpListener::bind(st.addr).unwrap();
    }

    #[test]
    fn a_station_feeds_the_server_without_recording() {
        let cfg = crate::runtime::RuntimeConfig {
            gamepad: false,
            ..crate::runtime::RuntimeConfig::default()
        };
        let (mut st, h) = crate::runtime::VirtualStation::new(cfg).unwrap();
        let s = LiveServer::start("127.0.0.1:0").unwrap();
        h.command(crate::runtime::RuntimeCommand::FoxgloveLive(
            s.tap(h.now_us()),
        ));
        st.advance(2.0).unwrap();
        assert!(
            h.view().recording.path.is_none(),
            "this test is about not recording"
        );
        let fed = s.status();
        // Every tick's thrust, pilot, autopilot and observer records, and the nav replies.
        assert!(fed.queued >= 4 * 100, "{fed:?}");
        assert_eq!(fed.dropped, 0);
        h.command(crate::runtime::RuntimeCommand::FoxgloveLive(None));
        st.advance(0.5).unwrap();
        let after = s.status().queued;
        st.advance(1.0).unwrap();
        assert_eq!(s.status().queued, after, "the station stopped serving");
    }
}
