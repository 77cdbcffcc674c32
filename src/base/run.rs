//! What a caller holds over one long run, handed to every method the same way: its
//! [`Cancel`] flag, checked by the method between its units of work, and where the method
//! reports how far it is.

use std::fmt;
use std::sync::Arc;

use super::cancel::{Cancel, Cancelled};

/// A progress report: `done` of `total` units of the method's own work (the grid's
/// factorisations, say). `total` may grow while the run finds it needs more (a grid box that
/// grows, a tolerance that asks for finer cells); `done` never falls.
pub type ProgressFn = dyn Fn(u64, u64) + Send + Sync;

/// The run control of one solve: a cancellation flag and a progress callback, both optional
/// (the default neither cancels nor reports). Clones share the flag and the callback.
///
/// ```
/// use std::sync::atomic::{AtomicU64, Ordering};
/// use std::sync::Arc;
/// use fpsolve::base::cancel::{Cancel, Cancelled};
/// use fpsolve::base::run::RunControl;
/// let seen = Arc::new(AtomicU64::new(0));
/// let cancel = Cancel::new();
/// let run = RunControl::new().cancelled_by(cancel.clone()).reporting({
///     let seen = seen.clone();
///     move |done, _total| seen.store(done, Ordering::Relaxed)
/// });
/// run.report(2, 3);
/// assert_eq!(seen.load(Ordering::Relaxed), 2);
/// assert_eq!(run.check(), Ok(()));
/// cancel.cancel();
/// assert_eq!(run.check(), Err(Cancelled));
/// ```
#[derive(Clone, Default)]
pub struct RunControl {
    cancel: Cancel,
    progress: Option<Arc<ProgressFn>>,
}

impl RunControl {
    /// A run nobody cancels and nobody watches.
    ///
    /// ```
    /// assert!(fpsolve::base::run::RunControl::new().check().is_ok());
    /// ```
    pub fn new() -> RunControl {
        RunControl::default()
    }

    /// The same control, stopped when `cancel` (or a clone of it) is set.
    ///
    /// ```
    /// use fpsolve::base::{cancel::Cancel, run::RunControl};
    /// let cancel = Cancel::new();
    /// cancel.cancel();
    /// assert!(RunControl::new().cancelled_by(cancel).check().is_err());
    /// ```
    pub fn cancelled_by(mut self, cancel: Cancel) -> RunControl {
        self.cancel = cancel;
        self
    }

    /// The same control, reporting progress to `progress(done, total)` (called from the
    /// thread doing the work: keep it short).
    ///
    /// ```
    /// let run = fpsolve::base::run::RunControl::new().reporting(|done, total| {
    ///     assert!(done <= total);
    /// });
    /// run.report(1, 2);
    /// ```
    pub fn reporting(mut self, progress: impl Fn(u64, u64) + Send + Sync + 'static) -> RunControl {
        self.progress = Some(Arc::new(progress));
        self
    }

    /// `Err(Cancelled)` once the flag is set: the method stops there and returns nothing of
    /// the run.
    ///
    /// # Errors
    /// [`Cancelled`] when the flag is set.
    ///
    /// ```
    /// assert_eq!(fpsolve::base::run::RunControl::new().check(), Ok(()));
    /// ```
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.cancel.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }

    /// Reports `done` of `total` units to the callback, if there is one.
    ///
    /// ```
    /// fpsolve::base::run::RunControl::new().report(1, 1); // nobody watches: nothing happens
    /// ```
    pub fn report(&self, done: u64, total: u64) {
        if let Some(f) = &self.progress {
            f(done, total);
        }
    }

    /// The same flag without the callback: for the parts of a run that report as one (a
    /// study's methods, each a unit of the study's progress).
    ///
    /// ```
    /// use fpsolve::base::{cancel::Cancel, run::RunControl};
    /// let cancel = Cancel::new();
    /// let part = RunControl::new().cancelled_by(cancel.clone()).reporting(|_, _| panic!()).silent();
    /// part.report(1, 1); // not passed on
    /// cancel.cancel();
    /// assert!(part.check().is_err());
    /// ```
    pub fn silent(&self) -> RunControl {
        RunControl {
            cancel: self.cancel.clone(),
            progress: None,
        }
    }

    /// The cancellation flag (for a run that hands it on).
    ///
    /// ```
    /// let run = fpsolve::base::run::RunControl::new();
    /// run.cancel_flag().cancel();
    /// assert!(run.check().is_err());
    /// ```
    pub fn cancel_flag(&self) -> &Cancel {
        &self.cancel
    }
}

impl fmt::Debug for RunControl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RunControl")
            .field("cancelled", &self.cancel.is_cancelled())
            .field("reporting", &self.progress.is_some())
            .finish()
    }
}
