//! The largest stable time step as a value: which state's drift decays fastest, where, and
//! the step it allows, printed so that the number shown is itself within the limit.

use std::fmt;

use serde::{Deserialize, Serialize};

/// λ·dt beyond which a decaying mode grows (the stability interval of the schemes on the
/// negative real axis).
pub const STABLE_RATE_TIMES_DT: f64 = 2.0;

/// How many standard deviations of the linearised stationary law the sampled states reach.
pub(in crate::mc) const REACH: f64 = 4.0;
/// The fastest decay of the drift along a state's own axis, −∂fᵢ/∂xᵢ, found over the states
/// a run is expected to visit, and the largest time step it allows.
///
/// An estimate, not a guarantee: the states are a 16 × 16 lattice over ±4 standard deviations
/// of the model linearised at the origin (±4 when that has no stationary law), and only the
/// diagonal of the drift's Jacobian is looked at (the damping, not the stiffness of the
/// spring). A run that still blows up is flagged by its blow-up verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepLimit {
    /// The state whose equation decays fastest.
    pub state: String,
    /// The rate −∂fᵢ/∂xᵢ there (> 0).
    pub rate: f64,
    /// The point (x, v) where it was found.
    pub at: [f64; 2],
    /// [`STABLE_RATE_TIMES_DT`] / `rate`.
    pub largest_dt: f64,
}

impl fmt::Display for StepLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the drift of `{s}` decays at the rate -∂f_{s}/∂{s} = {rate:.4e} at ({x:.4e}, {v:.4e}), \
             and the explicit scheme is stable only for rate·dt ≤ {STABLE_RATE_TIMES_DT}: the \
             largest stable dt is {dt:e} (estimated over ±{REACH} standard deviations of the \
             model linearised at the origin; accuracy needs a smaller dt still)",
            s = self.state,
            rate = self.rate,
            x = self.at[0],
            v = self.at[1],
            dt = floor_significant(self.largest_dt, 3),
        )
    }
}

/// `x` rounded down to `digits` significant digits, so that the value printed is itself
/// within the limit it reports.
fn floor_significant(x: f64, digits: i32) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.log10().floor() as i32);
    let down = (x * scale).floor() / scale;
    // The division may land a hair above x; one ulp down keeps the promise.
    if down > x {
        down - down * f64::EPSILON
    } else {
        down
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_printed_limit_never_exceeds_the_limit() {
        for x in [2e-6, 1.0 / 3.0, 0.0105, 7.77e-12, 2.0 / 190.0] {
            let d = floor_significant(x, 3);
            assert!(d <= x && d > 0.99 * x, "{x} -> {d}");
        }
        assert_eq!(floor_significant(0.012345, 3), 0.0123);
    }
}
