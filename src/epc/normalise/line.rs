//! A ridge density along a coordinate line, split where it is not analytic.
//!
//! Inside a ridge the density is exp(Q)·w, w = 0 off the region's masked cells and, on them,
//! the cutoff of Q ([`DensityGrid::in_mask`]): 0 for Q ≤ floor, a C^∞ (not analytic) rise
//! across the next [`TAPER_E_FOLDS`], 1 above, and 0 again above the band's top. Along a
//! line, the masked cells come in runs ([`DensityGrid::mask_runs`]); within a run each point
//! is in one of three *classes* by its Q alone: zero, transition (the cutoff's rise) or core
//! (w = 1, where the density is exp(Q), analytic). The class boundaries are found by
//! sampling Q every quarter of the grid spacing and bisecting every change of class to
//! rounding (where Q is proven monotone between the two samples, the float the bisection ends
//! at is found by Newton's method and a walk over adjacent floats instead: see
//! `DensityGrid::leave_by_root`). Two changes that cancel between samples are missed only where Q touches a level
//! without a sign change wider than a sample step can hide: Q then strays past the level by
//! far less than 1e−2 e-folds (Q'' is O(10) in scaled units across the region), where the
//! cutoff differs from 0 or 1 by less than e^−100, so the stretch stays analytic to far below
//! rounding.

use super::grid::{taper, DensityGrid, TAPER_E_FOLDS};
use super::poly::horner;

/// What the density is on a stretch of a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stretch {
    /// exp(Q): the cutoff is 1.
    Core,
    /// exp(Q)·taper: the cutoff's C^∞ rise from 0 to 1 (Q within TAPER_E_FOLDS above the
    /// floor), where the density is at most exp(floor + TAPER_E_FOLDS).
    Transition,
}

/// The class of a point by its Q: `None` where the density is zero (Q out of the band
/// [`DensityGrid::in_mask`] admits). The cutoff itself is not evaluated (two exponentials): a
/// transition point where it underflows to 0 is classed a transition, of value 0.
#[inline]
fn class(grid: &DensityGrid, q: f64) -> Option<Stretch> {
    if !grid.in_band(q) {
        None
    } else if (q - grid.floor) / TAPER_E_FOLDS >= 1.0 {
        Some(Stretch::Core)
    } else {
        Some(Stretch::Transition)
    }
}

/// Bisection steps from a sample interval (a quarter of a grid spacing) to rounding.
const BISECTIONS: usize = 60;

impl DensityGrid {
    /// The stretches of the runs `runs` (scaled units, in order) of a line on which Q is the
    /// polynomial `c` (Horner in the line's variable), into `out` (cleared first): the core
    /// and transition stretches in order, tiling each run but for its zero stretches.
    pub(crate) fn stretches(
        &self,
        c: &[f64],
        runs: &[[f64; 2]],
        out: &mut Vec<([f64; 2], Stretch)>,
    ) {
        out.clear();
        let step = 0.25 * self.h[0].min(self.h[1]);
        let class_at = |t: f64| class(self, horner(c, t));
        for &[a, b] in runs {
            let samples = ((b - a) / step).ceil().max(1.0) as usize;
            let (mut start, mut current) = (a, class_at(a));
            // The last point known to be of the current class.
            let mut known = a;
            for s in 1..=samples {
                let t = if s == samples {
                    b
                } else {
                    a + (b - a) * s as f64 / samples as f64
                };
                while class_at(t) != current {
                    // Where the class first leaves `current` in (known, t]: hi is the first
                    // point found of another class, the stretch's end.
                    let hi = self.leave(c, known, t, current);
                    if let Some(kind) = current {
                        out.push(([start, hi], kind));
                    }
                    (start, current, known) = (hi, class_at(hi), hi);
                }
                known = t;
            }
            if let Some(kind) = current {
                if start < b {
                    out.push(([start, b], kind));
                }
            }
        }
    }

    /// The first point of (`lo`, `hi`] whose class is not `current` (that of `lo`; `hi`'s is
    /// another): what bisecting (`lo`, `hi`] to rounding gives ([`Self::leave_by_bisection`]),
    /// found by Newton's method where Q is monotone on the interval
    /// ([`Self::leave_by_root`]), by the bisection itself elsewhere.
    fn leave(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> f64 {
        self.leave_by_root(c, lo, hi, current)
            .unwrap_or_else(|| self.leave_by_bisection(c, lo, hi, current))
    }

    /// Bisection of (`lo`, `hi`] for where the class first leaves `current`, down to adjacent
    /// floating-point numbers (or [`BISECTIONS`] halvings): `hi` ends as the first point
    /// found of another class.
    fn leave_by_bisection(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> f64 {
        let (mut lo, mut hi) = (lo, hi);
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if class(self, horner(c, mid)) == current {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }

    /// The bisection's answer without its sixty evaluations of Q, where it can be had
    /// directly; `None` where it cannot (the caller bisects).
    ///
    /// Where Q is monotone on (`lo`, `hi`], the points of class `current` (whose Q lies in one
    /// interval of levels, or outside one for the zero class) form an interval starting at
    /// `lo`, so the class changes once: bisection, which keeps a point of class `current` at
    /// its low end and one of another class at its high end until the two are adjacent
    /// floating-point numbers, ends with `hi` at the first number of another class, s. That
    /// number is found here by Newton's method on Q = the level crossed, then a walk over
    /// adjacent numbers to the change. Refused (`None`) where that reasoning does not hold:
    /// - Q not proven monotone: |Q'| at the middle must exceed twice the bound on |Q''| times
    ///   the interval's length, so that Q' keeps its sign across it;
    /// - near t = 0, where sixty halvings stop short of adjacent numbers;
    /// - where the computed class flickers at the change (rounding of Q at the level): the
    ///   two numbers below s and the two above must agree with the single change, as the
    ///   ones bisection might visit;
    /// - where Newton's method or the walk does not settle within a few steps.
    fn leave_by_root(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> Option<f64> {
        let is_current = |t: f64| class(self, horner(c, t)) == current;
        let width = hi - lo;
        // Sixty halvings of `width` reach adjacent numbers where |t| ≥ width·2^−6; this keeps
        // a margin of eight.
        let nearest = if lo <= 0.0 && hi >= 0.0 {
            0.0
        } else {
            lo.abs().min(hi.abs())
        };
        if nearest.is_nan() || nearest < width / 8.0 {
            return None;
        }
        let n = c.len() - 1;
        if n == 0 {
            return None;
        }
        let m = 0.5 * (lo + hi);
        let reach = lo.abs().max(hi.abs());
        let (mut slope, mut curvature) = (0.0, 0.0);
        for k in (1..=n).rev() {
            slope = slope * m + k as f64 * c[k];
        }
        for k in (2..=n).rev() {
            curvature = curvature * reach + (k * (k - 1)) as f64 * c[k].abs();
        }
        // Written so that a NaN refuses.
        if slope.is_nan() || slope.abs() <= 2.0 * curvature * width || curvature.is_nan() {
            return None;
        }
        let rising = slope > 0.0;
        // The level Q crosses where the class leaves `current` (see `class`).
        let top = self.q_max + 1e-9 * (1.0 + self.q_max.abs());
        let core = self.floor + TAPER_E_FOLDS;
        let level = match (current, rising) {
            (Some(Stretch::Core), true) => top,
            (Some(Stretch::Core), false) => core,
            (Some(Stretch::Transition), true) => core,
            (Some(Stretch::Transition), false) => self.floor,
            (None, true) => self.floor,
            (None, false) => top,
        };
        // Newton's method on Q − level from the middle, kept inside the interval.
        let mut x = m;
        let mut settled = false;
        for _ in 0..12 {
            let (mut q, mut dq) = (c[n], 0.0);
            for &ck in c[..n].iter().rev() {
                dq = dq * x + q;
                q = q * x + ck;
            }
            let next = (x - (q - level) / dq).clamp(lo, hi);
            if !next.is_finite() {
                return None;
            }
            let step = (next - x).abs();
            x = next;
            if step <= 4.0 * f64::EPSILON * x.abs() {
                settled = true;
                break;
            }
        }
        if !settled {
            return None;
        }
        // The walk to the change: s is of another class, the number below it of `current`.
        const WALK: usize = 16;
        let mut s = x.clamp(lo.next_up(), hi);
        if is_current(s) {
            let mut found = false;
            for _ in 0..WALK {
                s = s.next_up();
                if s > hi {
                    return None;
                }
                if !is_current(s) {
                    found = true;
                    break;
                }
            }
            if !found {
                return None;
            }
        } else {
            let mut found = false;
            for _ in 0..WALK {
                let below = s.next_down();
                if below <= lo || is_current(below) {
                    found = true;
                    break;
                }
                s = below;
            }
            if !found {
                return None;
            }
        }
        // No flicker next to the change.
        let below2 = s.next_down().next_down();
        let clean = (below2 <= lo || is_current(below2))
            && [s.next_up(), s.next_up().next_up()]
                .iter()
                .all(|&t| t > hi || !is_current(t));
        clean.then_some(s)
    }

    /// The density (relative to C, i.e. exp(Q)·cutoff) at Q = `q` on a stretch of `kind`:
    /// the stretch's own formula, so that at its ends it is the limit from inside.
    #[inline]
    pub(crate) fn on_stretch(&self, kind: Stretch, q: f64) -> f64 {
        match kind {
            Stretch::Core => 1.0,
            Stretch::Transition => taper((q - self.floor) / TAPER_E_FOLDS),
        }
    }

    /// The largest Q on a transition stretch, floor + TAPER_E_FOLDS: there the density is at
    /// most C·exp of this (the cutoff is at most 1), the bound callers use where a
    /// transition's share of a line integral is negligible.
    pub(crate) fn transition_max_q(&self) -> f64 {
        self.floor + TAPER_E_FOLDS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ridge grid with the given levels (only `floor`, `q_max` and the spacing matter here).
    fn levels(floor: f64, q_max: f64) -> DensityGrid {
        DensityGrid {
            g1: vec![0.0, 1.0],
            g2: vec![0.0, 1.0],
            h: [0.2, 0.2],
            p: vec![0.0; 4],
            mask: Some(vec![true; 4]),
            floor,
            q_max,
            log_z: 0.0,
        }
    }

    /// Newton's answer is the bisection's, bit for bit, on every sample interval where a
    /// quartic's class changes, and it is the one taken at most of them.
    #[test]
    fn root_finds_what_bisection_finds() {
        let grid = levels(-15.0, 0.0);
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut changes, mut by_root) = (0, 0);
        for _ in 0..400 {
            // −a t² + b t³ − d t⁴ + e t + f: a peak near the origin falling through the levels.
            let c = [
                -0.5 * uniform(),
                uniform() - 0.5,
                -(0.5 + uniform()),
                0.2 * (uniform() - 0.5),
                -0.05 * uniform(),
            ];
            let step = 0.05;
            let mut t = -8.0;
            while t < 8.0 {
                let (lo, hi) = (t, t + step);
                let current = class(&grid, horner(&c, lo));
                if class(&grid, horner(&c, hi)) != current {
                    changes += 1;
                    let bisected = grid.leave_by_bisection(&c, lo, hi, current);
                    if let Some(root) = grid.leave_by_root(&c, lo, hi, current) {
                        by_root += 1;
                        assert_eq!(root.to_bits(), bisected.to_bits(), "{c:?} on ({lo}, {hi}]");
                    }
                    assert_eq!(grid.leave(&c, lo, hi, current), bisected);
                }
                t += step;
            }
        }
        assert!(changes > 1000, "{changes}");
        assert!(by_root * 10 > changes * 9, "{by_root} of {changes}");
    }
}
