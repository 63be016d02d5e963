//! `topside sim reference --params PARAMS.json --case NAME --integrator rk4|euler --out OUT.csv`
//!
//! Runs one case of a Fossen reference parameter file (the format of
//! shared/testdata/fossen_reference/parameters.json) and writes its trajectory with the
//! reference files' exact header and `%.15e` row layout. The parsing and the runner live
//! in `rov_sim::reference`.

use std::process::ExitCode;

use anyhow::Context as _;
use rov_sim::reference::{ReferenceIntegrator, ReferenceParams, reference_csv, run_reference_case};

use crate::cmd_sim::{IntegratorArg, ReferenceArgs};

pub fn run(args: ReferenceArgs) -> anyhow::Result<ExitCode> {
    let label = args.params.display().to_string();
    let text =
        std::fs::read_to_string(&args.params).with_context(|| format!("cannot read {label}"))?;
    let params = ReferenceParams::parse(&text, &label)?;
    let integrator = match args.integrator {
        IntegratorArg::Rk4 => ReferenceIntegrator::Rk4,
        IntegratorArg::Euler => ReferenceIntegrator::SemiImplicitEuler,
    };
    let rows = run_reference_case(&params, &args.case, integrator)?;
    std::fs::write(&args.out, reference_csv(&rows))
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    Ok(ExitCode::SUCCESS)
}
