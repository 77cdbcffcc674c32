//! Long calls from Python: the work runs on a scoped thread with the GIL released, while the
//! calling thread polls Python's signal handlers every ~50 ms; a KeyboardInterrupt (or any
//! exception a handler raises) sets the run's [`Cancel`] flag, waits for the worker to stop
//! at its next check, and is re-raised. No thread outlives the call.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use fpsolve::base::cancel::Cancel;
use pyo3::panic::PanicException;
use pyo3::prelude::*;

/// How often the calling thread looks at Python's signals.
const POLL: Duration = Duration::from_millis(50);

/// Runs `work` with the GIL released on a worker thread, cancelling it when a Python signal
/// handler raises; returns the work's value or the handler's exception.
pub(crate) fn interruptible<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> T + Send,
{
    let cancel = Cancel::new();
    let slot: Mutex<Option<std::thread::Result<T>>> = Mutex::new(None);
    let ready = Condvar::new();
    std::thread::scope(|scope| {
        let worker_cancel = cancel.clone();
        let (slot_ref, ready_ref) = (&slot, &ready);
        scope.spawn(move || {
            let out = catch_unwind(AssertUnwindSafe(|| work(&worker_cancel)));
            *slot_ref.lock().unwrap_or_else(|p| p.into_inner()) = Some(out);
            ready_ref.notify_all();
        });
        loop {
            let done = py.allow_threads(|| {
                let guard = slot.lock().unwrap_or_else(|p| p.into_inner());
                let (guard, _) = ready
                    .wait_timeout_while(guard, POLL, |s| s.is_none())
                    .unwrap_or_else(|p| p.into_inner());
                guard.is_some()
            });
            if done {
                break;
            }
            if let Err(interrupt) = py.check_signals() {
                cancel.cancel();
                // The scope joins the worker when it returns; wait for it without the GIL.
                py.allow_threads(|| {
                    let guard = slot.lock().unwrap_or_else(|p| p.into_inner());
                    let _unused = ready
                        .wait_while(guard, |s| s.is_none())
                        .unwrap_or_else(|p| p.into_inner());
                });
                return Err(interrupt);
            }
        }
        Ok(())
    })?;
    let out = slot
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .expect("the worker stored its result before the scope ended");
    out.map_err(|panic| {
        let text = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic in fpsolve".to_string());
        PanicException::new_err(text)
    })
}
