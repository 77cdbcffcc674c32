//! Why a time-stepping run stopped without its outputs.

/// Why a time-stepping run failed: a setting out of range (before any step), an error
/// control that cannot meet its tolerance, a stage matrix that could not be factorised, or
/// a cancelled run. Numeric failures carry the time and step size they happened at.
///
/// ```
/// use fpsolve::numerics::timestep::StepError;
/// let e = StepError::StepSizeTooSmall { time: 1.5, step: 1e-15, min: 1e-12 };
/// assert!(e.to_string().contains("t = 1.5"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A setting is out of range; nothing was computed.
    #[error("time-stepper setting `{setting}` = {value} is invalid: {expected}")]
    Setting {
        /// The setting (`tolerance`, `times`, `initial`, `first_step`).
        setting: &'static str,
        /// The value given, printed.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The error control shrank the step below the smallest allowed.
    #[error(
        "the step size fell to {step:.3e} at t = {time} (smallest allowed {min:.3e}): the \
         error control cannot meet the tolerance there"
    )]
    StepSizeTooSmall {
        /// Where.
        time: f64,
        /// The step size reached.
        step: f64,
        /// The smallest step allowed.
        min: f64,
    },
    /// More steps than the run allows.
    #[error("{steps} steps taken by t = {time}, the most a run may take")]
    TooManySteps {
        /// Where the run stopped.
        time: f64,
        /// Steps taken (accepted and rejected).
        steps: usize,
    },
    /// The stage matrix I − d h A could not be factorised and solved to its backward-error
    /// check.
    #[error("the stage matrix at t = {time} with step {step:.3e} could not be solved: {detail}")]
    Factorization {
        /// Where.
        time: f64,
        /// The step size.
        step: f64,
        /// Why each factorisation failed.
        detail: String,
    },
    /// The operator A(t) could not be built at a stage time (a coefficient not finite
    /// there).
    #[error("the operator at t = {time} could not be built: {detail}")]
    Operator {
        /// Where.
        time: f64,
        /// Why.
        detail: String,
    },
    /// The run's cancel flag was set.
    #[error("cancelled at t = {time}")]
    Cancelled {
        /// Where the run stopped.
        time: f64,
    },
}
