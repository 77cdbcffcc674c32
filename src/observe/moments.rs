//! Moments of a quantity taken from the joint density directly: E[g^k] = ∬ g^k p dx.

use rayon::prelude::*;

use super::line_moments::LineQuadrants;
use super::moment_sums::{
    finer_if_agreeing, moments_of_pairs, CentralSums, ObservableMoments, PointMass, RawSums,
    POINT_MASS_FLOOR,
};
use super::ObservableMap;
use crate::density::JointDensity;
use crate::symbolic::{DeltaPolicy, Tape};

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points.
const GL_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// Panels per axis and geometric levels (ratio 0.2) of the panels next to 0, of the rule the
/// moments are taken with.
const FINE: Rule = Rule {
    panels: 64,
    graded: 20,
};
/// A second, different rule: a moment whose two values disagree by more than
/// [`EXISTENCE_TOLERANCE`] does not exist (its integral diverges: every extra graded level
/// adds as much as the last, as for E[1/|z|]) or cannot be determined by quadrature.
const CHECK: Rule = Rule {
    panels: 48,
    graded: 14,
};
/// Relative disagreement of E[|g|^k] between the two rules above which moment k is declared
/// not to exist: a convergent integrable singularity on an axis (|z|^−½) costs ~1e−5, a
/// divergent one O(1).
const EXISTENCE_TOLERANCE: f64 = 1e-3;

/// A composite Gauss–Legendre rule: panels per axis, and graded levels next to 0.
#[derive(Clone, Copy)]
struct Rule {
    panels: usize,
    graded: usize,
}

/// Nodes and weights of the composite rule on [lo, hi] (split at 0 when 0 is inside).
fn axis_rule(lo: f64, hi: f64, rule: Rule) -> Vec<(f64, f64)> {
    let mut parts = vec![(lo, hi)];
    if lo < 0.0 && hi > 0.0 {
        parts = vec![(lo, 0.0), (0.0, hi)];
    }
    let mut out = Vec::new();
    for (a, b) in parts {
        let n = ((rule.panels as f64 * (b - a) / (hi - lo)).ceil() as usize).max(4);
        let w = (b - a) / n as f64;
        for k in 0..n {
            let (pa, pb) = (a + k as f64 * w, a + (k + 1) as f64 * w);
            graded_panel(pa, pb, rule.graded, &GAUSS_8, &mut out);
        }
    }
    out
}

/// Gauss–Legendre rules on [−1, 1] as (node ≥ 0, weight) pairs, each node but 0 standing for
/// ±node: 8 points, 4 points and 3 points.
const GAUSS_8: [(f64, f64); 4] = [
    (GL_X[0], GL_W[0]),
    (GL_X[1], GL_W[1]),
    (GL_X[2], GL_W[2]),
    (GL_X[3], GL_W[3]),
];
const GAUSS_4: [(f64, f64); 2] = [
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];
const GAUSS_3: [(f64, f64); 2] = [(0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];

/// Appends the nodes and weights of the Gauss rule `gauss` on the panel [pa, pb], or, for a
/// panel with an end at 0, of the 8-point rule on `graded` geometric levels (ratio 0.2)
/// towards 0, so that a singularity of g on an axis (log|z|, |z|^−½) is integrated
/// accurately.
fn graded_panel(pa: f64, pb: f64, graded: usize, gauss: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    let panel = |a: f64, b: f64, gauss: &[(f64, f64)], out: &mut Vec<(f64, f64)>| {
        let (c, w) = (0.5 * (a + b), b - a);
        for &(x, wt) in gauss {
            if x == 0.0 {
                out.push((c, 0.5 * w * wt));
            } else {
                out.push((c - 0.5 * w * x, 0.5 * w * wt));
                out.push((c + 0.5 * w * x, 0.5 * w * wt));
            }
        }
    };
    let far = if pa == 0.0 {
        pb
    } else if pb == 0.0 {
        pa
    } else {
        panel(pa, pb, gauss, out);
        return;
    };
    let mut outer = far;
    for _ in 0..graded {
        let inner = 0.2 * outer;
        panel(inner.min(outer), inner.max(outer), &GAUSS_8, out);
        outer = inner;
    }
    panel(outer.min(0.0), outer.max(0.0), &GAUSS_8, out);
}

/// Nodes and weights of a rule on the pieces between `breaks` (sorted, the axis's ends
/// first and last) where a density is polynomial of degree ≤ 3 along the axis
/// ([`JointDensity::breakpoints`]): `gauss` on each piece, pieces split at 0 and graded
/// towards it as in [`axis_rule`] (where a map has its kinks and singularities). Exact for
/// the density times any polynomial of degree up to 2·points − 2 on a piece.
fn piece_rule(breaks: &[f64], graded: usize, gauss: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for w in breaks.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        if a < 0.0 && b > 0.0 {
            graded_panel(a, 0.0, graded, gauss, &mut out);
            graded_panel(0.0, b, graded, gauss, &mut out);
        } else {
            graded_panel(a, b, graded, gauss, &mut out);
        }
    }
    out
}

/// The moments of `map` under `density` (see [`Moments`](crate::stats::Moments)).
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{moments, ObservableMap};
/// use fpsolve::symbolic::Expr;
/// struct Normal;
/// impl JointDensity for Normal {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[-10.0, 10.0], [-10.0, 10.0]]
///     }
/// }
/// let states = ["z".into(), "v".into()];
/// let vsq = ObservableMap::classify(&(Expr::sym("v") * Expr::sym("v")), &states);
/// let m = moments(&Normal, &vsq);
/// assert!((m.moments.mean - 1.0).abs() < 1e-12);
/// assert!((m.moments.raw[1] - 3.0).abs() < 1e-12); // E[v⁴] = 3
/// assert_eq!(m.undefined_mass, 0.0);
/// ```
pub fn moments(density: &dyn JointDensity, map: &ObservableMap) -> ObservableMoments {
    moments_of_all(density, &[map]).remove(0)
}

/// [`moments`] of several quantities under one density: the density is evaluated once per
/// quadrature node for all of them (it is the expensive part, an exponential of a
/// polynomial), each quantity's map at the same nodes.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{moments, moments_of_all, ObservableMap};
/// use fpsolve::symbolic::Expr;
/// struct Normal;
/// impl JointDensity for Normal {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[-10.0, 10.0], [-10.0, 10.0]]
///     }
/// }
/// let states = ["z".into(), "v".into()];
/// let z = ObservableMap::classify(&Expr::sym("z"), &states);
/// let vsq = ObservableMap::classify(&(Expr::sym("v") * Expr::sym("v")), &states);
/// let all = moments_of_all(&Normal, &[&z, &vsq]);
/// assert_eq!(all[1], moments(&Normal, &vsq));
/// assert!((all[0].moments.raw[3] - 3.0).abs() < 1e-12); // E[z⁴] = 3
/// ```
pub fn moments_of_all(
    density: &dyn JointDensity,
    maps: &[&ObservableMap],
) -> Vec<ObservableMoments> {
    // ± a state under an analytic density: a tensor Clenshaw–Curtis rule on each quadrant,
    // checked against its half (see `Quadrants::signed`); under a density smooth piecewise
    // along lines, line integrals under an outer rule (see `LineQuadrants`); the composite
    // grid for the rest, and where a fixed rule's check fails.
    let pieces = [density.breakpoints(0), density.breakpoints(1)];
    let fixed: Vec<Option<ObservableMoments>> = if let [Some(b0), Some(b1)] = &pieces {
        // Polynomial on the pieces (a grid's interpolant): a Gauss rule on every piece is
        // exact for the states' moments, and the check rule below still tells which moments
        // of a general map exist.
        let fine = Grid::new(
            density,
            [
                piece_rule(b0, FINE.graded, &GAUSS_4),
                piece_rule(b1, FINE.graded, &GAUSS_4),
            ],
        );
        let check = maps
            .iter()
            .any(|m| matches!(m, ObservableMap::General { .. }))
            .then(|| {
                Grid::new(
                    density,
                    [
                        piece_rule(b0, CHECK.graded, &GAUSS_3),
                        piece_rule(b1, CHECK.graded, &GAUSS_3),
                    ],
                )
            });
        return of_rules(maps, &fine, check.as_ref(), vec![None; maps.len()]);
    } else if density.analytic() {
        let quadrants = Quadrants::new(density);
        let signed: Vec<(usize, [[f64; 2]; 2])> = maps
            .iter()
            .filter_map(|map| match map {
                ObservableMap::SignedState { state, sign } => Some((*state, *sign)),
                ObservableMap::General { .. } => None,
            })
            .collect();
        let mut of_signed = quadrants.signed(&signed).into_iter();
        maps.iter()
            .map(|map| match map {
                ObservableMap::SignedState { .. } => of_signed.next().flatten(),
                ObservableMap::General { .. } => None,
            })
            .collect()
    } else if by_pieces(density) {
        let mut wanted = [false; 2];
        for map in maps {
            if let ObservableMap::SignedState { state, .. } = map {
                wanted[*state] = true;
            }
        }
        let mut lines = LineQuadrants::new(density, wanted);
        maps.iter()
            .map(|map| match map {
                ObservableMap::SignedState { state, sign } => lines.signed(*state, sign),
                ObservableMap::General { .. } => None,
            })
            .collect()
    } else {
        vec![None; maps.len()]
    };
    if fixed.iter().all(Option::is_some) {
        return fixed.into_iter().flatten().collect();
    }
    let ext = density.extent();
    let composite = |rule: Rule| {
        Grid::new(
            density,
            [
                axis_rule(ext[0][0], ext[0][1], rule),
                axis_rule(ext[1][0], ext[1][1], rule),
            ],
        )
    };
    let fine = composite(FINE);
    // A state's moments exist for any density fpsolve normalises (exp(Q) on the plane, or cut
    // at a ridge): the second rule is only needed for general maps.
    let check = maps
        .iter()
        .any(|m| matches!(m, ObservableMap::General { .. }))
        .then(|| composite(CHECK));
    of_rules(maps, &fine, check.as_ref(), fixed)
}

/// The moments of each of `maps` by the `fine` rule, those of general maps up to the order
/// `fine` and `check` agree on, where `fixed` has none.
fn of_rules(
    maps: &[&ObservableMap],
    fine: &Grid,
    check: Option<&Grid>,
    fixed: Vec<Option<ObservableMoments>>,
) -> Vec<ObservableMoments> {
    // Each quantity on its own thread: its sums are its own, so the result does not depend
    // on the number of threads.
    maps.par_iter()
        .zip(fixed)
        .map(|(map, fixed)| {
            if let Some(m) = fixed {
                return m;
            }
            if let ObservableMap::SignedState { state, sign } = map {
                // ± a state: g is as cheap as reading the node, so it is not stored.
                let g = |x: [f64; 2]| {
                    sign[usize::from(x[0] >= 0.0)][usize::from(x[1] >= 0.0)] * x[*state]
                };
                return moments_of_pairs(|| fine.nodes().map(|&(x, w)| (g(x), w)), 4);
            }
            let f = fine.samples(map);
            let existing = match check {
                Some(check) => established(&f, &check.samples(map)),
                None => 4,
            };
            let mut m = f.moments(existing);
            m.point_masses = fine.point_masses(map);
            m
        })
        .collect()
}

/// Whether `density` tells the smooth pieces of its lines ([`JointDensity::smooth_pieces`]).
fn by_pieces(density: &dyn JointDensity) -> bool {
    let ext = density.extent();
    let mut pieces = Vec::new();
    density.smooth_pieces(0, 0.5 * (ext[0][0] + ext[0][1]), ext[1], &mut pieces)
}

/// Relative agreement of the moments by the tensor Clenshaw–Curtis rule and its half below
/// which the finer one's are taken (it is far more accurate than the agreement).
const FIXED_TOLERANCE: f64 = 1e-10;

/// The density at the nodes of a tensor Clenshaw–Curtis rule on each quadrant (the axes are
/// quadrant edges, where ± a state has its kinks), with the weights of the rule and of its
/// half: `[(x, [w_fine·p, w_coarse·p])]` per quadrant, indexed by `2·[x1 ≥ 0] + [x2 ≥ 0]`.
struct Quadrants {
    nodes: [Vec<([f64; 2], [f64; 2])>; 4],
}

impl Quadrants {
    fn new(density: &dyn JointDensity) -> Quadrants {
        let ext = density.extent();
        let halves = |a: usize| {
            [
                super::fixed::finest_pair(ext[a][0].min(0.0), 0.0),
                super::fixed::finest_pair(0.0, ext[a][1].max(0.0)),
            ]
        };
        let (h1, h2) = (halves(0), halves(1));
        let nodes = [0, 1, 2, 3].map(|q| {
            let (r1, r2) = (&h1[q / 2], &h2[q % 2]);
            let x1: Vec<f64> = r1.iter().map(|r| r.0).collect();
            let x2: Vec<f64> = r2.iter().map(|r| r.0).collect();
            let mut p = vec![0.0; x1.len() * x2.len()];
            density.pdf_on_grid(&x1, &x2, &mut p);
            let mut nodes = Vec::with_capacity(p.len());
            for (&(x1, w1), p) in r1.iter().zip(p.chunks(x2.len())) {
                for (&(x2, w2), &p) in r2.iter().zip(p) {
                    nodes.push(([x1, x2], [w1[0] * w2[0] * p, w1[1] * w2[1] * p]));
                }
            }
            nodes
        });
        Quadrants { nodes }
    }

    /// For each (state, sign) of `signed`, the moments of g = s(q)·x_state by the finer rule
    /// where the two rules agree to [`FIXED_TOLERANCE`] (see [`finer_if_agreeing`]), `None`
    /// where they do not. Every quantity's sums under both rules are taken in one pass over
    /// the nodes (and one more for the central sums), each in the order of the nodes, as
    /// [`moments_of_pairs`] takes them for one quantity and one rule.
    fn signed(&self, signed: &[(usize, [[f64; 2]; 2])]) -> Vec<Option<ObservableMoments>> {
        let mut raw = vec![[RawSums::EMPTY; 2]; signed.len()];
        self.for_each_pair(signed, |i, g, w| {
            raw[i][0].add(g, w[0]);
            raw[i][1].add(g, w[1]);
        });
        let means: Vec<[f64; 2]> = raw.iter().map(|r| r.map(|r| r.mean(4))).collect();
        let mut central = vec![[CentralSums::EMPTY; 2]; signed.len()];
        self.for_each_pair(signed, |i, g, w| {
            central[i][0].add(g, means[i][0], w[0]);
            central[i][1].add(g, means[i][1], w[1]);
        });
        raw.iter()
            .zip(&central)
            .map(|(raw, central)| {
                finer_if_agreeing(|rule| raw[rule].moments(&central[rule], 4), FIXED_TOLERANCE)
            })
            .collect()
    }

    /// Calls `f(i, g, w)` for each node, in quadrant order and node order, and within a node
    /// for each quantity i of `signed`: g = s(q)·x_state, w the node's weights in both rules.
    #[inline(always)]
    fn for_each_pair(
        &self,
        signed: &[(usize, [[f64; 2]; 2])],
        mut f: impl FnMut(usize, f64, [f64; 2]),
    ) {
        for (q, nodes) in self.nodes.iter().enumerate() {
            for (x, w) in nodes {
                for (i, (state, sign)) in signed.iter().enumerate() {
                    f(i, sign[q / 2][q % 2] * x[*state], *w);
                }
            }
        }
    }
}

/// Rows of a rule evaluated together (one task of the parallel evaluation).
const ROWS_PER_BLOCK: usize = 32;

/// How many of E|g|^k, k = 1…4, the two rules agree on.
fn established(fine: &Samples, check: &Samples) -> usize {
    let mut existing = 0;
    for k in 1..=4 {
        let (a, b) = (fine.absolute(k), check.absolute(k));
        let agree = a.is_finite()
            && b.is_finite()
            && (a - b).abs() <= EXISTENCE_TOLERANCE * a.abs().max(b.abs()).max(1e-300);
        if !agree {
            break;
        }
        existing = k;
    }
    existing
}

/// The nodes of a rule with their weights times the density (zero-density nodes left out),
/// in blocks of rows (in order; not concatenated, which would copy them).
struct Grid {
    blocks: Vec<Vec<([f64; 2], f64)>>,
    /// The extent's widths.
    width: [f64; 2],
}

impl Grid {
    /// The tensor rule of the axis rules `r1`, `r2` (each node with its weight) under
    /// `density`.
    fn new(density: &dyn JointDensity, [r1, r2]: [Vec<(f64, f64)>; 2]) -> Grid {
        let ext = density.extent();
        // Blocks of rows in parallel, kept in order: the sums over the nodes are the same, bit
        // for bit, on any number of threads.
        let x2: Vec<f64> = r2.iter().map(|r| r.0).collect();
        let blocks: Vec<Vec<([f64; 2], f64)>> = r1
            .par_chunks(ROWS_PER_BLOCK)
            .map(|rows| {
                let x1: Vec<f64> = rows.iter().map(|r| r.0).collect();
                let mut p = vec![0.0; x1.len() * x2.len()];
                density.pdf_on_grid(&x1, &x2, &mut p);
                let mut nodes = Vec::with_capacity(p.len());
                for (&(x1, w1), p) in rows.iter().zip(p.chunks(x2.len())) {
                    for (&(x2, w2), &p) in r2.iter().zip(p) {
                        if p != 0.0 {
                            nodes.push(([x1, x2], w1 * w2 * p));
                        }
                    }
                }
                nodes
            })
            .collect();
        Grid {
            blocks,
            width: [ext[0][1] - ext[0][0], ext[1][1] - ext[1][0]],
        }
    }

    /// The values a general map takes with probability at least [`POINT_MASS_FLOOR`]: the
    /// weight of the nodes where g is finite and equal, bit for bit, to its values a step of
    /// 1e−6 of the extent away on either side along each axis (a smooth g changes over such
    /// a step unless its gradient vanishes, and then only on a curve, which carries no
    /// mass), grouped by g's value. Sorted by value.
    fn point_masses(&self, map: &ObservableMap) -> Vec<PointMass> {
        let ObservableMap::General { expr, states } = map else {
            return Vec::new();
        };
        // An analytic g that depends on the states is constant on no region: only a kink
        // (or no state at all) makes one, so the other maps skip the five evaluations a node.
        if !expr.has_kink() && (expr.mentions(&states[0]) || expr.mentions(&states[1])) {
            return Vec::new();
        }
        let Ok(tape) = Tape::compile(
            std::slice::from_ref(expr),
            &[&*states[0], &*states[1]],
            DeltaPolicy::Zero,
        ) else {
            return Vec::new();
        };
        let (mut scratch, mut out) = (Vec::new(), [0.0]);
        let mut g = |x: [f64; 2]| {
            tape.eval(&x, &mut scratch, &mut out);
            out[0]
        };
        let step = self.width.map(|w| 1e-6 * w);
        let (mut total, mut flat): (f64, Vec<(f64, f64)>) = (0.0, Vec::new());
        for &(x, w) in self.nodes() {
            total += w;
            let g0 = g(x);
            let level = g0.is_finite()
                && [0, 1].iter().all(|&a| {
                    [-1.0, 1.0].iter().all(|s| {
                        let mut y = x;
                        y[a] += s * step[a];
                        g(y).to_bits() == g0.to_bits()
                    })
                });
            if level {
                // +0 and −0 are one value.
                flat.push((g0 + 0.0, w));
            }
        }
        flat.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut masses: Vec<PointMass> = Vec::new();
        for (value, w) in flat {
            match masses.last_mut() {
                Some(m) if m.value.to_bits() == value.to_bits() => m.probability += w,
                _ => masses.push(PointMass {
                    value,
                    probability: w,
                }),
            }
        }
        for m in &mut masses {
            m.probability /= total;
        }
        masses.retain(|m| m.probability >= POINT_MASS_FLOOR);
        masses
    }

    /// The nodes with their weights times the density, in order.
    fn nodes(&self) -> impl Iterator<Item = &([f64; 2], f64)> + '_ {
        self.blocks.iter().flatten()
    }

    /// (g, weight·p) at every node; g is NaN where it is undefined.
    fn samples(&self, map: &ObservableMap) -> Samples {
        let tape = match map {
            ObservableMap::General { expr, states } => Some(Tape::compile(
                std::slice::from_ref(expr),
                &[&*states[0], &*states[1]],
                DeltaPolicy::Zero,
            )),
            ObservableMap::SignedState { .. } => None,
        };
        let (mut scratch, mut out) = (Vec::new(), [0.0]);
        let samples: Vec<(f64, f64)> = self
            .nodes()
            .map(|&(x, w)| {
                let g = match (map, &tape) {
                    (ObservableMap::SignedState { state, sign }, _) => {
                        sign[usize::from(x[0] >= 0.0)][usize::from(x[1] >= 0.0)] * x[*state]
                    }
                    (_, Some(Ok(t))) => {
                        t.eval(&x, &mut scratch, &mut out);
                        out[0]
                    }
                    _ => f64::NAN,
                };
                (g, w)
            })
            .collect();
        let defined: f64 = samples
            .iter()
            .filter(|s| s.0.is_finite())
            .map(|s| s.1)
            .sum();
        Samples { samples, defined }
    }
}

/// (g, weight·p) at every node of a rule; g is NaN where it is undefined.
struct Samples {
    samples: Vec<(f64, f64)>,
    /// Σ weight·p where g is defined.
    defined: f64,
}

impl Samples {
    /// The moments, the first `existing` of them established (the others NaN).
    fn moments(&self, existing: usize) -> ObservableMoments {
        moments_of_pairs(|| self.samples.iter().copied(), existing)
    }

    /// The samples where g is defined.
    fn defined(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.samples.iter().copied().filter(|s| s.0.is_finite())
    }

    /// E[f(g)] given g defined.
    fn expect(&self, f: impl Fn(f64) -> f64) -> f64 {
        self.defined().map(|(g, w)| f(g) * w).sum::<f64>() / self.defined
    }

    /// E[|g|^k] given g defined.
    fn absolute(&self, k: usize) -> f64 {
        self.expect(|g| g.abs().powi(k as i32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bivariate normal with means `m`, standard deviations `sd` and correlation `rho`,
    /// analytic, on a fixed extent.
    struct Normal {
        m: [f64; 2],
        sd: [f64; 2],
        rho: f64,
    }

    impl JointDensity for Normal {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            let (a, b) = (
                (x[0] - self.m[0]) / self.sd[0],
                (x[1] - self.m[1]) / self.sd[1],
            );
            let d = 1.0 - self.rho * self.rho;
            (-(a * a - 2.0 * self.rho * a * b + b * b) / (2.0 * d)).exp()
                / (2.0 * std::f64::consts::PI * d.sqrt() * self.sd[0] * self.sd[1])
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            [[-8.0, 9.0], [-7.0, 10.0]]
        }
        fn analytic(&self) -> bool {
            true
        }
    }

    /// A map constant on a region of the plane (`max`, `min` that clip; `sgn`) takes that
    /// value with positive probability, reported as a point mass; smooth maps, ± a state and
    /// maps whose gradient vanishes only on a curve (v², z·v) have none.
    #[test]
    fn maps_constant_on_a_region_have_point_masses() {
        use crate::symbolic::{Expr, Func};
        let d = Normal {
            m: [0.0, 0.0],
            sd: [1.0, 1.0],
            rho: 0.0,
        };
        let states = ["z".into(), "v".into()];
        let (z, v) = (Expr::sym("z"), Expr::sym("v"));
        let masses = |e: Expr| moments(&d, &ObservableMap::classify(&e, &states)).point_masses;
        let max = Expr::Call(Func::Max, vec![z.clone(), Expr::num(0.0)]);
        let m = masses(max);
        assert_eq!(m.len(), 1, "{m:?}");
        assert_eq!(m[0].value, 0.0);
        assert!((m[0].probability - 0.5).abs() < 1e-3, "{m:?}");
        // min(|z|, 1) = 1 where |z| ≥ 1: P = 2(1 − Φ(1)) = 0.317311.
        let min = Expr::Call(
            Func::Min,
            vec![Expr::call(Func::Abs, z.clone()), Expr::num(1.0)],
        );
        let m = masses(min);
        assert_eq!(m.len(), 1, "{m:?}");
        assert_eq!(m[0].value, 1.0);
        assert!((m[0].probability - 0.317_310_5).abs() < 2e-3, "{m:?}");
        let m = masses(Expr::call(Func::Sgn, z.clone() - v.clone()));
        assert_eq!(m.iter().map(|m| m.value).collect::<Vec<_>>(), [-1.0, 1.0]);
        assert!(
            m.iter().all(|m| (m.probability - 0.5).abs() < 1e-2),
            "{m:?}"
        );
        for smooth in [
            v.clone() * v.clone(),
            z.clone() * v.clone(),
            z.clone() + v.clone(),
            Expr::call(Func::Abs, z.clone()),
        ] {
            assert!(masses(smooth.clone()).is_empty(), "{smooth}");
        }
    }

    /// The one pass over the nodes for every quantity and both rules gives, bit for bit, each
    /// quantity's moments taken alone (two passes per rule, as `moments_of_pairs` takes them),
    /// both where the rules agree and where they do not (a density narrow against the
    /// extent); the quantities are z, |z|, v and sgn(z)·v, in an order with repeats.
    #[test]
    fn one_pass_is_each_quantity_alone() {
        let signs = [
            (0, [[1.0, 1.0], [1.0, 1.0]]),
            (0, [[-1.0, -1.0], [1.0, 1.0]]),
            (1, [[1.0, 1.0], [1.0, 1.0]]),
            (1, [[-1.0, -1.0], [1.0, 1.0]]),
            (0, [[1.0, 1.0], [1.0, 1.0]]),
        ];
        let mut agreed = [0, 0];
        for d in [
            Normal {
                m: [0.4, -0.7],
                sd: [1.3, 2.1],
                rho: 0.35,
            },
            Normal {
                m: [0.05, 0.0],
                sd: [0.02, 0.03],
                rho: -0.2,
            },
        ] {
            let quadrants = Quadrants::new(&d);
            let together = quadrants.signed(&signs);
            for ((state, sign), together) in signs.iter().zip(together) {
                let alone =
                    finer_if_agreeing(
                        |rule| {
                            moments_of_pairs(
                                || {
                                    quadrants.nodes.iter().enumerate().flat_map(
                                        move |(q, nodes)| {
                                            let s = sign[q / 2][q % 2];
                                            nodes.iter().map(move |(x, w)| (s * x[*state], w[rule]))
                                        },
                                    )
                                },
                                4,
                            )
                        },
                        FIXED_TOLERANCE,
                    );
                agreed[usize::from(alone.is_some())] += 1;
                assert_eq!(together, alone, "state {state}, sign {sign:?}");
            }
        }
        // Both outcomes were met: the rules agree on the wide density, not on the narrow one.
        assert_eq!(agreed, [5, 5]);
    }
}
