//! `topside lab cv --model M --data F [--data G ...] [--json] [--threads N]`: per-session and
//! leave-one-session-out held-out fit of a model on its own command channels, free run and
//! multiple shooting, before and after calibration ([`rov_lab::cross_validate`]).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use rov_lab::cross_validate::leave_one_session_out;
use rov_lab::lm::LmOptions;

/// `topside lab cv`.
#[derive(Debug, Args)]
pub struct CvArgs {
    /// The model: model1, model2, model3, a vehicle file or a saved extended model.
    #[arg(long)]
    model: String,
    /// Logs, one session each (at least two; repeatable, or several after one --data).
    #[arg(long, required = true, num_args = 1..)]
    data: Vec<PathBuf>,
    /// Log map (TOML) for the logs (any supported format).
    #[arg(long, value_name = "MAP.toml")]
    map: Option<PathBuf>,
    /// Multiple-shooting window, s (the lab's own views use 20 s).
    #[arg(long, default_value_t = rov_lab::calibrate::SHOOTING_WINDOW_S)]
    window_s: f64,
    /// JSON on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    work: crate::lab_progress::WorkArgs,
}

fn pct(x: Option<f64>) -> String {
    x.map_or_else(|| "     -".into(), |v| format!("{v:6.1}"))
}

/// Runs `topside lab cv`.
pub fn run(a: CvArgs) -> anyhow::Result<ExitCode> {
    let model = crate::cmd_lab::load_model_arg(&a.model)?;
    let map = crate::cmd_lab::load_map(a.map.as_deref())?;
    let runs = crate::cmd_lab::load_runs(&a.data, map.as_ref())?;
    let opts = LmOptions {
        threads: a.work.threads(),
        ..Default::default()
    };
    let cv = crate::lab_progress::with_progress(|| {
        leave_one_session_out(&model, &runs, &opts, a.window_s)
    })?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&cv)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{}: leave-one-session-out over {} sessions (fit %: multiple shooting in {} s windows / free run; before = as given, after = calibrated on the other sessions)",
        a.model,
        cv.sessions.len(),
        cv.window_s
    );
    for s in &cv.sessions {
        println!("  held out {} ({} run(s))", s.session, s.runs);
        for (ch, b) in &s.before {
            let af = s.after.get(ch);
            println!(
                "    {:<10} shooting {} -> {}   free run {} -> {}",
                ch,
                pct(b.fit_pct),
                pct(af.and_then(|c| c.fit_pct)),
                pct(b.fit_pct_free_run),
                pct(af.and_then(|c| c.fit_pct_free_run)),
            );
        }
    }
    println!("  median over sessions:");
    for (ch, m) in &cv.median {
        println!(
            "    {:<10} shooting {} -> {}   free run {} -> {}   ({} sessions)",
            ch,
            pct(m.shooting_before),
            pct(m.shooting_after),
            pct(m.free_run_before),
            pct(m.free_run_after),
            m.sessions
        );
    }
    Ok(ExitCode::SUCCESS)
}
