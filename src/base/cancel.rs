//! Cooperative cancellation of long runs (Monte Carlo, sweeps): a shared flag that the caller
//! sets (from a signal handler, another thread, Python's Ctrl-C) and the run checks between
//! units of work, returning a typed "cancelled" outcome instead of a partial result.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A cancellation flag shared between the caller and a run: clones share one flag.
///
/// ```
/// use fpsolve::base::cancel::Cancel;
/// let cancel = Cancel::new();
/// let seen_by_run = cancel.clone();
/// assert!(!seen_by_run.is_cancelled());
/// cancel.cancel();
/// assert!(seen_by_run.is_cancelled());
/// ```
#[derive(Clone, Debug, Default)]
pub struct Cancel {
    flag: Arc<AtomicBool>,
}

impl Cancel {
    /// A flag not yet set.
    ///
    /// ```
    /// assert!(!fpsolve::base::cancel::Cancel::new().is_cancelled());
    /// ```
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Asks every run holding this flag (or a clone) to stop at its next check.
    ///
    /// ```
    /// let c = fpsolve::base::cancel::Cancel::new();
    /// c.cancel();
    /// assert!(c.is_cancelled());
    /// ```
    pub fn cancel(&self) {
        self.flag.store(true, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called on this flag or a clone.
    ///
    /// ```
    /// assert!(!fpsolve::base::cancel::Cancel::default().is_cancelled());
    /// ```
    pub fn is_cancelled(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }
}

/// The error of a run stopped by its [`Cancel`] flag: nothing of the run is returned.
///
/// ```
/// assert_eq!(fpsolve::base::cancel::Cancelled.to_string(), "cancelled before it finished");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("cancelled before it finished")]
pub struct Cancelled;
