//! `.ass` (Advanced SubStation Alpha v4+) subtitles: the telemetry that VLC, mpv and
//! ffmpeg show over an exported video. The caller provides the text of each line (e.g.
//! with [`telemetry_text`]); this module writes the file.
//!
//! Times in the file count from the video's first frame: lines carry session times and
//! [`write_ass`] subtracts the video's origin, so the text lines up with the MP4 that
//! [`crate::export`] writes from the same session.

use std::fmt::Write as _;

/// One subtitle line, on the session clock.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SubtitleLine {
    /// Shown from, ns.
    pub start_ns: u64,
    /// Shown until, ns (> `start_ns`).
    pub end_ns: u64,
    /// Text; `\n` starts a new line.
    pub text: String,
}

/// Lines from timed texts: each shown until the next one starts, the last for
/// `last_duration_ns`. Unsorted input is sorted; lines of zero length are dropped.
pub fn lines_from_samples(
    mut samples: Vec<(u64, String)>,
    last_duration_ns: u64,
) -> Vec<SubtitleLine> {
    samples.sort_by_key(|(t, _)| *t);
    let ends: Vec<u64> = samples
        .iter()
        .skip(1)
        .map(|(t, _)| *t)
        .chain(std::iter::once(
            samples
                .last()
                .map_or(0, |(t, _)| t.saturating_add(last_duration_ns)),
        ))
        .collect();
    samples
        .into_iter()
        .zip(ends)
        .filter(|((start, _), end)| end > start)
        .map(|((start_ns, text), end_ns)| SubtitleLine {
            start_ns,
            end_ns,
            text,
        })
        .collect()
}

/// What one telemetry line shows.
#[derive(Debug, Clone, PartialEq)]
pub struct TelemetryText {
    /// Seconds since the session start.
    pub t_s: f64,
    /// Depth, m.
    pub depth_m: f64,
    /// Heading, degrees.
    pub heading_deg: f64,
    /// Pitch, degrees.
    pub pitch_deg: f64,
    /// Roll, degrees.
    pub roll_deg: f64,
    /// Autopilot state, e.g. "depth 3.0 m, heading 090°" or "manual".
    pub autopilot: String,
}

/// The standard telemetry text: `T+12.3 s  depth 3.02 m  heading 090°` on the first line,
/// `pitch −1.2°  roll 0.4°  AP …` on the second. Non-finite values show as `--`.
pub fn telemetry_text(t: &TelemetryText) -> String {
    let num = |v: f64, prec: usize| {
        if v.is_finite() {
            format!("{v:.prec$}")
        } else {
            "--".to_owned()
        }
    };
    let heading = if t.heading_deg.is_finite() {
        format!("{}°", rov_types::angle::compass_text(t.heading_deg))
    } else {
        "--".to_owned()
    };
    format!(
        "T+{} s  depth {} m  heading {heading}\npitch {}°  roll {}°  AP {}",
        num(t.t_s, 1),
        num(t.depth_m, 2),
        num(t.pitch_deg, 1),
        num(t.roll_deg, 1),
        t.autopilot
    )
}

/// `h:mm:ss.cc` (centiseconds, rounded down).
fn ass_time(ns: u64) -> String {
    let cs = ns / 10_000_000;
    let (h, rem) = (cs / 360_000, cs % 360_000);
    let (m, rem) = (rem / 6000, rem % 6000);
    let (s, c) = (rem / 100, rem % 100);
    format!("{h}:{m:02}:{s:02}.{c:02}")
}

/// Escapes text for an event line: braces would start override codes, a backslash an
/// escape, and a newline becomes `\N`.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '{' => out.push('('),
            '}' => out.push(')'),
            '\\' => out.push('/'),
            '\n' => out.push_str("\\N"),
            '\r' => {}
            c => out.push(c),
        }
    }
    out
}

/// The `.ass` file text. `origin_ns` is the session time of the video's first frame
/// (lines before it are cut at 0); `size_px` is the video size (the script resolution, so
/// the font scales with the picture).
pub fn write_ass(
    lines: &[SubtitleLine],
    origin_ns: u64,
    size_px: (u32, u32),
    title: &str,
) -> String {
    let (w, h) = (size_px.0.max(1), size_px.1.max(1));
    let font_px = (h / 24).max(10);
    let margin = (h / 40).max(4);
    let mut s = String::new();
    let _ = write!(
        s,
        "[Script Info]\n\
         ; Written by topside (rov_video)\n\
         Title: {}\n\
         ScriptType: v4.00+\n\
         WrapStyle: 2\n\
         ScaledBorderAndShadow: yes\n\
         PlayResX: {w}\n\
         PlayResY: {h}\n\
         \n\
         [V4+ Styles]\n\
         Format: Name, Fontname, Fontsize, PrimaryColour, SecondaryColour, OutlineColour, BackColour, Bold, Italic, Underline, StrikeOut, ScaleX, ScaleY, Spacing, Angle, BorderStyle, Outline, Shadow, Alignment, MarginL, MarginR, MarginV, Encoding\n\
         Style: Telemetry,DejaVu Sans Mono,{font_px},&H00FFFFFF,&H000000FF,&H00000000,&H80000000,0,0,0,0,100,100,0,0,1,2,0,1,{margin},{margin},{margin},1\n\
         \n\
         [Events]\n\
         Format: Layer, Start, End, Style, Name, MarginL, MarginR, MarginV, Effect, Text\n",
        escape(title).replace("\\N", " ")
    );
    for l in lines {
        if l.end_ns <= origin_ns || l.end_ns <= l.start_ns {
            continue;
        }
        let start = l.start_ns.saturating_sub(origin_ns);
        let end = l.end_ns - origin_ns;
        let _ = writeln!(
            s,
            "Dialogue: 0,{},{},Telemetry,,0,0,0,,{}",
            ass_time(start),
            ass_time(end),
            escape(&l.text)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_escapes() {
        assert_eq!(ass_time(0), "0:00:00.00");
        assert_eq!(ass_time(3_723_450_000_000), "1:02:03.45");
        assert_eq!(escape("a{b}\\c\nd"), "a(b)/c\\Nd");
    }

    #[test]
    fn samples_become_contiguous_lines() {
        let l = lines_from_samples(
            vec![
                (2_000, "b".into()),
                (1_000, "a".into()),
                (2_000, "dup".into()),
            ],
            500,
        );
        assert_eq!(l.len(), 2);
        assert_eq!(
            (l[0].start_ns, l[0].end_ns, l[0].text.as_str()),
            (1_000, 2_000, "a")
        );
        assert_eq!((l[1].start_ns, l[1].end_ns), (2_000, 2_500));
    }

    #[test]
    fn file_has_header_and_events() {
        let lines = lines_from_samples(
            vec![
                (1_000_000_000, "one".into()),
                (2_000_000_000, "two\nlines".into()),
            ],
            1_000_000_000,
        );
        let text = write_ass(&lines, 1_500_000_000, (640, 480), "dive");
        assert!(text.starts_with("[Script Info]"));
        assert!(text.contains("PlayResX: 640"));
        let events: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("Dialogue:"))
            .collect();
        assert_eq!(events.len(), 2);
        assert_eq!(
            events[0],
            "Dialogue: 0,0:00:00.00,0:00:00.50,Telemetry,,0,0,0,,one"
        );
        assert_eq!(
            events[1],
            "Dialogue: 0,0:00:00.50,0:00:01.50,Telemetry,,0,0,0,,two\\Nlines"
        );
    }

    #[test]
    fn telemetry_text_shows_every_field() {
        let t = telemetry_text(&TelemetryText {
            t_s: 12.34,
            depth_m: 3.017,
            heading_deg: -270.0,
            pitch_deg: -1.25,
            roll_deg: f64::NAN,
            autopilot: "depth 3.0 m".into(),
        });
        assert_eq!(
            t,
            "T+12.3 s  depth 3.02 m  heading 090°\npitch -1.2°  roll --°  AP depth 3.0 m"
        );
    }
}
