//! `topside lab` through the library (the CLI module compiled into this test) and, once
//! main.rs wires the subcommand, through the real binary.

#[allow(dead_code)]
#[path = "../src/cmd_lab.rs"]
mod cmd_lab;

#[test]
fn lab_module_compiles_and_lists() {
    use clap::Parser;
    #[derive(Debug, clap::Parser)]
    struct Cli {
        #[command(subcommand)]
        command: Cmd,
    }
    #[derive(Debug, clap::Subcommand)]
    enum Cmd {
        Lab(cmd_lab::LabArgs),
    }
    for args in [["topside", "lab", "effects"], ["topside", "lab", "models"]] {
        let cli = Cli::parse_from(args);
        let Cmd::Lab(a) = cli.command;
        assert_eq!(cmd_lab::run(a).unwrap(), std::process::ExitCode::SUCCESS);
    }
}
