//! Video source specifications: the text of `topside --video SOURCE` and of the station
//! config, parsed into a [`SourceSpec`], and the GStreamer description of each source.
//!
//! | text | source |
//! |---|---|
//! | `sim` | the simulator's camera ([`crate::simcam`]; not a GStreamer source) |
//! | `none` | no video |
//! | `test` | `videotestsrc` (live, SMPTE bars) with the running time drawn by `timeoverlay` |
//! | `v4l2:/dev/videoN` (or just `/dev/videoN`) | a V4L2 capture device, e.g. the USB frame grabber that digitises the Pro 4's composite video |
//! | `rtsp://…`, `rtsps://…` | an RTSP camera (`rtspsrc`, 100 ms jitter buffer, any codec via `decodebin`) |
//! | `udp://[HOST]:PORT` | RTP/H.264 on UDP (payload 96, BlueOS and most ROV companions: port 5600) |
//! | `file:///PATH` (also `http(s)://…`) | a video file or stream through `uridecodebin` |
//! | anything else | a GStreamer pipeline description that outputs raw video, e.g. `videotestsrc pattern=ball` |

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use crate::error::{Result, VideoError};

/// Where video comes from. Parse with [`SourceSpec::parse`] (or `str::parse`); print with
/// `Display` (the same text parses back).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SourceSpec {
    /// The simulator's camera (rendered in code; see [`crate::simcam`]).
    Sim,
    /// No video.
    None,
    /// GStreamer's test pattern with a running clock.
    Test,
    /// A V4L2 capture device.
    V4l2 {
        /// Device node, e.g. `/dev/video0`.
        device: PathBuf,
    },
    /// An RTSP stream.
    Rtsp {
        /// The full URI.
        uri: String,
    },
    /// RTP/H.264 on UDP.
    Udp {
        /// Address to listen on (`0.0.0.0` when not given; a multicast group joins it).
        host: String,
        /// UDP port.
        port: u16,
    },
    /// A file or another URI that `uridecodebin` understands.
    Uri {
        /// The full URI.
        uri: String,
    },
    /// A GStreamer pipeline description producing raw video.
    Pipeline {
        /// The description.
        description: String,
    },
}

fn bad(spec: &str, reason: impl Into<String>) -> VideoError {
    VideoError::BadSourceSpec {
        spec: spec.to_owned(),
        reason: reason.into(),
    }
}

impl SourceSpec {
    /// Parses a source text (see the [module docs](self)).
    ///
    /// # Errors
    /// [`VideoError::BadSourceSpec`] naming the text and what is wrong.
    pub fn parse(text: &str) -> Result<Self> {
        let t = text.trim();
        if t.is_empty() {
            return Err(bad(text, "empty"));
        }
        let lower = t.to_ascii_lowercase();
        match lower.as_str() {
            "sim" => return Ok(Self::Sim),
            "none" | "off" => return Ok(Self::None),
            "test" => return Ok(Self::Test),
            _ => {}
        }
        if let Some(dev) = t.strip_prefix("v4l2:") {
            return Self::v4l2(text, dev);
        }
        if t.starts_with("/dev/") {
            return Self::v4l2(text, t);
        }
        if let Some((scheme, rest)) = t.split_once("://") {
            let scheme = scheme.to_ascii_lowercase();
            return match scheme.as_str() {
                "rtsp" | "rtsps" | "rtspt" => {
                    if rest.is_empty() || rest.starts_with('/') {
                        Err(bad(text, "the RTSP URI has no host"))
                    } else {
                        Ok(Self::Rtsp { uri: t.to_owned() })
                    }
                }
                "udp" => Self::udp(text, rest),
                "file" => {
                    if rest.starts_with('/') && rest.len() > 1 {
                        Ok(Self::Uri { uri: t.to_owned() })
                    } else {
                        Err(bad(text, "a file URI needs an absolute path: file:///PATH"))
                    }
                }
                "http" | "https" => {
                    if rest.is_empty() {
                        Err(bad(text, "the URI has no host"))
                    } else {
                        Ok(Self::Uri { uri: t.to_owned() })
                    }
                }
                other => Err(bad(text, format!("unknown URI scheme `{other}`"))),
            };
        }
        if t.contains("appsink") {
            return Err(bad(
                text,
                "a source pipeline must not contain its own appsink (the station adds one)",
            ));
        }
        Ok(Self::Pipeline {
            description: t.to_owned(),
        })
    }

    fn v4l2(text: &str, dev: &str) -> Result<Self> {
        let dev = dev.trim();
        if !dev.starts_with("/dev/") || dev.len() <= "/dev/".len() {
            return Err(bad(text, "a V4L2 source is v4l2:/dev/videoN"));
        }
        if dev.contains(char::is_whitespace) || dev.contains('!') {
            return Err(bad(text, "the device path contains spaces or `!`"));
        }
        Ok(Self::V4l2 {
            device: PathBuf::from(dev),
        })
    }

    fn udp(text: &str, rest: &str) -> Result<Self> {
        let rest = rest.trim_end_matches('/');
        let rest = rest.strip_prefix('@').unwrap_or(rest);
        let (host, port) = rest
            .rsplit_once(':')
            .ok_or_else(|| bad(text, "a UDP source needs a port: udp://[HOST]:PORT"))?;
        let port: u16 = port
            .parse()
            .map_err(|_| bad(text, format!("UDP port `{port}` is not a number 1..65535")))?;
        if port == 0 {
            return Err(bad(text, "UDP port 0 is not allowed (1..65535)"));
        }
        let host = host.trim_start_matches('[').trim_end_matches(']');
        if host.contains(|c: char| c.is_whitespace() || c == '!' || c == '"') {
            return Err(bad(text, format!("UDP host `{host}` is not an address")));
        }
        Ok(Self::Udp {
            host: if host.is_empty() {
                "0.0.0.0".to_owned()
            } else {
                host.to_owned()
            },
            port,
        })
    }

    /// `true` for the sources that go through GStreamer (all but `sim` and `none`).
    pub fn uses_gstreamer(&self) -> bool {
        !matches!(self, Self::Sim | Self::None)
    }

    /// The GStreamer elements this source needs (checked before a capture starts, so a
    /// missing plugin is named at once).
    pub fn required_elements(&self) -> &'static [&'static str] {
        match self {
            Self::Sim | Self::None | Self::Pipeline { .. } => &[],
            Self::Test => &["videotestsrc", "timeoverlay"],
            Self::V4l2 { .. } => &["v4l2src", "decodebin", "deinterlace"],
            Self::Rtsp { .. } => &["rtspsrc", "decodebin"],
            Self::Udp { .. } => &[
                "udpsrc",
                "rtpjitterbuffer",
                "rtph264depay",
                "h264parse",
                "avdec_h264",
            ],
            Self::Uri { .. } => &["uridecodebin"],
        }
    }

    /// The GStreamer description of the source part (up to raw video of any format and
    /// size), or `None` for `sim` and `none`.
    ///
    /// `test_size_px` is the test pattern's size and `test_fps` its rate.
    pub fn gst_description(&self, test_size_px: (u32, u32), test_fps: u32) -> Option<String> {
        Some(match self {
            Self::Sim | Self::None => return None,
            Self::Test => format!(
                "videotestsrc is-live=true pattern=smpte ! video/x-raw,width={},height={},framerate={}/1 ! timeoverlay halignment=center valignment=center font-desc=\"Sans 28\"",
                test_size_px.0, test_size_px.1, test_fps
            ),
            // Composite grabbers deliver interlaced YUYV (or MJPEG): decodebin passes raw
            // video through or decodes it; deinterlace only acts on interlaced caps.
            Self::V4l2 { device } => format!(
                "v4l2src device={} ! decodebin ! deinterlace mode=auto",
                quote(&device.to_string_lossy())
            ),
            Self::Rtsp { uri } => format!(
                "rtspsrc location={} latency=100 drop-on-latency=true ! decodebin",
                quote(uri)
            ),
            Self::Udp { host, port } => format!(
                "udpsrc address={} port={port} caps=\"application/x-rtp,media=video,clock-rate=90000,encoding-name=H264,payload=96\" ! rtpjitterbuffer latency=50 drop-on-latency=true ! rtph264depay ! h264parse ! avdec_h264",
                quote(host)
            ),
            Self::Uri { uri } => format!("uridecodebin uri={}", quote(uri)),
            Self::Pipeline { description } => description.clone(),
        })
    }
}

/// Quotes a property value for a pipeline description.
fn quote(s: &str) -> String {
    let escaped = s.replace('\\', "\\\\").replace('"', "\\\"");
    format!("\"{escaped}\"")
}

impl FromStr for SourceSpec {
    type Err = VideoError;
    fn from_str(s: &str) -> Result<Self> {
        Self::parse(s)
    }
}

impl fmt::Display for SourceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sim => f.write_str("sim"),
            Self::None => f.write_str("none"),
            Self::Test => f.write_str("test"),
            Self::V4l2 { device } => write!(f, "v4l2:{}", device.display()),
            Self::Rtsp { uri } | Self::Uri { uri } => f.write_str(uri),
            Self::Udp { host, port } => {
                if host.contains(':') {
                    write!(f, "udp://[{host}]:{port}")
                } else {
                    write!(f, "udp://{host}:{port}")
                }
            }
            Self::Pipeline { description } => f.write_str(description),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keywords_and_devices() {
        assert_eq!(SourceSpec::parse("sim").unwrap(), SourceSpec::Sim);
        assert_eq!(SourceSpec::parse(" NONE ").unwrap(), SourceSpec::None);
        assert_eq!(SourceSpec::parse("test").unwrap(), SourceSpec::Test);
        assert_eq!(
            SourceSpec::parse("v4l2:/dev/video2").unwrap(),
            SourceSpec::V4l2 {
                device: "/dev/video2".into()
            }
        );
        assert_eq!(
            SourceSpec::parse("/dev/video0").unwrap(),
            SourceSpec::V4l2 {
                device: "/dev/video0".into()
            }
        );
    }

    #[test]
    fn uris() {
        assert_eq!(
            SourceSpec::parse("udp://:5600").unwrap(),
            SourceSpec::Udp {
                host: "0.0.0.0".into(),
                port: 5600
            }
        );
        assert_eq!(
            SourceSpec::parse("udp://@239.0.0.1:5000").unwrap(),
            SourceSpec::Udp {
                host: "239.0.0.1".into(),
                port: 5000
            }
        );
        assert!(matches!(
            SourceSpec::parse("rtsp://192.168.2.2:8554/cam").unwrap(),
            SourceSpec::Rtsp { .. }
        ));
        assert!(matches!(
            SourceSpec::parse("file:///tmp/dive.mp4").unwrap(),
            SourceSpec::Uri { .. }
        ));
        assert!(matches!(
            SourceSpec::parse("videotestsrc pattern=ball").unwrap(),
            SourceSpec::Pipeline { .. }
        ));
    }

    #[test]
    fn display_parses_back() {
        for s in [
            "sim",
            "none",
            "test",
            "v4l2:/dev/video3",
            "rtsp://cam.local/stream",
            "udp://0.0.0.0:5600",
            "udp://[::1]:5600",
            "file:///a/b.mkv",
            "videotestsrc ! videoconvert",
        ] {
            let spec = SourceSpec::parse(s).unwrap();
            assert_eq!(SourceSpec::parse(&spec.to_string()).unwrap(), spec, "{s}");
        }
    }

    #[test]
    fn bad_specs_name_the_problem() {
        for (s, needle) in [
            ("", "empty"),
            ("v4l2:", "v4l2:/dev/videoN"),
            ("v4l2:video0", "v4l2:/dev/videoN"),
            ("udp://host", "needs a port"),
            ("udp://:99999", "not a number"),
            ("udp://:0", "port 0"),
            ("rtsp://", "no host"),
            ("file://relative.mp4", "absolute path"),
            ("gopher://x", "unknown URI scheme `gopher`"),
            ("videotestsrc ! appsink", "appsink"),
        ] {
            let e = SourceSpec::parse(s).unwrap_err().to_string();
            assert!(e.contains(needle), "{s}: {e}");
            assert!(e.contains(&format!("`{s}`")), "{s}: {e}");
        }
    }

    #[test]
    fn descriptions_quote_paths() {
        let d = SourceSpec::V4l2 {
            device: "/dev/video\"0".into(),
        }
        .gst_description((640, 480), 25)
        .unwrap();
        assert!(d.contains("device=\"/dev/video\\\"0\""), "{d}");
        assert!(SourceSpec::Sim.gst_description((640, 480), 25).is_none());
    }
}
