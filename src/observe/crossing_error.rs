//! Why a crossing rate or an impact statistic is not available: typed reasons, never a number.

use thiserror::Error;

/// Why [`crossing_rate`](super::crossing_rate) or
/// [`impact_statistics`](super::impact_statistics) gives no number.
///
/// ```
/// use fpsolve::observe::CrossingError;
/// let e = CrossingError::NoiseDriven { quantity: "v".into(), noise: "xi".into() };
/// assert!(e.to_string().contains("white noise `xi`"));
/// ```
#[derive(Clone, Debug, Error, PartialEq)]
pub enum CrossingError {
    /// The quantity's rate of change contains a white noise: its paths are nowhere
    /// differentiable, cross every level infinitely often near each crossing, and Rice's
    /// formula ∫ (ġ)⁺ p has no finite ġ to integrate.
    #[error(
        "the rate of change of `{quantity}` contains the white noise `{noise}`: its level \
         crossings have no finite rate (Rice's formula needs a finite derivative)"
    )]
    NoiseDriven {
        /// The state or observable.
        quantity: String,
        /// The noise source in its rate.
        noise: String,
    },
    /// Rice's formula is not implemented for this kind of observable.
    #[error("crossing rates are not available for the observable `{quantity}`: {why}")]
    NotAvailable {
        /// The observable.
        quantity: String,
        /// What it would need.
        why: String,
    },
    /// A requested level is not a finite number.
    #[error("crossing level {level} of `{quantity}` is not a finite number")]
    Level {
        /// The state or observable.
        quantity: String,
        /// The level as given.
        level: f64,
    },
    /// The drift (the rate of change) or the impact law has no finite value at a point the
    /// integral needs.
    #[error("`{expr}` has no finite value at ({x1}, {x2}): {why}")]
    NotFinite {
        /// The expression, printed.
        expr: String,
        /// The point.
        x1: f64,
        /// The point.
        x2: f64,
        /// What the evaluation said.
        why: String,
    },
    /// Impact statistics need a wall in the model's own coordinates (a law that reverses the
    /// velocity, with a `domain` side); a pass-through law is the Zhuravlev form, whose
    /// coordinate z is not the user's position.
    #[error(
        "the impact law at {state} = {at} lets the state pass through (the Zhuravlev form): \
         impact statistics are given for a wall with a `domain` side, in the model's own \
         coordinates"
    )]
    PassThrough {
        /// The state that meets the barrier.
        state: String,
        /// The barrier's position.
        at: f64,
    },
    /// A speed at which the impact-velocity PDF was asked is negative or not finite.
    #[error("impact speed {speed} is not a finite number ≥ 0")]
    Speed {
        /// The speed as given.
        speed: f64,
    },
    /// The density carries no flux at the barrier (no mass approaches it within its extent):
    /// the flux-weighted statistics would be 0/0.
    #[error("no probability flux reaches the barrier at {state} = {at}")]
    NoFlux {
        /// The state that meets the barrier.
        state: String,
        /// The barrier's position.
        at: f64,
    },
    /// Curves written to one table must share their quantity and levels.
    #[error("the crossing curve of `{method}` is not on the levels of `{quantity}` the table has")]
    Levels {
        /// The method whose curve differs.
        method: String,
        /// The table's quantity.
        quantity: String,
    },
}
