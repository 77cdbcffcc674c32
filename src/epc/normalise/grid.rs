//! The normalised density on a tensor grid in ξ: the trapezoid sum over the plane or over a
//! ridge's region (a flood-filled mask with a smooth cutoff), and the weight that applies the
//! same region to a density evaluated anywhere.

use super::report::{NormalisationKind, NotNormalisable};
use super::Poly;
use crate::epc::exp::exp_in_place;

/// The normalised density on a grid in scaled variables.
#[derive(Clone, Debug)]
pub(crate) struct DensityGrid {
    /// The ξ1 nodes.
    pub g1: Vec<f64>,
    /// The ξ2 nodes.
    pub g2: Vec<f64>,
    /// The spacings.
    pub h: [f64; 2],
    /// Density in ξ (∫ p dξ = 1), row-major in ξ1; zero outside the region.
    pub p: Vec<f64>,
    /// Inside a ridge: the grid points of the connected component of {Q ≥ floor} holding the
    /// mode, dilated by one point (4-neighbours); `None` on the plane. The region is
    /// {Q ≥ floor} ∩ (cells of these points), so its edge is the smooth level set Q = floor
    /// wherever the component is more than a cell away from others (no staircase along the
    /// cell boundaries), and at grid points it is exactly the component.
    pub mask: Option<Vec<bool>>,
    /// The pass value (Q below it is outside the region).
    pub floor: f64,
    /// max Q on the region (the reference of `p`).
    pub q_max: f64,
    /// ln ∫ exp(Q) dξ over the region.
    pub log_z: f64,
}

impl DensityGrid {
    /// The factor (0 to 1) that multiplies exp(Q) at ξ, where Q = `q`: 1 on the plane; inside
    /// a ridge 0 outside the region and, within it, the smooth cutoff [`taper`] across the
    /// last [`TAPER_E_FOLDS`] above the floor, so that the density falls continuously (with
    /// all its derivatives) to 0 at the region's edge instead of jumping there.
    pub(crate) fn weight(&self, x: [f64; 2], q: f64) -> f64 {
        if self.mask.is_none() {
            return 1.0;
        }
        self.weight_with(q, || [self.node(0, x[0]), self.node(1, x[1])])
    }

    /// The index of the grid node nearest to ξ_axis = `x`, `None` off the grid: what
    /// [`DensityGrid::weight`] looks the mask up with, for callers that evaluate many points
    /// on one line and find each line's node once.
    pub(crate) fn node(&self, axis: usize, x: f64) -> Option<usize> {
        let (g, h) = if axis == 0 {
            (&self.g1, self.h[0])
        } else {
            (&self.g2, self.h[1])
        };
        let i = round_half_away((x - g[0]) / h);
        (i >= 0.0 && (i as usize) < g.len()).then_some(i as usize)
    }

    /// [`DensityGrid::weight`] at a point whose nodes ([`DensityGrid::node`]) `node` gives,
    /// called only when the mask is looked up (inside a ridge, Q within the region's bounds).
    pub(crate) fn weight_with(&self, q: f64, node: impl FnOnce() -> [Option<usize>; 2]) -> f64 {
        let Some(mask) = &self.mask else {
            return 1.0;
        };
        if !self.in_band(q) {
            return 0.0;
        }
        match node() {
            [Some(i), Some(j)] if mask[i * self.g2.len() + j] => self.in_mask(q),
            _ => 0.0,
        }
    }

    /// The same bound on Q as the flood fill that built the mask (the mode is the region's
    /// maximum; what rises above it lies beyond the ridge). Written as the negation of the
    /// test for "outside" so that a NaN Q is in the band, as it always was (and gives NaN).
    #[inline]
    pub(super) fn in_band(&self, q: f64) -> bool {
        !(q <= self.floor || q > self.q_max + 1e-9 * (1.0 + self.q_max.abs()))
    }

    /// [`DensityGrid::weight`] at a point whose node lies in the mask (inside a ridge): the
    /// cutoff of Q alone, so that along a run of masked cells ([`DensityGrid::mask_runs`]) the
    /// weight is a smooth (C^∞) function of Q up to the run's ends, where it takes the limit
    /// from inside the run.
    #[inline]
    pub(crate) fn in_mask(&self, q: f64) -> f64 {
        if self.in_band(q) {
            taper((q - self.floor) / TAPER_E_FOLDS)
        } else {
            0.0
        }
    }

    /// Inside a ridge, the runs of masked cells on the line ξ_axis = `at` within `range` of
    /// the other variable, in order, into `out` (cleared first): the intervals where
    /// [`DensityGrid::weight`] looks up a masked node, so that the density is
    /// exp(Q)·[`DensityGrid::in_mask`] on each and zero between them. A cell is the set of
    /// points that round to its node, so a run's ends are half a spacing beyond its first
    /// and last nodes. `false` on the plane (no mask: the whole line is one run).
    pub(crate) fn mask_runs(
        &self,
        axis: usize,
        at: f64,
        range: [f64; 2],
        out: &mut Vec<[f64; 2]>,
    ) -> bool {
        out.clear();
        let Some(mask) = &self.mask else {
            return false;
        };
        let Some(i) = self.node(axis, at) else {
            return true;
        };
        let (g, h) = if axis == 0 {
            (&self.g2, self.h[1])
        } else {
            (&self.g1, self.h[0])
        };
        let n2 = self.g2.len();
        let masked = |k: usize| {
            if axis == 0 {
                mask[i * n2 + k]
            } else {
                mask[k * n2 + i]
            }
        };
        let mut k = 0;
        while k < g.len() {
            if !masked(k) {
                k += 1;
                continue;
            }
            let first = k;
            while k < g.len() && masked(k) {
                k += 1;
            }
            let lo = (g[0] + (first as f64 - 0.5) * h).max(range[0]);
            let hi = (g[0] + (k as f64 - 0.5) * h).min(range[1]);
            if lo < hi {
                out.push([lo, hi]);
            }
        }
        true
    }
}

/// `t.round()` (halves away from zero) without the library call that `round` is on the
/// baseline x86-64 target: truncation by conversion to an integer, then the exact remainder
/// (t − trunc t is exact for |t| < 2^52). Only the sign of a zero result may differ from
/// `round`'s, which no caller sees (the result is compared with 0 and used as an index).
#[inline]
pub(crate) fn round_half_away(t: f64) -> f64 {
    // NaN, infinities and values too large to have a fraction: the library routine.
    if t.is_nan() || t.abs() >= 4.0e15 {
        return t.round();
    }
    let r = t as i64 as f64;
    let f = t - r;
    if f >= 0.5 {
        r + 1.0
    } else if f <= -0.5 {
        r - 1.0
    } else {
        r
    }
}

/// Width (e-folds of Q) of the smooth cutoff inside a ridge region, above its floor.
pub(crate) const TAPER_E_FOLDS: f64 = 1.0;

/// A C^∞ step: 0 for t ≤ 0, 1 for t ≥ 1, e^{−1/t}/(e^{−1/t} + e^{−1/(1−t)}) between.
pub(crate) fn taper(t: f64) -> f64 {
    if t <= 0.0 {
        0.0
    } else if t >= 1.0 {
        1.0
    } else {
        let a = (-1.0 / t).exp();
        let b = (-1.0 / (1.0 - t)).exp();
        a / (a + b)
    }
}

/// The largest normalisation grid, in points (64 MB of f64 per array).
const MAX_GRID_POINTS: f64 = 8.0e6;

/// The trapezoid sum of exp(Q) on a grid of `cells` over the box (widened by 0.2), inside the
/// ridge's region when there is one: the normalised grid, Z_h and Z_2h.
#[allow(clippy::too_many_arguments)]
pub(super) fn trapezoid_on_region(
    q: &Poly,
    kind: &NormalisationKind,
    mode: [f64; 2],
    q_mode: f64,
    floor: f64,
    lo: [f64; 2],
    hi: [f64; 2],
    cells: [usize; 2],
) -> Result<(DensityGrid, f64, f64), NotNormalisable> {
    // A density spread over a box this many cells wide (scaled units, where the weights'
    // σ is 1) is not one the grid can resolve: refuse rather than allocate without bound.
    let points = (cells[0] as f64 + 1.0) * (cells[1] as f64 + 1.0);
    if !(points.is_finite() && points <= MAX_GRID_POINTS) {
        return Err(NotNormalisable::TooWide {
            lo,
            hi,
            points,
            limit: MAX_GRID_POINTS,
        });
    }
    let axis = |a: usize| -> (Vec<f64>, f64) {
        let (l, u) = (lo[a] - 0.2, hi[a] + 0.2);
        let h = (u - l) / cells[a] as f64;
        ((0..=cells[a]).map(|i| l + i as f64 * h).collect(), h)
    };
    let (g1, h1) = axis(0);
    let (g2, h2) = axis(1);
    let mut grid = DensityGrid {
        g1,
        g2,
        h: [h1, h2],
        p: vec![],
        mask: None,
        floor: f64::NEG_INFINITY,
        q_max: q_mode,
        log_z: 0.0,
    };
    let qv = q.on_grid(&grid.g1, &grid.g2);
    let n2 = grid.g2.len();
    let plane = matches!(kind, NormalisationKind::Plane { .. });
    if !plane {
        // The region: the connected component of {Q ≥ floor} that holds the mode, the floor
        // one e-fold above the pass so that the grid cannot leak across the saddle (what lies
        // below the floor inside the region carries less than e^-(depth-1) of the peak).
        let mut mask = vec![false; qv.len()];
        let i0 = ((mode[0] - grid.g1[0]) / h1).round() as usize;
        let j0 = ((mode[1] - grid.g2[0]) / h2).round() as usize;
        let mut stack = vec![(i0, j0)];
        while let Some((i, j)) = stack.pop() {
            let idx = i * n2 + j;
            if mask[idx] || qv[idx] < floor || qv[idx] > q_mode + 1e-9 * (1.0 + q_mode.abs()) {
                continue;
            }
            mask[idx] = true;
            if i > 0 {
                stack.push((i - 1, j));
            }
            if i + 1 < grid.g1.len() {
                stack.push((i + 1, j));
            }
            if j > 0 {
                stack.push((i, j - 1));
            }
            if j + 1 < n2 {
                stack.push((i, j + 1));
            }
        }
        // Dilation: a grid point next to the component with Q ≥ floor is in it already (the
        // fill is 4-connected), so at grid points membership is unchanged and the trapezoid
        // sum below integrates exactly the density `contains` admits.
        let n1 = grid.g1.len();
        let mut dilated = mask.clone();
        for i in 0..n1 {
            for j in 0..n2 {
                if mask[i * n2 + j] {
                    if i > 0 {
                        dilated[(i - 1) * n2 + j] = true;
                    }
                    if i + 1 < n1 {
                        dilated[(i + 1) * n2 + j] = true;
                    }
                    if j > 0 {
                        dilated[i * n2 + j - 1] = true;
                    }
                    if j + 1 < n2 {
                        dilated[i * n2 + j + 1] = true;
                    }
                }
            }
        }
        grid.mask = Some(dilated);
        grid.floor = floor;
    }
    let q_ref = if plane {
        qv.iter().copied().fold(q_mode, f64::max)
    } else {
        q_mode
    };
    // The points `contains` admits: on the plane all, inside a ridge the component.
    let inside = |idx: usize| {
        grid.mask.as_ref().is_none_or(|m| {
            m[idx] && qv[idx] >= floor && qv[idx] <= q_mode + 1e-9 * (1.0 + q_mode.abs())
        })
    };
    // exp(Q − Q_ref) over the whole grid at once (vectorised), then the cutoff and the sums
    // point by point in order.
    let mut p: Vec<f64> = qv.iter().map(|q| q - q_ref).collect();
    exp_in_place(&mut p);
    let (mut z, mut z2) = (0.0, 0.0);
    for i in 0..grid.g1.len() {
        for j in 0..n2 {
            let idx = i * n2 + j;
            if inside(idx) {
                let w = if plane {
                    1.0
                } else {
                    taper((qv[idx] - floor) / TAPER_E_FOLDS)
                };
                let v = p[idx] * w;
                p[idx] = v;
                z += v;
                if i % 2 == 0 && j % 2 == 0 {
                    z2 += v;
                }
            } else {
                p[idx] = 0.0;
            }
        }
    }
    // The box edges lie where the density is negligible: the trapezoid end corrections vanish.
    let zh = z * h1 * h2;
    if !(zh.is_finite() && zh > 0.0) {
        return Err(NotNormalisable::IntegralNotFinite { value: zh });
    }
    let z2h = z2 * 4.0 * h1 * h2;
    p.iter_mut().for_each(|v| *v /= zh);
    grid.p = p;
    grid.q_max = q_ref;
    grid.log_z = zh.ln() + q_ref;
    Ok((grid, zh, z2h))
}

#[cfg(test)]
mod tests {
    use super::round_half_away;

    #[test]
    fn round_half_away_is_round() {
        let mut t = 0.0_f64;
        let cases = [
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            0.49999999999999994,
            -2.5000000000000004,
            1e15 + 0.5,
        ];
        for c in cases {
            assert_eq!(round_half_away(c), c.round(), "{c}");
        }
        for k in 0..100_000 {
            t = (t * 3.7 + 0.61).fract();
            let x = (t - 0.5) * 2e3 + (k % 7) as f64 * 0.5;
            assert_eq!(round_half_away(x), x.round(), "{x}");
        }
        assert!(round_half_away(f64::NAN).is_nan());
        assert_eq!(round_half_away(1e300), 1e300);
    }
}
