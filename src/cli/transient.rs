//! `fpsolve transient MODEL --times A:B:N`: the density as it evolves from the model's
//! `initial` line (or `--initial`; rest without either), on the grid. Every flag is read
//! and checked before any step; writes `moments_vs_t.csv`, one `pdf_<state>_t.csv` per
//! state and `summary.json`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;
use fpsolve::grid::{Cells, Domain, GridTransient, Initial, TransientHistory, TRANSIENT_TOLERANCE};
use fpsolve::model::{BoundModel, Model};
use fpsolve::report::{write_json, Provenance};
use serde::Serialize;

/// The flags of `fpsolve transient`.
#[derive(Args, Debug)]
pub(crate) struct TransientArgs {
    /// Output times: FIRST:LAST:COUNT (COUNT >= 2, 0 <= FIRST < LAST).
    #[arg(long, value_name = "A:B:N")]
    times: String,
    /// Cells of the grid, position and velocity (default 200,400).
    #[arg(long, value_name = "NX,NV")]
    cells: Option<Cells>,
    /// The box, `STATE=LO:HI,STATE=LO:HI` (default: the stationary solver's box; required
    /// for a model whose coefficients depend on the time).
    #[arg(long, value_name = "BOX", allow_hyphen_values = true)]
    domain: Option<String>,
    /// The L1 error each step may make per unit time (default 1e-4).
    #[arg(long, value_name = "TOL")]
    tol: Option<f64>,
    /// Where the run starts, overriding the model's `initial` line: `rest`,
    /// `point z = 1, v = 0`, `gaussian mean z = 0, v = 0 cov 1, 0, 0, 1`.
    #[arg(long, value_name = "START", allow_hyphen_values = true)]
    initial: Option<String>,
    /// Methods: `grid` only so far.
    #[arg(long, value_name = "M,...", default_value = "grid")]
    method: String,
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Output directory (default: out/<model name>_transient).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A checked `transient` command.
pub(crate) struct TransientPlan {
    path: PathBuf,
    model: Model,
    bound: BoundModel,
    initial: Initial,
    initial_text: String,
    times: Vec<f64>,
    cells: [usize; 2],
    domain: Option<Domain>,
    tolerance: f64,
    out: PathBuf,
}

/// Reads and checks everything before any step.
pub(crate) fn plan(path: PathBuf, args: TransientArgs) -> Result<TransientPlan> {
    for m in args.method.split(',').map(str::trim) {
        match m {
            "grid" => {}
            "mc" => {
                return Err(anyhow!(
                    "--method mc: the Monte Carlo transient is not yet available; use `grid`"
                ))
            }
            other => return Err(anyhow!("--method {other}: expected `grid`")),
        }
    }
    let times = super::passage::parse_times(&args.times).context("--times")?;
    let (model, bound) = crate::load_amended(&path, &args.set, |model| match &args.initial {
        Some(text) => model.with_initial(text).map_err(crate::lib),
        None => Ok(model),
    })?;
    let (initial, initial_text) = match model.initial() {
        None => (Initial::Rest, "rest".to_string()),
        Some(spec) => {
            let state = spec
                .bind(&bound)
                .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?;
            (Initial::from(state), format!("{state:?}"))
        }
    };
    let cells = args.cells.unwrap_or_default().0;
    fpsolve::grid::check_cells(cells).map_err(|e| anyhow::Error::new(e).context("--cells"))?;
    let states = bound.states();
    let domain = args
        .domain
        .as_deref()
        .map(|d| Domain::parse_named(d, [&*states[0], &*states[1]]))
        .transpose()
        .map_err(|e| anyhow::Error::new(e).context("--domain"))?;
    if domain.is_none() && bound.time_dependent() {
        return Err(anyhow!(
            "--domain: required for a model whose coefficients depend on the time (the \
             automatic box is sized from a stationary law), e.g. --domain {}=-5:5,{}=-5:5",
            states[0],
            states[1]
        ));
    }
    let tolerance = args.tol.unwrap_or(TRANSIENT_TOLERANCE);
    if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
        return Err(anyhow!("--tol {tolerance}: expected a number in (0, 1)"));
    }
    let out = args
        .out
        .unwrap_or_else(|| Path::new("out").join(format!("{}_transient", model.name())));
    Ok(TransientPlan {
        path,
        model,
        bound,
        initial,
        initial_text,
        times,
        cells,
        domain,
        tolerance,
        out,
    })
}

#[derive(Serialize)]
struct Output {
    t: f64,
    mass: f64,
    negative_mass: f64,
    edge_mass: f64,
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    method: &'static str,
    initial: &'a str,
    times: usize,
    /// The run's settings and what it did (cells, box, tolerance, steps, factorisations).
    grid: &'a fpsolve::grid::TransientReport,
    outputs: Vec<Output>,
}

/// The quantities reported, states then observables, with their moments at each output.
fn moments_csv(model: &BoundModel, h: &TransientHistory) -> String {
    let mut names: Vec<String> = model.states().iter().map(|s| s.to_string()).collect();
    names.extend(model.observables().iter().map(|o| o.name.to_string()));
    let mut csv = String::from("t");
    for q in &names {
        let _ = write!(csv, ",{q}_mean,{q}_variance,{q}_kurtosis");
    }
    csv.push('\n');
    for s in &h.snapshots {
        let _ = write!(csv, "{}", s.t);
        for m in s.moments.iter().chain(&s.observables) {
            let _ = write!(csv, ",{},{},{}", m.mean, m.variance, m.kurtosis);
        }
        csv.push('\n');
    }
    csv
}

/// The marginal of state `axis` at every output, long format.
fn pdf_csv(h: &TransientHistory, axis: usize) -> String {
    let mut csv = String::from("t,x,grid\n");
    for s in &h.snapshots {
        let m = &s.marginals[axis];
        for (x, p) in m.centres.iter().zip(&m.density) {
            let _ = writeln!(csv, "{},{x},{p}", s.t);
        }
    }
    csv
}

/// Steps and writes the output directory.
pub(crate) fn run(plan: TransientPlan) -> Result<()> {
    let run = crate::begin_output(&plan.out)?;
    let mut transient = GridTransient::new(&plan.bound)
        .cells(plan.cells[0], plan.cells[1])
        .initial(plan.initial.clone())
        .tolerance(plan.tolerance)
        .times(plan.times.clone());
    if let Some(d) = plan.domain {
        transient = transient.domain(d);
    }
    let history = transient
        .run()
        .map_err(|e| anyhow::Error::new(e).context(plan.path.display().to_string()))?;
    let write = |name: &str, text: String| {
        run.out()
            .write_atomic(name, text.as_bytes())
            .map_err(crate::lib)
    };
    write("moments_vs_t.csv", moments_csv(&plan.bound, &history))?;
    let states = plan.bound.states();
    for (axis, q) in states.iter().enumerate() {
        write(&format!("pdf_{q}_t.csv"), pdf_csv(&history, axis))?;
    }
    let summary = Summary {
        provenance: Provenance::now(Some(&plan.model)),
        method: "grid",
        initial: &plan.initial_text,
        times: plan.times.len(),
        grid: &history.report,
        outputs: history
            .snapshots
            .iter()
            .map(|s| Output {
                t: s.t,
                mass: s.mass,
                negative_mass: s.negative_mass,
                edge_mass: s.edge_mass,
            })
            .collect(),
    };
    write_json(run.out(), "summary.json", &summary).map_err(crate::lib)?;
    let r = &history.report;
    let peak = history
        .snapshots
        .iter()
        .max_by(|a, b| a.moments[0].variance.total_cmp(&b.moments[0].variance));
    if let Some(p) = peak {
        crate::cli::console::sayln!(
            "grid transient {}x{}: {} steps ({} rejected), {} factorisations; peak sd of {} \
             {:.6} at t = {}; worst |mass - 1| {:.1e}, negative mass {:.1e}",
            r.cells[0],
            r.cells[1],
            r.accepted,
            r.rejected,
            r.factorizations,
            states[0],
            p.moments[0].variance.sqrt(),
            p.t,
            r.mass_drift,
            r.negative_mass
        );
    }
    crate::commit_output(run, 2 + states.len())
}
