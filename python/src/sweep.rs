//! `fpsolve.sweep`'s native half: a parameter sweep over every point, in parallel, by each
//! method asked; the result is the library's `SweepResult` in its serde form (JSON text), from
//! which the Python layer builds arrays. Interruptible: Ctrl-C stops it between points.

use fpsolve::grid::Cells;
use fpsolve::mc::Shard;
use fpsolve::solve::{MethodName, MethodSet};
use fpsolve::sweep::{merge_sweep_shards, Sweep, SweepShard, SweepSpec};
use pyo3::prelude::*;

use crate::errors;
use crate::interrupt::interruptible_reporting;
use crate::model::PyModel;

/// Runs the sweep of `model` over `swept` (name, values; the points are their Cartesian
/// product) with the overrides `fixed` (name, expression) at every point.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, swept, fixed, methods, degree, cells=None, threads=None, shard=None, progress=None))]
pub(crate) fn sweep_json(
    py: Python<'_>,
    model: &PyModel,
    swept: Vec<(String, Vec<f64>)>,
    fixed: Vec<(String, String)>,
    methods: Vec<String>,
    degree: usize,
    cells: Option<[usize; 2]>,
    threads: Option<usize>,
    shard: Option<(u64, u64)>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<String> {
    let pool = crate::pool::thread_pool(threads)?;
    // The command line's `--set` arguments, so that one reader checks them (duplicates, too
    // many points, …); Rust prints an f64 so that it reads back exactly.
    let mut args: Vec<String> = swept
        .iter()
        .map(|(name, values)| {
            let list: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
            format!("{name}={}", list.join(","))
        })
        .collect();
    args.extend(fixed.iter().map(|(name, expr)| format!("{name}={expr}")));
    let spec = SweepSpec::parse(&args).map_err(|e| errors::sweep_error(py, &e))?;
    spec.validate(&model.model)
        .map_err(|e| errors::sweep_error(py, &e))?;
    let names = methods
        .iter()
        .map(|m| m.parse::<MethodName>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| errors::bad_argument(e.to_string()))?;
    let methods = MethodSet::new(names).map_err(|e| errors::bad_argument(e.to_string()))?;
    let mut sweep = Sweep::new(&model.model, &spec)
        .methods(methods)
        .degree(degree);
    if let Some(c) = cells {
        sweep = sweep.cells(Cells(c));
    }
    sweep.check().map_err(|e| errors::sweep_error(py, &e))?;
    if let Some((index, count)) = shard {
        // The command line's `--shard K/N` checks, with K from 0 here.
        let shard = Shard::new(index, count)
            .map_err(|e| errors::other::<errors::SweepError>(py, "shard", e.to_string()))?;
        let part = interruptible_reporting(py, progress.as_ref(), |cancel, counter| {
            let report = |done: u64, total: u64| counter.report(done, total);
            let sweep = sweep.progress(&report);
            pool.install(|| sweep.run_shard(shard, cancel))
        })?
        .map_err(|e| errors::other::<errors::SweepError>(py, "cancelled", e.to_string()))?;
        return serde_json::to_string(&part).map_err(|e| errors::bad_argument(e.to_string()));
    }
    let result = interruptible_reporting(py, progress.as_ref(), |cancel, counter| {
        let report = |done: u64, total: u64| counter.report(done, total);
        let sweep = sweep.progress(&report);
        pool.install(|| sweep.run_cancellable(cancel))
    })?
    .map_err(|e| errors::other::<errors::SweepError>(py, "cancelled", e.to_string()))?;
    serde_json::to_string(&result).map_err(|e| errors::bad_argument(e.to_string()))
}

/// Joins the parts of one split sweep (`sweep_json(..., shard=...)`'s texts, in any order)
/// into the unsplit sweep's `sweep.json` text, as `fpsolve merge` does: checked first.
#[pyfunction]
pub(crate) fn merge_sweep_json(py: Python<'_>, shards: Vec<String>) -> PyResult<String> {
    let parts = shards
        .iter()
        .map(|text| serde_json::from_str::<SweepShard>(text))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| errors::other::<errors::SweepError>(py, "not_a_shard", e.to_string()))?;
    let named: Vec<(String, SweepShard)> = parts.into_iter().map(|s| (s.file_name(), s)).collect();
    // On the shared pool: the merge's provenance states the parts' threads, or the pool's.
    let merged = crate::pool::on_pool(py, || merge_sweep_shards(&named))?
        .map_err(|e| errors::other::<errors::SweepError>(py, "shard", e.to_string()))?;
    Ok(merged.json().to_string())
}
