//! `fpsolve.merge`'s native half for Monte Carlo parts: the library's checked, bit-exact
//! merge of `ShardOutput`s (the command line's `fpsolve merge`).

use fpsolve::mc::{merge_shards, ShardOutput};
use fpsolve::report::Provenance;
use pyo3::prelude::*;

use crate::errors;

/// Joins the parts of one split run (their JSON texts, in any order) into the run's result:
/// its JSON, the flags and the warnings, as `_Model.simulate` returns them.
#[pyfunction]
pub(crate) fn merge_mc_json(
    py: Python<'_>,
    shards: Vec<String>,
) -> PyResult<(String, Vec<String>, Vec<String>)> {
    let parts = shards
        .iter()
        .map(|text| serde_json::from_str::<ShardOutput>(text))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| {
            errors::other::<errors::MonteCarloError>(
                py,
                "not_a_shard",
                format!("not a Monte Carlo shard: {e}"),
            )
        })?;
    // The merge's provenance states the parts' model and the threads they ran with (the
    // shared pool's when no part says).
    let (result, provenance) = crate::pool::on_pool(py, || {
        let provenance = Provenance::merged(parts.iter().map(|p| p.provenance.as_ref()));
        merge_shards(&parts).map(|r| (r, provenance))
    })?
    .map_err(|e| errors::mc_error(py, &e))?;
    crate::model::mc_outcome(&result, &provenance)
}
