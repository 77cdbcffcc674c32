//! `Model.transient`: the density as it evolves from the model's start, on the grid and by
//! Monte Carlo, as `fpsolve transient` computes it (src/cli/transient.rs): the same checks in
//! the same order and before any work, the same defaults, the same library calls
//! (`fpsolve::job::transient`), so the same numbers to the bit. Returns the finished run,
//! whose tables, `summary.json` text and warnings the pure-Python layer
//! (`fpsolve/_transient.py`) makes arrays, and which writes the command line's files.

use std::path::PathBuf;

use fpsolve::grid::Domain;
use fpsolve::job::transient::{
    initial_state, Columns, McSettings, Methods, TransientRun, TransientRunError,
    TransientSettings, TransientSetupError, TransientWarning,
};
use fpsolve::model::BoundModel;
use fpsolve::report::RunDir;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arguments::{cells_of, times_of};
use crate::errors;
use crate::interrupt::abandonable;
use crate::model::PyModel;

/// Named columns as NumPy arrays.
type Arrays<'py> = Vec<(String, Bound<'py, PyArray1<f64>>)>;

/// A finished transient: the histories, the model they are of, `summary.json`'s text and
/// the warnings.
#[pyclass(name = "_Transient", module = "fpsolve._fpsolve", frozen)]
pub(crate) struct PyTransient {
    run: TransientRun,
    bound: BoundModel,
    summary: String,
    warnings: Vec<TransientWarning>,
}

fn arrays(py: Python<'_>, columns: Columns) -> Arrays<'_> {
    columns
        .names
        .into_iter()
        .zip(columns.values)
        .map(|(name, values)| (name, values.into_pyarray(py)))
        .collect()
}

#[pymethods]
impl PyTransient {
    /// `summary.json`'s text.
    fn summary_json(&self) -> &str {
        &self.summary
    }

    /// The states, then the observables (the grid's quantities).
    fn quantities(&self) -> Vec<String> {
        let states = self.bound.states().iter().map(|s| s.to_string());
        let observables = self.bound.observables().iter().map(|o| o.name.to_string());
        states.chain(observables).collect()
    }

    /// `moments_vs_t.csv`'s columns.
    fn moments<'py>(&self, py: Python<'py>) -> Arrays<'py> {
        arrays(py, self.run.moments(&self.bound))
    }

    /// `pdf_<state>_t.csv`'s columns for state `axis` (0 or 1).
    fn pdf<'py>(&self, py: Python<'py>, axis: usize) -> PyResult<Arrays<'py>> {
        if axis > 1 {
            return Err(errors::bad_argument(format!(
                "axis {axis}: expected 0 or 1"
            )));
        }
        Ok(arrays(py, self.run.pdf(axis)))
    }

    /// The warnings as the CLI words them, each with whether it flags the run (the CLI's
    /// exit status 1).
    fn warnings(&self) -> Vec<(String, bool)> {
        self.warnings
            .iter()
            .map(|w| (w.to_string(), w.flags()))
            .collect()
    }

    /// Writes the command line's files into `out` (staged, then moved into place whole);
    /// returns the directory written.
    #[pyo3(signature = (out, figures=true))]
    fn write(&self, py: Python<'_>, out: PathBuf, figures: bool) -> PyResult<PathBuf> {
        let failed = |e: fpsolve::report::ReportError| {
            errors::other::<errors::JobError>(py, "output", e.to_string())
        };
        let run = RunDir::begin(&out, "fpsolve (Python) Model.transient").map_err(failed)?;
        py.allow_threads(|| {
            self.run
                .write(run.out(), &self.bound, &self.summary, figures)
        })
        .map_err(failed)?;
        run.commit().map_err(failed)
    }
}

/// A refusal before any work as the package's classes say it: a setting out of range a
/// `ValueError` naming the keyword, the grid's and Monte Carlo's refusals theirs.
fn setup_error(py: Python<'_>, e: &TransientSetupError) -> PyErr {
    match (e, e.setting()) {
        (TransientSetupError::Grid(g), _) => errors::transient_error(py, g),
        (TransientSetupError::Mc(m), _) => errors::mc_transient_error(py, m),
        (_, Some(keyword)) => errors::bad_argument(format!("{keyword}: {e}")),
        (_, None) => errors::bad_argument(e.to_string()),
    }
}

/// The transient of `model` as `fpsolve transient`: checks every argument in the CLI's
/// order, runs, and returns the finished run.
#[pyfunction]
#[pyo3(signature = (model, times, cells, domain, tol, initial, method, trajectories, dt, seed, threads, set=None, period=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn transient(
    py: Python<'_>,
    model: &Bound<'_, PyModel>,
    times: &Bound<'_, PyAny>,
    cells: Option<[i64; 2]>,
    domain: Option<String>,
    tol: Option<f64>,
    initial: Option<String>,
    method: String,
    trajectories: i64,
    dt: f64,
    seed: u64,
    threads: Option<usize>,
    set: Option<&Bound<'_, PyDict>>,
    period: Option<f64>,
) -> PyResult<PyTransient> {
    let this = model.get();
    // The CLI's order: the cells (read with the flags), the methods, the times, the model
    // with its overrides and start, the box, the trajectories, then the library's checks.
    let cells = cells_of(cells)?;
    let methods: Methods = method
        .parse()
        .map_err(|e| errors::bad_argument(format!("method: {e}")))?;
    let times = times_of(times)?;
    let (amended, bound) = this.bind_amended(py, set, |model| match &initial {
        Some(text) => model.with_initial(text),
        None => Ok(model.clone()),
    })?;
    let path = this.path.as_deref();
    let named = path.map_or(String::new(), |p| format!("{}: ", p.display()));
    let initial = initial_state(&amended, &bound)
        .map_err(|e| errors::unlocated_model_error(py, "initial", path, format!("{named}{e}")))?;
    let states = bound.states();
    let domain = domain
        .map(|d| Domain::parse_named(&d, [&*states[0], &*states[1]]))
        .transpose()
        .map_err(|e| errors::bad_argument(format!("domain: {e}")))?;
    let mut mc = McSettings {
        dt,
        seed,
        ..McSettings::default()
    };
    if methods.mc() {
        // As the CLI reads --trajectories.
        if !(1..=1_000_000_000_000_000).contains(&trajectories) {
            return Err(errors::bad_argument(format!(
                "trajectories: {trajectories} must be between 1 and 1e15"
            )));
        }
        mc.trajectories = trajectories as u64;
    }
    let settings = TransientSettings {
        methods,
        times,
        initial,
        cells,
        domain,
        tolerance: tol,
        mc,
        period,
    };
    let checked = settings.check(&bound).map_err(|e| setup_error(py, &e))?;
    let pool = crate::pool::thread_pool(threads)?;
    let finished = abandonable(py, {
        let bound = bound.clone();
        move || {
            // The provenance on the pool the run used (its threads).
            pool.install(|| {
                let run = checked.run(&bound)?;
                let provenance = fpsolve::report::Provenance::now_bound(&bound);
                Ok::<_, TransientRunError>((run, provenance))
            })
        }
    })?;
    let (run, provenance) = finished.map_err(|e| match e {
        TransientRunError::Grid(e) => errors::transient_error(py, &e),
        TransientRunError::Mc(e) => errors::mc_transient_error(py, &e),
        TransientRunError::Bins(e) => errors::mc_error(py, &e),
    })?;
    let (summary, _) = run
        .summary_json(&bound, provenance)
        .map_err(|e| errors::other::<errors::JobError>(py, "summary", e.to_string()))?;
    let warnings = run.warnings(&bound);
    Ok(PyTransient {
        run,
        bound,
        summary,
        warnings,
    })
}
