//! Why a grid transient was refused or failed.

use crate::grid::{Domain, GridError};
use crate::model::PeriodError;
use crate::numerics::timestep::StepError;

/// Why [`crate::grid::GridTransient::run`] returned no history: a setting out of range or an
/// initial density the box does not hold (both before any step), the grid's own refusal of
/// the model, or the time stepper's failure (with its time and step size).
///
/// ```
/// use fpsolve::grid::TransientError;
/// let e = TransientError::Setting { setting: "times", value: "[]".into(), expected: "at least one time" };
/// assert!(e.to_string().contains("times"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TransientError {
    /// A setting is out of range; nothing was computed.
    #[error("grid transient setting `{setting}` = {value} is invalid: {expected}")]
    Setting {
        /// The setting (`times`, `tolerance`, `initial`, `domain`; for a periodic state
        /// `period`, `residual`, `steps`, `max_maps`).
        setting: &'static str,
        /// The value given, printed.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The initial density has more than [`crate::grid::INITIAL_MASS_LOSS`] of its mass
    /// outside the box: the box is not enlarged, give one that holds the start
    /// ([`crate::grid::GridTransient::domain`]).
    #[error(
        "the initial density has mass {inside:.12} inside the box x in [{}, {}], v in [{}, {}] \
         (at least 1 - {allowed:e} needed): give a domain that holds the start",
        domain.x[0], domain.x[1], domain.v[0], domain.v[1]
    )]
    InitialOutsideDomain {
        /// The initial density's mass inside the box.
        inside: f64,
        /// The largest mass allowed outside.
        allowed: f64,
        /// The box.
        domain: Domain,
    },
    /// A periodic state was asked of a model whose coefficients do not mention the time,
    /// or with a period that is not theirs ([`crate::grid::GridTransient::periodic`]; the
    /// check every method shares, [`crate::model::BoundModel::check_period`]). Never
    /// [`PeriodError::NotPositive`]: a period that is not positive is the `period`
    /// [`TransientError::Setting`].
    #[error(transparent)]
    Period(PeriodError),
    /// The grid refused the model or could not build its operator.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The time stepper failed.
    #[error("time stepping failed: {0}")]
    Step(#[from] StepError),
}

impl From<PeriodError> for TransientError {
    /// The shared period check's refusal as the grid words it (a period that is not
    /// positive is the `period` setting).
    fn from(e: PeriodError) -> TransientError {
        match e {
            PeriodError::NotPositive { period } => TransientError::Setting {
                setting: "period",
                value: format!("{period}"),
                expected: "finite, positive",
            },
            other => TransientError::Period(other),
        }
    }
}
