//! The crate's error type: every variant names the source (or the file, or the element)
//! and what is missing or wrong, so a message can go to the pilot as it is.

use std::path::PathBuf;

/// An error of the video crate.
#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    /// GStreamer itself could not start (libraries missing or broken).
    #[error("GStreamer could not start: {reason}")]
    GstInit {
        /// What GStreamer said.
        reason: String,
    },
    /// A source specification that does not parse.
    #[error(
        "video source `{spec}`: {reason} (expected sim, none, test, v4l2:/dev/videoN, rtsp://…, udp://[HOST]:PORT, file:///PATH or a GStreamer pipeline)"
    )]
    BadSourceSpec {
        /// The text given.
        spec: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A GStreamer element is not installed.
    #[error(
        "{context}: the GStreamer element `{element}` is not installed (Debian package {package})"
    )]
    MissingPlugin {
        /// The source or job that needs it.
        context: String,
        /// The element's factory name.
        element: String,
        /// The Debian package that provides it.
        package: &'static str,
    },
    /// A pipeline description that GStreamer rejects.
    #[error("{context}: bad GStreamer pipeline `{description}`: {reason}")]
    BadPipeline {
        /// The source or job.
        context: String,
        /// The description.
        description: String,
        /// GStreamer's message.
        reason: String,
    },
    /// A capture device that does not exist or is not a capture device.
    #[error("video source `{source_name}`: no capture device at {}", path.display())]
    DeviceMissing {
        /// The source as given.
        source_name: String,
        /// The device path.
        path: PathBuf,
    },
    /// A running pipeline failed.
    #[error("{context}: {reason}")]
    Pipeline {
        /// The source or job.
        context: String,
        /// What GStreamer reported (element and message).
        reason: String,
    },
    /// Something did not happen in time.
    #[error("{context}: {what} within {waited_ms} ms")]
    Timeout {
        /// The source or job.
        context: String,
        /// What was awaited, e.g. "no frame".
        what: String,
        /// How long we waited, ms.
        waited_ms: u64,
    },
    /// A frame whose pixel buffer does not match its size.
    #[error(
        "video frame {width_px}×{height_px}: RGBA buffer of {len_bytes} bytes, expected {expected_bytes}"
    )]
    FrameSize {
        /// Width, px.
        width_px: u32,
        /// Height, px.
        height_px: u32,
        /// Bytes given.
        len_bytes: usize,
        /// Bytes expected (width × height × 4).
        expected_bytes: usize,
    },
    /// A setting outside its allowed range.
    #[error("video setting `{field}` = {value} is outside the allowed range {allowed}")]
    InvalidConfig {
        /// The setting.
        field: &'static str,
        /// Its value, as text.
        value: String,
        /// What is accepted.
        allowed: &'static str,
    },
    /// The encoder or decoder thread has stopped (after an error or `finish`).
    #[error("{context}: stopped ({reason})")]
    Stopped {
        /// Encoder or decoder.
        context: &'static str,
        /// Why.
        reason: String,
    },
    /// Nothing to export: the session holds no decodable video.
    #[error("{context}: {reason}")]
    NoVideo {
        /// The job.
        context: String,
        /// What is missing.
        reason: String,
    },
    /// A file could not be written or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
}

/// Shorthand.
pub type Result<T, E = VideoError> = std::result::Result<T, E>;
