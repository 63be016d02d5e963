//! `topside sim reference --params PARAMS.json --case NAME --integrator rk4|euler --out OUT.csv`
//!
//! Runs one case of a Fossen reference parameter file (the format of
//! shared/testdata/fossen_reference/parameters.json) and writes its trajectory with the
//! reference files' header and columns, numbers in the shortest form that reads back
//! exactly. Rows are written as they are computed (to `OUT.csv.partial`, renamed when
//! complete), so a run of millions of steps needs no more memory than a short one. The
//! parsing and the runner live in `rov_sim::reference`.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use rov_sim::reference::{
    REFERENCE_HEADER, ReferenceIntegrator, ReferenceParams, push_reference_row,
    run_reference_case_with,
};

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
    let partial = {
        let mut n = args.out.clone().into_os_string();
        n.push(".partial");
        PathBuf::from(n)
    };
    let file = std::fs::File::create(&partial)
        .with_context(|| format!("cannot write {}", partial.display()))?;
    let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
    let mut line = String::with_capacity(512);
    let write_err = |e: std::io::Error| anyhow::anyhow!("cannot write {}: {e}", partial.display());
    writeln!(out, "{REFERENCE_HEADER}").map_err(write_err)?;
    let res = run_reference_case_with(&params, &args.case, integrator, |row| {
        line.clear();
        push_reference_row(&mut line, row);
        out.write_all(line.as_bytes()).map_err(write_err)
    });
    let res = res.and_then(|()| out.flush().map_err(write_err));
    drop(out);
    if let Err(e) = res {
        let _ = std::fs::remove_file(&partial);
        return Err(e);
    }
    std::fs::rename(&partial, &args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    Ok(ExitCode::SUCCESS)
}
