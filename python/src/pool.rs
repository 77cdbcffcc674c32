//! The worker threads of every call into the library, in pools this module owns: rayon's
//! global pool is never used, because a process forked after it started (a `multiprocessing`
//! or `ProcessPoolExecutor` worker under the `fork` start method) inherits the pool's state
//! but none of its threads, and its first parallel call waits forever for them.
//!
//! The shared pool remembers the process that built it; a forked child finds another pid and
//! builds its own. The parent's pool is leaked in the child, never dropped: dropping it would
//! signal threads that do not exist there, through locks that may have been held at the fork.

use std::sync::{Arc, Mutex};

use pyo3::{PyResult, Python};

use crate::errors;

/// The shared pool and the process it belongs to.
static SHARED: Mutex<Option<(u32, Arc<rayon::ThreadPool>)>> = Mutex::new(None);

/// The pool of calls that ask for no thread count (one thread per core), built on first use
/// in each process.
pub(crate) fn shared() -> PyResult<Arc<rayon::ThreadPool>> {
    let pid = std::process::id();
    // A poisoned lock only means a panic elsewhere while it was held; the slot stays valid.
    let mut slot = SHARED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((owner, pool)) = slot.as_ref() {
        if *owner == pid {
            return Ok(Arc::clone(pool));
        }
    }
    let pool = Arc::new(build(0)?);
    if let Some((_, inherited)) = slot.replace((pid, Arc::clone(&pool))) {
        std::mem::forget(inherited);
    }
    Ok(pool)
}

/// A pool of `threads` workers (the shared pool when `None`); a `ValueError` for 0. Results
/// do not depend on the pool's size, only the time does.
pub(crate) fn thread_pool(threads: Option<usize>) -> PyResult<Arc<rayon::ThreadPool>> {
    match threads {
        Some(0) => Err(errors::bad_argument("threads must be at least 1")),
        Some(n) => Ok(Arc::new(build(n)?)),
        None => shared(),
    }
}

/// Runs `work` on the shared pool with the GIL released.
pub(crate) fn on_pool<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = shared()?;
    Ok(py.allow_threads(|| pool.install(work)))
}

/// rayon reads 0 as "one per core".
fn build(threads: usize) -> PyResult<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| errors::bad_argument(format!("threads: {e}")))
}
