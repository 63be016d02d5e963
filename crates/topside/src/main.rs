//! `topside`: the VideoRay Pro 4 control station.
//!
//! With no arguments it opens the station on the built-in simulated vehicle. The
//! subcommands give headless access for scripts and tests; each lives in its own module.

mod cmd_proto;
mod cmd_sim;
mod cmd_sim_paper;
mod cmd_sim_reference;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "topside",
    version,
    about = "Control station for the VideoRay Pro 4 ROV"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Encode and decode Pro 4 tether-protocol frames.
    Proto(cmd_proto::ProtoArgs),
    /// Run the simulator: reproduce the paper's experiments or a Fossen reference case.
    Sim(cmd_sim::SimArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Proto(args)) => cmd_proto::run(args),
        Some(Command::Sim(args)) => cmd_sim::run(args),
        None => Err(anyhow::anyhow!(
            "the station GUI is not built yet; use a subcommand (see --help)"
        )),
    };
    match result {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::from(2)
        }
    }
}
