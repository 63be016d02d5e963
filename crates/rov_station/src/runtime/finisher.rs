//! Finishing a recording off the control thread.
//!
//! Stopping a recording means waiting: the video encoder delivers its last access units
//! (up to [`crate::runtime::video::FINISH_TIMEOUT`]), then the recorder drains its queue,
//! writes the summary and syncs the file. None of that may hold up a control tick ("video
//! and the GUI never hold up the control loop"), so the control thread hands the
//! [`Recorder`] and the recording's encoder to a `station-rec-finish` thread and keeps
//! ticking. The engine polls the finished ones once per tick ([`Finishers::poll`], no
//! waiting, no allocation while none is running), and the view lists the files being
//! saved until each is saved ([`crate::runtime::RecordingView::finishing`]).
//!
//! A new recording may start while an older one finishes (they are separate files,
//! writers and encoders); one to a file still being saved is refused with the reason.
//! At the station's exit every finisher is waited for, at most [`EXIT_WAIT`] in all
//! ([`Finishers::wait_all`]); a file still unfinished then is named (the recorder
//! thread keeps writing until the process ends; `rov_session::recover` reads a file
//! without its summary).

use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rov_session::WriteSummary;

use crate::runtime::recorder::{Recorder, RecorderError};

/// How long the station's exit waits for recordings still being saved, in all.
pub const EXIT_WAIT: Duration = Duration::from_secs(10);

/// The outcome of finishing one recording.
#[derive(Debug)]
pub(crate) struct Finished {
    /// The file.
    pub path: PathBuf,
    /// Why the video's last units may be missing (the encoder failed or timed out).
    pub video_error: Option<String>,
    /// The writer's summary, or its error.
    pub result: Result<WriteSummary, RecorderError>,
}

#[derive(Debug)]
struct Finishing {
    path: PathBuf,
    state: State,
}

#[derive(Debug)]
enum State {
    Thread(JoinHandle<Finished>),
    /// Finished where it was handed over (no thread could be started).
    Done(Finished),
}

/// The recordings being finished; see the [module docs](self).
#[derive(Debug, Default)]
pub(crate) struct Finishers {
    running: Vec<Finishing>,
}

/// Finishes one recording: the encoder's last units first (they go to the recorder's
/// queue), then the writer.
fn finish(recorder: Recorder, encoder: Option<rov_video::Encoder>) -> Finished {
    #[cfg(test)]
    test_gate::wait();
    let video_error = encoder.and_then(|e| {
        e.finish(crate::runtime::video::FINISH_TIMEOUT)
            .err()
            .map(|e| e.to_string())
    });
    let path = recorder.path().to_path_buf();
    Finished {
        path,
        video_error,
        result: recorder.stop(),
    }
}

impl Finishers {
    /// Hands a stopped recording to a finisher thread. If no thread can be started the
    /// recording is finished here (waiting) rather than lost.
    pub fn start(&mut self, recorder: Recorder, encoder: Option<rov_video::Encoder>) {
        let path = recorder.path().to_path_buf();
        // The closure owns both; if the thread cannot start they come back with the error.
        let parts = std::sync::Arc::new(std::sync::Mutex::new(Some((recorder, encoder))));
        let theirs = std::sync::Arc::clone(&parts);
        let spawned = std::thread::Builder::new()
            .name("station-rec-finish".into())
            .spawn(move || {
                // Started by the control thread: not at its real-time priority.
                crate::runtime::priority::normal_current();
                let taken = theirs
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner)
                    .take();
                match taken {
                    Some((r, e)) => finish(r, e),
                    None => unreachable_finished(),
                }
            });
        let state = match spawned {
            Ok(join) => State::Thread(join),
            Err(_) => {
                let taken = parts
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner)
                    .take();
                State::Done(match taken {
                    Some((r, e)) => finish(r, e),
                    None => unreachable_finished(),
                })
            }
        };
        self.running.push(Finishing { path, state });
    }

    /// Whether `path` is being finished now.
    pub fn is_finishing(&self, path: &Path) -> bool {
        self.running.iter().any(|f| f.path == path)
    }

    /// Whether any recording is being finished.
    pub fn is_empty(&self) -> bool {
        self.running.is_empty()
    }

    /// The files being finished, oldest first.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.running.iter().map(|f| f.path.as_path())
    }

    /// Hands every finished recording to `done`, without waiting.
    pub fn poll(&mut self, mut done: impl FnMut(Finished)) {
        let mut i = 0;
        while i < self.running.len() {
            let ready = self.running.get(i).is_some_and(|f| match &f.state {
                State::Thread(j) => j.is_finished(),
                State::Done(_) => true,
            });
            if ready {
                let f = self.running.remove(i);
                done(joined(f));
            } else {
                i += 1;
            }
        }
    }

    /// Waits for every finisher, at most `limit` in all; the finished ones go to `done`.
    /// Returns the files still unfinished when the time ran out.
    pub fn wait_all(&mut self, limit: Duration, mut done: impl FnMut(Finished)) -> Vec<PathBuf> {
        let until = Instant::now() + limit;
        loop {
            self.poll(&mut done);
            if self.running.is_empty() || Instant::now() >= until {
                break;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        self.running.drain(..).map(|f| f.path).collect()
    }
}

fn joined(f: Finishing) -> Finished {
    match f.state {
        State::Done(d) => d,
        State::Thread(j) => j.join().unwrap_or(Finished {
            path: f.path,
            video_error: None,
            result: Err(RecorderError::FinisherPanicked),
        }),
    }
}

/// The parts were taken twice: cannot happen (one taker each), reported as an error
/// rather than a panic.
fn unreachable_finished() -> Finished {
    Finished {
        path: PathBuf::new(),
        video_error: None,
        result: Err(RecorderError::FinishedTwice),
    }
}

/// Tests hold finishers at their start to show the control loop keeps ticking while a
/// recording is being saved (a slow disk or encoder, made deterministic).
#[cfg(test)]
pub(crate) mod test_gate {
    use std::sync::{Condvar, Mutex};

    static CLOSED: Mutex<bool> = Mutex::new(false);
    static OPENED: Condvar = Condvar::new();

    /// Finishers started from now on wait until [`open`].
    pub fn close() {
        *CLOSED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = true;
    }

    /// Lets every waiting finisher go on.
    pub fn open() {
        *CLOSED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = false;
        OPENED.notify_all();
    }

    pub(super) fn wait() {
        let mut g = CLOSED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        while *g {
            g = OPENED
                .wait(g)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }
}
