//! `Model.reliability` (alias `Model.passage`): first passage out of the safe set on the grid
//! and by Monte Carlo, as `fpsolve reliability` computes it (src/cli/reliability.rs): the same
//! checks, in the same order and before any work, the same defaults, the same library calls,
//! so the same numbers to the bit. Returns `summary.json`'s JSON, the quasi-stationary
//! marginals, the crossing tables (`crossings_<q>.csv`'s text) and the console's warnings;
//! the pure-Python layer (`fpsolve/_passage.py`) makes them arrays.

use fpsolve::grid::{Domain, PassageError};
use fpsolve::job::passage::{
    parse_pair, McSettings, PassageRun, PassageRunError, PassageScope, PassageSettings,
};
use fpsolve::model::{BoundModel, BoundSafe};
use fpsolve::solve::SolveError as LibSolveError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::IntoPyObjectExt;

use crate::arguments::{cells_of, times_of};
use crate::errors::{self, Asked};
use crate::interrupt::abandonable;
use crate::model::PyModel;

/// The quasi-stationary marginals: (state, centres, density) per state.
type Marginals = Vec<(String, Vec<f64>, Vec<f64>)>;

/// The crossing tables: (quantity, `crossings_<q>.csv`'s text) per quantity.
type Crossings = Vec<(String, String)>;

/// The start: a pair, or the CLI's `X,V` text; default rest.
fn start_of(start: Option<&Bound<'_, PyAny>>) -> PyResult<[f64; 2]> {
    let Some(start) = start else {
        return Ok([0.0, 0.0]);
    };
    if let Ok(text) = start.extract::<String>() {
        return parse_pair(&text).map_err(|e| errors::bad_argument(format!("start: {e}")));
    }
    let [x, v]: [f64; 2] = start.extract().map_err(|_| {
        errors::bad_argument("start: expected (x, v), two numbers, or the text `X,V`")
    })?;
    for (t, value) in [("x", x), ("v", v)] {
        if !value.is_finite() {
            return Err(errors::bad_argument(format!(
                "start: {t} = {value} is not finite"
            )));
        }
    }
    Ok([x, v])
}

/// The methods: `grid`, `mc` or both (a comma list, or a sequence of names).
fn methods_of(method: &Bound<'_, PyAny>) -> PyResult<(bool, bool)> {
    let names: Vec<String> = if let Ok(text) = method.extract::<String>() {
        text.split(',').map(|m| m.trim().to_string()).collect()
    } else {
        method.extract().map_err(|_| {
            errors::bad_argument("method: expected \"grid\", \"mc\", \"grid,mc\" or a list of them")
        })?
    };
    if names.is_empty() || names.iter().any(|m| !matches!(m.as_str(), "grid" | "mc")) {
        return Err(errors::bad_argument(format!(
            "method {}: expected `grid`, `mc` or `grid,mc`",
            names.join(",")
        )));
    }
    Ok((
        names.iter().any(|m| m == "grid"),
        names.iter().any(|m| m == "mc"),
    ))
}

/// A grid first-passage failure as the package's classes say it: bad settings and starts
/// are `ValueError`s (checked before any work as the CLI does, so only the box and the safe
/// set's probability reach here), the grid's own failures its `SolveError`s.
fn passage_error(py: Python<'_>, e: PassageError) -> PyErr {
    let text = e.to_string();
    match e {
        PassageError::Grid(g) => errors::solve_error(
            py,
            &LibSolveError::Grid(g),
            &Asked {
                method: "grid",
                degree: None,
            },
        ),
        PassageError::Singular { nx, nv, .. } => errors::grid_solve_error(
            py,
            "singular",
            text,
            vec![
                ("nx", nx.into_py_any(py).unwrap_or_else(|_| py.None())),
                ("nv", nv.into_py_any(py).unwrap_or_else(|_| py.None())),
            ],
        ),
        PassageError::Step(_) => errors::grid_solve_error(py, "step", text, vec![]),
        _ => errors::bad_argument(text),
    }
}

/// First passage of `model` out of its safe set (or `safe`), as `fpsolve reliability`: returns
/// `summary.json`'s JSON, the quasi-stationary marginals (empty when the grid did not run or
/// found no decay), the crossing tables and the warnings the CLI prints. `mean_only`: the mean
/// times alone, as `--mean-only` (not with `times`).
#[pyfunction]
#[pyo3(signature = (model, safe, start, times, cells, method, paths, dt, horizon, seed, threads, set=None, domain=None, mean_only=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn passage(
    py: Python<'_>,
    model: &Bound<'_, PyModel>,
    safe: Option<String>,
    start: Option<&Bound<'_, PyAny>>,
    times: Option<&Bound<'_, PyAny>>,
    cells: Option<[i64; 2]>,
    method: &Bound<'_, PyAny>,
    paths: i64,
    dt: f64,
    horizon: Option<f64>,
    seed: u64,
    threads: Option<usize>,
    set: Option<&Bound<'_, PyDict>>,
    domain: Option<String>,
    mean_only: bool,
) -> PyResult<(String, Marginals, Crossings, Vec<String>)> {
    let this = model.get();
    // What clap refuses first on the command line (--mean-only with --times).
    if mean_only && times.is_some() {
        return Err(errors::bad_argument(
            "mean_only: not with times= (the mean times alone have no output times)",
        ));
    }
    let path = this.path.as_deref();
    // The order of the CLI's plan: methods, the model with its overrides and safe set, the
    // start, the times, the cells, the box, the Monte Carlo's settings, the grid's checks.
    let (grid, mc) = methods_of(method)?;
    let (amended, bound) = this.bind_amended(py, set, |model| match &safe {
        Some(text) => model.with_safe(text),
        None => Ok(model.clone()),
    })?;
    let named = path.map_or(String::new(), |p| format!("{}: ", p.display()));
    let safe_set = amended
        .safe()
        .ok_or_else(|| {
            errors::bad_argument(format!(
                "{named}no safe set: add a `safe` line to the model or give safe="
            ))
        })?
        .bind(&bound)
        .map_err(|e| errors::unlocated_model_error(py, "safe", path, format!("{named}{e}")))?;
    let start = start_of(start)?;
    if !safe_set.contains(start) {
        return Err(errors::bad_argument(format!(
            "start {},{}: not inside the safe set `{}`",
            start[0], start[1], safe_set.text
        )));
    }
    let times = match times {
        Some(t) => times_of(t)?,
        None => Vec::new(),
    };
    let cells = cells_of(cells)?;
    let states = bound.states();
    let domain = match domain {
        None => None,
        Some(_) if !grid => {
            return Err(errors::bad_argument(
                "domain: only the grid uses a box (method \"grid\" or \"grid,mc\")",
            ))
        }
        Some(text) => Some(
            Domain::parse_named(&text, [&*states[0], &*states[1]])
                .map_err(|e| errors::bad_argument(format!("domain: {e}")))?,
        ),
    };
    if paths < 0 {
        return Err(errors::bad_argument(format!(
            "paths: {paths}: expected a non-negative whole number"
        )));
    }
    let mc = mc.then_some(McSettings {
        paths: paths as u64,
        dt,
        horizon: horizon.or_else(|| times.last().copied()),
        seed,
    });
    if let Some(m) = &mc {
        if m.horizon.is_none() && !grid {
            return Err(errors::bad_argument(if mean_only {
                "method \"mc\", mean_only: give horizon= (without the grid there is no mean \
                 time to set the horizon from)"
            } else {
                "method \"mc\": give horizon= or times= (without the grid there is no mean time \
                 to set the horizon from)"
            }));
        }
        // A placeholder horizon when it comes from the grid's mean time, as the CLI.
        m.check(&bound, &safe_set, start)
            .map_err(|e| errors::mc_error(py, &e))?;
    } else if horizon.is_some() {
        return Err(errors::bad_argument(
            "horizon: only the Monte Carlo uses it (method \"mc\")",
        ));
    }
    let settings = PassageSettings {
        start,
        times,
        cells,
        domain,
        grid,
        mc,
        scope: if mean_only {
            PassageScope::MeanTimes
        } else {
            PassageScope::Full
        },
    };
    if grid {
        // The box against the walls and the start, a model without a stationary density
        // without a box: refused before any solve, as the CLI.
        settings
            .grid_passage(&bound, &safe_set)
            .check()
            .map_err(|e| match domain {
                Some(_) => errors::bad_argument(format!("domain: {e}")),
                None => passage_error(py, e),
            })?;
    }
    let pool = crate::pool::thread_pool(threads)?;

    let run = abandonable(py, {
        let (bound, safe_set) = (bound.clone(), safe_set.clone());
        move || {
            // The provenance on the pool the run used (its threads).
            pool.install(|| {
                let run = PassageRun::solve(&bound, &safe_set, &settings);
                run.map(|run| (run, fpsolve::report::Provenance::now_bound(&bound)))
            })
        }
    })?
    .map_err(|e| match e {
        PassageRunError::Grid(e) => passage_error(py, e),
        PassageRunError::Mc(e) => errors::mc_error(py, &e),
    })?;
    let (run, provenance) = run;
    outcome(this, &bound, &safe_set, start, &run, provenance)
}

/// The report, the marginals, the crossing tables and the warnings of a finished run.
fn outcome(
    model: &PyModel,
    bound: &BoundModel,
    safe: &BoundSafe,
    start: [f64; 2],
    run: &PassageRun,
    provenance: fpsolve::report::Provenance,
) -> PyResult<(String, Marginals, Crossings, Vec<String>)> {
    let model_file = model
        .path
        .as_ref()
        .map_or(String::new(), |p| p.display().to_string());
    let summary = run.summary(
        provenance,
        "fpsolve.Model.reliability".into(),
        model_file,
        bound,
        safe,
        start,
    );
    let json = serde_json::to_string(&summary).map_err(|e| errors::bad_argument(e.to_string()))?;
    let mut marginals = Vec::new();
    if let Some([qx, qv]) = run.grid.as_ref().and_then(|g| g.quasi_stationary.as_ref()) {
        let states = bound.states();
        for (q, name) in [(qx, &states[0]), (qv, &states[1])] {
            marginals.push((name.to_string(), q.centres.clone(), q.density.clone()));
        }
    }
    let crossings = run.stationary.as_ref().map_or(Vec::new(), |s| {
        s.crossing_tables()
            .into_iter()
            .map(|(q, text)| (q.to_string(), text.to_string()))
            .collect()
    });
    let warnings = run.warnings().iter().map(ToString::to_string).collect();
    Ok((json, marginals, crossings, warnings))
}
