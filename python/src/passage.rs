//! `Model.passage`: first passage out of the safe set on the grid and by Monte Carlo, as
//! `fpsolve passage` computes it (src/cli/passage.rs): the same checks, in the same order and
//! before any work, the same defaults, the same library calls, so the same numbers to the
//! bit. Returns `summary.json`'s JSON, the quasi-stationary marginals and the console's
//! warnings; the pure-Python layer (`fpsolve/_passage.py`) makes them arrays.

use fpsolve::grid::PassageError;
use fpsolve::job::passage::{parse_pair, parse_times, McSettings, PassageRun, PassageRunError};
use fpsolve::model::{BoundModel, BoundSafe};
use fpsolve::solve::SolveError as LibSolveError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::IntoPyObjectExt;

use crate::errors::{self, Asked};
use crate::interrupt::abandonable;
use crate::model::PyModel;

/// The quasi-stationary marginals: (state, centres, density) per state.
type Marginals = Vec<(String, Vec<f64>, Vec<f64>)>;

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

/// The output times: the CLI's `A:B:N` text, or the times themselves (finite, non-negative,
/// non-decreasing, 1 to 100000 of them); none by default.
fn times_of(times: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<f64>> {
    let Some(times) = times else {
        return Ok(Vec::new());
    };
    if let Ok(text) = times.extract::<String>() {
        return parse_times(&text).map_err(|e| errors::bad_argument(format!("times: {e}")));
    }
    let t: Vec<f64> = times.extract().map_err(|_| {
        errors::bad_argument("times: expected the text `FIRST:LAST:COUNT` or a sequence of times")
    })?;
    let ordered = t.windows(2).all(|w| w[0] <= w[1]);
    if t.is_empty()
        || t.len() > 100_000
        || !ordered
        || t.iter().any(|t| !(t.is_finite() && *t >= 0.0))
    {
        return Err(errors::bad_argument(format!(
            "times: expected 1 to 100000 finite, non-negative, non-decreasing times, got {} \
             values",
            t.len()
        )));
    }
    Ok(t)
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

/// A safe set that cannot be bound (a bound not finite at these parameters, or empty): a
/// `ModelError` with the model's path and the library's message.
fn safe_error(py: Python<'_>, model: &PyModel, text: String) -> PyErr {
    let err = errors::other::<errors::ModelError>(py, "safe", text.clone());
    let path = model.path.as_ref().map(|p| p.display().to_string());
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("path", path)?;
        value.setattr("line", py.None())?;
        value.setattr("column", py.None())?;
        value.setattr("message", text)?;
        value.setattr("help", py.None())?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// A grid first-passage failure as the package's classes say it: bad settings and starts
/// are `ValueError`s (checked before any work as the CLI does, so only the box and the safe
/// set's probability reach here), the grid's own failures its `SolveError`s.
fn passage_error(py: Python<'_>, e: PassageError) -> PyErr {
    let text = e.to_string();
    let grid = |kind: &str, attrs: Vec<(&str, PyObject)>| {
        let err = errors::other::<errors::GridSolveError>(py, kind, text.clone());
        let value = err.value(py);
        let set = || -> PyResult<()> {
            value.setattr("method", "grid")?;
            value.setattr("degree", py.None())?;
            for (name, v) in attrs {
                value.setattr(name, v)?;
            }
            Ok(())
        };
        match set() {
            Ok(()) => err,
            Err(e) => e,
        }
    };
    match e {
        PassageError::Grid(g) => errors::solve_error(
            py,
            &LibSolveError::Grid(g),
            &Asked {
                method: "grid",
                degree: None,
            },
        ),
        PassageError::Singular { nx, nv, .. } => grid(
            "singular",
            vec![
                ("nx", nx.into_py_any(py).unwrap_or_else(|_| py.None())),
                ("nv", nv.into_py_any(py).unwrap_or_else(|_| py.None())),
            ],
        ),
        PassageError::Step(_) => grid("step", vec![]),
        _ => errors::bad_argument(text),
    }
}

/// First passage of `model` out of its safe set (or `safe`), as `fpsolve passage`: returns
/// `summary.json`'s JSON, the quasi-stationary marginals (empty when the grid did not run or
/// found no decay) and the warnings the CLI prints.
#[pyfunction]
#[pyo3(signature = (model, safe, start, times, cells, method, paths, dt, horizon, seed, threads, set=None))]
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
) -> PyResult<(String, Marginals, Vec<String>)> {
    let this = model.get();
    let path = this.path.as_deref();
    // The order of the CLI's plan: methods, the model with its overrides and safe set, the
    // start, the times, the cells, the Monte Carlo's settings.
    let (grid, mc) = methods_of(method)?;
    let overrides = crate::model::overrides(py, set)?;
    this.model
        .bind(&overrides)
        .map_err(|e| errors::bind_error(py, &e, path))?;
    let amended = match &safe {
        Some(text) => this
            .model
            .with_safe(text)
            .map_err(|e| errors::model_error(py, &e, None))?,
        None => this.model.clone(),
    };
    let bound = amended
        .bind(&overrides)
        .map_err(|e| errors::bind_error(py, &e, path))?;
    let named = path.map_or(String::new(), |p| format!("{}: ", p.display()));
    let safe_set = amended
        .safe()
        .ok_or_else(|| {
            errors::bad_argument(format!(
                "{named}no safe set: add a `safe` line to the model or give safe="
            ))
        })?
        .bind(&bound)
        .map_err(|e| safe_error(py, this, format!("{named}{e}")))?;
    let start = start_of(start)?;
    if !safe_set.contains(start) {
        return Err(errors::bad_argument(format!(
            "start {},{}: not inside the safe set `{}`",
            start[0], start[1], safe_set.text
        )));
    }
    let times = times_of(times)?;
    let cells = match cells {
        None => fpsolve::grid::DEFAULT_CELLS,
        Some([nx, nv]) => {
            let n = |c: i64| {
                usize::try_from(c).map_err(|_| {
                    errors::bad_argument(format!(
                        "cells: ({nx}, {nv}): expected even numbers of cells, at least 8 per axis"
                    ))
                })
            };
            [n(nx)?, n(nv)?]
        }
    };
    fpsolve::grid::check_cells(cells).map_err(|e| errors::bad_argument(format!("cells: {e}")))?;
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
            return Err(errors::bad_argument(
                "method \"mc\": give horizon= or times= (without the grid there is no mean time \
                 to set the horizon from)",
            ));
        }
        // A placeholder horizon when it comes from the grid's mean time, as the CLI.
        m.check(&bound, &safe_set, start)
            .map_err(|e| errors::mc_error(py, &e))?;
    } else if horizon.is_some() {
        return Err(errors::bad_argument(
            "horizon: only the Monte Carlo uses it (method \"mc\")",
        ));
    }
    let pool = crate::pool::thread_pool(threads)?;

    let run = abandonable(py, {
        let (bound, safe_set, times) = (bound.clone(), safe_set.clone(), times.clone());
        move || {
            // The provenance on the pool the run used (its threads).
            pool.install(|| {
                let run = PassageRun::solve(&bound, &safe_set, start, &times, cells, grid, mc);
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

/// The report, the marginals and the warnings of a finished run.
fn outcome(
    model: &PyModel,
    bound: &BoundModel,
    safe: &BoundSafe,
    start: [f64; 2],
    run: &PassageRun,
    provenance: fpsolve::report::Provenance,
) -> PyResult<(String, Marginals, Vec<String>)> {
    let model_file = model
        .path
        .as_ref()
        .map_or(String::new(), |p| p.display().to_string());
    let summary = run.summary(
        provenance,
        "fpsolve.Model.passage".into(),
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
    let warnings = run.warnings().iter().map(ToString::to_string).collect();
    Ok((json, marginals, warnings))
}
