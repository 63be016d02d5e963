//! A recording as the pilot sees it: the engine stamps the records while one runs and
//! says in the view and the events what the runtime's recorder did (started, refused,
//! stopped, saved). The recorder, its thread and the finishers that save a stopped
//! recording belong to the runtime (`runtime::host`).

use super::*;

impl Engine {
    /// [`Input::RecordingStarted`].
    pub(super) fn recording_started(&mut self, path: PathBuf, now_us: u64) {
        self.recording_started_us = Some(now_us);
        self.last_record_ns = 0;
        let name = file_name(&path);
        let v = &mut self.pipeline.view.recording;
        v.path = Some(path);
        v.error = None;
        self.event(
            now_us,
            "recording",
            Severity::Info,
            format!("recording to {name}"),
        );
    }

    /// [`Input::RecordingRefused`].
    pub(super) fn recording_refused(&mut self, why: String, now_us: u64) {
        self.pipeline.view.recording.error = Some(why.clone());
        self.event(
            now_us,
            "recording",
            Severity::Warning,
            format!("cannot record: {why}"),
        );
    }

    /// [`Input::RecordingProgress`].
    pub(super) fn recording_progress(&mut self, p: RecordingProgress) {
        let v = &mut self.pipeline.view.recording;
        v.messages = p.messages;
        v.dropped = p.dropped;
        if let Some(e) = p.error {
            v.error = Some(e);
        }
    }

    /// [`Input::RecordingStopped`]: the file is being saved.
    pub(super) fn recording_stopped(&mut self, now_us: u64) {
        self.recording_started_us = None;
        let v = &mut self.pipeline.view.recording;
        let path = v.path.take();
        v.elapsed_s = 0.0;
        let name = path.as_deref().map_or_else(String::new, file_name);
        self.event(
            now_us,
            "recording",
            Severity::Info,
            format!("recording stopped: {name}, saving"),
        );
    }

    /// [`Input::Finishing`]: the files being saved, in the view (changed only when the
    /// list changes).
    pub(super) fn show_finishing(&mut self, paths: &[PathBuf]) {
        let v = &mut self.pipeline.view.recording.finishing;
        if v.as_slice() != paths {
            *v = paths.to_vec();
        }
    }

    /// [`Input::Saved`]: a recording is saved (or failed); the view and the events say so.
    pub(super) fn saved(&mut self, s: Saved, now_us: u64) {
        let name = file_name(&s.path);
        if let Some(e) = s.video_error {
            self.event(
                now_us,
                "recording",
                Severity::Warning,
                format!("video recording of {name} ended with an error: {e}"),
            );
        }
        let recording = self.recording();
        let v = &mut self.pipeline.view.recording;
        match s.result {
            Ok(messages) => {
                v.last_file = Some(s.path);
                if !recording {
                    v.messages = messages;
                }
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!("recording saved: {name} ({messages} messages)"),
                );
            }
            Err(e) => {
                v.error = Some(format!("{name}: {e}"));
                self.event(
                    now_us,
                    "recording",
                    Severity::Warning,
                    format!("recording failed: {name}: {e}"),
                );
            }
        }
    }
}
