//! Moments of ± a state under a density that is smooth only piecewise along lines (EPC inside
//! a ridge), from one family of lines x_o = u across the outer state o's axis
//! ([`OUTER`]), each integrated over the two halves of the inner state i's axis (split into
//! the density's smooth pieces, [`half_line_moments`]) for its moments
//! M_j(u) = ∫_half t^j p(u, t) dt, j = 0…4, on one set of density values:
//! - E[(s·x_o)^k] = Σ_quadrants ∫ (s·u)^k M_0(u) du, with the central moments by a second pass
//!   about the mean (as for any (g, weight) pairs);
//! - E[(s·x_i)^k] = Σ_quadrants s^k ∫ M_k(u) du, with the variance and kurtosis formed from
//!   these raw moments ([`Moments::from_raw`]): exact where the mean is small against the
//!   standard deviation (the velocity of an oscillator), up to a digit of the rule tolerance
//!   lost where it is not (|mean|/sd = 1.4 for |z| of vibro_duffing at degree 4, whose
//!   variance and kurtosis are within 7e−13 of nested adaptive quadrature at 1e−12, the
//!   tolerance being 2.4e−8).
//!
//! One family instead of one per state halves the lines a study's moments take. The outer
//! integral takes the nested Clenshaw–Curtis rule of 128 intervals on each half of the outer
//! axis, checked against its half like the tensor rule of an analytic density, at the rule
//! tolerance ([`rule_tolerance`]), for every quantity asked; the rule is refined once (256)
//! where a check fails.
//!
//! M_j(u) itself is smooth but for two kinds of feature, both confined to the density's
//! transitions (where its cutoff rises, below e^−(d−1) of the peak inside a ridge of depth d):
//! jumps where u crosses a boundary of the region's mask cells (the transitions at a line's
//! ends gain or lose a cell), and the tangencies at the extremes of u where a line stops
//! meeting the core. Their weight is bounded by the mass of the transitions, about
//! e^−(d−1) (2.2e−7 for vibro_duffing at degree 4, depth 16.2), the density's own stated
//! accuracy; the outer check sees them where they matter at the tolerance, and the composite
//! rule takes over when it fails.

use rayon::prelude::*;

use super::fixed::{nodes, pair};
use super::lines::{half_line_moments, rule_tolerance};
use super::moment_sums::{finer_if_agreeing, moments_of_pairs, ObservableMoments};
use super::JointDensity;
use crate::stats::Moments;

/// The outer rule's number of intervals first tried, and its refinement when the check fails.
const LEVELS: [usize; 2] = [128, 256];

/// The state along whose axis the outer rule runs: the lines are x_OUTER = u. The velocity
/// (state 1) of the bundled oscillators: its lines' outer integrals pass the check at 128
/// intervals where the displacement's need 256 (vibro_duffing at degree 4: the mask's jumps
/// lie across the displacement's axis), and the displacement's moments, formed from raw
/// moments, then carry its large mean (|z|) where the velocity's mean is 0.
const OUTER: usize = 1;
/// The inner state's moments t^j, j = 0…MOMENTS − 1, each line gives.
const MOMENTS: usize = 5;

/// The line moments M_j over the two halves of the inner state (index 0: t < 0, 1: t > 0).
type LineMoments = [[f64; MOMENTS]; 2];
/// An outer node u with its line moments, once computed.
type OuterNode = (f64, Option<LineMoments>);

/// On each half of the outer state's axis, the line moments at the nodes of the outer rule
/// (the 256-interval rule's nodes; the 128-interval rule's are its even ones, filled first).
pub(super) struct LineQuadrants<'a> {
    density: &'a dyn JointDensity,
    tolerance: f64,
    /// `nodes[h]`: `(u, line moments)` at each node of the 256 rule on half h of the outer
    /// axis, `None` where not yet computed; empty for a half of zero length.
    nodes: [Vec<OuterNode>; 2],
    /// The outer rule's intervals in use.
    level: usize,
}

impl<'a> LineQuadrants<'a> {
    /// The line moments at the nodes of the 128-interval rule, where any state is `wanted`:
    /// all of them whichever is, so that a quantity's moments are the same bits asked alone
    /// or with others.
    pub(super) fn new(density: &'a dyn JointDensity, wanted: [bool; 2]) -> LineQuadrants<'a> {
        let mut lines = LineQuadrants {
            density,
            tolerance: rule_tolerance(density),
            nodes: Default::default(),
            level: LEVELS[0],
        };
        if wanted.iter().any(|&w| w) {
            for h in 0..2 {
                let [lo, hi] = lines.half(OUTER, h);
                if hi > lo {
                    // The nodes alone: the 256-interval rule's weights are computed only
                    // where its check is needed.
                    lines.nodes[h] = nodes(lo, hi, LEVELS[1])
                        .into_iter()
                        .map(|u| (u, None))
                        .collect();
                }
            }
            lines.fill(LEVELS[0]);
        }
        lines
    }

    /// The half `h` (0: negative, 1: positive) of state `a`'s axis within the extent.
    fn half(&self, a: usize, h: usize) -> [f64; 2] {
        let ext = self.density.extent();
        if h == 0 {
            [ext[a][0].min(0.0), 0.0]
        } else {
            [0.0, ext[a][1].max(0.0)]
        }
    }

    /// Computes the line moments at the nodes of the `n`-interval rule not yet computed.
    fn fill(&mut self, n: usize) {
        let stride = LEVELS[1] / n;
        let inner = 1 - OUTER;
        let ranges = [self.half(inner, 0), self.half(inner, 1)];
        let (density, tolerance) = (self.density, self.tolerance);
        for nodes in &mut self.nodes {
            // Each node's two half-lines on their own task: the values do not depend on the
            // number of threads.
            nodes
                .par_iter_mut()
                .enumerate()
                .filter(|(k, node)| k % stride == 0 && node.1.is_none())
                .for_each(|(_, node)| {
                    let u = node.0;
                    node.1 = Some(half_line_moments::<MOMENTS>(
                        density, OUTER, u, ranges, tolerance,
                    ));
                });
        }
        self.level = n;
    }

    /// The moments of g = s(q)·x_state by the outer rule where it agrees with its half to the
    /// rule tolerance, refining the rule once (128 to 256 intervals) where it does not;
    /// `None` where even that fails or there are no lines.
    pub(super) fn signed(
        &mut self,
        state: usize,
        sign: &[[f64; 2]; 2],
    ) -> Option<ObservableMoments> {
        if self.nodes.iter().all(Vec::is_empty) {
            return None;
        }
        for n in LEVELS {
            if self.level < n {
                self.fill(n);
            }
            if let Some(m) = self.signed_at(state, sign, n) {
                return Some(m);
            }
        }
        None
    }

    /// [`LineQuadrants::signed`] by the `n`-interval outer rule and its half.
    fn signed_at(&self, state: usize, sign: &[[f64; 2]; 2], n: usize) -> Option<ObservableMoments> {
        let stride = LEVELS[1] / n;
        // The weights of the n rule and its half on each half-axis.
        let weights: Vec<Vec<[f64; 2]>> = (0..2)
            .map(|h| {
                let [lo, hi] = self.half(OUTER, h);
                if hi > lo {
                    pair(lo, hi, n).into_iter().map(|(_, w)| w).collect()
                } else {
                    Vec::new()
                }
            })
            .collect();
        let weights = &weights;
        // Each quadrant q (x1's half q / 2, x2's half q % 2) as (its sign, the outer axis's
        // half, the inner's), with the outer rule's nodes and weights there.
        let quadrant = move |q: usize, rule: usize| {
            let s = sign[q / 2][q % 2];
            let (ho, hi) = if OUTER == 0 {
                (q / 2, q % 2)
            } else {
                (q % 2, q / 2)
            };
            self.nodes[ho]
                .iter()
                .step_by(stride)
                .zip(&weights[ho])
                .map(move |(&(u, m), w)| (s, u, w[rule], m.map_or([f64::NAN; MOMENTS], |m| m[hi])))
        };
        finer_if_agreeing(
            |rule| {
                if state == OUTER {
                    moments_of_pairs(
                        || {
                            (0..4).flat_map(move |q| {
                                quadrant(q, rule).map(|(s, u, w, m)| (s * u, w * m[0]))
                            })
                        },
                        4,
                    )
                } else {
                    inner_moments(
                        (0..4).flat_map(move |q| quadrant(q, rule).map(|(s, _, w, m)| (s, w, m))),
                    )
                }
            },
            self.tolerance,
        )
    }
}

/// The moments of g = s·x_inner from (s, outer weight, line moments) at the outer nodes of
/// every quadrant: E[g^k] = Σ w·s^k·M_k / Σ w·M_0, each sum in the order given, and the
/// central moments from these ([`Moments::from_raw`]).
fn inner_moments(nodes: impl Iterator<Item = (f64, f64, [f64; MOMENTS])>) -> ObservableMoments {
    let (mut mass, mut sums) = (-0.0, [-0.0; 4]);
    for (s, w, m) in nodes {
        mass += w * m[0];
        let mut sk = 1.0;
        for (k, sum) in sums.iter_mut().enumerate() {
            sk *= s;
            *sum += w * sk * m[k + 1];
        }
    }
    ObservableMoments {
        moments: Moments::from_raw(sums.map(|s| s / mass)),
        undefined_mass: 0.0,
        existing: 4,
        point_masses: Vec::new(),
    }
}
