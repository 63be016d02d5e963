//! Small GStreamer helpers shared by capture, encoding, decoding and export: start-up,
//! building a pipeline from a description with errors that name the missing element and
//! its Debian package, reading bus errors, and waiting for the end of a stream.

use std::time::{Duration, Instant};

use gstreamer as gst;
use gstreamer::prelude::*;

use crate::error::{Result, VideoError};

/// Starts GStreamer (idempotent, thread-safe). Every entry point of the crate calls it.
///
/// # Errors
/// [`VideoError::GstInit`] if the GStreamer libraries cannot start.
pub fn init() -> Result<()> {
    gst::init().map_err(|e| VideoError::GstInit {
        reason: e.to_string(),
    })
}

/// The Debian 12 package that provides a GStreamer element (for error messages).
pub fn package_of(element: &str) -> &'static str {
    match element {
        "videotestsrc" | "videoconvert" | "videoscale" | "videorate" | "appsrc" | "appsink"
        | "timeoverlay" | "textoverlay" | "clockoverlay" | "decodebin" | "uridecodebin"
        | "playbin" | "capsfilter" | "queue" | "fakesink" | "filesrc" | "filesink" => {
            "gstreamer1.0-plugins-base"
        }
        "v4l2src" | "rtspsrc" | "udpsrc" | "udpsink" | "rtph264depay" | "rtph264pay"
        | "rtpjitterbuffer" | "mp4mux" | "qtdemux" | "deinterlace" | "jpegdec"
        | "matroskademux" | "matroskamux" | "souphttpsrc" => "gstreamer1.0-plugins-good",
        "h264parse" | "assrender" => "gstreamer1.0-plugins-bad",
        "x264enc" => "gstreamer1.0-plugins-ugly",
        "avdec_h264" | "avdec_h265" => "gstreamer1.0-libav",
        _ => "of a GStreamer plugin that provides it (see gst-inspect-1.0)",
    }
}

/// Checks that every element is installed.
///
/// # Errors
/// [`VideoError::MissingPlugin`] for the first missing element.
pub fn require_elements(context: &str, elements: &[&str]) -> Result<()> {
    init()?;
    for name in elements {
        if gst::ElementFactory::find(name).is_none() {
            return Err(missing(context, name));
        }
    }
    Ok(())
}

pub(crate) fn missing(context: &str, element: &str) -> VideoError {
    VideoError::MissingPlugin {
        context: context.to_owned(),
        element: element.to_owned(),
        package: package_of(element),
    }
}

/// Builds a pipeline from a `gst-launch-1.0` style description.
///
/// # Errors
/// [`VideoError::MissingPlugin`] naming the first element that is not installed,
/// [`VideoError::BadPipeline`] for any other parse error.
pub fn parse_pipeline(context: &str, description: &str) -> Result<gst::Pipeline> {
    init()?;
    let mut ctx = gst::ParseContext::new();
    let parsed =
        gst::parse::launch_full(description, Some(&mut ctx), gst::ParseFlags::FATAL_ERRORS);
    let element = match parsed {
        Ok(e) => e,
        Err(err) => {
            if let Some(name) = ctx.missing_elements().first() {
                return Err(missing(context, name));
            }
            return Err(VideoError::BadPipeline {
                context: context.to_owned(),
                description: description.to_owned(),
                reason: err.to_string(),
            });
        }
    };
    match element.downcast::<gst::Pipeline>() {
        Ok(p) => Ok(p),
        Err(single) => {
            // A description with one element: wrap it.
            let pipeline = gst::Pipeline::new();
            pipeline.add(&single).map_err(|e| VideoError::BadPipeline {
                context: context.to_owned(),
                description: description.to_owned(),
                reason: e.to_string(),
            })?;
            Ok(pipeline)
        }
    }
}

/// A bus error as one line: the element that failed, its message, and what GStreamer's
/// debug text says is missing (a decoder, an element) or its last line.
pub fn describe_error(err: &gst::message::Error) -> String {
    let src = err
        .src()
        .map(|s| s.path_string().to_string())
        .unwrap_or_else(|| "pipeline".to_owned());
    let mut text = format!("{src}: {}", err.error());
    if let Some(dbg) = err.debug() {
        if let Some(m) = missing_from_debug(&dbg) {
            text = format!("{m} is not installed ({src})");
        } else if let Some(last) = dbg.lines().map(str::trim).rfind(|l| !l.is_empty()) {
            let detail: String = last
                .rsplit("): ")
                .next()
                .unwrap_or(last)
                .chars()
                .take(160)
                .collect();
            if !detail.is_empty() && !text.contains(&detail) {
                text.push_str(" (");
                text.push_str(&detail);
                text.push(')');
            }
        }
    }
    text
}

/// "Missing decoder: H.264 (High 4:4:4 Profile)" from a decodebin debug text, without the
/// caps that follow.
fn missing_from_debug(dbg: &str) -> Option<String> {
    let line = dbg
        .lines()
        .find(|l| l.contains("Missing decoder:") || l.contains("Missing element:"))?;
    let start = line.find("Missing ")?;
    let rest = line.get(start..)?;
    let end = [
        " (video/",
        " (audio/",
        " (application/",
        " (image/",
        " (text/",
    ]
    .iter()
    .filter_map(|p| rest.find(p))
    .min()
    .unwrap_or(rest.len());
    rest.get(..end).map(|s| s.trim().to_owned())
}

/// A missing-plugin message (a decoder that decodebin could not find), as text.
pub fn describe_missing_plugin(msg: &gst::MessageRef) -> Option<String> {
    gstreamer_pbutils::MissingPluginMessage::parse(msg)
        .ok()
        .map(|m| m.description().to_string())
}

/// Sets a state and reports a failure with the bus's reason.
///
/// # Errors
/// [`VideoError::Pipeline`] with the element and message from the bus.
pub fn set_state(
    context: &str,
    pipeline: &gst::Pipeline,
    state: gst::State,
) -> Result<gst::StateChangeSuccess> {
    pipeline.set_state(state).map_err(|_| VideoError::Pipeline {
        context: context.to_owned(),
        reason: bus_error_now(pipeline)
            .unwrap_or_else(|| format!("the pipeline refused to go to {state:?}")),
    })
}

/// The first error (or missing plugin) waiting on the bus, if any.
pub fn bus_error_now(pipeline: &gst::Pipeline) -> Option<String> {
    let bus = pipeline.bus()?;
    let mut missing_plugin = None;
    while let Some(msg) = bus.pop_filtered(&[gst::MessageType::Error, gst::MessageType::Element]) {
        match msg.view() {
            gst::MessageView::Error(e) => {
                return Some(match missing_plugin {
                    Some(m) => format!("{m} is not installed; {}", describe_error(e)),
                    None => describe_error(e),
                });
            }
            _ => {
                if let Some(m) = describe_missing_plugin(&msg) {
                    missing_plugin = Some(m);
                }
            }
        }
    }
    missing_plugin.map(|m| format!("{m} is not installed"))
}

/// Waits for the end of stream (or an error) on the bus.
///
/// # Errors
/// [`VideoError::Pipeline`] on a bus error, [`VideoError::Timeout`] if neither came.
pub fn wait_eos(context: &str, pipeline: &gst::Pipeline, timeout: Duration) -> Result<()> {
    let bus = pipeline.bus().ok_or_else(|| VideoError::Pipeline {
        context: context.to_owned(),
        reason: "the pipeline has no bus".to_owned(),
    })?;
    let deadline = Instant::now() + timeout;
    let mut missing_plugin: Option<String> = None;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(VideoError::Timeout {
                context: context.to_owned(),
                what: "the stream did not end".to_owned(),
                waited_ms: u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX),
            });
        }
        let Some(msg) = bus.timed_pop_filtered(
            gst::ClockTime::from_nseconds(u64::try_from(left.as_nanos()).unwrap_or(u64::MAX)),
            &[
                gst::MessageType::Eos,
                gst::MessageType::Error,
                gst::MessageType::Element,
            ],
        ) else {
            continue;
        };
        match msg.view() {
            gst::MessageView::Eos(_) => return Ok(()),
            gst::MessageView::Error(e) => {
                let mut reason = describe_error(e);
                if let Some(m) = missing_plugin {
                    reason = format!("{m} is not installed; {reason}");
                }
                return Err(VideoError::Pipeline {
                    context: context.to_owned(),
                    reason,
                });
            }
            _ => {
                if let Some(m) = describe_missing_plugin(&msg) {
                    missing_plugin = Some(m);
                }
            }
        }
    }
}

/// A typed element from a pipeline by name.
///
/// # Errors
/// [`VideoError::BadPipeline`] if it is absent or of another type.
pub fn by_name<T: IsA<gst::Element>>(
    context: &str,
    pipeline: &gst::Pipeline,
    name: &str,
) -> Result<T> {
    pipeline
        .by_name(name)
        .and_then(|e| e.downcast::<T>().ok())
        .ok_or_else(|| VideoError::BadPipeline {
            context: context.to_owned(),
            description: name.to_owned(),
            reason: format!("no element named `{name}` of the expected type"),
        })
}

/// The pixels of an RGBA sample, tightly packed (rows copied past any stride padding),
/// with the width and height; `None` if the sample is not readable RGBA video.
pub(crate) fn rgba_of_sample(sample: &gst::Sample) -> Option<(u32, u32, Vec<u8>)> {
    use gstreamer_video::prelude::*;
    let info = gstreamer_video::VideoInfo::from_caps(sample.caps()?).ok()?;
    let buffer = sample.buffer()?;
    let frame = gstreamer_video::VideoFrameRef::from_buffer_ref_readable(buffer, &info).ok()?;
    let (w, h) = (info.width(), info.height());
    let row_bytes = w as usize * 4;
    let stride = usize::try_from(*frame.plane_stride().first()?).ok()?;
    let data = frame.plane_data(0).ok()?;
    let mut rgba = Vec::with_capacity(row_bytes * h as usize);
    for row in data.chunks(stride.max(1)).take(h as usize) {
        rgba.extend_from_slice(row.get(..row_bytes)?);
    }
    Some((w, h, rgba))
}

/// Nanoseconds of a `Duration`, saturating.
pub(crate) fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}
