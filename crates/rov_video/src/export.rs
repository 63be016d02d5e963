//! Export: a session's access units as an MP4 (H.264) plus the `.ass` telemetry
//! subtitles beside it, optionally with the same text burned into the picture.
//!
//! * **Passthrough** (default): `appsrc → h264parse → mp4mux → filesink`; the recorded
//!   units are stored as they are (no re-encoding, no quality loss, fast).
//! * **Overlay**: `appsrc → h264parse → avdec_h264 → textoverlay (text from a second
//!   appsrc, timed like the subtitles) → x264enc → h264parse → mp4mux`; the text of each
//!   subtitle line is drawn into the frames it covers.
//!
//! Units before the first key frame cannot be decoded and are left out; units failing
//! the structural check ([`crate::annexb::check`]) are skipped; both are counted. The MP4
//! starts at the first key frame's time, and so do the subtitle times.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Duration;

use gstreamer as gst;
use gstreamer::prelude::*;
use gstreamer_app as gst_app;

use crate::annexb::{self, AccessUnit};
use crate::error::{Result, VideoError};
use crate::gst_util;
use crate::subtitles::{SubtitleLine, write_ass};

/// What an export did.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportSummary {
    /// The MP4 written.
    pub mp4: PathBuf,
    /// The `.ass` written beside it.
    pub ass: PathBuf,
    /// Units written (passthrough) or frames encoded (overlay).
    pub frames: u64,
    /// Units before the first key frame, left out.
    pub skipped_before_key: u64,
    /// Units that failed the structural check, skipped.
    pub malformed: u64,
    /// Session time of the first frame, ns (the MP4's and the subtitles' zero).
    pub origin_ns: u64,
    /// Duration of the video, s (last frame's time − first + one frame).
    pub duration_s: f64,
    /// Video size, px (from the decoder in overlay mode, from the caller otherwise).
    pub size_px: (u32, u32),
}

/// Export settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// Burn the subtitle text into the frames (re-encodes).
    pub overlay: bool,
    /// Video size for the `.ass` script resolution, px.
    pub size_px: (u32, u32),
    /// Duration of the last frame when it cannot be measured, ns.
    pub last_frame_ns: u64,
    /// Title written into the `.ass` file.
    pub title: String,
    /// Bit rate of the re-encoded video in overlay mode, kbit/s.
    pub overlay_bitrate_kbit_s: u32,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            overlay: false,
            size_px: (640, 480),
            last_frame_ns: 40_000_000,
            title: "topside session".to_owned(),
            overlay_bitrate_kbit_s: 2000,
        }
    }
}

/// The `.ass` path beside an MP4 (`dive.mp4` → `dive.ass`).
pub fn ass_path(mp4: &Path) -> PathBuf {
    mp4.with_extension("ass")
}

const CONTEXT: &str = "video export";

/// Writes `out` (MP4) and `out` with extension `.ass` from the access units (in time
/// order; an iterator so a long session is never held in memory) and the subtitle lines
/// (session times).
///
/// # Errors
/// [`VideoError::NoVideo`] if no unit is decodable (no key frame), [`VideoError::MissingPlugin`],
/// [`VideoError::Pipeline`] if GStreamer fails, [`VideoError::Io`] for the `.ass` file.
pub fn export_mp4(
    aus: impl IntoIterator<Item = AccessUnit>,
    lines: &[SubtitleLine],
    out: &Path,
    options: &ExportOptions,
) -> Result<ExportSummary> {
    let mut elements = vec!["appsrc", "h264parse", "mp4mux", "filesink"];
    if options.overlay {
        elements.extend(["avdec_h264", "videoconvert", "textoverlay", "x264enc"]);
    }
    gst_util::require_elements(CONTEXT, &elements)?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|source| VideoError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let location = out
        .to_string_lossy()
        .replace('\\', "\\\\")
        .replace('"', "\\\"");
    let description = if options.overlay {
        format!(
            "appsrc name=src format=time is-live=false block=true max-bytes=4000000 \
               caps=video/x-h264,stream-format=byte-stream,alignment=au \
             ! h264parse ! avdec_h264 max-threads=1 output-corrupt=false max-errors=-1 ! videoconvert \
             ! textoverlay name=ov valignment=bottom halignment=left line-alignment=left \
               font-desc=\"DejaVu Sans Mono, 14\" shaded-background=true \
             ! videoconvert ! x264enc tune=zerolatency speed-preset=superfast bitrate={} bframes=0 key-int-max=50 \
             ! h264parse ! mp4mux ! filesink location=\"{location}\" \
             appsrc name=text format=time is-live=false caps=text/x-raw,format=utf8 ! ov.text_sink",
            options.overlay_bitrate_kbit_s.clamp(100, 20_000)
        )
    } else {
        format!(
            "appsrc name=src format=time is-live=false block=true max-bytes=4000000 \
               caps=video/x-h264,stream-format=byte-stream,alignment=au \
             ! h264parse ! mp4mux ! filesink location=\"{location}\""
        )
    };
    let pipeline = gst_util::parse_pipeline(CONTEXT, &description)?;
    let src: gst_app::AppSrc = gst_util::by_name(CONTEXT, &pipeline, "src")?;
    let text_src: Option<gst_app::AppSrc> = if options.overlay {
        Some(gst_util::by_name(CONTEXT, &pipeline, "text")?)
    } else {
        None
    };
    gst_util::set_state(CONTEXT, &pipeline, gst::State::Playing)?;
    let result = feed(&pipeline, &src, text_src.as_ref(), aus, lines, options);
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let _ = pipeline.set_state(gst::State::Null);
            let _ = fs::remove_file(out);
            return Err(e);
        }
    };
    let wait = gst_util::wait_eos(CONTEXT, &pipeline, Duration::from_secs(600));
    let _ = pipeline.set_state(gst::State::Null);
    wait?;
    let (frames, skipped_before_key, malformed, origin_ns, duration_ns) = summary;
    let ass = ass_path(out);
    let text = write_ass(lines, origin_ns, options.size_px, &options.title);
    fs::write(&ass, text).map_err(|source| VideoError::Io {
        path: ass.clone(),
        source,
    })?;
    Ok(ExportSummary {
        mp4: out.to_path_buf(),
        ass,
        frames,
        skipped_before_key,
        malformed,
        origin_ns,
        duration_s: duration_ns as f64 * 1e-9,
        size_px: options.size_px,
    })
}

type Fed = (u64, u64, u64, u64, u64);

fn push(
    pipeline: &gst::Pipeline,
    src: &gst_app::AppSrc,
    au: AccessUnit,
    origin_ns: u64,
    duration_ns: u64,
) -> Result<()> {
    let pts = au.pts_ns.saturating_sub(origin_ns);
    let key = au.key_frame;
    let mut buffer = gst::Buffer::from_slice(au.data);
    if let Some(b) = buffer.get_mut() {
        b.set_pts(gst::ClockTime::from_nseconds(pts));
        b.set_dts(gst::ClockTime::from_nseconds(pts));
        b.set_duration(gst::ClockTime::from_nseconds(duration_ns));
        if !key {
            b.set_flags(gst::BufferFlags::DELTA_UNIT);
        }
    }
    src.push_buffer(buffer)
        .map(|_| ())
        .map_err(|e| VideoError::Pipeline {
            context: CONTEXT.to_owned(),
            reason: gst_util::bus_error_now(pipeline)
                .unwrap_or_else(|| format!("the muxer refused data: {e:?}")),
        })
}

fn push_text(src: &gst_app::AppSrc, lines: &[SubtitleLine], origin_ns: u64) {
    for l in lines {
        if l.end_ns <= origin_ns || l.end_ns <= l.start_ns {
            continue;
        }
        let start = l.start_ns.saturating_sub(origin_ns);
        let mut b = gst::Buffer::from_slice(l.text.clone().into_bytes());
        if let Some(m) = b.get_mut() {
            m.set_pts(gst::ClockTime::from_nseconds(start));
            m.set_duration(gst::ClockTime::from_nseconds(l.end_ns - origin_ns - start));
        }
        let _ = src.push_buffer(b);
    }
    let _ = src.end_of_stream();
}

fn feed(
    pipeline: &gst::Pipeline,
    src: &gst_app::AppSrc,
    text: Option<&gst_app::AppSrc>,
    aus: impl IntoIterator<Item = AccessUnit>,
    lines: &[SubtitleLine],
    options: &ExportOptions,
) -> Result<Fed> {
    let mut origin: Option<u64> = None;
    let mut pending: Option<AccessUnit> = None;
    let (mut frames, mut before_key, mut malformed) = (0u64, 0u64, 0u64);
    let mut last_step_ns = options.last_frame_ns.max(1);
    let mut last_pts = 0u64;
    for au in aus {
        if annexb::check(&au.data).is_err() {
            malformed += 1;
            continue;
        }
        let o = match origin {
            Some(o) => o,
            None if au.key_frame => {
                origin = Some(au.pts_ns);
                if let Some(t) = text {
                    push_text(t, lines, au.pts_ns);
                }
                au.pts_ns
            }
            None => {
                before_key += 1;
                continue;
            }
        };
        if let Some(prev) = pending.take() {
            if au.pts_ns <= prev.pts_ns {
                // Out of order or repeated time: keep the earlier unit, drop this one.
                malformed += 1;
                pending = Some(prev);
                continue;
            }
            last_step_ns = au.pts_ns - prev.pts_ns;
            push(pipeline, src, prev, o, last_step_ns)?;
            frames += 1;
        }
        last_pts = au.pts_ns;
        pending = Some(au);
    }
    let Some(o) = origin else {
        return Err(VideoError::NoVideo {
            context: CONTEXT.to_owned(),
            reason: format!(
                "no key frame among the video messages ({before_key} units before any key frame, {malformed} malformed): nothing can be decoded"
            ),
        });
    };
    if let Some(prev) = pending.take() {
        push(pipeline, src, prev, o, last_step_ns)?;
        frames += 1;
    }
    let _ = src.end_of_stream();
    let duration_ns = last_pts.saturating_sub(o) + last_step_ns;
    Ok((frames, before_key, malformed, o, duration_ns))
}
