//! The live Foxglove server, end to end: `topside record --sim --foxglove-ws` flies the
//! simulated Pro 4 through the whole real-time station while a WebSocket client in this
//! test speaks the SDK's `foxglove.sdk.v1` to it (tungstenite, our own minimal client: the
//! server side is the SDK's), as Foxglove would.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use tungstenite::client::IntoClientRequest;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

/// The subprotocol the SDK (0.30) negotiates: `foxglove.sdk.v1`, the successor of
/// `foxglove.websocket.v1` that current Foxglove offers (inline schemas).
const SUBPROTOCOL: &str = "foxglove.sdk.v1";

fn topside() -> Command {
    Command::new(env!("CARGO_BIN_EXE_topside"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("foxglove_live");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Starts `topside record --sim` with the live server on a free port; stderr lines
/// arrive on the receiver.
fn record(out: &std::path::Path, duration_s: f64, ws: &str) -> (Child, Receiver<String>) {
    let mut child = topside()
        .args(["record", "--sim", "--json", "--duration-s"])
        .arg(duration_s.to_string())
        .arg("--out")
        .arg(out)
        .args(["--foxglove-ws", ws])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// The URL the station says it serves on.
fn served_url(lines: &Receiver<String>, seen: &mut Vec<String>) -> String {
    let deadline = Instant::now() + Duration::from_secs(20);
    while Instant::now() < deadline {
        if let Ok(l) = lines.recv_timeout(Duration::from_millis(100)) {
            seen.push(l.clone());
            if let Some(rest) = l.strip_prefix("Foxglove live: serving ") {
                return rest.split_whitespace().next().unwrap().to_string();
            }
        }
    }
    panic!("the station never said where it serves: {seen:?}");
}

#[derive(Debug, Clone)]
struct Advertised {
    id: u64,
    encoding: String,
    schema_name: String,
    schema_encoding: String,
    schema: String,
}

fn connect(url: &str) -> WebSocket<MaybeTlsStream<TcpStream>> {
    let mut req = url.into_client_request().unwrap();
    req.headers_mut()
        .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
    let (ws, resp) = tungstenite::connect(req).unwrap();
    assert_eq!(
        resp.headers()
            .get("Sec-WebSocket-Protocol")
            .and_then(|v| v.to_str().ok()),
        Some(SUBPROTOCOL),
        "the server must accept the Foxglove subprotocol"
    );
    if let MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .unwrap();
    }
    ws
}

/// One message, or None on a read timeout.
fn next(ws: &mut WebSocket<MaybeTlsStream<TcpStream>>) -> Option<Message> {
    match ws.read() {
        Ok(m) => Some(m),
        Err(tungstenite::Error::Io(e))
            if matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ) =>
        {
            None
        }
        Err(e) => panic!("websocket: {e}"),
    }
}

/// A `messageData` frame: (subscription id, log time ns, payload).
fn message_data(bytes: &[u8]) -> Option<(u32, u64, &[u8])> {
    if bytes.first() != Some(&0x01) || bytes.len() < 13 {
        return None;
    }
    let sub = u32::from_le_bytes(bytes[1..5].try_into().unwrap());
    let t = u64::from_le_bytes(bytes[5..13].try_into().unwrap());
    Some((sub, t, &bytes[13..]))
}

#[test]
fn a_foxglove_client_subscribes_and_receives_telemetry_at_the_recorded_rate() {
    let out = tmp("live.mcap");
    let _ = std::fs::remove_file(&out);
    let (mut child, lines) = record(&out, 9.0, "127.0.0.1:0");
    let mut stderr = Vec::new();
    let url = served_url(&lines, &mut stderr);
    assert!(url.starts_with("ws://127.0.0.1:"), "{url}");
    let mut ws = connect(&url);

    // serverInfo, then the advertisement of every channel.
    let mut channels: BTreeMap<String, Advertised> = BTreeMap::new();
    let mut server_info = None;
    let mut texts = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline && (server_info.is_none() || channels.len() < 13) {
        let m = next(&mut ws);
        texts.push(format!("{m:?}").chars().take(300).collect::<String>());
        if let Some(Message::Text(t)) = m {
            let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
            match v["op"].as_str() {
                Some("serverInfo") => server_info = Some(v),
                Some("advertise") => {
                    for c in v["channels"].as_array().unwrap() {
                        let s = |k: &str| c[k].as_str().unwrap_or_default().to_string();
                        channels.insert(
                            s("topic"),
                            Advertised {
                                id: c["id"].as_u64().unwrap(),
                                encoding: s("encoding"),
                                schema_name: s("schemaName"),
                                schema_encoding: s("schemaEncoding"),
                                schema: s("schema"),
                            },
                        );
                    }
                }
                _ => {}
            }
        }
    }
    let info = server_info.expect("no serverInfo");
    assert!(
        info["name"].as_str().unwrap().starts_with("topside"),
        "{info}"
    );
    for topic in [
        "/telemetry/nav",
        "/telemetry/status",
        "/command/thrust",
        "/pilot/input",
        "/autopilot/state",
        "/observer/state",
        "/link/stats",
        "/events",
        "/truth/state",
        "/tf",
        "/vehicle/pose",
        "/vehicle/track",
    ] {
        assert!(
            channels.contains_key(topic),
            "{topic} not advertised: {channels:?} {texts:?}"
        );
    }
    // The same schemas and encodings as a recorded session.
    let nav = channels["/telemetry/nav"].clone();
    assert_eq!(
        (
            nav.encoding.as_str(),
            nav.schema_encoding.as_str(),
            nav.schema_name.as_str()
        ),
        ("json", "jsonschema", "topside.TelemetryNav")
    );
    let schema: serde_json::Value = serde_json::from_str(&nav.schema).unwrap();
    assert!(schema["properties"]["depth_m"].is_object(), "{schema}");
    let tf = channels["/tf"].clone();
    assert_eq!(
        (
            tf.encoding.as_str(),
            tf.schema_encoding.as_str(),
            tf.schema_name.as_str()
        ),
        ("protobuf", "protobuf", "foxglove.FrameTransform")
    );
    assert!(!tf.schema.is_empty());

    // The camera video the station records (the sim camera), as a recorded session has it.
    let video = channels
        .get("/camera/video")
        .cloned()
        .expect("/camera/video not advertised");
    assert_eq!(
        (video.encoding.as_str(), video.schema_name.as_str()),
        ("protobuf", "foxglove.CompressedVideo")
    );
    let subscribe = serde_json::json!({
        "op": "subscribe",
        "subscriptions": [
            {"id": 1, "channelId": nav.id},
            {"id": 2, "channelId": tf.id},
            {"id": 3, "channelId": video.id},
        ],
    });
    ws.send(Message::Text(subscribe.to_string().into()))
        .unwrap();
    let subscribed = Instant::now();

    // The first navigation record within 2 s, a plausible one.
    let mut first_nav = None;
    let mut tf_msg = None;
    let mut video_msgs: Vec<(u64, Vec<u8>)> = Vec::new();
    while subscribed.elapsed() < Duration::from_secs(2) && first_nav.is_none() {
        if let Some(Message::Binary(b)) = next(&mut ws)
            && let Some((sub, t, payload)) = message_data(&b)
        {
            if sub == 1 {
                first_nav = Some((t, payload.to_vec(), subscribed.elapsed()));
            } else if sub == 2 {
                tf_msg = Some(payload.to_vec());
            } else if sub == 3 {
                video_msgs.push((t, payload.to_vec()));
            }
        }
    }
    let (first_t, payload, latency) = first_nav.expect("no /telemetry/nav within 2 s");
    let rec: rov_session::NavRecord = serde_json::from_slice(&payload).unwrap();
    assert!(
        (0.0..360.0).contains(&rec.heading_deg)
            && rec.pitch_deg.abs() < 45.0
            && rec.roll_deg.abs() < 45.0
            && (-1.0..20.0).contains(&rec.depth_m)
            && rec
                .pressure_mbar
                .is_some_and(|p| (900.0..4000.0).contains(&p)),
        "implausible nav record: {rec:?}"
    );
    let now_unix_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    assert!(
        now_unix_ns.abs_diff(first_t) < 5_000_000_000,
        "log time {first_t} is not the wall clock ({now_unix_ns})"
    );

    // The rate over 3 s, counted by arrival and by log time.
    let mut n = 0u32;
    let mut last_t = first_t;
    let window = Instant::now();
    while window.elapsed() < Duration::from_secs(3) {
        if let Some(Message::Binary(b)) = next(&mut ws)
            && let Some((sub, t, payload)) = message_data(&b)
        {
            if sub == 1 {
                n += 1;
                last_t = t;
            } else if sub == 2 && tf_msg.is_none() {
                tf_msg = Some(payload.to_vec());
            } else if sub == 3 {
                video_msgs.push((t, payload.to_vec()));
            }
        }
    }
    let arrival_hz = f64::from(n) / window.elapsed().as_secs_f64();
    let logged_hz = f64::from(n) / ((last_t - first_t) as f64 * 1e-9);

    // The pose as Foxglove's 3D panel reads it.
    let tf = rov_session::foxglove::decode_transform(&tf_msg.expect("no /tf message")).unwrap();
    assert_eq!(
        (tf.parent_frame_id.as_str(), tf.child_frame_id.as_str()),
        ("world", "vehicle")
    );
    let z = tf.translation.unwrap().z;
    assert!((-20.0..1.0).contains(&z), "{z}");

    // Live H.264 access units (foxglove.CompressedVideo), a key frame among them within
    // the 5 s (the encoder's key-frame interval is at most 2 s).
    let frames: Vec<rov_session::foxglove::VideoFrame> = video_msgs
        .iter()
        .map(|(t, p)| rov_session::foxglove::decode_video(*t, p).unwrap())
        .collect();
    assert!(frames.len() >= 10, "{} live video frames", frames.len());
    assert!(frames.iter().any(|f| f.key_frame), "no key frame served");
    assert!(frames.windows(2).all(|w| w[1].t_ns > w[0].t_ns));

    drop(ws);
    let status = child.wait().unwrap();
    let rest: Vec<String> = lines.try_iter().collect();
    assert!(status.success(), "{stderr:?} {rest:?}");
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut child.stdout.take().unwrap(), &mut stdout).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(summary["foxglove"]["dropped"], 0, "{summary}");

    // The recorded rate of the same dive.
    let session = rov_session::open(&out).unwrap();
    let t = session
        .topics()
        .into_iter()
        .find(|t| t.topic == "/telemetry/nav")
        .unwrap();
    let recorded_hz = (t.count - 1) as f64 / ((t.last_ns - t.first_ns) as f64 * 1e-9);
    eprintln!(
        "first nav {:.0} ms after subscribing; live {arrival_hz:.1} Hz by arrival, {logged_hz:.1} Hz by log time; recorded {recorded_hz:.1} Hz; {} live video frames",
        latency.as_secs_f64() * 1e3,
        frames.len()
    );
    for (what, hz) in [("arrival", arrival_hz), ("log time", logged_hz)] {
        assert!(
            (hz - recorded_hz).abs() < 0.1 * recorded_hz,
            "live rate by {what} {hz:.1} Hz vs recorded {recorded_hz:.1} Hz"
        );
    }
}

#[test]
fn a_bad_address_is_named_and_the_dive_is_recorded_anyway() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let in_use = taken.local_addr().unwrap().to_string();
    for (ws, says) in [
        (in_use.as_str(), "in use"),
        ("nonsense", "expected ADDR:PORT"),
    ] {
        let out = tmp("bad_addr.mcap");
        let _ = std::fs::remove_file(&out);
        let (mut child, lines) = record(&out, 1.0, ws);
        let status = child.wait().unwrap();
        let err: Vec<String> = lines.iter().collect();
        assert!(status.success(), "{err:?}");
        let warning = err
            .iter()
            .find(|l| l.starts_with("warning: --foxglove-ws"))
            .unwrap_or_else(|| panic!("no warning: {err:?}"));
        assert!(warning.contains(ws) && warning.contains(says), "{warning}");
        assert!(rov_session::open(&out).unwrap().is_complete());
    }
}
