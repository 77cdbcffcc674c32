//! A ridge density along a coordinate line, split where it is not analytic.
//!
//! Inside a ridge the density is exp(Q)·w, w = 0 off the region's masked cells and, on them,
//! the cutoff of Q ([`DensityGrid::in_mask`]): 0 for Q ≤ floor, a C^∞ (not analytic) rise
//! across the next [`TAPER_E_FOLDS`], 1 above, and 0 again above the band's top. Along a
//! line, the masked cells come in runs ([`DensityGrid::mask_runs`]); within a run each point
//! is in one of three *classes* by its Q alone: zero, transition (the cutoff's rise) or core
//! (w = 1, where the density is exp(Q), analytic). The class boundaries are found by
//! sampling Q every quarter of the grid spacing and bisecting every change of class to
//! rounding. Two changes that cancel between samples are missed only where Q touches a level
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
                    // Bisect (known, t] for where the class first leaves `current`: hi is
                    // the first point found of another class, the stretch's end.
                    let (mut lo, mut hi) = (known, t);
                    for _ in 0..BISECTIONS {
                        let mid = 0.5 * (lo + hi);
                        if mid <= lo || mid >= hi {
                            break;
                        }
                        if class_at(mid) == current {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
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
