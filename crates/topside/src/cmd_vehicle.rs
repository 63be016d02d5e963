//! `topside vehicle new|check`: start a vehicle file from a frame's template, and check
//! one (statics, mixing matrix, implausible things, and with a log the sign and response
//! of every command channel). The checks are `rov_lab::vehicle_check`'s; this module reads
//! files and prints.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use rov_dynamics::models::vehicle::VehicleDef;
use rov_lab::Run;
use rov_lab::vehicle_check::sign::{ChannelCheck, sign_check};
use rov_lab::vehicle_check::{VehicleReport, check_vehicle};

#[derive(Debug, Args)]
pub struct VehicleArgs {
    #[command(subcommand)]
    command: VehicleCommand,
}

#[derive(Debug, Subcommand)]
enum VehicleCommand {
    /// Write a commented vehicle-file template for a frame: every number the maker or the
    /// literature gives with its source, TODO with an uncertainty for what it cannot know.
    New(NewArgs),
    /// Check a vehicle file: mass, displacement, net weight, CG/CB and static trim, the
    /// mixing matrix (each command channel → body force and moment), the largest force and
    /// moment per axis, every implausible thing; with --log, the sign and response of each
    /// command channel in the log. Exit status 1 when something is implausible or a
    /// channel disagrees with the log.
    Check(CheckArgs),
}

/// Frames with a template.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum Frame {
    /// VideoRay Pro 4: port, starboard, vertical thrusters (the Pro 4 protocol's channels).
    Pro4,
    /// VideoRay Pro 4 with the lateral thruster accessory.
    #[value(name = "pro4-lateral")]
    Pro4Lateral,
    /// BlueROV2 (standard, 6 x T200, ArduSub Vectored): one channel per motor output.
    Bluerov2,
    /// BlueROV2 Heavy (8 x T200, ArduSub Vectored-6DOF): one channel per motor output.
    #[value(name = "bluerov2-heavy")]
    Bluerov2Heavy,
    /// Six thrusters (four vectored horizontal, two vertical), one free channel each,
    /// every number a TODO.
    Custom,
}

impl Frame {
    fn template(self) -> &'static str {
        match self {
            Frame::Pro4 => include_str!("../../../config/vehicles/templates/pro4.toml"),
            Frame::Pro4Lateral => {
                include_str!("../../../config/vehicles/templates/pro4-lateral.toml")
            }
            Frame::Bluerov2 => include_str!("../../../config/vehicles/templates/bluerov2.toml"),
            Frame::Bluerov2Heavy => {
                include_str!("../../../config/vehicles/templates/bluerov2-heavy.toml")
            }
            Frame::Custom => include_str!("../../../config/vehicles/templates/custom.toml"),
        }
    }
}

#[derive(Debug, Args)]
struct NewArgs {
    /// The frame.
    #[arg(long, value_enum)]
    frame: Frame,
    /// The file to write.
    #[arg(long, value_name = "FILE.toml")]
    out: PathBuf,
    /// Overwrite an existing file.
    #[arg(long)]
    force: bool,
}

#[derive(Debug, Args)]
struct CheckArgs {
    /// The vehicle file.
    file: PathBuf,
    /// A log to check the channels' signs against (repeatable): an MCAP session, a
    /// measurement CSV (extra `NAME_pct` columns for built-in channels) or a BlueROV2 tank
    /// CSV; with --map, any log the map describes.
    #[arg(long, value_name = "LOG", num_args = 1..)]
    log: Vec<PathBuf>,
    /// The log map (TOML) that says how the log's fields become the lab's signals and the
    /// vehicle's command channels.
    #[arg(long, value_name = "MAP.toml")]
    map: Option<PathBuf>,
    /// JSON on stdout (`statics`, `mixing`, `limits`, `issues`, `channels[]`).
    #[arg(long)]
    json: bool,
}

pub fn run(args: VehicleArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        VehicleCommand::New(a) => run_new(a),
        VehicleCommand::Check(a) => run_check(a),
    }
}

fn run_new(a: NewArgs) -> anyhow::Result<ExitCode> {
    if a.out.exists() && !a.force {
        anyhow::bail!("{} exists; pass --force to overwrite it", a.out.display());
    }
    let text = a.frame.template();
    fs::write(&a.out, text).with_context(|| format!("writing {}", a.out.display()))?;
    let todo = text.matches("TODO").count();
    eprintln!(
        "wrote {} ({todo} TODO items to fill in); then: topside vehicle check {}",
        a.out.display(),
        a.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Reads the logs for the sign check: through the map when one is given (any supported
/// log format, on the vehicle's own channel names), else as `lab` reads logs.
fn load_check_logs(logs: &[PathBuf], map: Option<&Path>) -> anyhow::Result<Vec<Run>> {
    let map = crate::cmd_lab::load_map(map)?;
    crate::cmd_lab::load_runs(logs, map.as_ref())
}

#[derive(serde::Serialize)]
struct CheckJson<'a> {
    file: String,
    #[serde(flatten)]
    report: &'a VehicleReport,
    logs: Vec<String>,
    runs: usize,
    data_notes: Vec<String>,
    channels: &'a [ChannelCheck],
}

fn run_check(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let label = a.file.display().to_string();
    let text = fs::read_to_string(&a.file).with_context(|| format!("reading {label}"))?;
    let def = VehicleDef::parse(&text, &label)?;
    let report = check_vehicle(&def)?;
    let runs = if a.log.is_empty() {
        if a.map.is_some() {
            anyhow::bail!("--map needs --log LOG");
        }
        Vec::new()
    } else {
        load_check_logs(&a.log, a.map.as_deref())?
    };
    let channels = if runs.is_empty() {
        report
            .mixing
            .iter()
            .map(|m| ChannelCheck {
                channel: m.channel.clone(),
                expected_dof: m.expected_dof.clone(),
                expected_sign: m.expected_sign,
                observed_dof: None,
                observed_sign: None,
                correlation: None,
                lag_s: None,
                agree: None,
                note: "no log given".into(),
                responses: Vec::new(),
            })
            .collect()
    } else {
        sign_check(&def, &report, &runs)
    };
    let mut data_notes = Vec::new();
    for r in &runs {
        for n in &r.treatment.notes {
            data_notes.push(format!("{}: {n}", r.name));
        }
        for l in &r.treatment.closed_loop {
            data_notes.push(format!(
                "{}: command {} follows {} (closed loop, {:.0} % explained): its correlation with the motion runs both ways",
                r.name,
                l.command,
                l.output,
                l.explained * 100.0
            ));
        }
    }
    let bad = !report.issues.is_empty() || channels.iter().any(|c| c.agree == Some(false));
    if a.json {
        let j = CheckJson {
            file: label,
            report: &report,
            logs: a.log.iter().map(|p| p.display().to_string()).collect(),
            runs: runs.len(),
            data_notes,
            channels: &channels,
        };
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        print_report(&label, &report, &channels, &data_notes, !runs.is_empty());
    }
    Ok(if bad {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn sign_str(s: i8) -> &'static str {
    if s < 0 { "-" } else { "+" }
}

fn print_report(
    label: &str,
    r: &VehicleReport,
    channels: &[ChannelCheck],
    notes: &[String],
    with_log: bool,
) {
    let s = &r.statics;
    println!("{label}: {} ({})", r.vehicle, r.structure);
    println!(
        "  mass {:.3} kg, displacement {:.3} kg ({:.5} m^3), W {:.2} N, B {:.2} N, net weight W-B {:+.2} N ({})",
        s.mass_kg,
        s.displacement_kg,
        s.volume_m3,
        s.weight_n,
        s.buoyancy_n,
        s.net_weight_n,
        if s.net_weight_n > 0.0 {
            "sinks"
        } else {
            "floats"
        }
    );
    println!(
        "  CG ({:.3}, {:.3}, {:.3}) m, CB ({:.3}, {:.3}, {:.3}) m from the CO; righting {:.3} N m/rad; static trim roll {:.2} deg, pitch {:.2} deg",
        s.cg_m[0],
        s.cg_m[1],
        s.cg_m[2],
        s.cb_m[0],
        s.cb_m[1],
        s.cb_m[2],
        s.righting_nm_per_rad,
        s.trim_roll_deg,
        s.trim_pitch_deg
    );
    println!("  hull box: {}", s.hull_box_source);
    println!("mixing (tau at +100 % of each channel alone; N, N m):");
    println!(
        "  {:<12} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}  moves",
        "channel", "X", "Y", "Z", "K", "M", "N"
    );
    for m in &r.mixing {
        let t = m.tau_plus_100;
        println!(
            "  {:<12} {:>8.2} {:>8.2} {:>8.2} {:>8.3} {:>8.3} {:>8.3}  {}{}",
            m.channel,
            t[0],
            t[1],
            t[2],
            t[3],
            t[4],
            t[5],
            sign_str(m.expected_sign),
            m.expected_dof
        );
    }
    println!("largest force and moment per axis:");
    for l in &r.limits {
        println!(
            "  {:<6} {:>8.2} .. {:>8.2} {}",
            l.dof, l.max_negative, l.max_positive, l.unit
        );
    }
    if r.issues.is_empty() {
        println!("issues: none");
    } else {
        println!("issues:");
        for i in &r.issues {
            println!("  [{}] {}", i.kind, i.message);
        }
    }
    if with_log {
        println!(
            "sign and response check (partial correlation of each command with each rate, lags 0-2 s):"
        );
        println!(
            "  {:<12} {:>9} {:>9} {:>7} {:>6}  agree  note",
            "channel", "expected", "observed", "corr", "lag s"
        );
        for c in channels {
            let obs = match (&c.observed_dof, c.observed_sign) {
                (Some(d), Some(s)) => format!("{}{d}", sign_str(s)),
                _ => "-".into(),
            };
            println!(
                "  {:<12} {:>9} {:>9} {:>7} {:>6}  {:<5}  {}",
                c.channel,
                format!("{}{}", sign_str(c.expected_sign), c.expected_dof),
                obs,
                c.correlation.map_or("-".into(), |x| format!("{x:.2}")),
                c.lag_s.map_or("-".into(), |x| format!("{x:.2}")),
                match c.agree {
                    Some(true) => "yes",
                    Some(false) => "NO",
                    None => "-",
                },
                c.note
            );
        }
        for n in notes {
            println!("  note: {n}");
        }
    }
}
