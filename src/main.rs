//! The `fpsolve` command line: argument parsing and calls into the library, nothing more.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, parse_expr, Override};

/// Stationary PDFs of randomly excited nonlinear oscillators.
#[derive(Parser, Debug)]
#[command(name = "fpsolve", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Read a model file, check it, and print it with its parameter values and its derived
    /// drift, diffusion and Fokker-Planck coefficients.
    Check {
        /// The model file (`.sde`).
        model: PathBuf,
        /// Override a parameter: `--set name=value`, the value an expression of numbers,
        /// `pi`, `e` and other parameters. May be repeated.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
    },
}

/// Exit status for a model or flag error (clap uses the same for usage errors).
const USAGE_ERROR: u8 = 2;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed stdout (`fpsolve check m.sde | head`) is not an error worth reporting.
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            let text = format!("{e:#}");
            let mut stderr = std::io::stderr().lock();
            let _ = if text.starts_with("error") {
                writeln!(stderr, "{text}")
            } else {
                writeln!(stderr, "error: {text}")
            };
            ExitCode::from(USAGE_ERROR)
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Check { model, set } => check(&model, &set),
    }
}

/// Parses `name=value` into an [`Override`].
fn parse_override(arg: &str) -> Result<Override> {
    let Some((name, value)) = arg.split_once('=') else {
        bail!("`--set {arg}`: expected NAME=VALUE");
    };
    let name = name.trim();
    if name.is_empty() {
        bail!("`--set {arg}`: the parameter name is missing");
    }
    let value = parse_expr(value).map_err(|e| anyhow::anyhow!("error: in `--set {arg}`\n{e}"))?;
    Ok(Override {
        name: name.to_string(),
        value,
    })
}

fn check(path: &std::path::Path, set: &[String]) -> Result<()> {
    let overrides = set
        .iter()
        .map(|s| parse_override(s))
        .collect::<Result<Vec<_>>>()?;
    let model = load_model(path).map_err(|e| anyhow::anyhow!("{e}"))?;
    let bound = model
        .bind(&overrides)
        .map_err(|e| anyhow::anyhow!("error: {e}"))?;
    let mut out = std::io::stdout().lock();
    write!(out, "{model}").context("writing to stdout")?;
    writeln!(out, "\n# parameter values").context("writing to stdout")?;
    for (name, value) in bound.params() {
        writeln!(out, "#   {name} = {value}").context("writing to stdout")?;
    }
    let fpk = FpkOperator::derive(&bound)
        .map_err(|e| anyhow::anyhow!("error: {}: {e}", path.display()))?;
    writeln!(out, "\n# derived Fokker-Planck operator").context("writing to stdout")?;
    for line in fpk.to_string().lines() {
        writeln!(out, "# {line}").context("writing to stdout")?;
    }
    out.flush().context("writing to stdout")?;
    Ok(())
}
