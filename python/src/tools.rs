//! `beamctl simulate`, `crlb` and `model` from Python: each command's own
//! options (clap), its own code, the JSON document `--json` prints.

use crate::{parse, to_py};
use beamctl::cli::args::{CrlbArgs, SimulateArgs};
use beamctl::cli::model::ModelArgs;
use pyo3::prelude::*;

#[derive(clap::Parser)]
#[command(name = "simulate")]
struct SimulateCmd {
    #[command(flatten)]
    args: SimulateArgs,
}

#[derive(clap::Parser)]
#[command(name = "crlb")]
struct CrlbCmd {
    #[command(flatten)]
    args: CrlbArgs,
}

#[derive(clap::Parser)]
#[command(name = "model")]
struct ModelCmd {
    #[command(flatten)]
    args: ModelArgs,
}

/// `beamctl simulate ARGV --json`: the JSON text (a law that produced no
/// estimate is in the report, not an error). The lock is released; Ctrl-C
/// stops the simulation (each seed's, with `seeds`) within a few thousand
/// evaluations.
#[pyfunction]
fn simulate_json(py: Python<'_>, argv: Vec<String>) -> PyResult<String> {
    let mut args = parse::<SimulateCmd>(argv)?.args;
    args.json = true;
    let mut pending: Option<PyErr> = None;
    let out = py.detach(|| {
        let mut interrupt = || crate::signalled(&mut pending);
        beamctl::cli::simulate::output_with(&args, Some(&mut interrupt))
    });
    out.map(|(text, _status)| text)
        .map_err(|e| crate::interrupted_or(e, pending))
}

/// `beamctl crlb ARGV --json`: the JSON text. The lock is released;
/// Ctrl-C stops the computation within a few thousand samples.
#[pyfunction]
fn crlb_json(py: Python<'_>, argv: Vec<String>) -> PyResult<String> {
    let mut args = parse::<CrlbCmd>(argv)?.args;
    args.json = true;
    let mut pending: Option<PyErr> = None;
    let out = py.detach(|| {
        let mut interrupt = || crate::signalled(&mut pending);
        beamctl::cli::crlb::output_with(&args, Some(&mut interrupt))
    });
    out.map_err(|e| crate::interrupted_or(e, pending))
}

/// `beamctl model ARGV --json`: the JSON text.
#[pyfunction]
fn model_json(argv: Vec<String>) -> PyResult<String> {
    let mut args = parse::<ModelCmd>(argv)?.args;
    args.json = true;
    beamctl::cli::model::output(&args).map_err(to_py)
}

/// The long flags of a command (`replay`, `simulate`, `crlb`, `model`),
/// each with whether it takes a value (false: a switch).
#[pyfunction]
fn option_names(command: &str) -> PyResult<Vec<(String, bool)>> {
    use clap::CommandFactory;
    let cmd = match command {
        "replay" => crate::ReplayCmd::command(),
        "simulate" => SimulateCmd::command(),
        "crlb" => CrlbCmd::command(),
        "model" => ModelCmd::command(),
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "command: no command named {other:?}"
            )))
        }
    };
    Ok(cmd
        .get_arguments()
        .filter_map(|a| {
            a.get_long()
                .map(|l| (l.to_string(), a.get_action().takes_values()))
        })
        .collect())
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(option_names, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_json, m)?)?;
    m.add_function(wrap_pyfunction!(crlb_json, m)?)?;
    m.add_function(wrap_pyfunction!(model_json, m)?)?;
    Ok(())
}
