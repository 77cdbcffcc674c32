//! The grid a quantity's PDF is tabulated on: where its density is at least 1e−8 of its peak.

use crate::density::JointDensity;
use crate::observe::{ObservableDensity, ObservableMap};
use crate::symbolic::{DeltaPolicy, Tape};

/// Grid points per PDF curve.
pub(crate) const GRID_POINTS: usize = 401;
/// The grid reaches where the density is this fraction of its peak.
const TAIL: f64 = 1e-8;

/// The common grid of a quantity under several densities, each given with the quantity's
/// map in that density's own states (EPC of an original-coordinates model solves the
/// Zhuravlev transform, y = x_b + |z|; the grid solver and EPC-impact the model as written,
/// y itself): the union of the windows where each density is at least [`TAIL`] of its
/// peak, each inside the values the quantity takes on its density's support (a wall is an
/// end point of the grid, never a point beyond it), [`GRID_POINTS`] points (empty when no
/// density has such a window).
pub(crate) fn common_grid(
    densities: &[(&dyn JointDensity, &ObservableMap, &ObservableDensity)],
) -> Vec<f64> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (joint, map, density) in densities {
        let [a, b] = value_range(*joint, map);
        // An empty or NaN range: the density has no values to scan.
        if a.partial_cmp(&b) != Some(std::cmp::Ordering::Less) {
            continue;
        }
        if let Some([a, b]) = scanned_window(&linspace(a, b, SCAN_POINTS), |x| density.pdf(x)) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
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

/// The interval of values the map takes on the density's extent where the density lives.
/// A density's extent ends at its walls (the grid solver's and EPC-impact's domain), so the
/// interval of a state, or of ± a state, ends exactly on them.
fn value_range(joint: &dyn JointDensity, map: &ObservableMap) -> [f64; 2] {
    let ext = joint.extent();
    match map {
        ObservableMap::SignedState { state, sign } => signed_range(&ext, *state, sign),
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
            // The axes (where abs and sgn have their kinks: the Zhuravlev map x_b + |z| has
            // its wall at z = 0) are sampled exactly.
            let axis = |k: usize| {
                let mut t = linspace(ext[k][0], ext[k][1], 121);
                if ext[k][0] < 0.0 && 0.0 < ext[k][1] {
                    t.push(0.0);
                }
                t
            };
            let (a1, a2) = (axis(0), axis(1));
            for &x1 in &a1 {
                for &x2 in &a2 {
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

/// The values of g = s(q)·x_state on the box `ext`: the hull of the image of each quadrant
/// q = (sgn x1, sgn x2) the box reaches (|z| on [−3, 2] is [0, 3]; y on [0.3, 9] is itself).
fn signed_range(ext: &[[f64; 2]; 2], state: usize, sign: &[[f64; 2]; 2]) -> [f64; 2] {
    let half = |k: usize, positive: usize| -> Option<[f64; 2]> {
        let [lo, hi] = ext[k];
        let (lo, hi) = if positive == 1 {
            (lo.max(0.0), hi)
        } else {
            (lo, hi.min(0.0))
        };
        (lo <= hi).then_some([lo, hi])
    };
    let mut out = [f64::INFINITY, f64::NEG_INFINITY];
    for (a, row) in sign.iter().enumerate() {
        for (b, &s) in row.iter().enumerate() {
            let (Some(r1), Some(r2)) = (half(0, a), half(1, b)) else {
                continue;
            };
            let [lo, hi] = if state == 0 { r1 } else { r2 };
            let (lo, hi) = if s > 0.0 { (lo, hi) } else { (-hi, -lo) };
            out = [out[0].min(lo), out[1].max(hi)];
        }
    }
    out
}

/// `n` points from `lo` to `hi`, both ends exact (a wall is an end point, not a point an
/// ulp beyond it where the density is 0).
fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            if i + 1 == n {
                hi
            } else {
                lo + (hi - lo) * i as f64 / (n - 1) as f64
            }
        })
        .collect()
}

/// Points of the scan that finds a density's window.
const SCAN_POINTS: usize = 241;
/// The scan evaluates every this many of its points first (see [`scanned_window`]).
const STRIDE: usize = 8;

/// [`window`] of the density `pdf` scanned at the points `x`, evaluated where the window
/// depends on it: every [`STRIDE`]-th point first; then every point within a stride of the
/// largest value found (the peak of a unimodal density lies there), and the points before the
/// first and after the last of them at or above [`TAIL`] of that peak (where the window's ends
/// are). The window is that of the whole scan wherever the density has no feature narrower
/// than a stride (a peak, or a rise above the tail level, between two points of the first
/// pass that are both below it); where the first pass finds no positive value, every point
/// is evaluated. A unimodal density takes about 60 evaluations of the 241.
fn scanned_window(x: &[f64], pdf: impl Fn(&[f64]) -> Vec<f64>) -> Option<[f64; 2]> {
    let n = x.len();
    let mut p: Vec<Option<f64>> = vec![None; n];
    let evaluate = |p: &mut Vec<Option<f64>>, wanted: &mut dyn Iterator<Item = usize>| {
        let mut idx: Vec<usize> = wanted.filter(|&i| i < n && p[i].is_none()).collect();
        idx.dedup();
        if idx.is_empty() {
            return;
        }
        let at: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
        for (&i, v) in idx.iter().zip(pdf(&at)) {
            p[i] = Some(v);
        }
    };
    // The first pass, with the scan's last point.
    evaluate(&mut p, &mut (0..n).step_by(STRIDE).chain([n - 1]));
    let peak_at = |p: &[Option<f64>]| {
        p.iter()
            .enumerate()
            .filter_map(|(i, v)| v.filter(|v| v.is_finite()).map(|v| (i, v)))
            .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
                Some((_, b)) if b >= v => best,
                _ => Some((i, v)),
            })
    };
    match peak_at(&p) {
        Some((k, peak)) if peak > 0.0 => {
            evaluate(&mut p, &mut (k.saturating_sub(STRIDE - 1)..k + STRIDE));
        }
        _ => evaluate(&mut p, &mut (0..n)),
    }
    let peak = peak_at(&p).map_or(0.0, |(_, v)| v);
    let above = |v: &Option<f64>| v.is_some_and(|v| v >= TAIL * peak);
    if let Some(first) = p.iter().position(above) {
        evaluate(&mut p, &mut (first.saturating_sub(STRIDE - 1)..first));
    }
    if let Some(last) = p.iter().rposition(above) {
        evaluate(&mut p, &mut (last + 1..last + STRIDE));
    }
    // Points not evaluated are taken to be below the tail level.
    let values: Vec<f64> = p.iter().map(|v| v.unwrap_or(0.0)).collect();
    window(x, &values)
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// The window from every point of the scan, and the number of points `scanned_window`
    /// evaluates.
    fn both(x: &[f64], f: impl Fn(f64) -> f64) -> (Option<[f64; 2]>, Option<[f64; 2]>, usize) {
        let count = Cell::new(0);
        let pdf = |x: &[f64]| {
            count.set(count.get() + x.len());
            x.iter().map(|&x| f(x)).collect()
        };
        let got = scanned_window(x, pdf);
        let all: Vec<f64> = x.iter().map(|&x| f(x)).collect();
        (got, window(x, &all), count.get())
    }

    #[test]
    fn the_strided_scan_finds_the_whole_scans_window() {
        let x = linspace(-12.0, 12.0, SCAN_POINTS);
        // Gaussians of several widths and centres (the window's ends fall anywhere between
        // two points of the first pass), a skewed density, and one with two modes.
        for k in 0..40 {
            let (c, s) = (-3.0 + 0.15 * k as f64, 0.4 + 0.07 * k as f64);
            let (got, want, n) = both(&x, |x| (-(x - c) * (x - c) / (2.0 * s * s)).exp());
            assert_eq!(got, want, "centre {c}, width {s}");
            assert!(n <= 70, "{n} evaluations");
        }
        let skewed = |x: f64| if x < 0.0 { (-x * x).exp() } else { (-x).exp() };
        let (got, want, _) = both(&x, skewed);
        assert_eq!(got, want);
        let two = |x: f64| (-(x - 4.0) * (x - 4.0)).exp() + 0.5 * (-(x + 5.0) * (x + 5.0)).exp();
        let (got, want, _) = both(&x, two);
        assert_eq!(got, want);
    }

    #[test]
    fn a_density_the_first_pass_misses_is_scanned_whole() {
        let x = linspace(-12.0, 12.0, SCAN_POINTS);
        // Positive on a single point of the scan, between two of the first pass.
        let spike = |t: f64| if (t - x[3]).abs() < 1e-9 { 1.0 } else { 0.0 };
        let (got, want, n) = both(&x, spike);
        assert_eq!(got, want);
        assert_eq!(got, Some([x[2], x[4]]));
        assert_eq!(n, SCAN_POINTS);
        // Nothing positive anywhere: no window.
        assert_eq!(both(&x, |_| 0.0).0, None);
        // NaN and infinite values are not peaks (as in `window`).
        let (got, want, _) = both(&x, |t| {
            if t == x[0] {
                f64::INFINITY
            } else {
                (-t * t).exp()
            }
        });
        assert_eq!(got, want);
    }
}
