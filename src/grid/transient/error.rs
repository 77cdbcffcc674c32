//! Why a grid transient was refused or failed.

use crate::grid::{Domain, GridError};
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
    /// A periodic state was asked of a model whose coefficients do not mention the time
    /// ([`crate::grid::GridTransient::periodic`]): its long-time density is the stationary
    /// one.
    #[error(
        "the coefficients of `{model}` do not depend on t, so there is no periodic state \
         apart from the stationary density: the stationary solver applies (fpsolve solve)"
    )]
    NotTimeDependent {
        /// The model's name.
        model: String,
    },
    /// A coefficient differs at t and t + period: the period given is not the
    /// coefficients' ([`crate::grid::GridTransient::periodic`]).
    #[error(
        "{coefficient} is not periodic with period {period}: {at_t} at t = {t} but \
         {at_next} at t + {period} (x = {x}, v = {v}); give the period of the coefficients"
    )]
    NotPeriodic {
        /// Which coefficient (`the drift of `v``, `the diffusion of `v``).
        coefficient: String,
        /// The period given.
        period: f64,
        /// The probe's time.
        t: f64,
        /// The probe's position.
        x: f64,
        /// The probe's velocity.
        v: f64,
        /// The coefficient at t.
        at_t: f64,
        /// The coefficient at t + period.
        at_next: f64,
    },
    /// The grid refused the model or could not build its operator.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The time stepper failed.
    #[error("time stepping failed: {0}")]
    Step(#[from] StepError),
}

impl From<crate::model::PeriodError> for TransientError {
    /// The shared period check's refusal as the grid words it (a period that is not
    /// positive is the `period` setting).
    fn from(e: crate::model::PeriodError) -> TransientError {
        use crate::model::PeriodError;
        match e {
            PeriodError::NotPositive { period } => TransientError::Setting {
                setting: "period",
                value: format!("{period}"),
                expected: "finite, positive",
            },
            PeriodError::NotTimeDependent { model } => TransientError::NotTimeDependent { model },
            PeriodError::NotPeriodic {
                coefficient,
                period,
                t,
                x,
                v,
                at_t,
                at_next,
            } => TransientError::NotPeriodic {
                coefficient,
                period,
                t,
                x,
                v,
                at_t,
                at_next,
            },
        }
    }
}
