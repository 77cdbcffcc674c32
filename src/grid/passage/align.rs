//! Moving the box so that a safe set that bounds the position alone has its bounds on cell
//! faces: the absorbing condition then sits where the set ends, not up to half a cell away.

use super::super::mesh::Domain;
use super::super::problem::Mechanical;
use crate::dynamics::BarrierKind;
use crate::model::{BoundModel, BoundSafe};

/// Points of the scan for the set's ends along x.
const SCAN: usize = 4096;

/// `box_` moved and stretched (by less than a cell of `nx`) so that the safe set's ends in x
/// fall on faces: both ends when the box is free, the end away from a wall when one end is
/// a wall (the wall is kept). Unchanged when the set depends on the velocity, has no end
/// inside the box or more than two, or the model has a pass-through barrier or a strip
/// (their faces are placed by the mesh).
pub(super) fn aligned(
    box_: Domain,
    nx: usize,
    problem: &Mechanical,
    safe: &BoundSafe,
    model: &BoundModel,
) -> Domain {
    if safe.quantity.mentions(&model.states()[1]) || problem.barriers.len() > 1 {
        return box_;
    }
    let wall = match problem.barriers.first().map(|b| b.kind) {
        None => None,
        Some(BarrierKind::Reflecting(side)) => Some(side),
        Some(_) => return box_,
    };
    let [x0, x1] = box_.x;
    let inside = |x: f64| safe.contains([x, 0.0]);
    let at = |k: usize| x0 + (x1 - x0) * k as f64 / SCAN as f64;
    let mut ends = Vec::new();
    for k in 0..SCAN {
        let (a, b) = (at(k), at(k + 1));
        if inside(a) != inside(b) {
            ends.push(bisect(&inside, a, b));
        }
    }
    let w = x1 - x0;
    let n = nx as f64;
    let mut out = box_;
    match (ends.as_slice(), wall) {
        ([lo, hi], None) => {
            let k = (n * (hi - lo) / w).round().clamp(1.0, n - 2.0);
            let h = (hi - lo) / k;
            let below = ((lo - x0) / h).round().clamp(1.0, n - k - 1.0);
            out.x = [lo - below * h, lo - below * h + n * h];
        }
        ([end], None) => {
            let k = (n * (end - x0) / w).round().clamp(1.0, n - 1.0);
            let h = (end - x0) / k;
            out.x = [x0, x0 + n * h];
        }
        (ends, Some(side)) if !ends.is_empty() => {
            use crate::model::BarrierSide;
            // The wall is the end the mesh keeps; align the set's end farthest from it.
            let (fixed, end) = match side {
                BarrierSide::Above => (x0, *ends.last().unwrap_or(&x1)),
                BarrierSide::Below => (x1, *ends.first().unwrap_or(&x0)),
            };
            let k = (n * (end - fixed).abs() / w).round().clamp(1.0, n - 1.0);
            let h = (end - fixed).abs() / k;
            out.x = match side {
                BarrierSide::Above => [x0, x0 + n * h],
                BarrierSide::Below => [x1 - n * h, x1],
            };
        }
        _ => {}
    }
    out
}

/// The point in [a, b] where `inside` changes, to a few ulps.
fn bisect(inside: &dyn Fn(f64) -> bool, mut a: f64, mut b: f64) -> f64 {
    let left = inside(a);
    for _ in 0..80 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if inside(m) == left {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}
