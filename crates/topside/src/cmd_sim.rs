//! `topside sim`: reproduce the paper's experiments, or run a Fossen reference case.

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

use crate::{cmd_sim_paper, cmd_sim_reference};

/// Arguments of `topside sim`.
#[derive(Debug, Args)]
pub struct SimArgs {
    #[command(subcommand)]
    command: SimCommand,
}

#[derive(Debug, Subcommand)]
enum SimCommand {
    /// Run seed 000's open-loop experiments through all three models; write PNG plots and CSVs.
    Paper(PaperArgs),
    /// Run a case of a Fossen reference parameter file and write its trajectory CSV.
    Reference(ReferenceArgs),
    /// Run any model (a base model or a saved extended one) on a measured run's commands.
    Run(crate::cmd_sim_run::RunArgs),
}

/// `topside sim paper --out DIR`
#[derive(Debug, Args)]
pub struct PaperArgs {
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Directory holding model1.toml, model2.toml and model3.toml (default: the built-in
    /// parameter files).
    #[arg(long)]
    pub models: Option<PathBuf>,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The simulated vehicle standing in for the paper's tank runs.
    #[arg(long, value_enum, default_value_t = TruthArg::Paper)]
    pub truth: TruthArg,
}

/// Which vehicle `sim paper` measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TruthArg {
    /// model3's 6-DOF plant plus the effects the paper measured (reverse-thrust weakness,
    /// vertical-thruster pitch coupling).
    Paper,
    /// model3 exactly as configured.
    Nominal,
}

/// Integration scheme of `sim reference`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    /// Classical fixed-step Runge-Kutta 4.
    Rk4,
    /// Fossen's semi-implicit Euler (velocity first, then position with the new velocity).
    Euler,
}

/// `topside sim reference --params PARAMS.json --case NAME --integrator rk4|euler --out OUT.csv`
#[derive(Debug, Args)]
pub struct ReferenceArgs {
    /// Parameter file in the format of shared/testdata/fossen_reference/parameters.json.
    #[arg(long)]
    pub params: PathBuf,
    /// Case name, a key of the file's `cases` table.
    #[arg(long)]
    pub case: String,
    /// Integration scheme.
    #[arg(long, value_enum)]
    pub integrator: IntegratorArg,
    /// Output CSV (the reference files' exact header and row layout).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: SimArgs) -> anyhow::Result<std::process::ExitCode> {
    match args.command {
        SimCommand::Paper(a) => cmd_sim_paper::run(a),
        SimCommand::Reference(a) => cmd_sim_reference::run(a),
        SimCommand::Run(a) => crate::cmd_sim_run::run(a),
    }
}
