//! Why a Monte Carlo transient was refused.

use crate::mc::McError;

/// Why [`crate::mc::McTransient::run`] returned no history; every variant is raised before
/// any trajectory is stepped.
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
    /// The model cannot be simulated, or dt is unstable for it (the stationary run's checks).
    #[error(transparent)]
    Mc(#[from] McError),
}
