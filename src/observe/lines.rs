//! Line integrals of a joint density over a segment of a coordinate line: the building block
//! of Eqs. 25 and 28 (and of the moments of ± a state under a density cut off to a region).
//!
//! Exact when the density can give it ([`JointDensity::line_integral`]). Otherwise, where the
//! density splits the line into smooth pieces ([`JointDensity::smooth_pieces`]):
//! - an analytic piece by the nested Clenshaw–Curtis rules, accepted when their doubling check
//!   is within the rule tolerance ([`rule_tolerance`]); adaptive Gauss–Kronrod quadrature of
//!   the same piece to 1e−10 when it is not;
//! - a transition piece (where a cutoff takes the density to zero, C^∞ but not analytic, so
//!   that a doubling check can be fooled: on vibro_duffing at degree 4 it passed at 2e−8 with
//!   an error of 2e−7) by the coarsest fixed rule when the bound max·length, summed over the
//!   line's transitions, is within half the tolerance of the analytic pieces' total (the
//!   rule's value and the integral both lie between 0 and that bound); adaptively to 1e−10
//!   otherwise (a line that runs mostly through transitions, near a region's edge).
//!
//! With transitions, the analytic pieces are held to half the tolerance, so that the line's
//! error is within the tolerance in all. A density that cannot tell where it is smooth gets
//! adaptive quadrature of the whole segment.

use std::cell::Cell;

use super::{fixed, quadrature};
use crate::density::{JointDensity, LinePiece, PieceKind};

/// The relative tolerance of the adaptive quadrature, and the tightest the fixed rules are
/// ever held to.
pub(crate) const ADAPTIVE_TOLERANCE: f64 = 1e-10;

/// The fixed rules' acceptance tolerance under `density`: a tenth of the accuracy it states
/// for itself ([`JointDensity::stated_accuracy`]), never tighter than 1e−10 (exactly 1e−10
/// for a density that states 1e−9 or better, such as EPC on the plane). A tenth, so that the
/// quadrature adds little to the error the density already has; no tighter, since resolving
/// an integrand beyond the accuracy of its values buys nothing.
pub(crate) fn rule_tolerance(density: &dyn JointDensity) -> f64 {
    let stated = density.stated_accuracy();
    if stated <= 1e-9 {
        ADAPTIVE_TOLERANCE
    } else {
        0.1 * stated
    }
}

/// ∫ p(x_axis = `at`, t) dt over `range` of the other state (see the module documentation),
/// within `tolerance` relative.
pub(crate) fn half_line(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    range: [f64; 2],
    tolerance: f64,
) -> f64 {
    if let Some(line) = density.line_integral(axis, at, range) {
        return line;
    }
    let mut pieces = PIECES.take();
    let [line] = smooth_line(density, axis, at, range, tolerance, &mut pieces);
    PIECES.set(pieces);
    line
}

thread_local! {
    // A line's pieces, kept between calls (a line integral allocates nothing).
    static PIECES: Cell<Vec<LinePiece>> = const { Cell::new(Vec::new()) };
}

/// [`half_line`] over the two halves `ranges` of the other state's axis on one line at once
/// (`ranges[0]` ends where `ranges[1]` starts, at 0 for the quadrants' halves; either may be
/// empty, and gives 0): the same two integrals, with the line's smooth pieces found once over
/// the whole segment and split where the halves meet, instead of once for each half.
pub(crate) fn half_lines(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    ranges: [[f64; 2]; 2],
    tolerance: f64,
) -> [f64; 2] {
    if !meet(&ranges) {
        return [0, 1].map(|h| {
            if empty(ranges[h]) {
                0.0
            } else {
                half_line(density, axis, at, ranges[h], tolerance)
            }
        });
    }
    if let Some(low) = density.line_integral(axis, at, ranges[0]) {
        return [low, half_line(density, axis, at, ranges[1], tolerance)];
    }
    half_line_moments::<1>(density, axis, at, ranges, tolerance).map(|[v]| v)
}

/// The moments ∫ t^j p(x_axis = `at`, t) dt, j = 0…K−1, of the other state t over each of
/// the two halves `ranges` of its axis (as in [`half_lines`], each half on one side of
/// t = 0), each within `tolerance` relative: the line's smooth pieces found once and
/// integrated by the nested rules on one set of density values for all K moments, each
/// moment held to the tests [`half_line`] holds the integral to (the transitions' bound
/// taken as max·∫|t|^j). For K = 1, [`half_lines`] of a density without exact line
/// integrals, bit for bit.
pub(crate) fn half_line_moments<const K: usize>(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    ranges: [[f64; 2]; 2],
    tolerance: f64,
) -> [[f64; K]; 2] {
    if let Some(breaks) = density.breakpoints(1 - axis) {
        return ranges.map(|r| polynomial_line::<K>(density, axis, at, &breaks, r));
    }
    let mut pieces = PIECES.take();
    let lines = if !meet(&ranges) {
        [0, 1].map(|h| {
            if empty(ranges[h]) {
                [0.0; K]
            } else {
                smooth_line(density, axis, at, ranges[h], tolerance, &mut pieces)
            }
        })
    } else if density.smooth_pieces(axis, at, [ranges[0][0], ranges[1][1]], &mut pieces) {
        // The first piece that reaches past the meeting point, split there when it starts
        // before it: the pieces of each half are then those the half alone has.
        let meet = ranges[0][1];
        let mut k = pieces
            .iter()
            .position(|p| p.range[1] > meet)
            .unwrap_or(pieces.len());
        if let Some(&piece) = pieces.get(k).filter(|p| p.range[0] < meet) {
            pieces[k].range[1] = meet;
            pieces.insert(
                k + 1,
                LinePiece {
                    range: [meet, piece.range[1]],
                    ..piece
                },
            );
            k += 1;
        }
        let (low, high) = pieces.split_at(k);
        [low, high].map(|part| pieces_integral(density, axis, at, part, tolerance))
    } else {
        ranges.map(|r| adaptive_line(density, axis, at, r))
    };
    PIECES.set(pieces);
    lines
}

/// The moments of [`half_line_moments`] over `range` for a density cubic in t between
/// `breaks` ([`JointDensity::breakpoints`] of the line's axis): the 4-point Gauss rule on each
/// piece (split at 0), exact for t^j times a cubic up to j = 4.
fn polynomial_line<const K: usize>(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    breaks: &[f64],
    range: [f64; 2],
) -> [f64; K] {
    const NODES: [f64; 4] = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    const WEIGHTS: [f64; 4] = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    debug_assert!(K <= 5, "4-point Gauss is exact for t^j·cubic up to j = 4");
    let mut t = Vec::with_capacity(4 * breaks.len());
    let mut w = Vec::with_capacity(4 * breaks.len());
    let mut piece = |a: f64, b: f64| {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        for (x, wt) in NODES.iter().zip(WEIGHTS) {
            t.push(c + h * x);
            w.push(h * wt);
        }
    };
    for pair in breaks.windows(2) {
        let (a, b) = (pair[0].max(range[0]), pair[1].min(range[1]));
        if b <= a {
            continue;
        }
        if a < 0.0 && b > 0.0 {
            piece(a, 0.0);
            piece(0.0, b);
        } else {
            piece(a, b);
        }
    }
    let mut p = vec![0.0; t.len()];
    line_values(density, axis, at, &t, &mut p);
    let mut out = [0.0; K];
    for ((t, w), p) in t.iter().zip(&w).zip(&p) {
        let mut tj = 1.0;
        for o in out.iter_mut() {
            *o += w * tj * p;
            tj *= t;
        }
    }
    out
}

/// Whether a range is empty (gives 0).
fn empty(range: [f64; 2]) -> bool {
    range[1] <= range[0]
}

/// Whether two halves of a line are both non-empty and meet (the first ends where the second
/// starts), so that the line's pieces can be found once over both.
fn meet(ranges: &[[f64; 2]; 2]) -> bool {
    !(empty(ranges[0]) || empty(ranges[1]) || ranges[0][1] != ranges[1][0])
}

/// The moments of [`half_line_moments`] over one `range`, with `pieces` for the line's smooth
/// pieces.
fn smooth_line<const K: usize>(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    range: [f64; 2],
    tolerance: f64,
    pieces: &mut Vec<LinePiece>,
) -> [f64; K] {
    if !density.smooth_pieces(axis, at, range, pieces) {
        return adaptive_line(density, axis, at, range);
    }
    pieces_integral(density, axis, at, pieces, tolerance)
}

/// The line's moments over `range` by adaptive quadrature of t^j times the density as
/// defined, for a density that cannot tell where it is smooth.
fn adaptive_line<const K: usize>(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    range: [f64; 2],
) -> [f64; K] {
    let f = |t: &[f64], out: &mut [f64]| line_values(density, axis, at, t, out);
    adaptive_moments(&f, range[0], range[1])
}

/// ∫ t^j f(t) dt, j = 0…K−1, over [`lo`, `hi`], each by adaptive quadrature to
/// [`ADAPTIVE_TOLERANCE`] (moment 0 of f itself).
fn adaptive_moments<const K: usize>(f: &dyn Fn(&[f64], &mut [f64]), lo: f64, hi: f64) -> [f64; K] {
    std::array::from_fn(|j| {
        // t^0 = 1 exactly: moment 0 is the integral of f itself, bit for bit.
        let weighted = |t: &[f64], out: &mut [f64]| {
            f(t, out);
            for (o, &t) in out.iter_mut().zip(t) {
                *o *= t.powi(j as i32);
            }
        };
        quadrature::integrate_adaptive_batch(&weighted, lo, hi, ADAPTIVE_TOLERANCE)
    })
}

/// max·∫|t|^j dt over `range`, j = 0…K−1: the bound on a transition's moments (its density
/// lies between 0 and `max`).
fn transition_bounds<const K: usize>(max: f64, [a, b]: [f64; 2]) -> [f64; K] {
    std::array::from_fn(|j| {
        let e = j as i32 + 1;
        let integral = if a < 0.0 && b > 0.0 {
            ((-a).powi(e) + b.powi(e)) / f64::from(e)
        } else {
            (b.powi(e) - a.powi(e)).abs() / f64::from(e)
        };
        max * integral
    })
}

/// The moments over a segment tiled by the density's smooth `pieces` (see the module
/// documentation), each within `tolerance` relative.
fn pieces_integral<const K: usize>(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    pieces: &[LinePiece],
    tolerance: f64,
) -> [f64; K] {
    let bounds = |piece: &LinePiece| match piece.kind {
        PieceKind::Analytic => None,
        PieceKind::Transition { max } => Some(transition_bounds::<K>(max, piece.range)),
    };
    let mut transitions = [0.0; K];
    for b in pieces.iter().filter_map(bounds) {
        for (t, b) in transitions.iter_mut().zip(b) {
            *t += b;
        }
    }
    let share = if transitions[0] > 0.0 { 0.5 } else { 1.0 };
    let integrate = |piece: &LinePiece, rule: Rule<K>| {
        // A piece's nodes at once: one row (or column) of the density.
        let f = |t: &[f64], out: &mut [f64]| density.pdf_on_piece(axis, at, piece, t, out);
        let [lo, hi] = piece.range;
        let fixed = match rule {
            Rule::Checked { abs } => fixed::nested_moments(&f, lo, hi, share * tolerance, abs),
            Rule::Coarsest => Some(fixed::coarsest_moments(&f, lo, hi)),
        };
        fixed.unwrap_or_else(|| adaptive_moments(&f, lo, hi))
    };
    let mut analytic = [-0.0; K];
    for piece in pieces.iter().filter(|p| p.kind == PieceKind::Analytic) {
        let m = integrate(piece, Rule::Checked { abs: [1e-300; K] });
        for (a, m) in analytic.iter_mut().zip(m) {
            *a += m;
        }
    }
    if transitions[0] == 0.0 {
        return analytic;
    }
    // The transitions' share of the error: half the tolerance of the analytic pieces' total,
    // spread over them in proportion to their bounds, moment by moment.
    let budget = analytic.map(|a| share * tolerance * a.abs());
    let negligible = (0..K).all(|j| transitions[j] <= budget[j]);
    let mut rest = [0.0; K];
    for piece in pieces.iter() {
        let Some(bound) = bounds(piece) else {
            continue;
        };
        let m = if negligible {
            integrate(piece, Rule::Coarsest)
        } else {
            integrate(
                piece,
                Rule::Checked {
                    abs: std::array::from_fn(|j| {
                        (budget[j] * bound[j] / transitions[j]).max(1e-300)
                    }),
                },
            )
        };
        for (r, m) in rest.iter_mut().zip(m) {
            *r += m;
        }
    }
    std::array::from_fn(|j| analytic[j] + rest[j])
}

/// How a piece is integrated (its K moments).
#[derive(Clone, Copy)]
enum Rule<const K: usize> {
    /// The nested fixed rules, accepted when their doubling check is within the relative
    /// tolerance or `abs` for every moment; adaptive quadrature to 1e−10 when it is not.
    Checked {
        /// The absolute tolerance of each moment.
        abs: [f64; K],
    },
    /// The coarsest fixed rule, unchecked (a transition whose bound is negligible).
    Coarsest,
}

/// p on the line x_axis = `at` at the points `t` of the other state.
fn line_values(density: &dyn JointDensity, axis: usize, at: f64, t: &[f64], out: &mut [f64]) {
    if axis == 0 {
        density.pdf_on_grid(&[at], t, out);
    } else {
        density.pdf_on_grid(t, &[at], out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::moments_of_all;

    /// vibro_duffing at degree 4: EPC normalised inside a ridge 16.2 e-folds deep (stated
    /// accuracy e^−15.2 = 2.4e−7, rule tolerance 2.4e−8).
    fn ridge() -> crate::Solution {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
        let bound = crate::model::load_model(&path).unwrap().bind(&[]).unwrap();
        crate::solve(&bound, crate::Method::Epc { degree: 4 }).unwrap()
    }

    #[test]
    fn ridge_lines_by_pieces_agree_with_tight_adaptive_quadrature() {
        let sol = ridge();
        let d = sol.joint();
        let tolerance = rule_tolerance(d);
        assert!(tolerance > 2e-8 && tolerance < 3e-8, "{tolerance:e}");
        let ext = d.extent();
        let mut transitions = 0;
        for axis in 0..2 {
            let other = 1 - axis;
            for k in 0..=40 {
                let at = ext[axis][0] + (ext[axis][1] - ext[axis][0]) * k as f64 / 40.0;
                for range in [[ext[other][0], 0.0], [0.0, ext[other][1]]] {
                    let mut pieces = Vec::new();
                    assert!(d.smooth_pieces(axis, at, range, &mut pieces));
                    transitions += pieces
                        .iter()
                        .filter(|p| p.kind != PieceKind::Analytic)
                        .count();
                    let fast = half_line(d, axis, at, range, tolerance);
                    // The density as defined (`pdf_on_grid`, with its mask lookups) over the
                    // whole segment, to 1e−13.
                    let f = |t: &[f64], out: &mut [f64]| line_values(d, axis, at, t, out);
                    let exact = quadrature::integrate_adaptive_batch(&f, range[0], range[1], 1e-13);
                    assert!(
                        (fast - exact).abs() <= tolerance * exact.abs() + 1e-300,
                        "axis {axis} at {at}: {fast:e} vs {exact:e}"
                    );
                    // The line's moments t^j p, j = 0…4, on one set of values: each within
                    // the tolerance of its own adaptive value.
                    let h = usize::from(range[0] >= 0.0);
                    let mut halves = [[ext[other][0], 0.0], [0.0, ext[other][1]]];
                    halves[1 - h] = [0.0, 0.0];
                    let moments = half_line_moments::<5>(d, axis, at, halves, tolerance)[h];
                    for (j, &m) in moments.iter().enumerate() {
                        let weighted = |t: &[f64], out: &mut [f64]| {
                            f(t, out);
                            for (o, t) in out.iter_mut().zip(t) {
                                *o *= t.powi(j as i32);
                            }
                        };
                        let exact = quadrature::integrate_adaptive_batch(
                            &weighted, range[0], range[1], 1e-13,
                        );
                        assert!(
                            (m - exact).abs() <= tolerance * exact.abs() + 1e-300,
                            "axis {axis} at {at} moment {j}: {m:e} vs {exact:e}"
                        );
                    }
                }
            }
        }
        // The ridge's lines do have transitions (the cutoff's rise), kept out of the
        // analytic pieces.
        assert!(transitions > 40, "{transitions}");
    }

    /// A transition's bound on its moments is max·∫|t|^j over the piece, on one side of 0 or
    /// across it.
    #[test]
    fn transition_bounds_are_max_times_the_moments_of_abs_t() {
        assert_eq!(
            transition_bounds::<3>(2.0, [1.0, 3.0]),
            [4.0, 8.0, 2.0 * 26.0 / 3.0]
        );
        assert_eq!(
            transition_bounds::<3>(2.0, [-3.0, -1.0]),
            [4.0, 8.0, 2.0 * 26.0 / 3.0]
        );
        assert_eq!(transition_bounds::<3>(2.0, [-1.0, 2.0]), [6.0, 5.0, 6.0]);
    }

    /// Both halves of a line at once are each half alone: the pieces found once over the
    /// whole segment and split at 0 are the halves' own (to the last bits of a stretch's end
    /// found by bisection near t = 0), on the ridge (pieces split at the meeting point) and
    /// on a density without pieces; an empty half gives 0, and halves that do not meet are
    /// taken one by one.
    #[test]
    fn both_halves_at_once_are_each_half_alone() {
        let sol = ridge();
        let d = sol.joint();
        let tolerance = rule_tolerance(d);
        let ext = d.extent();
        for axis in 0..2 {
            let other = 1 - axis;
            let ranges = [[ext[other][0], 0.0], [0.0, ext[other][1]]];
            for k in 0..=60 {
                let at = ext[axis][0] + (ext[axis][1] - ext[axis][0]) * k as f64 / 60.0;
                let both = half_lines(d, axis, at, ranges, tolerance);
                for h in 0..2 {
                    let alone = half_line(d, axis, at, ranges[h], tolerance);
                    assert!(
                        (both[h] - alone).abs() <= 1e-13 * alone.abs(),
                        "axis {axis} at {at} half {h}: {:e} vs {alone:e}",
                        both[h]
                    );
                }
            }
        }
        let at = 0.3 * ext[0][1];
        let one = half_line(d, 0, at, [0.0, ext[1][1]], tolerance);
        assert_eq!(
            half_lines(d, 0, at, [[0.0, 0.0], [0.0, ext[1][1]]], tolerance),
            [0.0, one]
        );
        let apart = [[ext[1][0], -0.5], [0.5, ext[1][1]]];
        assert_eq!(
            half_lines(d, 0, at, apart, tolerance),
            apart.map(|r| half_line(d, 0, at, r, tolerance))
        );
        // A density with neither pieces nor an exact line integral: adaptive on each half.
        struct Normal;
        impl JointDensity for Normal {
            fn pdf(&self, x: [f64; 2]) -> f64 {
                (-0.5 * (x[0] * x[0] + x[1] * x[1])).exp() / (2.0 * std::f64::consts::PI)
            }
            fn extent(&self) -> [[f64; 2]; 2] {
                [[-9.0, 9.0], [-9.0, 9.0]]
            }
        }
        let both = half_lines(&Normal, 1, 0.5, [[-9.0, 0.0], [0.0, 9.0]], 1e-10);
        let expected = 0.5 * (-0.125_f64).exp() / (2.0 * std::f64::consts::PI).sqrt();
        for v in both {
            assert!((v / expected - 1.0).abs() < 1e-9, "{v:e}");
        }
    }

    /// The moments of ± each state inside the ridge (z and v by the pairs of the outer
    /// state or the line moments of the inner one, |z| and sgn(z)·v with their quadrants'
    /// signs) against nested adaptive quadrature to 1e−12 in x1-then-x2 order: raw moments,
    /// variance and kurtosis within the rule tolerance (|z|'s central moments, formed from raw
    /// ones with |mean|/sd = 1.4, included).
    #[test]
    fn ridge_moments_by_lines_agree_with_nested_adaptive_quadrature() {
        let sol = ridge();
        let d = sol.joint();
        let names = ["z", "y", "v", "ydot"];
        let maps: Vec<_> = names
            .iter()
            .map(|n| &sol.quantity(n).unwrap().map)
            .collect();
        let all = moments_of_all(d, &maps);
        let ext = d.extent();
        let tolerance = rule_tolerance(d);
        // ∫∫ over the quadrant (h1, h2) of x1^a·x2^b·p, inner integral over x2 on each x1-line.
        let half = |axis: usize, h: usize| {
            if h == 0 {
                [ext[axis][0], 0.0]
            } else {
                [0.0, ext[axis][1]]
            }
        };
        let quadrant = |h: [usize; 2], a: i32, b: i32| {
            let line = |u: f64| {
                let f = |t: &[f64], out: &mut [f64]| {
                    line_values(d, 0, u, t, out);
                    for (o, t) in out.iter_mut().zip(t) {
                        *o *= t.powi(b);
                    }
                };
                let [lo, hi] = half(1, h[1]);
                quadrature::integrate_adaptive_batch(&f, lo, hi, 1e-12)
            };
            let [lo, hi] = half(0, h[0]);
            quadrature::integrate_adaptive(&|u: f64| u.powi(a) * line(u), lo, hi, 1e-12)
        };
        let quadrants = [[0, 0], [0, 1], [1, 0], [1, 1]];
        let mass: f64 = quadrants.iter().map(|&h| quadrant(h, 0, 0)).sum();
        // [state, sign of the quadrants with x1 < 0] for z, |z|, v, sgn(z)·v.
        for (k, (state, negative)) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)]
            .into_iter()
            .enumerate()
        {
            let raw: [f64; 4] = std::array::from_fn(|j| {
                let p = j as i32 + 1;
                quadrants
                    .iter()
                    .map(|&h| {
                        let s: f64 = if h[0] == 0 { negative } else { 1.0 };
                        let (a, b) = if state == 0 { (p, 0) } else { (0, p) };
                        s.powi(p) * quadrant(h, a, b)
                    })
                    .sum::<f64>()
                    / mass
            });
            let exact = crate::stats::Moments::from_raw(raw);
            let got = &all[k].moments;
            for j in 0..4 {
                let scale = raw[3].powf((j as f64 + 1.0) / 4.0);
                assert!(
                    (got.raw[j] - raw[j]).abs() <= tolerance * scale,
                    "{} raw {}: {:e} vs {:e}",
                    names[k],
                    j + 1,
                    got.raw[j],
                    raw[j]
                );
            }
            for (what, g, e) in [
                ("variance", got.variance, exact.variance),
                ("kurtosis", got.kurtosis, exact.kurtosis),
            ] {
                assert!(
                    (g - e).abs() <= tolerance * e.abs(),
                    "{} {what}: {g} vs {e}",
                    names[k]
                );
            }
        }
    }
}
