//! Capture devices for the Connection tab: V4L2 video sources found by GStreamer's
//! device monitor (USB frame grabbers, webcams), each with a ready [`SourceSpec`] and a
//! summary of the formats it offers.

use std::path::PathBuf;

use gstreamer as gst;
use gstreamer::prelude::*;

use crate::error::{Result, VideoError};
use crate::gst_util;
use crate::source::SourceSpec;

/// A capture device.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaptureDevice {
    /// The name the driver gives (e.g. "USB2.0 PC CAMERA" or "AV TO USB2.0").
    pub name: String,
    /// Device node.
    pub path: PathBuf,
    /// The source to capture from it (`v4l2:PATH`).
    pub spec: SourceSpec,
    /// Raw and compressed formats offered, e.g. `YUY2 720×480 @ 30000/1001`, at most 12.
    pub formats: Vec<String>,
}

const MAX_FORMATS: usize = 12;

fn describe_caps(caps: &gst::CapsRef) -> Vec<String> {
    let mut out = Vec::new();
    for s in caps.iter() {
        let kind = match s.name().as_str() {
            "video/x-raw" => s
                .get::<String>("format")
                .unwrap_or_else(|_| "raw".to_owned()),
            "image/jpeg" => "MJPEG".to_owned(),
            "video/x-h264" => "H.264".to_owned(),
            other => other.to_owned(),
        };
        let size = match (s.get::<i32>("width"), s.get::<i32>("height")) {
            (Ok(w), Ok(h)) => format!(" {w}×{h}"),
            _ => String::new(),
        };
        let rate = s
            .get::<gst::Fraction>("framerate")
            .map(|f| format!(" @ {}/{}", f.numer(), f.denom()))
            .unwrap_or_default();
        let text = format!("{kind}{size}{rate}");
        if !out.contains(&text) {
            out.push(text);
        }
        if out.len() >= MAX_FORMATS {
            break;
        }
    }
    out
}

/// The V4L2 capture devices present now (an empty list when there are none).
///
/// # Errors
/// [`VideoError::GstInit`] or [`VideoError::Pipeline`] if the device monitor cannot start.
pub fn list_capture_devices() -> Result<Vec<CaptureDevice>> {
    gst_util::init()?;
    let monitor = gst::DeviceMonitor::new();
    monitor.add_filter(Some("Video/Source"), None);
    monitor.start().map_err(|e| VideoError::Pipeline {
        context: "listing capture devices".to_owned(),
        reason: e.to_string(),
    })?;
    let mut out = Vec::new();
    for dev in monitor.devices() {
        let props = dev.properties();
        let path = props.as_ref().and_then(|p| {
            ["device.path", "api.v4l2.path", "object.path"]
                .iter()
                .find_map(|k| p.get::<String>(*k).ok())
                .filter(|s| s.starts_with("/dev/"))
        });
        let Some(path) = path else {
            continue; // not a V4L2 node (e.g. a PipeWire or libcamera proxy)
        };
        let path = PathBuf::from(path);
        out.push(CaptureDevice {
            name: dev.display_name().to_string(),
            spec: SourceSpec::V4l2 {
                device: path.clone(),
            },
            path,
            formats: dev.caps().map(|c| describe_caps(&c)).unwrap_or_default(),
        });
    }
    monitor.stop();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out.dedup_by(|a, b| a.path == b.path);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_summary() {
        gst_util::init().unwrap();
        let caps: gst::Caps = "video/x-raw,format=YUY2,width=720,height=480,framerate=30000/1001; image/jpeg,width=640,height=480,framerate=30/1; video/x-raw,format=YUY2,width=720,height=480,framerate=30000/1001"
            .parse()
            .unwrap();
        assert_eq!(
            describe_caps(&caps),
            vec![
                "YUY2 720×480 @ 30000/1001".to_owned(),
                "MJPEG 640×480 @ 30/1".to_owned()
            ]
        );
    }
}
