//! The discretisation-error estimate of what a grid solution writes: its curves, not its
//! cell masses.
//!
//! A solution answers every question through its interpolant ([`GridSolution::pdf`]: fourth-
//! order point values at the centres, bicubic between them where the density is resolved,
//! bilinear elsewhere): the marginal curves, their moments and tails are those of the
//! interpolant, whose error is the finite-volume error of the cell averages plus the
//! reconstruction error (read as point values by a linear interpolant, the averages put the
//! linear oscillator's position marginal at 200×400 cells 4.8e−4 from exact in L1 where its
//! cell masses were 1.1e−4 off; the reconstruction brings the curve to 9.5e−5). The same
//! questions put to the half-resolution solution differ from the fine one's by both errors at
//! once, so their difference, scaled by Richardson's 1/(2^order − 1) with order 1 and by
//! Roache's safety factor 1.25 (the grid convergence index of a study whose order is known:
//! the lowest order the exact cases show), bounds the fine answer's error whenever the
//! solution converges at order at least 1. Without the safety factor the velocity's standard
//! deviation under the Zhuravlev form with r = 1 is 1.1 times its estimate (it converges at
//! order 1 there).
//!
//! The L1 distances of the curves (what a tolerance is held to) take the order the solution
//! shows instead, when a third solve on a quarter of the cells per axis is at hand: the
//! quarter–half difference over the half–fine one is 2^p for convergence of order p, and the
//! fine curve's error is then 1.25·D/(2^p − 1) (Roache's grid convergence index from three
//! grids), p kept within [`CURVE_ORDERS`]. The curves converge as the cell masses do, at
//! order 1.5 to 3; the order-1 estimate stated 3 to 5 times
//! their true error, and a tolerance paid for that caution in cells. The moments and tails
//! keep order 1: a state's standard deviation can converge at order 1 where its curve
//! converges faster (the velocity under the Zhuravlev form with r = 1).

use super::solution::{richardson_factor, DiscretisationEstimate, GridSolution, SAFETY};

/// Evaluation points per cell of the fine mesh along an axis: the midpoint rule on the
/// piecewise-cubic difference of two curves is then within a few per cent of its integral.
const POINTS_PER_CELL: usize = 8;

/// The level, relative to a marginal's peak, above which its tails are compared.
pub const TAIL_LEVEL: f64 = 1e-5;

/// The orders an L1 estimate may take from three solves where the scheme is second order
/// or the density has a singular corner: at most 3/2, and at least 1/2 (a quarter solve
/// closer to the half than the fine one is makes the estimate three times the fine–half
/// difference, more cautious than order 1). Second order: the general form's operator
/// (the general form); its cell masses converge more slowly as the
/// cells shrink than three coarse solves show (the mechanical operator before its fluxes were
/// made third order: the linear oscillator's position masses 3.1e−4, 1.1e−4, 3.7e−5, 2.0e−5
/// from exact at 100×200 … 560×1120 cells, orders 1.5, 1.6, 1.8; at order 2 the estimate was
/// 0.7 of the true error). The corner: a wall whose law is not elastic (the density jumps at
/// the wall's v = 0), where the mechanical operator's masses converge at about 2 away from
/// the corner and at 1.2–1.3 beside it (the paper's case 1, masses within 0.5 of the corner
/// 9.1e−5, 3.9e−5, 1.5e−5 from a 768×1536 solve at 96×192, 192×384, 384×768), so that the
/// corner sets the order as the cells shrink; at 1.5 the estimate states 3–5 times the true
/// error there (192×384: 4.2e−4 against 9.1e−5).
pub const CURVE_ORDERS: [f64; 2] = [0.5, 1.5];

/// The highest order an L1 estimate may take on the mechanical form without a singular
/// corner, whose fluxes are third order: its cell masses converge at 3.0 from 128×256 to
/// 512×1024 on every exact case (errors fall eightfold per doubling: the linear oscillator's
/// position 3.8e−4, 4.9e−5, 6.1e−6; the elastic wall at rest 4.4e−5, 5.6e−6, 7.1e−7), so an
/// estimate at 5/2 states about twice the true error.
pub const SMOOTH_CURVE_ORDER: f64 = 2.5;

/// The fewest cells on an axis of the quarter solve for an order above
/// [`COARSE_CURVE_ORDER`] to be trusted: on coarser cells the interpolant is bilinear on
/// more of the quads (their point values differ by more than the bicubic's factor), and the
/// curves converge more slowly than the masses. Measured: with quarter solves of 23 to 29
/// cells in x (fine 92 to 116, the tolerance 1e−3) order 5/2 stated 0.78 to 1.05 of the true
/// error (the cubic-damping case, velocity: 3.4e−4 stated, 4.4e−4 true); order 2 states 1.6
/// times more.
const RESOLVED_QUARTER: usize = 48;

/// The highest order an L1 estimate takes when the quarter solve has fewer than
/// [`RESOLVED_QUARTER`] cells on an axis.
const COARSE_CURVE_ORDER: f64 = 2.0;

/// The order of convergence an L1 difference `fine_half` of the fine and half solves and
/// `half_quarter` of the half and quarter ones show, at least `CURVE_ORDERS[0]` and at most
/// `cap`.
fn observed_order(fine_half: f64, half_quarter: f64, cap: f64) -> f64 {
    let p = (half_quarter / fine_half).log2();
    if p.is_nan() {
        CURVE_ORDERS[0]
    } else {
        p.clamp(CURVE_ORDERS[0], cap)
    }
}

/// The estimate of `fine`'s errors from the solution `coarse` of the same problem on half the
/// cells per axis (both clipped and of unit mass), assuming convergence of order `order`;
/// with `quarter`, the solution on a quarter of the cells per axis, the curves' L1 estimates
/// take the order the three show, at most `cap`.
pub(super) fn estimate(
    fine: &GridSolution,
    coarse: &GridSolution,
    quarter: Option<&GridSolution>,
    order: f64,
    cap: f64,
) -> DiscretisationEstimate {
    let factor = richardson_factor(order);
    let coarse_quarter =
        quarter.is_some_and(|q| q.report.cells.iter().any(|&n| n < RESOLVED_QUARTER));
    let d = fine.domain();
    let mut out = DiscretisationEstimate {
        x: 0.0,
        v: 0.0,
        mean: [0.0; 2],
        std: [0.0; 2],
        tail: [0.0; 2],
        tail_level: TAIL_LEVEL,
        coarse_cells: coarse.report.cells,
        order,
        curve_order: [order; 2],
        shown_order: [order; 2],
        quarter_cells: quarter.map(|q| q.report.cells),
    };
    for axis in 0..2 {
        let [lo, hi] = if axis == 0 { d.x } else { d.v };
        let n = POINTS_PER_CELL * fine.report.cells[axis];
        let h = (hi - lo) / n as f64;
        let at: Vec<f64> = (0..n).map(|k| lo + (k as f64 + 0.5) * h).collect();
        let curve = |sol: &GridSolution| -> Vec<f64> {
            at.iter()
                .map(|&u| sol.line_integral(axis, u, [f64::NEG_INFINITY, f64::INFINITY]))
                .collect()
        };
        let (f, c) = (curve(fine), curve(coarse));
        let distance = |a: &[f64], b: &[f64]| -> f64 {
            a.iter().zip(b).map(|(a, b)| (a - b).abs()).sum::<f64>() * h
        };
        let l1 = distance(&f, &c);
        let shown = match quarter {
            Some(q) => observed_order(l1, distance(&c, &curve(q)), cap),
            None => order,
        };
        let curve_order = if coarse_quarter {
            shown.min(COARSE_CURVE_ORDER)
        } else {
            shown
        };
        let moments = |p: &[f64]| {
            let mass: f64 = p.iter().sum::<f64>() * h;
            let mean = at.iter().zip(p).map(|(u, p)| u * p).sum::<f64>() * h / mass;
            let var = at
                .iter()
                .zip(p)
                .map(|(u, p)| (u - mean).powi(2) * p)
                .sum::<f64>()
                * h
                / mass;
            (mean, var.max(0.0).sqrt())
        };
        let ((mf, sf), (mc, sc)) = (moments(&f), moments(&c));
        let peak = f.iter().cloned().fold(0.0, f64::max);
        // The largest ratio of the two curves where the fine one is above the level; a
        // coarse curve at 0 there (a hole) makes it infinite.
        let tail = f
            .iter()
            .zip(&c)
            .filter(|(a, _)| **a >= TAIL_LEVEL * peak)
            .map(|(a, b)| {
                if *b > 0.0 {
                    (a / b).log10().abs()
                } else {
                    f64::INFINITY
                }
            })
            .fold(0.0, f64::max);
        let l1 = l1 * richardson_factor(curve_order);
        if axis == 0 {
            out.x = l1;
        } else {
            out.v = l1;
        }
        out.curve_order[axis] = curve_order;
        out.shown_order[axis] = shown;
        out.mean[axis] = (mf - mc).abs() * factor;
        out.std[axis] = (sf - sc).abs() * factor;
        out.tail[axis] = tail * SAFETY;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observed_order_is_the_ratio_of_differences_within_bounds() {
        let cap = CURVE_ORDERS[1];
        assert!((observed_order(1e-3, 2.5e-3, cap) - 2.5f64.log2()).abs() < 1e-12);
        // A lucky pair is not trusted beyond the cap; a quarter solve closer to the half
        // than the fine one gives the most cautious order.
        assert_eq!(observed_order(1e-3, 4e-3, cap), 1.5);
        assert_eq!(observed_order(1e-3, 1e-1, cap), 1.5);
        assert_eq!(observed_order(1e-3, 1e-1, SMOOTH_CURVE_ORDER), 2.5);
        assert!((observed_order(1e-3, 4e-3, SMOOTH_CURVE_ORDER) - 2.0).abs() < 1e-12);
        assert_eq!(observed_order(1e-3, 5e-4, cap), 0.5);
        assert_eq!(observed_order(0.0, 0.0, cap), 0.5);
        assert_eq!(observed_order(0.0, 1e-3, cap), 1.5);
    }
}
