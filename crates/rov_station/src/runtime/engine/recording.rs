//! Recording start, stop and the off-thread save (finishers) of the engine.

use super::*;

impl Engine {
    pub(super) fn start_recording(&mut self, path: &std::path::Path, now_us: u64) {
        if self.recorder.is_some() {
            self.stop_recording(now_us);
        }
        if self.finishers.is_finishing(path) {
            let e = format!(
                "{} is still being saved from the last recording; record to another file",
                file_name(path)
            );
            self.pipeline.view.recording.error = Some(e.clone());
            self.event(
                now_us,
                "recording",
                Severity::Warning,
                format!("cannot record: {e}"),
            );
            return;
        }
        let info = SessionInfo {
            vehicle: self.source_label.clone(),
            software_version: env!("CARGO_PKG_VERSION").to_string(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64()),
            config_toml: self.cfg.config_toml.clone(),
        };
        match Recorder::start(path, &info, now_us, self.cfg.record_blocking) {
            Ok(r) => {
                self.last_record_ns.set(0);
                let video = self
                    .video
                    .as_ref()
                    .map(|v| v.begin_recording(r.video_tap().with_live(self.live.clone())));
                self.recorder = Some(r);
                if let Some(Err(e)) = video {
                    // The error says "recording without video" itself.
                    self.event(now_us, "recording", Severity::Warning, e.to_string());
                }
                let v = &mut self.pipeline.view.recording;
                v.path = Some(path.to_path_buf());
                v.error = None;
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!("recording to {}", file_name(path)),
                );
            }
            Err(e) => {
                self.pipeline.view.recording.error = Some(e.to_string());
                self.event(
                    now_us,
                    "recording",
                    Severity::Warning,
                    format!("cannot record: {e}"),
                );
            }
        }
    }

    /// Stops the recording: its encoder and writer are handed to a finisher thread (the
    /// encoder's last units, the summary and the sync take up to seconds the control
    /// loop must not spend); the view lists the file as being saved until it is. On
    /// virtual time (`record_blocking`) the file is finished before this returns.
    pub fn stop_recording(&mut self, now_us: u64) {
        let Some(r) = self.recorder.take() else {
            return;
        };
        let path = r.path().to_path_buf();
        let encoder = self.video.as_ref().and_then(|v| v.detach_recording());
        self.finishers.start(r, encoder);
        let v = &mut self.pipeline.view.recording;
        v.path = None;
        v.elapsed_s = 0.0;
        self.event(
            now_us,
            "recording",
            Severity::Info,
            format!("recording stopped: {}, saving", file_name(&path)),
        );
        if self.cfg.record_blocking {
            // Virtual time: no real-time loop to protect, and the run's next step may
            // read the file.
            self.wait_for_finishers(EXIT_WAIT, now_us);
        } else {
            self.show_finishing();
        }
    }

    /// The files being saved, in the view (changed only when the list changes).
    pub(super) fn show_finishing(&mut self) {
        let v = &mut self.pipeline.view.recording.finishing;
        if !v.iter().map(PathBuf::as_path).eq(self.finishers.paths()) {
            *v = self.finishers.paths().map(Path::to_path_buf).collect();
        }
    }

    /// Takes in the recordings saved since the last call (each tick; never waits).
    pub(super) fn poll_finishers(&mut self, now_us: u64) {
        if self.finishers.is_empty() {
            return;
        }
        let mut done = Vec::new();
        self.finishers.poll(|f| done.push(f));
        for f in done {
            self.saved(f, now_us);
        }
        self.show_finishing();
    }

    /// Waits for every recording being saved, at most `limit` in all.
    pub(super) fn wait_for_finishers(&mut self, limit: std::time::Duration, now_us: u64) {
        let mut done = Vec::new();
        let left = self.finishers.wait_all(limit, |f| done.push(f));
        for f in done {
            self.saved(f, now_us);
        }
        for p in left {
            let e = format!(
                "{} was not finished within {} s; open it to recover what was written",
                file_name(&p),
                limit.as_secs()
            );
            self.pipeline.view.recording.error = Some(e.clone());
            self.event(now_us, "recording", Severity::Warning, e);
        }
        self.show_finishing();
    }

    /// A recording is saved (or failed): the view and the events say so.
    pub(super) fn saved(&mut self, f: Finished, now_us: u64) {
        let name = file_name(&f.path);
        if let Some(e) = f.video_error {
            self.event(
                now_us,
                "recording",
                Severity::Warning,
                format!("video recording of {name} ended with an error: {e}"),
            );
        }
        let recording = self.recorder.is_some();
        let v = &mut self.pipeline.view.recording;
        match f.result {
            Ok(s) => {
                v.last_file = Some(f.path);
                if !recording {
                    v.messages = s.messages;
                }
                self.event(
                    now_us,
                    "recording",
                    Severity::Info,
                    format!("recording saved: {name} ({} messages)", s.messages),
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
