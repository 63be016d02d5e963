//! `topside lab`: the model lab — compare a model with measurements, see where it fails,
//! learn which physical effect is missing, add it and watch the error fall.
//!
//! * `topside lab compare --model M --data F.csv [--data G.csv ...] [--effects ID,ID] [--json] [--plots DIR]`
//! * `topside lab diagnose --model M --data TRAIN.csv [--data ...] --validate VAL.csv [--json] [--plots DIR]`
//! * `topside lab add --model M [--effects ID[,ID...]] [--terms term:DOF:SLUG[,...]] --data TRAIN.csv --validate VAL.csv [--json] [--save OUT.toml] [--plots DIR]`
//! * `topside lab effects`, `topside lab models`
//!
//! M is `model1`, `model2`, `model3`, a vehicle definition file (`config/vehicles/*.toml`)
//! or a saved extended-model TOML. Data files are measurement CSVs, MCAP sessions
//! (`.mcap`, through `rov_session`), or the BlueROV2 tank CSVs of shared/real_data
//! (recognised by their `ch5_surge` column; their six body-axis demands become command
//! channels a vehicle file mixes, and a Pro 4 view feeds the Pro 4 models). Every file
//! goes through the real-log treatment of [`rov_lab::ingest`] (time stamps, gaps,
//! spikes, closed loop), reported in words. `--json` prints one JSON document on stdout
//! and nothing else (notes go into the JSON or to stderr); the text report goes to
//! stdout otherwise.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};
use rov_lab::catalog::EffectId;
use rov_lab::diagnose::{DiagnoseOptions, Status, diagnose};
use rov_lab::lab::{
    AddReport, ChannelSummary, CompareReport, add_with_terms, compare, diagnose_json,
};
use rov_lab::model::{BaseKind, LabModel};
use rov_lab::persist::save_extended_model;
use rov_lab::plots::{comparison_png, error_fall_png, failure_pngs, residual_png};
use rov_lab::progress::Loading;
use rov_lab::{Run, parse_effect_list};
use rov_types::model_id::ModelId;

/// How `diagnose` decides its verdict (shown by `topside lab --help`; the full statement
/// is in `rov_lab::verdict`).
const VERDICT_HELP: &str = "\
Verdict of `lab diagnose` (\"verdict\" in --json): adequate | explained | unexplained.
For every channel the model predicts and the held-out runs measure, the multiple-shooting
residual e (spikes excluded) is tested against H0 \"the model is right up to its
parameters' documented uncertainty\":
  0. H0 fitted first: the free parameters and the documented-uncertain fixed ones are
     refitted to their maximum a posteriori point on the training runs (one Gauss-Newton
     step with the documented priors); the steps below test that refit, or the model as
     it is when that passes in more channels (in as many: the one closer to the data).
  1. Expected level s0^2 = sigma_n^2 + sigma_theta^2 + sigma_u^2 + sigma_x^2: the
     channel's noise floor (never below q/sqrt(12) for a signal recorded on a lattice of
     step q) plus the prediction variance the parameter uncertainty allows (posterior of
     the same parameters), the commands' resolution and timing allow, and the windows'
     start states (smoothed readings, off by their smoothing error) allow.
  2. Level test: N_eff*MS/s0^2 ~ chi^2(N_eff), N_eff the Bartlett effective sample size;
     consistent when MS/s0^2 <= chi^2_{1-a/m}(N_eff)/N_eff, a = 0.01 Bonferroni over the m
     tested channels.
  3. Structure: a channel above that level is still consistent only if its residual is
     white (<= 5 % of autocorrelation lags outside the 99 % band) and correlates with no
     input or state (cross-correlation against the Bartlett bound).
  4. Distance: an RMSE above 3 noise floors is never consistent.
  5. Floor: within that, an RMSE at most 1.1 s0 is consistent (the noise floor is itself
     an estimate; nothing is left for a model to explain).
adequate = every channel of the calibrated base consistent, no finding needed;
explained = the accepted findings (catalog effects, discovered terms) make every channel
consistent; unexplained = some channel still is not: the \"unexplained\" array gives its
RMSE, noise, ratio, where the misfit concentrates and what it correlates with.";

/// Arguments of `topside lab`.
#[derive(Debug, Args)]
#[command(after_long_help = VERDICT_HELP)]
pub struct LabArgs {
    #[command(subcommand)]
    command: LabCommand,
}

#[derive(Debug, Subcommand)]
enum LabCommand {
    /// Compare a model (optionally with effects) with measured runs in three error views.
    Compare(CompareArgs),
    /// Calibrate the base, rank the catalog effects by held-out evidence, search terms
    /// outside the catalog, and give a verdict (see `topside lab --help`).
    #[command(after_long_help = VERDICT_HELP)]
    Diagnose(DiagnoseArgs),
    /// Add effects and discovered terms to a model, refit, and show the held-out error
    /// before and after.
    Add(AddArgs),
    /// List the 17 catalog effects.
    Effects(ListArgs),
    /// List, for each base model, the catalog effects it already contains.
    Models(ListArgs),
    /// Per-session and leave-one-session-out held-out fit (free run and multiple
    /// shooting) per channel, before and after calibration.
    Cv(crate::cmd_lab_cv::CvArgs),
    /// Run the station's model watch over a session or log: alerts when the vehicle
    /// stops behaving like the model (a mismatch from the start, or a change during the
    /// dive), with the likely causes ranked.
    Watch(crate::cmd_lab_watch::WatchArgs),
}

/// `topside lab compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Log map (TOML) for the --data and --validate logs: how their fields become the
    /// lab's signals and the vehicle's command channels (any supported log format).
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// model1, model2, model3, a vehicle definition or a saved extended-model TOML.
    #[arg(long)]
    pub model: String,
    /// Measured runs (CSV or MCAP); repeat for several.
    #[arg(long = "data", required = true)]
    pub data: Vec<PathBuf>,
    /// Effects to add (fitted on the same data), comma-separated IDs.
    #[arg(long)]
    pub effects: Option<String>,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    #[command(flatten)]
    pub work: crate::lab_progress::WorkArgs,
}

/// `topside lab diagnose`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// Log map (TOML) for the --data and --validate logs: how their fields become the
    /// lab's signals and the vehicle's command channels (any supported log format).
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// model1, model2, model3, a vehicle definition or a saved extended-model TOML.
    #[arg(long)]
    pub model: String,
    /// Training runs; repeat for several.
    #[arg(long = "data", required = true)]
    pub data: Vec<PathBuf>,
    /// Held-out runs; repeat for several.
    #[arg(long = "validate", required = true)]
    pub validate: Vec<PathBuf>,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    #[command(flatten)]
    pub work: crate::lab_progress::WorkArgs,
}

/// `topside lab add`.
#[derive(Debug, Args)]
pub struct AddArgs {
    /// Log map (TOML) for the --data and --validate logs: how their fields become the
    /// lab's signals and the vehicle's command channels (any supported log format).
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// model1, model2, model3, a vehicle definition or a saved extended-model TOML.
    #[arg(long)]
    pub model: String,
    /// Effects to add, comma-separated IDs, in order.
    #[arg(long, required_unless_present = "terms")]
    pub effects: Option<String>,
    /// Discovered terms to add after the effects, comma-separated ids as `lab diagnose`
    /// reports them (for example `term:yaw:v_absr`).
    #[arg(long)]
    pub terms: Option<String>,
    /// Training runs; repeat for several.
    #[arg(long = "data", required = true)]
    pub data: Vec<PathBuf>,
    /// Held-out runs; repeat for several.
    #[arg(long = "validate", required = true)]
    pub validate: Vec<PathBuf>,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Save the extended model as TOML (loadable by sim, hold and the lab).
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Write PNG plots into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    #[command(flatten)]
    pub work: crate::lab_progress::WorkArgs,
}

/// `topside lab effects|models`.
#[derive(Debug, Args)]
pub struct ListArgs {
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Loads a model argument (`model1`, `model2`, `model3` or `FILE.toml`: a base-model
/// file, a vehicle definition or a saved extended model) for `lab`, `sim run` and
/// `replay --model`: [`load_model_id`] of the parsed argument.
pub fn load_model_arg(arg: &str) -> anyhow::Result<LabModel> {
    let id: ModelId = arg.parse().with_context(|| format!("--model {arg}"))?;
    load_model_id(&id, "--model")
}

/// The command line's one model loader: reads a model file (errors say `flag: reading
/// FILE`) and loads it, or a shipped base, through the lab's one loader
/// [`rov_lab::load_model`] (its errors name the file, key, value and range). `hold`,
/// `record`, the station and the lab all load their `--model` and `--vehicle` here.
pub fn load_model_id(id: &ModelId, flag: &str) -> anyhow::Result<LabModel> {
    let text = match id {
        ModelId::Base(_) => None,
        ModelId::File(path) => Some(
            fs::read_to_string(path)
                .with_context(|| format!("{flag}: reading {}", path.display()))?,
        ),
    };
    Ok(rov_lab::load_model(id, text.as_deref())?)
}

/// Loads one log as a single continuous run (for commands that need one, such as
/// `sim run`): a log that gaps split into several pieces is refused with their count.
pub fn load_run(path: &Path, map: Option<&rov_logs::LogMap>) -> anyhow::Result<Run> {
    let mut runs = load_log_with(path, map)?;
    if runs.len() != 1 {
        anyhow::bail!(
            "{}: gaps split the log into {} pieces; this command needs one continuous run",
            path.display(),
            runs.len()
        );
    }
    Ok(runs.remove(0))
}

/// Reads a log map (TOML) named on the command line.
pub fn load_map(path: Option<&Path>) -> anyhow::Result<Option<rov_logs::LogMap>> {
    let Some(path) = path else {
        return Ok(None);
    };
    let text = fs::read_to_string(path)
        .with_context(|| format!("reading the log map {}", path.display()))?;
    let map = rov_logs::LogMap::parse(&text, &path.display().to_string())?;
    Ok(Some(map))
}

/// Loads one log: measurement CSV, MCAP session, or BlueROV2 tank CSV, as runs (a gap
/// splits a log into several), with the real-log treatment applied and recorded: the
/// lab's one log loader ([`rov_lab::loader`]), which the GUI's Model lab reads through
/// too.
pub fn load_log(path: &Path) -> anyhow::Result<Vec<Run>> {
    load_log_with(path, None)
}

/// [`load_log`], or with a log map any log the map describes (CSV/TSV, DataFlash, tlog,
/// ROS bags, MCAP with CDR messages), read through [`rov_lab::mapped::mapped_runs`].
pub fn load_log_with(path: &Path, map: Option<&rov_logs::LogMap>) -> anyhow::Result<Vec<Run>> {
    let label = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_else(|| path.display().to_string());
    if let Some(map) = map {
        // Not counted: the whole file is read and parsed at once.
        let _stage = Loading::start(&label, 0);
        let bytes = fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        return rov_lab::mapped::mapped_runs(&bytes, map, &label)
            .with_context(|| format!("reading {} through the map {}", path.display(), map.label));
    }
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
    {
        let (session, mut stream) = open_session_stream(path, &label)?;
        let mut loading = Loading::start(&label, session.count(rov_session::Topic::Nav.name()));
        let done = rov_session::measurements_until(&session, &mut |_, row| {
            stream.push(row);
            loading.row()
        })
        .with_context(|| format!("reading measurements from {}", path.display()))?
        .ok_or(rov_lab::LabError::Cancelled)?;
        for w in done.warnings {
            eprintln!("warning: {label}: {w}");
        }
        return Ok(stream.finish(done.present)?);
    }
    let _stage = Loading::start(&label, 0);
    let bytes = fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(rov_lab::loader::read_bytes(&bytes, &label)?.runs()?)
}

/// Opens a session for the lab: the summary gives its nav message count, and so the
/// plan of [`rov_lab::stream`] (every row, or decimated to at most
/// [`rov_lab::stream::MAX_LAB_ROWS`]), before any row is read. This is what "open" means
/// in the lab's long-session figures.
pub fn open_session_stream(
    path: &Path,
    label: &str,
) -> anyhow::Result<(rov_session::Session, rov_lab::stream::LogStream)> {
    let session =
        rov_session::open(path).with_context(|| format!("opening session {}", path.display()))?;
    let nav = session.count(rov_session::Topic::Nav.name());
    let stream = rov_lab::stream::LogStream::new(label, nav);
    if stream.factor() > 1 {
        eprintln!(
            "note: {label}: {nav} rows over {:.1} h; the lab keeps one sample in {} (see the data notes)",
            session.duration_s() / 3600.0,
            stream.factor()
        );
    }
    Ok((session, stream))
}

/// Every log of a list, through the map when one is given.
/// Reading is a stage of the lab's progress ("loading dive.mcap 120000/864000 rows" on a
/// terminal's bar).
pub fn load_runs(paths: &[PathBuf], map: Option<&rov_logs::LogMap>) -> anyhow::Result<Vec<Run>> {
    crate::lab_progress::with_progress(|| {
        let mut out = Vec::new();
        for p in paths {
            out.extend(load_log_with(p, map)?);
        }
        Ok(out)
    })
}

fn write_pngs(dir: &Path, pngs: Vec<(String, Vec<u8>)>) -> anyhow::Result<()> {
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for (name, bytes) in pngs {
        let p = dir.join(&name);
        fs::write(&p, bytes).with_context(|| format!("writing {}", p.display()))?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map_or_else(|| "  low exc.".into(), |v| format!("{v:9.1}"))
}

fn print_summary_table(title: &str, m: &std::collections::BTreeMap<String, ChannelSummary>) {
    println!("{title}");
    println!(
        "  {:<10} {:>9} {:>10} {:>9} {:>10} {:>9}",
        "channel", "fit %", "RMSE", "fit % fr", "RMSE fr", "noise"
    );
    // A view that could not be computed reads "—" (null in the JSON).
    let rmse = |x: Option<f64>| x.map_or_else(|| "—".into(), |v| format!("{v:.4}"));
    for (k, c) in m {
        println!(
            "  {:<10} {} {:>10} {} {:>10} {:>9.4}",
            k,
            fmt_opt(c.fit_pct),
            rmse(c.rmse_shooting),
            fmt_opt(c.fit_pct_free_run),
            rmse(c.rmse_free_run),
            c.noise
        );
    }
}

fn run_compare(a: CompareArgs) -> anyhow::Result<ExitCode> {
    let model = load_model_arg(&a.model)?;
    let map = load_map(a.map.as_deref())?;
    let runs = load_runs(&a.data, map.as_ref())?;
    let effects = match &a.effects {
        Some(s) => parse_effect_list(s)?,
        None => Vec::new(),
    };
    let threads = a.work.threads();
    let report =
        crate::lab_progress::with_progress(|| compare(&model, &a.model, &runs, &effects, threads))?;
    if let Some(dir) = &a.plots {
        let mut pngs = Vec::new();
        for (i, run) in runs.iter().enumerate() {
            let (f, s) = (&report.free_run[i], &report.shooting[i]);
            pngs.push(comparison_png(
                run,
                &[("free run", f), ("multiple shooting", s)],
                &a.model.replace(['/', '\\'], "_"),
            )?);
            pngs.push(residual_png(
                run,
                &[("free run", f), ("multiple shooting", s)],
                "compare",
            )?);
        }
        pngs.extend(failure_pngs(&report.failures, "compare")?);
        write_pngs(dir, pngs)?;
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_compare(&report);
    }
    Ok(ExitCode::SUCCESS)
}

fn print_compare(r: &CompareReport) {
    println!(
        "model {}{}",
        r.model,
        if r.effects.is_empty() {
            String::new()
        } else {
            format!(" + {}", r.effects.join(" + "))
        }
    );
    for n in &r.notes {
        println!("note: {n}");
    }
    for (view, vm) in &r.pooled {
        println!("pooled, {view}:");
        for (ch, m) in &vm.channels {
            println!(
                "  {:<10} fit {} %  RMSE {:.4}  max {:.4}  bias {:+.4}  drift {:+.5}/s",
                ch,
                fmt_opt(m.fit_pct),
                m.rmse,
                m.max_abs,
                m.bias,
                m.drift_per_s
            );
        }
    }
    if !r.not_predicted.is_empty() {
        println!("not predicted by the model: {}", r.not_predicted.join(", "));
    }
    for f in &r.failures {
        println!("where {} fails (multiple shooting):", f.channel);
        let mut bins = f.by_command.clone();
        bins.sort_by(|a, b| b.mean.abs().total_cmp(&a.mean.abs()));
        for b in bins.iter().take(4) {
            println!(
                "  {:<22} mean {:+.4} ± {:.4} (n {})",
                b.label, b.mean, b.ci95, b.n
            );
        }
        for w in f.worst_windows.iter().take(3) {
            println!(
                "  worst window {} {:.1}–{:.1} s: RMSE {:.4}, bias {:+.4}",
                w.run, w.t_start_s, w.t_end_s, w.rmse, w.bias
            );
        }
        let cross: Vec<String> = f
            .cross_correlation
            .iter()
            .filter(|c| c.significant_lags.iter().any(|l| *l > 0))
            .map(|c| c.with.clone())
            .collect();
        println!(
            "  residual autocorrelation outside the 99 % band at {:.0} % of lags{}",
            f.autocorrelation_outside * 100.0,
            if cross.is_empty() {
                String::new()
            } else {
                format!(
                    "; correlated with past {} (unmodelled input dynamics)",
                    cross.join(", ")
                )
            }
        );
    }
}

fn run_diagnose(a: DiagnoseArgs) -> anyhow::Result<ExitCode> {
    let model = load_model_arg(&a.model)?;
    let map = load_map(a.map.as_deref())?;
    let train = load_runs(&a.data, map.as_ref())?;
    let val = load_runs(&a.validate, map.as_ref())?;
    let opts = DiagnoseOptions {
        threads: a.work.threads(),
        ..Default::default()
    };
    let d = crate::lab_progress::with_progress(|| diagnose(&model, &a.model, &train, &val, &opts))?;
    if let Some(dir) = &a.plots {
        let base = rov_lab::evaluate::evaluate(&d.calibrated, &val)?;
        let fin = rov_lab::evaluate::evaluate(&d.final_model, &val)?;
        let mut pngs = Vec::new();
        for (i, run) in val.iter().enumerate() {
            let mut preds = vec![("calibrated base", &base.shooting[i])];
            if !d.accepted.is_empty() {
                preds.push(("with findings", &fin.shooting[i]));
            }
            pngs.push(comparison_png(run, &preds, "diagnose")?);
            pngs.push(residual_png(run, &preds, "diagnose")?);
        }
        let failures: Vec<_> = rov_dynamics::models::Channel::ALL
            .iter()
            .filter_map(|c| rov_lab::analysis::channel_failure(&val, &base.shooting, *c))
            .collect();
        pngs.extend(failure_pngs(&failures, "diagnose_base")?);
        let j = diagnose_json(&d);
        pngs.push(error_fall_png(&j.error_fall, "diagnose")?);
        write_pngs(dir, pngs)?;
    }
    let j = diagnose_json(&d);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("model {} — {}", j.model, j.summary);
    print_verdict(&j);
    print_summary_table(
        "baseline (calibrated base on the held-out data; fit/RMSE with multiple shooting, fr = free run):",
        &j.baseline.channels,
    );
    if !j.not_predicted.is_empty() {
        println!("not predicted by the model: {}", j.not_predicted.join(", "));
    }
    println!("findings, best first:");
    for (i, f) in j.findings.iter().enumerate() {
        let status = match f.status {
            Status::Significant => "SIGNIFICANT",
            Status::Ambiguous => "ambiguous",
            Status::NotSignificant => "not significant",
            Status::Screened => "screened",
            Status::NotTestable => "not testable",
            Status::NotApplicable => "not applicable",
            Status::Contained => "contained",
        };
        let red: Vec<String> = f
            .validation_rmse_reduction_pct
            .iter()
            // The JSON carries reductions (positive = better); the text says the change
            // of the RMSE (negative = better), as the GUI's lab tab does.
            .map(|(k, v)| format!("{k} {:+.0} %", -v))
            .collect();
        println!(
            "{:>2}. {:<22} {:<15}{}{}",
            i + 1,
            f.effect,
            status,
            if f.contained {
                " (refit of a contained effect)"
            } else {
                ""
            },
            if red.is_empty() {
                String::new()
            } else {
                format!(" held-out RMSE change ({}): {}", f.view, red.join(", "))
            }
        );
        println!("      {}", f.explanation);
        // An accepted finding's conflicts matter to whoever uses the model: in full. A
        // candidate that was not accepted gets one line (the JSON has each in full).
        if f.significant {
            for c in &f.conflicts {
                println!("      conflict: {c}");
            }
        } else if let Some(c) = f.conflict_summary() {
            println!("      conflicts: {c}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The verdict and what was done to the data, in words (text report of `diagnose`).
fn print_verdict(j: &rov_lab::lab::DiagnoseJson) {
    println!(
        "verdict: {} (held-out residuals tested against noise floor and parameter uncertainty; see `topside lab --help`)",
        j.verdict.name()
    );
    for u in &j.unexplained {
        println!("  unexplained: {}", u.description);
    }
    for d in &j.data {
        println!("data: {d}");
    }
    if j.closed_loop {
        println!(
            "data: recorded in closed loop (inputs computed from the measured outputs); judged on multiple shooting"
        );
    }
    for n in &j.calibration_notes {
        println!("calibration: {n}");
    }
    for n in &j.search_notes {
        println!("term search: {n}");
    }
}

fn print_add(r: &AddReport) {
    println!("model {} + {}", r.model, r.effects.join(" + "));
    for d in &r.data {
        println!("data: {d}");
    }
    for n in &r.notes {
        println!("note: {n}");
    }
    if !r.refitted_contained.is_empty() {
        println!(
            "already contained (refitted, not added): {}",
            r.refitted_contained.join(", ")
        );
    }
    print_summary_table("before (calibrated base, held-out):", &r.before);
    print_summary_table("after (held-out):", &r.after);
    println!("held-out RMSE reduction (multiple shooting / free run):");
    for (k, v) in &r.rmse_reduction_pct {
        println!(
            "  {:<10} {:+.1} % / {:+.1} %",
            k,
            v,
            r.rmse_reduction_pct_free_run.get(k).copied().unwrap_or(0.0)
        );
    }
    println!("error fall (held-out RMSE, multiple shooting):");
    for s in &r.error_fall {
        let v: Vec<String> = s.rmse.iter().map(|(k, x)| format!("{k} {x:.4}")).collect();
        println!("  {:<28} {}", s.label, v.join("  "));
    }
    println!("fitted parameters:");
    for p in &r.params {
        println!("  {:<36} {:.5} ± {:.5} {}", p.key, p.value, p.std, p.unit);
    }
}

fn run_add(a: AddArgs) -> anyhow::Result<ExitCode> {
    let model = load_model_arg(&a.model)?;
    let effects = match &a.effects {
        Some(s) => parse_effect_list(s)?,
        None => Vec::new(),
    };
    let terms: Vec<String> = a
        .terms
        .iter()
        .flat_map(|s| s.split(','))
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty())
        .collect();
    let map = load_map(a.map.as_deref())?;
    let train = load_runs(&a.data, map.as_ref())?;
    let val = load_runs(&a.validate, map.as_ref())?;
    let threads = a.work.threads();
    let r = crate::lab_progress::with_progress(|| {
        add_with_terms(&model, &a.model, &effects, &terms, &train, &val, threads)
    })?;
    if let Some(path) = &a.save
        && let Some(m) = &r.model_fitted
    {
        let text = save_extended_model(
            m,
            &format!("fitted by `topside lab add` on {} run(s)", train.len()),
        );
        fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("saved {}", path.display());
    }
    if let Some(dir) = &a.plots {
        let mut pngs = Vec::new();
        if let (Some(first), Some(last)) = (r.evaluations.first(), r.evaluations.last()) {
            for (i, run) in val.iter().enumerate() {
                let preds = [("before", &first.shooting[i]), ("after", &last.shooting[i])];
                pngs.push(comparison_png(run, &preds, "add")?);
                pngs.push(residual_png(run, &preds, "add")?);
            }
        }
        pngs.push(error_fall_png(&r.error_fall, "add")?);
        write_pngs(dir, pngs)?;
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print_add(&r);
    }
    Ok(ExitCode::SUCCESS)
}

#[derive(serde::Serialize)]
struct EffectRow {
    id: &'static str,
    code: &'static str,
    group: rov_lab::catalog::EffectGroup,
    term: &'static str,
    params: Vec<String>,
    signature: &'static str,
    needs: &'static str,
}

fn run_effects(a: ListArgs) -> anyhow::Result<ExitCode> {
    let rows: Vec<EffectRow> = EffectId::ALL
        .iter()
        .map(|e| {
            let i = e.info();
            EffectRow {
                id: i.key,
                code: i.code,
                group: i.group,
                term: i.term,
                params: rov_lab::params::effect_params(*e)
                    .iter()
                    .map(|p| format!("{} [{}]", p.key(), p.meta().unit))
                    .collect(),
                signature: i.signature,
                needs: i.needs,
            }
        })
        .collect();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        for r in rows {
            println!("{} ({}, {:?})", r.id, r.code, r.group);
            println!("    term:      {}", r.term);
            println!("    params:    {}", r.params.join(", "));
            println!("    signature: {}", r.signature);
            println!("    needs:     {}", r.needs);
        }
    }
    Ok(ExitCode::SUCCESS)
}

#[derive(serde::Serialize)]
struct ModelRow {
    model: &'static str,
    contains: Vec<&'static str>,
    not_applicable: Vec<(&'static str, &'static str)>,
    calibrated: Vec<String>,
}

fn run_models(a: ListArgs) -> anyhow::Result<ExitCode> {
    let rows: Vec<ModelRow> = BaseKind::ALL
        .iter()
        .map(|k| ModelRow {
            model: k.name(),
            contains: EffectId::ALL
                .iter()
                .filter(|e| k.contains(**e))
                .map(|e| e.key())
                .collect(),
            not_applicable: EffectId::ALL
                .iter()
                .filter_map(|e| k.not_applicable(*e).map(|r| (e.key(), r)))
                .collect(),
            calibrated: k.calibration_params().iter().map(|p| p.key()).collect(),
        })
        .collect();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        for r in rows {
            println!("{}", r.model);
            println!(
                "    contains (refitted, never proposed as an addition): {}",
                if r.contains.is_empty() {
                    "none".into()
                } else {
                    r.contains.join(", ")
                }
            );
            for (e, why) in &r.not_applicable {
                println!("    not applicable: {e} — {why}");
            }
            println!("    calibrated: {}", r.calibrated.join(", "));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs `topside lab`.
pub fn run(args: LabArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        LabCommand::Compare(a) => run_compare(a),
        LabCommand::Diagnose(a) => run_diagnose(a),
        LabCommand::Add(a) => run_add(a),
        LabCommand::Effects(a) => run_effects(a),
        LabCommand::Models(a) => run_models(a),
        LabCommand::Cv(a) => crate::cmd_lab_cv::run(a),
        LabCommand::Watch(a) => crate::cmd_lab_watch::run(a),
    }
}
