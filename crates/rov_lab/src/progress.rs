//! Progress and cancellation of long lab work (a diagnosis of a whole dive takes minutes).
//!
//! The lab's entry points keep their signatures: a caller that wants progress runs them
//! inside [`Progress::run`], which makes the [`Progress`] the current one of this thread.
//! The lab reports its documented steps ([`Stage`]: "calibrating 3/5", "screening 9/17
//! effects", "term search: yaw") to the current progress, and every model simulation
//! checks whether it was cancelled, so a cancelled diagnosis stops within one simulation
//! of each worker. The lab's worker pool ([`crate::par`]) carries the current progress
//! into its workers. Reading no clock and doing no I/O, this stays a library concern: the
//! CLI draws a bar from the stages, the GUI polls [`Progress::latest`].

use std::cell::RefCell;
use std::fmt;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::LabError;

/// One step of lab work and how far it is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stage {
    /// What is being done ("calibrating", "screening", "term search: yaw").
    pub name: String,
    /// Items done (of `total`).
    pub done: usize,
    /// Items in the step (0 when the step is not counted).
    pub total: usize,
    /// What the items are ("effects", "candidates"; empty for none).
    pub unit: &'static str,
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.total == 0 {
            return f.write_str(&self.name);
        }
        write!(f, "{} {}/{}", self.name, self.done, self.total)?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

/// Called with every stage the work reports (from any of the lab's threads).
type Sink = Box<dyn Fn(&Stage) + Send + Sync>;

struct Inner {
    cancelled: AtomicBool,
    latest: Mutex<Option<Stage>>,
    sink: Option<Sink>,
}

/// The progress of one piece of lab work, and its cancel switch. Clones share both.
#[derive(Clone)]
pub struct Progress {
    inner: Arc<Inner>,
}

impl fmt::Debug for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Progress")
            .field("cancelled", &self.is_cancelled())
            .field("latest", &self.latest())
            .finish()
    }
}

impl Default for Progress {
    fn default() -> Self {
        Self::new()
    }
}

impl Progress {
    /// A progress that only keeps the latest stage (see [`Progress::latest`]).
    pub fn new() -> Self {
        Self::build(None)
    }

    /// A progress that also calls `sink` with every stage (from the lab's threads).
    pub fn with_sink(sink: impl Fn(&Stage) + Send + Sync + 'static) -> Self {
        Self::build(Some(Box::new(sink)))
    }

    fn build(sink: Option<Sink>) -> Self {
        Self {
            inner: Arc::new(Inner {
                cancelled: AtomicBool::new(false),
                latest: Mutex::new(None),
                sink,
            }),
        }
    }

    /// Asks the work to stop: its simulations fail with [`LabError::Cancelled`] from now
    /// on, and [`Progress::run`] returns that error.
    pub fn cancel(&self) {
        self.inner.cancelled.store(true, Ordering::Relaxed);
    }

    /// Whether [`Progress::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.inner.cancelled.load(Ordering::Relaxed)
    }

    /// The last stage reported.
    pub fn latest(&self) -> Option<Stage> {
        self.inner.latest.lock().ok().and_then(|s| s.clone())
    }

    /// Runs `work` with this progress current on this thread (and in the lab's workers).
    /// Returns [`LabError::Cancelled`] when it was cancelled, whatever the work returned
    /// (work cut short may have swallowed a failed simulation and carried on).
    pub fn run<T>(&self, work: impl FnOnce() -> Result<T, LabError>) -> Result<T, LabError> {
        self.run_with(work)
    }

    /// [`Progress::run`] for work whose error type holds the lab's (a caller's own steps
    /// around the lab's, such as reading the files).
    pub fn run_with<T, E: From<LabError>>(
        &self,
        work: impl FnOnce() -> Result<T, E>,
    ) -> Result<T, E> {
        let _current = enter(Some(self.clone()));
        let out = work();
        if self.is_cancelled() {
            return Err(LabError::Cancelled.into());
        }
        out
    }

    /// Reports a stage (the lab reports its own through the current progress; a caller
    /// running steps of its own around the lab's may report those too).
    pub fn report(&self, stage: Stage) {
        if let Some(sink) = &self.inner.sink {
            sink(&stage);
        }
        if let Ok(mut l) = self.inner.latest.lock() {
            *l = Some(stage);
        }
    }
}

thread_local! {
    static CURRENT: RefCell<Option<Progress>> = const { RefCell::new(None) };
}

/// The progress current on this thread.
pub(crate) fn current() -> Option<Progress> {
    CURRENT.with(|c| c.borrow().clone())
}

/// Restores the previous current progress on drop.
pub(crate) struct Entered {
    prev: Option<Progress>,
}

impl Drop for Entered {
    fn drop(&mut self) {
        let prev = self.prev.take();
        CURRENT.with(|c| *c.borrow_mut() = prev);
    }
}

/// Makes `p` the current progress of this thread until the guard drops.
pub(crate) fn enter(p: Option<Progress>) -> Entered {
    let prev = CURRENT.with(|c| std::mem::replace(&mut *c.borrow_mut(), p));
    Entered { prev }
}

/// Reports a stage to the current progress (none: nothing happens).
pub(crate) fn stage(name: impl Into<String>, done: usize, total: usize, unit: &'static str) {
    CURRENT.with(|c| {
        if let Some(p) = c.borrow().as_ref() {
            p.report(Stage {
                name: name.into(),
                done,
                total,
                unit,
            });
        }
    });
}

/// A counted stage whose items finish on any of the lab's workers: each [`Counter::tick`]
/// reports the stage with one more item done.
#[derive(Debug)]
pub(crate) struct Counter {
    name: String,
    total: usize,
    unit: &'static str,
    done: std::sync::atomic::AtomicUsize,
}

impl Counter {
    /// Reports the stage with nothing done yet.
    pub(crate) fn start(name: impl Into<String>, total: usize, unit: &'static str) -> Self {
        let name = name.into();
        stage(name.clone(), 0, total, unit);
        Self {
            name,
            total,
            unit,
            done: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// One more item done.
    pub(crate) fn tick(&self) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        stage(
            self.name.clone(),
            done.min(self.total),
            self.total,
            self.unit,
        );
    }
}

/// Reading a log row by row, as a stage of its own ("loading dive.mcap 120000/864000
/// rows"): the rows read are reported at most every [`Loading::REPORT_ROWS`] rows, and
/// [`Loading::row`] breaks when the current work was cancelled, so that a reader stops
/// within a few thousand rows (well under a second) instead of reading an 8-hour
/// session to its end. Without a current progress it only counts.
#[derive(Debug)]
pub struct Loading {
    name: String,
    total: usize,
    done: usize,
    progress: Option<Progress>,
}

impl Loading {
    /// Rows between two reports (and two looks at the cancel switch).
    pub const REPORT_ROWS: usize = 4096;

    /// Starts the stage "loading `what`" of `total_rows` (0: not known; the stage is not
    /// counted) on the current progress.
    pub fn start(what: &str, total_rows: usize) -> Self {
        let name = format!("loading {what}");
        stage(name.clone(), 0, total_rows, "rows");
        Self {
            name,
            total: total_rows,
            done: 0,
            progress: current(),
        }
    }

    /// One row read; `Break` once the work was cancelled (stop reading).
    pub fn row(&mut self) -> ControlFlow<()> {
        self.done += 1;
        if !self.done.is_multiple_of(Self::REPORT_ROWS) {
            return ControlFlow::Continue(());
        }
        let Some(p) = &self.progress else {
            return ControlFlow::Continue(());
        };
        let total = self.total.max(self.done);
        p.report(Stage {
            name: self.name.clone(),
            done: if self.total == 0 { 0 } else { self.done },
            total: if self.total == 0 { 0 } else { total },
            unit: "rows",
        });
        if p.is_cancelled() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    /// Rows read so far.
    pub fn rows(&self) -> usize {
        self.done
    }
}

/// `Err(LabError::Cancelled)` once the current progress was cancelled.
pub(crate) fn checkpoint() -> Result<(), LabError> {
    let cancelled = CURRENT.with(|c| c.borrow().as_ref().is_some_and(Progress::is_cancelled));
    if cancelled {
        Err(LabError::Cancelled)
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loading_reports_rows_read_and_stops_once_cancelled() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = Arc::clone(&seen);
        let p = Progress::with_sink(move |s| {
            if let Ok(mut v) = s2.lock() {
                v.push(s.to_string());
            }
        });
        let p2 = p.clone();
        let read = p.run(|| {
            let mut l = Loading::start("dive.mcap", 3 * Loading::REPORT_ROWS);
            let mut k = 0;
            while l.row().is_continue() {
                k += 1;
                if k == Loading::REPORT_ROWS + 10 {
                    p2.cancel();
                }
                assert!(k < 3 * Loading::REPORT_ROWS, "never stopped");
            }
            Ok(l.rows())
        });
        assert_eq!(read, Err(LabError::Cancelled));
        let seen = seen.lock().map(|v| v.clone()).unwrap_or_default();
        assert_eq!(
            seen,
            [
                "loading dive.mcap 0/12288 rows",
                "loading dive.mcap 4096/12288 rows",
                "loading dive.mcap 8192/12288 rows"
            ]
        );
        // Without a current progress it counts and never stops.
        let mut l = Loading::start("x", 0);
        assert!((0..10_000).all(|_| l.row().is_continue()));
        assert_eq!(l.rows(), 10_000);
    }

    #[test]
    fn stages_reach_the_sink_and_cancel_ends_the_work_with_cancelled() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s2 = Arc::clone(&seen);
        let p = Progress::with_sink(move |s| {
            if let Ok(mut v) = s2.lock() {
                v.push(s.to_string());
            }
        });
        let out = p.run(|| {
            stage("calibrating", 1, 5, "");
            stage("term search: yaw", 0, 0, "");
            checkpoint()?;
            Ok(7)
        });
        assert_eq!(out, Ok(7));
        let seen_now = seen.lock().map(|v| v.clone()).unwrap_or_default();
        assert_eq!(seen_now, ["calibrating 1/5", "term search: yaw"]);
        assert_eq!(p.latest().map(|s| s.name), Some("term search: yaw".into()));
        // Outside `run`, nothing is current.
        stage("ignored", 0, 0, "");
        assert!(checkpoint().is_ok());
        p.cancel();
        let out = p.run(|| {
            checkpoint()?;
            Ok(1)
        });
        assert_eq!(out, Err(LabError::Cancelled));
        // Work that swallowed the failure still ends cancelled.
        assert_eq!(p.run(|| Ok(2)), Err(LabError::Cancelled));
    }
}
