//! Where within one step a path left the safe set: the test of every step that the screen
//! (`screen.rs`) could not clear.
//!
//! Between the ends of a step the position is the cubic Hermite interpolant of the positions
//! and velocities (the position is C¹ between impacts) and the velocity linear, sampled at
//! [`SUBSTEPS`] points: an excursion out and back within a step is caught, which testing the
//! ends alone would miss (a bias of order √dt in the mean time). The exit is interpolated
//! linearly between the last sample inside and the first outside.

use crate::model::BoundSafe;

/// Samples of the interpolated path per step at which the safe set is tested.
pub(super) const SUBSTEPS: usize = 4;

/// The end of a step: the state and its quantity.
pub(super) type End = ([f64; 2], f64);

/// Whether the path left `safe` within a step of size `h` from `a` to `b` (states and
/// quantities; `a` inside) and where (in [0, 1]). `scratch` is the quantity's working
/// memory.
pub(super) fn left_within(
    safe: &BoundSafe,
    a: End,
    b: End,
    h: f64,
    scratch: &mut Vec<f64>,
) -> Option<f64> {
    let ([x0, v0], q0) = a;
    let ([x1, v1], q1) = b;
    let mut last = (0.0, q0);
    for k in 1..=SUBSTEPS {
        let s = k as f64 / SUBSTEPS as f64;
        let q = if k == SUBSTEPS {
            q1
        } else {
            let (s2, s3) = (s * s, s * s * s);
            let x = (2.0 * s3 - 3.0 * s2 + 1.0) * x0
                + (s3 - 2.0 * s2 + s) * h * v0
                + (-2.0 * s3 + 3.0 * s2) * x1
                + (s3 - s2) * h * v1;
            safe.quantity_with([x, v0 + s * (v1 - v0)], scratch)
        };
        if !safe.inside(q) {
            let f = fraction(safe, last.1, q);
            return Some(last.0 + f / SUBSTEPS as f64);
        }
        last = (s, q);
    }
    None
}

/// Where between two samples the quantity, `q0` (inside) at the first and `q1` (outside) at
/// the second, reached the bound it crossed, linearly interpolated (in [0, 1]).
fn fraction(safe: &BoundSafe, q0: f64, q1: f64) -> f64 {
    let bound = match (safe.lower, safe.upper) {
        (_, Some(b)) if q1 >= b => b,
        (Some(a), _) => a,
        (None, Some(b)) => b,
        (None, None) => return 1.0,
    };
    let d = q1 - q0;
    if d == 0.0 || d.is_nan() {
        1.0
    } else {
        ((bound - q0) / d).clamp(0.0, 1.0)
    }
}
