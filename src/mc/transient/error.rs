//! Why a Monte Carlo transient was refused.

use crate::mc::McError;

/// Why [`crate::mc::McTransient::run`] or [`crate::mc::McPeriodic::run`] returned no
/// history; every variant but [`McTransientError::NoPeriodicState`] (which a pilot ensemble
/// finds) is raised before any trajectory is stepped.
///
/// ```
/// use fpsolve::mc::McTransientError;
/// let e = McTransientError::Setting { setting: "dt", value: "-1".into(), expected: "a positive step" };
/// assert!(e.to_string().contains("dt"));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum McTransientError {
    /// A setting is out of range.
    #[error("Monte Carlo transient setting `{setting}` = {value} is invalid: {expected}")]
    Setting {
        /// The setting (`times`, `dt`, `trajectories`, `initial`, `bins`).
        setting: &'static str,
        /// The value given, printed.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The start puts trajectories on the far side of a reflecting wall.
    /// (A Gaussian start must keep [`crate::mc::WALL_SDS`] standard deviations from the
    /// wall, so that less than 1e−9 of it lies beyond.)
    #[error(
        "the initial law's mean lies {sds:.3} standard deviations on the model's side of the \
         wall at {state} = {at} (at least {} needed, so that under 1e-9 of it lies beyond): give \
         a start on the model's side",
        crate::mc::WALL_SDS
    )]
    StartBeyondWall {
        /// The signed distance of the start's mean from the wall, in its standard deviations
        /// along the wall's state (negative: on the wrong side).
        sds: f64,
        /// The state the wall bounds.
        state: String,
        /// Where the wall is.
        at: f64,
    },
    /// The period given is not the coefficients' (the check every method shares,
    /// [`crate::model::BoundModel::check_period`]).
    #[error(transparent)]
    Period(#[from] crate::model::PeriodError),
    /// The pilot's stroboscopic statistics (at t = kP) still drifted when the next doubling
    /// of its horizon would have passed its budget of trajectory steps.
    #[error(
        "no periodic state found: the pilot's moments at phase 0 (t = kP, P = {period}) still          drift after {periods} periods ({spent:e} trajectory steps, the next doubling would          pass {budget:e}); the damping may be too light for Monte Carlo to forget the start"
    )]
    NoPeriodicState {
        /// The period.
        period: f64,
        /// The pilot's last horizon, in periods.
        periods: u64,
        /// Trajectory steps the pilot took.
        spent: f64,
        /// Its budget.
        budget: f64,
    },
    /// The model cannot be simulated, or dt is unstable for it (the stationary run's checks).
    #[error(transparent)]
    Mc(#[from] McError),
}
