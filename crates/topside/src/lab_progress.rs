//! The lab's long commands (`lab compare|diagnose|add`): their worker count and a
//! progress bar on stderr when it is a terminal (the lab reports its stages through
//! [`rov_lab::progress`]; nothing is drawn into a pipe or a log file).

use std::io::IsTerminal;
use std::time::Duration;

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rov_lab::LabError;
use rov_lab::progress::{Progress, Stage};

/// Worker threads of a lab command.
#[derive(Debug, Clone, Copy, Args)]
pub struct WorkArgs {
    /// Worker threads (default: every core). The result is the same for any count.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Option<u16>,
}

impl WorkArgs {
    /// The worker count to use.
    pub fn threads(&self) -> usize {
        self.threads
            .map_or_else(rov_lab::par::default_threads, usize::from)
    }
}

/// Runs lab work with a progress bar on stderr when stderr is a terminal.
pub fn with_progress<T, E: From<LabError>>(work: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
    if !std::io::stderr().is_terminal() {
        return Progress::new().run_with(work);
    }
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    // The stage's words and count in the message, so that no redraw shows the count of one
    // stage with the words of another; the bar's length and position change together.
    let counted = ProgressStyle::with_template("{spinner} {elapsed:>4} [{bar:30}] {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    let open = ProgressStyle::with_template("{spinner} {elapsed:>4} {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
    bar.set_style(open.clone());
    bar.enable_steady_tick(Duration::from_millis(200));
    let b = bar.clone();
    let progress = Progress::with_sink(move |s: &Stage| {
        if s.total == 0 {
            b.set_style(open.clone());
        } else {
            b.set_style(counted.clone());
            b.update(|state| {
                state.set_len(s.total as u64);
                state.set_pos(s.done as u64);
            });
        }
        b.set_message(s.to_string());
    });
    let out = progress.run_with(work);
    bar.finish_and_clear();
    out
}
