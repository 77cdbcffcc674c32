//! Long calls from Python: the work runs on a scoped thread with the GIL released, while the
//! calling thread polls Python's signal handlers every ~50 ms; a KeyboardInterrupt (or any
//! exception a handler raises) sets the run's [`Cancel`] flag, waits for the worker to stop
//! at its next check, and is re-raised. No thread outlives the call. A caller's progress
//! callback is called from the same poll, with the GIL, when the worker's count has moved.
//!
//! Work that has no cancellation points (a grid solve is one sparse factorisation) runs
//! [`abandonable`]: on an interrupt the call returns at once and the worker, detached, finishes
//! on its own and drops its result.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use fpsolve::base::cancel::Cancel;
use pyo3::exceptions::PyRuntimeError;
use pyo3::panic::PanicException;
use pyo3::prelude::*;

/// How often the calling thread looks at Python's signals.
const POLL: Duration = Duration::from_millis(50);

/// How far the worker is, as it reports it (`done` of `total` units: points, batches).
#[derive(Default)]
pub(crate) struct Progress {
    done: AtomicU64,
    total: AtomicU64,
}

impl Progress {
    /// The worker's report.
    pub(crate) fn report(&self, done: u64, total: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(done, Ordering::Relaxed);
    }

    fn read(&self) -> (u64, u64) {
        (
            self.done.load(Ordering::Relaxed),
            self.total.load(Ordering::Relaxed),
        )
    }
}

/// Runs `work` with the GIL released on a worker thread, cancelling it when a Python signal
/// handler raises, and calls `callback(done, total)` with the GIL whenever the work's
/// [`Progress`] has moved since the last call (at most every ~50 ms, and once at the end); a
/// callback that raises cancels the work like Ctrl-C, and its exception is the call's.
pub(crate) fn interruptible_reporting<T, F>(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    work: F,
) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel, &Progress) -> T + Send,
{
    let progress = Progress::default();
    let mut shown = (0, 0);
    let mut show = || -> PyResult<()> {
        let now = progress.read();
        match callback {
            Some(f) if now != shown && now.1 > 0 => {
                shown = now;
                f.call1(now).map(|_| ())
            }
            _ => Ok(()),
        }
    };
    let cancel = Cancel::new();
    let slot: Mutex<Option<std::thread::Result<T>>> = Mutex::new(None);
    let ready = Condvar::new();
    std::thread::scope(|scope| {
        let worker_cancel = cancel.clone();
        let (slot_ref, ready_ref, progress_ref) = (&slot, &ready, &progress);
        scope.spawn(move || {
            let out = catch_unwind(AssertUnwindSafe(|| work(&worker_cancel, progress_ref)));
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
            if let Err(interrupt) = py.check_signals().and_then(|()| show()) {
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
    show()?;
    let out = slot
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .expect("the worker stored its result before the scope ended");
    out.map_err(panic_error)
}

/// Runs `work` with the GIL released on a detached thread while the calling thread polls
/// Python's signal handlers every ~50 ms; a handler's exception (KeyboardInterrupt) is returned
/// at once, within one poll, and the worker is left to finish by itself: its result (and
/// whatever it owns, e.g. a staging directory, cleaned up on drop) is dropped then. For work
/// without cancellation points, whose only way to stop early is not to be waited for.
pub(crate) fn abandonable<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    abandonable_cancelling(py, move |_| work())
}

/// [`abandonable`] for work with a few cancellation points far apart (a grid solve checks
/// between its factorisations): on an interrupt the call returns at once, as there, and the
/// flag handed to `work` is set, so that the detached worker stops at its next check instead
/// of running to its end unseen.
pub(crate) fn abandonable_cancelling<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce(Cancel) -> T + Send + 'static,
{
    type Slot<T> = (Mutex<Option<std::thread::Result<T>>>, Condvar);
    let slot: Arc<Slot<T>> = Arc::new((Mutex::new(None), Condvar::new()));
    let worker_slot = Arc::clone(&slot);
    let cancel = Cancel::new();
    let worker_cancel = cancel.clone();
    std::thread::Builder::new()
        .name("fpsolve-call".into())
        .spawn(move || {
            let out = catch_unwind(AssertUnwindSafe(|| work(worker_cancel)));
            let (value, ready) = &*worker_slot;
            // Stored even when the caller is gone (interrupted): dropped with the last Arc.
            *value.lock().unwrap_or_else(|p| p.into_inner()) = Some(out);
            ready.notify_all();
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a worker thread: {e}")))?;
    loop {
        let done = py.allow_threads(|| {
            let (value, ready) = &*slot;
            let guard = value.lock().unwrap_or_else(|p| p.into_inner());
            let (mut guard, _) = ready
                .wait_timeout_while(guard, POLL, |s| s.is_none())
                .unwrap_or_else(|p| p.into_inner());
            guard.take()
        });
        match done {
            Some(out) => return out.map_err(panic_error),
            None => {
                if let Err(interrupt) = py.check_signals() {
                    cancel.cancel();
                    return Err(interrupt);
                }
            }
        }
    }
}

/// A worker's panic as Python's `PanicException`, with the panic's message.
fn panic_error(panic: Box<dyn std::any::Any + Send>) -> PyErr {
    let text = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic in fpsolve".to_string());
    PanicException::new_err(text)
}
