//! `fpsolve.Model`: a model file read and validated, its derived operator, and the calls that
//! solve or simulate it with parameter overrides.

use std::path::{Path, PathBuf};

use fpsolve::base::limits::memory_limit_bytes;
use fpsolve::base::run::RunControl;
use fpsolve::grid::Cells;
use fpsolve::mc::{Grid, McConfig, Shard, Simulation};
use fpsolve::model::{load_model, parse_model, BoundModel, Model, Override};
use fpsolve::solve::{Method, MethodName, Problem};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::errors::{self, Asked};
use crate::interrupt::{abandonable_cancelling, interruptible_reporting};
use crate::solution::PySolution;

/// A validated model (`Model.load(path)`, `Model.from_text(text)`).
#[pyclass(name = "_Model", module = "fpsolve._fpsolve", frozen)]
pub(crate) struct PyModel {
    pub(crate) model: Model,
    pub(crate) path: Option<PathBuf>,
    /// The text `model` was parsed from: what a pickled model carries.
    pub(crate) text: String,
}

/// Overrides from a dict `{name: value}`: a number, or a string holding an expression of
/// numbers, `pi`, `e` and other parameters (as `--set name=expr` takes it).
pub(crate) fn overrides(
    py: Python<'_>,
    set: Option<&Bound<'_, PyDict>>,
) -> PyResult<Vec<Override>> {
    let Some(set) = set else {
        return Ok(Vec::new());
    };
    let mut out = Vec::with_capacity(set.len());
    for (key, value) in set.iter() {
        let name: String = key.extract()?;
        if value.is_instance_of::<PyString>() {
            let text: String = value.extract()?;
            let parsed = format!("{name}={text}")
                .parse::<Override>()
                .map_err(|e| errors::set_error(py, &e))?;
            out.push(parsed);
        } else if let Ok(x) = value.extract::<f64>() {
            // Any real Python converts with float(): int, float, NumPy's scalars and 0-d
            // arrays, Fraction.
            out.push(Override::number(&name, x));
        } else {
            let t = value.get_type().name()?.to_string();
            return Err(errors::bad_argument(format!(
                "parameter `{name}`: expected a number or an expression string, got {t}"
            )));
        }
    }
    Ok(out)
}

impl PyModel {
    /// The model bound with `set` and the run's settings, checked before any work (the
    /// preflight `simulate` and `simulate_shard` share).
    #[allow(clippy::too_many_arguments)]
    fn checked_run(
        &self,
        py: Python<'_>,
        samples: u64,
        seed: u64,
        dt: Option<f64>,
        spacing: Option<f64>,
        trajectories: Option<u64>,
        bins: Option<usize>,
        record: &Record,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<(BoundModel, McConfig)> {
        let bound = self.bind(py, set)?;
        let config = mc_config(samples, seed, dt, spacing, trajectories, bins, record)
            .map_err(|e| errors::mc_error(py, &e))?;
        config
            .preflight(&bound)
            .map_err(|e| errors::mc_error(py, &e))?;
        Ok((bound, config))
    }

    pub(crate) fn bind(
        &self,
        py: Python<'_>,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<BoundModel> {
        let overrides = overrides(py, set)?;
        self.model
            .bind(&overrides)
            .map_err(|e| errors::bind_error(py, &e, self.path.as_deref()))
    }

    /// The model amended by a line given beside it (a `safe=` or `initial=` text), bound
    /// with `set`, in the CLI's order: the overrides against the model as read, then the
    /// amendment (a `ModelError` located in its text), then the amended model bound.
    pub(crate) fn bind_amended(
        &self,
        py: Python<'_>,
        set: Option<&Bound<'_, PyDict>>,
        amend: impl FnOnce(&Model) -> Result<Model, fpsolve::model::ModelError>,
    ) -> PyResult<(Model, BoundModel)> {
        let overrides = overrides(py, set)?;
        let path = self.path.as_deref();
        self.model
            .bind(&overrides)
            .map_err(|e| errors::bind_error(py, &e, path))?;
        let amended = amend(&self.model).map_err(|e| errors::model_error(py, &e, None))?;
        let bound = amended
            .bind(&overrides)
            .map_err(|e| errors::bind_error(py, &e, path))?;
        Ok((amended, bound))
    }
}

/// The grid's box `text` gives (`x=LO:HI,v=LO:HI`, the model's state names), checked
/// against the model's walls before any work, as the CLI's `--domain`; only with the grid.
fn grid_domain(
    text: Option<&str>,
    method: &Method,
    model: &BoundModel,
) -> PyResult<Option<fpsolve::grid::Domain>> {
    let Some(text) = text else {
        return Ok(None);
    };
    if !matches!(method, Method::Grid { .. }) {
        return Err(errors::bad_argument(format!(
            "domain {text}: only the grid solver takes a box (method {})",
            method.name()
        )));
    }
    let [x, v] = model.states();
    let domain = fpsolve::grid::Domain::parse_named(text, [x, v])
        .map_err(|e| errors::bad_argument(format!("domain: {e}")))?;
    fpsolve::grid::GridSolver::new(model)
        .domain(domain)
        .check()
        .map_err(|e| errors::bad_argument(format!("domain {text}: {e}")))?;
    Ok(Some(domain))
}

/// The grid's L1 tolerance `tol=` asks (issue 34), checked as the command line's `--tol`:
/// 0 < tol <= 0.5, not with `cells`, only for the grid. The grid then chooses its cells and
/// its report's `tolerance` says what it achieved. The grid without `cells` or `tol` is
/// solved to [`fpsolve::grid::DEFAULT_TOLERANCE`], as on the command line.
fn grid_tolerance(
    tol: Option<f64>,
    cells: Option<[usize; 2]>,
    method: &str,
) -> PyResult<Option<f64>> {
    let Some(tol) = tol else {
        let grid = matches!(method.parse(), Ok(MethodName::Grid));
        return Ok(grid
            .then(|| fpsolve::grid::front_end_tolerance(None, cells.is_some()))
            .flatten());
    };
    fpsolve::grid::check_tolerance(tol).map_err(|e| errors::bad_argument(format!("tol: {e}")))?;
    if let Some([nx, nv]) = cells {
        return Err(errors::bad_argument(format!(
            "tol {tol} with cells ({nx}, {nv}): give one (the tolerance chooses the cells)"
        )));
    }
    if !matches!(method.parse(), Ok(MethodName::Grid)) {
        return Err(errors::bad_argument(format!(
            "tol {tol}: only the grid solver takes a tolerance (method {method})"
        )));
    }
    Ok(Some(tol))
}

/// The method named `method` at `degree` / on `cells`.
pub(crate) fn method(name: &str, degree: usize, cells: Option<[usize; 2]>) -> PyResult<Method> {
    let parsed: MethodName = name
        .parse()
        .map_err(|e: fpsolve::solve::MethodNameError| errors::bad_argument(e.to_string()))?;
    let method = parsed
        .method()
        .settle(degree, cells.unwrap_or(fpsolve::grid::DEFAULT_CELLS));
    // The grid's cells must fit in memory, checked before any work.
    if let Method::Grid { cells } = method {
        Cells(cells)
            .within(memory_limit_bytes())
            .map_err(|e| errors::bad_argument(format!("cells: {e}")))?;
    }
    Ok(method)
}

#[pymethods]
impl PyModel {
    /// Reads and validates the model file at `path`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyModel> {
        // `load_model` checks the file (a regular file, its size, its encoding) and reports
        // it as the command line does; the model kept is then parsed from the text read
        // after, so that the text a pickle carries is the model's own even if the file
        // changed in between.
        let read = py.allow_threads(|| {
            load_model(&path)?;
            let text = std::fs::read_to_string(&path).map_err(|source| {
                fpsolve::model::ModelError::Io {
                    path: path.clone(),
                    source,
                }
            })?;
            let model = parse_model(&text, Some(&path))?;
            Ok((model, text))
        });
        let (model, text) = read.map_err(|e| errors::model_error(py, &e, Some(&path)))?;
        Ok(PyModel {
            model,
            path: Some(path),
            text,
        })
    }

    /// Parses and validates model text; `path` only names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, path=None))]
    fn from_text(py: Python<'_>, text: &str, path: Option<PathBuf>) -> PyResult<PyModel> {
        let model = parse_model(text, path.as_deref())
            .map_err(|e| errors::model_error(py, &e, path.as_deref()))?;
        Ok(PyModel {
            model,
            path,
            text: text.to_string(),
        })
    }

    /// The model text.
    #[getter]
    fn text(&self) -> &str {
        &self.text
    }

    #[getter]
    fn name(&self) -> &str {
        self.model.name()
    }

    #[getter]
    fn description(&self) -> &str {
        self.model.description()
    }

    #[getter]
    fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    #[getter]
    fn states(&self) -> Vec<String> {
        self.model.states().iter().map(|s| s.to_string()).collect()
    }

    #[getter]
    fn observables(&self) -> Vec<String> {
        self.model
            .observables()
            .iter()
            .map(|o| o.name.to_string())
            .collect()
    }

    /// The parameters' values with `set` applied, in declaration order.
    #[pyo3(signature = (set=None))]
    fn parameters(
        &self,
        py: Python<'_>,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Vec<(String, f64)>> {
        let bound = self.bind(py, set)?;
        Ok(bound
            .params()
            .iter()
            .map(|(n, v)| (n.to_string(), *v))
            .collect())
    }

    /// What `fpsolve check` prints: the model, its parameter values and derived operator.
    #[pyo3(signature = (set=None))]
    fn check(&self, py: Python<'_>, set: Option<&Bound<'_, PyDict>>) -> PyResult<String> {
        let bound = self.bind(py, set)?;
        crate::pool::on_pool(py, || fpsolve::check::render(&self.model, &bound))?
            .map_err(|e| errors::derive_error(py, &e, self.path.as_deref()))
    }

    /// Solves the stationary FPK equation by `method` (GIL released); `domain` is the grid's
    /// box as `--domain` takes it (`x=LO:HI,v=LO:HI` with the model's state names); `tol` the
    /// grid's L1 tolerance as `--tol` takes it (see [`grid_tolerance`]).
    #[pyo3(signature = (method, degree, cells=None, set=None, domain=None, tol=None))]
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &self,
        py: Python<'_>,
        method: &str,
        degree: usize,
        cells: Option<[usize; 2]>,
        set: Option<&Bound<'_, PyDict>>,
        domain: Option<&str>,
        tol: Option<f64>,
    ) -> PyResult<PySolution> {
        let tol = grid_tolerance(tol, cells, method)?;
        let chosen = self::method(method, degree, cells)?;
        let asked = Asked {
            method,
            degree: (!matches!(chosen, Method::Grid { .. })).then_some(degree),
        };
        let bound = self.bind(py, set)?;
        let domain = grid_domain(domain, &chosen, &bound)?;
        // A grid solve stops only between its factorisations: Ctrl-C returns at once, and the
        // solve, left running, stops at its next check.
        let pool = crate::pool::shared()?;
        let solved = abandonable_cancelling(py, move |cancel| {
            pool.install(|| {
                // Made on the pool, so that it states the pool's threads.
                let provenance = fpsolve::report::Provenance::now_bound(&bound);
                let problem = Problem::new(&bound)?
                    .with_grid_domain(domain)
                    .with_grid_tolerance(tol);
                let run = RunControl::new().cancelled_by(cancel);
                problem.solve_with(chosen, &run).map(|s| (s, provenance))
            })
        })?;
        let (solution, provenance) = solved.map_err(|e| errors::solve_error(py, &e, &asked))?;
        Ok(PySolution::new(
            solution,
            method.to_string(),
            asked.degree,
            provenance,
        ))
    }

    /// Runs the Monte Carlo simulation; returns its result as JSON (the `McResult`'s serde
    /// form). Interruptible: Ctrl-C cancels the run and raises KeyboardInterrupt.
    #[pyo3(signature = (samples, seed, threads, dt, spacing, trajectories, bins, grids, levels=Vec::new(), impact_speeds=None, set=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn simulate(
        &self,
        py: Python<'_>,
        samples: u64,
        seed: u64,
        threads: Option<usize>,
        dt: Option<f64>,
        spacing: Option<f64>,
        trajectories: Option<u64>,
        bins: Option<usize>,
        grids: Vec<(String, f64, f64, usize)>,
        levels: Vec<(String, Vec<f64>)>,
        impact_speeds: Option<(f64, f64, usize)>,
        set: Option<&Bound<'_, PyDict>>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<(String, Vec<String>, Vec<String>)> {
        let pool = crate::pool::thread_pool(threads)?;
        let record = Record {
            grids,
            levels,
            impact_speeds,
        };
        let (bound, config) = self.checked_run(
            py,
            samples,
            seed,
            dt,
            spacing,
            trajectories,
            bins,
            &record,
            set,
        )?;
        // The pilot run that sizes the histograms is parallel too: on the pool, not rayon's
        // global one.
        let (simulation, provenance) = py
            .allow_threads(|| {
                pool.install(|| {
                    // Made on the pool, so that it states the pool's threads.
                    let provenance = fpsolve::report::Provenance::now_bound(&bound);
                    Simulation::new(&bound, &config).map(|s| (s, provenance))
                })
            })
            .map_err(|e| errors::mc_error(py, &e))?;
        let run = interruptible_reporting(py, progress.as_ref(), |cancel, counter| {
            let report = |done: u64, total: u64| counter.report(done, total);
            pool.install(|| simulation.run_cancellable(&report, cancel))
        })?;
        let result = run.map_err(|e| errors::mc_error(py, &e))?;
        mc_outcome(&result, &provenance)
    }

    /// Runs part `index` (from 0) of `count` of the Monte Carlo simulation (its statistics
    /// batches); returns the part as JSON (`ShardOutput`'s serde form, the command line's
    /// `shard_K_of_N.json`, with its provenance: the model and the threads it ran with), which
    /// `merge_mc_json` joins with the others.
    #[pyo3(signature = (index, count, samples, seed, threads, dt, spacing, trajectories, bins, grids, levels=Vec::new(), impact_speeds=None, set=None))]
    #[allow(clippy::too_many_arguments)]
    fn simulate_shard(
        &self,
        py: Python<'_>,
        index: u64,
        count: u64,
        samples: u64,
        seed: u64,
        threads: Option<usize>,
        dt: Option<f64>,
        spacing: Option<f64>,
        trajectories: Option<u64>,
        bins: Option<usize>,
        grids: Vec<(String, f64, f64, usize)>,
        levels: Vec<(String, Vec<f64>)>,
        impact_speeds: Option<(f64, f64, usize)>,
        set: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        let pool = crate::pool::thread_pool(threads)?;
        let shard = Shard::new(index, count).map_err(|e| errors::mc_error(py, &e))?;
        let record = Record {
            grids,
            levels,
            impact_speeds,
        };
        let (bound, config) = self.checked_run(
            py,
            samples,
            seed,
            dt,
            spacing,
            trajectories,
            bins,
            &record,
            set,
        )?;
        let part = py
            .allow_threads(|| pool.install(|| Simulation::new(&bound, &config)?.run_shard(shard)));
        let part = part.map_err(|e| errors::mc_error(py, &e))?;
        serde_json::to_string(&part).map_err(|e| errors::bad_argument(e.to_string()))
    }

    fn __repr__(&self) -> String {
        match &self.path {
            Some(p) => format!("Model.load({:?})", p.display().to_string()),
            None => format!("<fpsolve.Model {:?}>", self.model.name()),
        }
    }
}

/// A Monte Carlo result as Python takes it: its JSON, its flags (what the CLI exits 1 for:
/// the verdict's failures and numbers without a finite value, which the JSON carries as null,
/// NaN in Python) and its warnings.
/// The JSON carries `provenance` first, as `mc_summary.json` does.
pub(crate) fn mc_outcome(
    result: &fpsolve::mc::McResult,
    provenance: &fpsolve::report::Provenance,
) -> PyResult<(String, Vec<String>, Vec<String>)> {
    let undefined = fpsolve::report::undefined_fields(result).map_err(errors::bad_argument)?;
    let flags = fpsolve::job::mc_flags(result, &undefined);
    let warnings = result.warnings.iter().map(ToString::to_string).collect();
    let text = |e: serde_json::Error| errors::bad_argument(e.to_string());
    let json = serde_json::to_string(result).map_err(text)?;
    Ok((
        provenance_first(provenance, &json).map_err(text)?,
        flags,
        warnings,
    ))
}

/// The JSON object `json` with `provenance` put in as its first member.
pub(crate) fn provenance_first(
    provenance: &fpsolve::report::Provenance,
    json: &str,
) -> Result<String, serde_json::Error> {
    let head = serde_json::to_string(provenance)?;
    let body = json.strip_prefix('{').unwrap_or(json);
    let sep = if body.starts_with('}') { "" } else { "," };
    Ok(format!("{{\"provenance\":{head}{sep}{body}"))
}

/// The Monte Carlo configuration of `simulate`: `samples` recorded samples in all, spread over
/// the trajectories as the command line's `--samples` does.
fn mc_config(
    samples: u64,
    seed: u64,
    dt: Option<f64>,
    spacing: Option<f64>,
    trajectories: Option<u64>,
    bins: Option<usize>,
    record: &Record,
) -> Result<McConfig, fpsolve::mc::McError> {
    let default = McConfig::default();
    let lanes = default.lanes as u64;
    let trajectories = trajectories
        .unwrap_or(default.trajectories)
        .max(1)
        .div_ceil(lanes)
        .saturating_mul(lanes);
    let grids = record
        .grids
        .iter()
        .map(|(name, lo, hi, n)| Ok((name.clone(), Grid::new(*lo, *hi, *n)?)))
        .collect::<Result<Vec<_>, fpsolve::mc::McError>>()?;
    let impact_speeds = match record.impact_speeds {
        Some((lo, hi, n)) => Some(Grid::new(lo, hi, n)?),
        None => None,
    };
    Ok(McConfig {
        dt: dt.unwrap_or(default.dt),
        spacing: spacing.unwrap_or(default.spacing),
        trajectories,
        samples: samples.div_ceil(trajectories).max(1),
        seed,
        bins: bins.unwrap_or(default.bins),
        grids,
        levels: record.levels.clone(),
        impact_speeds,
        ..default
    })
}

/// What a Monte Carlo run records besides its defaults: histogram grids by quantity,
/// crossing levels by quantity, the impact-speed histogram's grid.
struct Record {
    grids: Vec<(String, f64, f64, usize)>,
    levels: Vec<(String, Vec<f64>)>,
    impact_speeds: Option<(f64, f64, usize)>,
}
