//! The grid a quantity's PDF is tabulated on: where its density is at least 1e−8 of its peak.

use crate::observe::{JointDensity, ObservableDensity, ObservableMap};
use crate::symbolic::{DeltaPolicy, Tape};

use super::Quantity;

/// Grid points per PDF curve.
pub(crate) const GRID_POINTS: usize = 401;
/// The grid reaches where the density is this fraction of its peak.
const TAIL: f64 = 1e-8;

/// The common grid of a quantity under several densities: the union of the windows where
/// each density is at least [`TAIL`] of its peak, [`GRID_POINTS`] points (empty when no
/// density has such a window).
pub(crate) fn common_grid(
    q: &Quantity,
    densities: &[(&dyn JointDensity, &ObservableDensity)],
) -> Vec<f64> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (joint, density) in densities {
        let [a, b] = value_range(*joint, q);
        let scan = linspace(a, b, 241);
        if let Some([a, b]) = window(&scan, &density.pdf(&scan)) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    // A quantity like |z| has its support edge at 0: start the grid exactly there.
    if non_negative(q) {
        lo = lo.max(0.0);
    }
    if lo >= hi {
        return Vec::new();
    }
    linspace(lo, hi, GRID_POINTS)
}

/// A density on a grid for printing: where the density of g is infinite (a grid point on a
/// saddle or degenerate critical value, e.g. v² at 0) there is no number to print, so the point
/// is left empty (NaN), which the CSV writes as an empty field and the figures as a gap.
pub(crate) fn printable(p: Vec<f64>) -> Vec<f64> {
    p.into_iter()
        .map(|v| if v.is_infinite() { f64::NAN } else { v })
        .collect()
}

/// The interval of values a quantity can take where the density lives.
fn value_range(joint: &dyn JointDensity, q: &Quantity) -> [f64; 2] {
    let ext = joint.extent();
    match &q.map {
        ObservableMap::SignedState { state, .. } => {
            let r = ext[*state][0].abs().max(ext[*state][1].abs());
            [-r, r]
        }
        ObservableMap::General { expr, states } => {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            let names = [&*states[0], &*states[1]];
            // A map that does not compile has no value anywhere: an empty range.
            let Ok(tape) = Tape::compile(std::slice::from_ref(expr), &names, DeltaPolicy::Reject)
            else {
                return [lo, hi];
            };
            let (mut scratch, mut g) = (Vec::new(), [0.0]);
            let n = 120;
            for i in 0..=n {
                for j in 0..=n {
                    let x1 = ext[0][0] + (ext[0][1] - ext[0][0]) * i as f64 / n as f64;
                    let x2 = ext[1][0] + (ext[1][1] - ext[1][0]) * j as f64 / n as f64;
                    if joint.pdf([x1, x2]) <= 0.0 {
                        continue;
                    }
                    tape.eval(&[x1, x2], &mut scratch, &mut g);
                    if g[0].is_finite() {
                        lo = lo.min(g[0]);
                        hi = hi.max(g[0]);
                    }
                }
            }
            [lo, hi]
        }
    }
}

fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// The window of a scanned density where it is at least `TAIL` of its peak, widened by one
/// scan step.
fn window(x: &[f64], p: &[f64]) -> Option<[f64; 2]> {
    // An infinite value (a saddle or degenerate critical value of g) is not a peak to scale by.
    let peak = p
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    if peak <= 0.0 {
        return None;
    }
    let first = p.iter().position(|v| *v >= TAIL * peak)?;
    let last = p.iter().rposition(|v| *v >= TAIL * peak)?;
    let lo = x[first.saturating_sub(1)];
    let hi = x[(last + 1).min(x.len() - 1)];
    Some([lo, hi])
}

/// Whether a signed-state quantity only takes values ≥ 0 (like |z|): every quadrant maps
/// its half-line of the state to the non-negative side.
fn non_negative(q: &Quantity) -> bool {
    let ObservableMap::SignedState { state, sign } = &q.map else {
        return false;
    };
    (0..2).all(|a| {
        (0..2).all(|b| {
            let half = if *state == 0 { a } else { b };
            let side = if half == 1 { 1.0 } else { -1.0 };
            sign[a][b] * side > 0.0
        })
    })
}
