//! `fpsolve passage MODEL`: first passage out of the safe set on the grid. Flags are read
//! and checked (the model, `--safe`, the start inside the set, the times, the cells) before
//! any solve; writes `passage.csv` and `summary.json`.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;
use fpsolve::grid::{Cells, GridPassage, PassageSolution};
use fpsolve::model::{BoundModel, BoundSafe, Model};
use fpsolve::report::write_json;
use serde::Serialize;

/// The flags of `fpsolve passage`.
#[derive(Args, Debug)]
pub(crate) struct PassageArgs {
    /// The safe set, overriding the model's `safe` line (`abs(z) < 2.5`, `-2 < z < 3`).
    #[arg(long, value_name = "SET", allow_hyphen_values = true)]
    safe: Option<String>,
    /// The start (position, velocity); default rest, 0,0.
    #[arg(long, value_name = "X,V", allow_hyphen_values = true)]
    start: Option<String>,
    /// Output times of R(t): FIRST:LAST:COUNT (COUNT >= 2, 0 <= FIRST < LAST).
    #[arg(long, value_name = "A:B:N")]
    times: Option<String>,
    /// Cells of the grid, position and velocity (default 200,400).
    #[arg(long, value_name = "NX,NV")]
    cells: Option<Cells>,
    /// Methods: `grid` only so far.
    #[arg(long, value_name = "M,...", default_value = "grid")]
    method: String,
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Output directory (default: out/<model name>_passage).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A checked `passage` command.
pub(crate) struct PassagePlan {
    path: PathBuf,
    model: Model,
    bound: BoundModel,
    safe: BoundSafe,
    start: [f64; 2],
    times: Vec<f64>,
    cells: [usize; 2],
    out: PathBuf,
}

/// Reads and checks everything before any solve.
pub(crate) fn plan(path: PathBuf, args: PassageArgs) -> Result<PassagePlan> {
    if args.method.split(',').any(|m| m.trim() != "grid") {
        return Err(anyhow!(
            "--method {}: only `grid` is available for first passage (Monte Carlo is not yet)",
            args.method
        ));
    }
    let (model, _, _) = crate::load(&path, &args.set)?;
    let model = match &args.safe {
        Some(text) => model.with_safe(text).map_err(crate::lib)?,
        None => model,
    };
    let overrides = args
        .set
        .iter()
        .map(|s| s.parse().map_err(crate::lib))
        .collect::<Result<Vec<_>>>()?;
    let bound = model.bind(&overrides).map_err(crate::at_error(&path))?;
    let safe = model
        .safe()
        .ok_or_else(|| {
            anyhow!(
                "{}: no safe set: add a `safe` line to the model or give --safe",
                path.display()
            )
        })?
        .bind(&bound)
        .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?;
    let start = match &args.start {
        None => [0.0, 0.0],
        Some(s) => parse_pair(s).context("--start")?,
    };
    if !safe.contains(start) {
        return Err(anyhow!(
            "--start {},{}: not inside the safe set `{}`",
            start[0],
            start[1],
            safe.text
        ));
    }
    let times = match &args.times {
        None => Vec::new(),
        Some(s) => parse_times(s).context("--times")?,
    };
    let cells = args.cells.unwrap_or_default().0;
    fpsolve::grid::check_cells(cells).map_err(|e| anyhow::Error::new(e).context("--cells"))?;
    let out = args
        .out
        .unwrap_or_else(|| Path::new("out").join(format!("{}_passage", model.name())));
    Ok(PassagePlan {
        path,
        model,
        bound,
        safe,
        start,
        times,
        cells,
        out,
    })
}

fn parse_pair(s: &str) -> Result<[f64; 2]> {
    let parts: Vec<&str> = s.split(',').collect();
    let num = |t: &str| -> Result<f64> {
        let v: f64 = t
            .trim()
            .parse()
            .map_err(|_| anyhow!("`{t}` is not a number"))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(anyhow!("`{t}` is not finite"))
        }
    };
    match parts.as_slice() {
        [x, v] => Ok([num(x)?, num(v)?]),
        _ => Err(anyhow!("`{s}`: expected X,V")),
    }
}

/// `FIRST:LAST:COUNT`, evenly spaced (shared with `fpsolve transient`).
pub(crate) fn parse_times(s: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = s.split(':').collect();
    let [a, b, n] = parts.as_slice() else {
        return Err(anyhow!("`{s}`: expected FIRST:LAST:COUNT"));
    };
    let (a, b): (f64, f64) = (
        a.trim()
            .parse()
            .map_err(|_| anyhow!("`{a}` is not a number"))?,
        b.trim()
            .parse()
            .map_err(|_| anyhow!("`{b}` is not a number"))?,
    );
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| anyhow!("`{n}` is not a count"))?;
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && a < b && (2..=100_000).contains(&n)) {
        return Err(anyhow!(
            "`{s}`: expected 0 <= FIRST < LAST, finite, and 2 <= COUNT <= 100000"
        ));
    }
    Ok((0..n)
        .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
        .collect())
}

#[derive(Serialize)]
struct Summary<'a> {
    fpsolve: &'static str,
    command: String,
    model: &'a str,
    model_file: String,
    safe: &'a str,
    start: [f64; 2],
    grid: &'a PassageSolution,
}

/// Solves and writes the output directory.
pub(crate) fn run(plan: PassagePlan) -> Result<()> {
    let run = crate::begin_output(&plan.out)?;
    let solution = GridPassage::new(&plan.bound, &plan.safe)
        .cells(plan.cells[0], plan.cells[1])
        .start(plan.start)
        .times(plan.times.clone())
        .run()
        .map_err(|e| anyhow::Error::new(e).context(plan.path.display().to_string()))?;
    let mut csv = String::from("t,R_grid,pdf_grid\n");
    for ((t, r), f) in solution
        .times
        .iter()
        .zip(&solution.reliability)
        .zip(&solution.pdf)
    {
        csv.push_str(&format!("{t},{r},{f}\n"));
    }
    run.out()
        .write_atomic("passage.csv", csv.as_bytes())
        .map_err(crate::lib)?;
    let summary = Summary {
        fpsolve: env!("CARGO_PKG_VERSION"),
        command: crate::command_line(),
        model: plan.model.name(),
        model_file: plan.path.display().to_string(),
        safe: &plan.safe.text,
        start: plan.start,
        grid: &solution,
    };
    write_json(run.out(), "summary.json", &summary).map_err(crate::lib)?;
    crate::cli::console::sayln!(
        "mean first-passage time from ({}, {}): {:.6} (grid {}x{}); stationary start: {:.6}",
        plan.start[0],
        plan.start[1],
        solution.mean_at_start,
        plan.cells[0],
        plan.cells[1],
        solution.mean_stationary
    );
    crate::commit_output(run, 2)
}
