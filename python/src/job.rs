//! `fpsolve.run_job`: the command line's main job (`fpsolve MODEL --out DIR`) from Python,
//! writing the same files the same way (staged, moved into place whole).

use std::path::PathBuf;

use fpsolve::job::{self, Job, JobSpec, Target};
use fpsolve::report::RunDir;
use fpsolve::solve::{MethodName, MethodSet, Problem};
use fpsolve::study::MethodPlan;
use pyo3::prelude::*;

use crate::errors::{self, Asked};
use crate::interrupt::abandonable;
use crate::model::{overrides, PyModel};

/// What the main job did: the table the command line prints, the files written, and what in
/// them is flagged (the reasons the command line would exit 1).
#[derive(IntoPyObject)]
pub(crate) struct JobOutcome {
    table: String,
    files: Vec<PathBuf>,
    flags: Vec<String>,
}

/// Runs the main job on `model` into `out`: EPC at `degrees` and the grid, with EPC-impact
/// where EPC cannot use the impact law, each where it applies ([`job::default_methods`]),
/// unless `methods` names others, with the overrides `set`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, out, methods=None, degrees=vec![2, 4], cells=None, set=None, figures=true, tol=None))]
pub(crate) fn run_job(
    py: Python<'_>,
    model: &PyModel,
    out: PathBuf,
    methods: Option<Vec<String>>,
    degrees: Vec<usize>,
    cells: Option<[usize; 2]>,
    set: Option<&Bound<'_, pyo3::types::PyDict>>,
    figures: bool,
    tol: Option<f64>,
) -> PyResult<JobOutcome> {
    let path = model.path.clone();
    let overrides = overrides(py, set)?;
    let bound = model
        .model
        .bind(&overrides)
        .map_err(|e| errors::bind_error(py, &e, path.as_deref()))?;
    let named = methods.is_some();
    let asked = Asked {
        method: "job",
        degree: None,
    };
    let problem = crate::pool::on_pool(py, || Problem::owning(bound))?
        .map_err(|e| errors::solve_error(py, &e, &asked))?;
    let methods = match methods {
        Some(m) => {
            let names = m
                .iter()
                .map(|m| m.parse::<MethodName>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| errors::bad_argument(e.to_string()))?;
            MethodSet::new(names).map_err(|e| errors::bad_argument(e.to_string()))?
        }
        None => job::default_methods(&problem).map_err(|e| errors::solve_error(py, &e, &asked))?,
    };
    let plan = MethodPlan::new(&problem, &methods, named)
        .map_err(|e| errors::other::<errors::NotApplicableError>(py, "methods", e.to_string()))?;
    // As the command line's --tol: checked, not with cells, only when the grid runs; without
    // cells or a tolerance the grid is solved to the default tolerance.
    let grid_runs = plan.run.contains(&MethodName::Grid);
    if let Some(t) = tol {
        fpsolve::grid::check_tolerance(t).map_err(|e| errors::bad_argument(format!("tol: {e}")))?;
        if let Some([nx, nv]) = cells {
            return Err(errors::bad_argument(format!(
                "tol {t} with cells ({nx}, {nv}): give one (the tolerance chooses the cells)"
            )));
        }
        if !grid_runs {
            return Err(errors::bad_argument(format!(
                "tol {t}: the grid solver does not run ({methods})"
            )));
        }
    }
    let tol = grid_runs
        .then(|| fpsolve::grid::front_end_tolerance(tol, cells.is_some()))
        .flatten();
    let problem = problem.with_grid_tolerance(tol);
    let spec = JobSpec {
        degrees,
        overrides,
        target: Target::Observables,
        methods,
        methods_named: named,
        cells: cells.unwrap_or(fpsolve::grid::DEFAULT_CELLS),
        figures,
        ..JobSpec::default()
    };
    let run = RunDir::begin(&out, "fpsolve (Python) run_job")
        .map_err(|e| errors::other::<errors::JobError>(py, "output", e.to_string()))?;
    let inner = model.model.clone();
    let pool = crate::pool::shared()?;
    // Ctrl-C returns at once; the abandoned job finishes unseen and its staging directory goes
    // with it (nothing is committed).
    let (run, report) = abandonable(py, move || {
        let report = pool.install(|| Job::new(&inner, &spec).problem(&problem).run(run.out()));
        (run, report)
    })?;
    let report = report.map_err(|e| errors::other::<errors::JobError>(py, "job", e.to_string()))?;
    let staging = run.out().path().to_path_buf();
    let dest = run
        .commit()
        .map_err(|e| errors::other::<errors::JobError>(py, "output", e.to_string()))?;
    // The files where they are now: moved from the staging directory into `out`.
    let files = report
        .files
        .iter()
        .map(|f| {
            f.strip_prefix(&staging)
                .map_or_else(|_| f.clone(), |rel| dest.join(rel))
        })
        .collect();
    Ok(JobOutcome {
        table: report.to_string(),
        files,
        flags: job::flags(&report),
    })
}
