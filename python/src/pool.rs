//! The worker threads of a parallel call (`simulate`, `sweep`): checked before any work.

use pyo3::PyResult;

use crate::errors;

/// A pool of `threads` workers (all cores when `None`); a `ValueError` for 0. Results do not
/// depend on the pool's size, only the time does.
pub(crate) fn thread_pool(threads: Option<usize>) -> PyResult<rayon::ThreadPool> {
    if threads == Some(0) {
        return Err(errors::bad_argument("threads must be at least 1"));
    }
    // rayon reads 0 as "one per core".
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| errors::bad_argument(format!("threads: {e}")))
}
