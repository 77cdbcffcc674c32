//! Moments of ± a state under a density that is smooth only piecewise along lines (EPC inside
//! a ridge): E[g^k] = Σ_quadrants ∫ (s·u)^k L(u) du, L(u) the line integral of the density
//! over the quadrant's half of the other state at x_state = u ([`half_line`], split into the
//! density's smooth pieces). The outer integral takes the nested Clenshaw–Curtis rule of 128
//! intervals on each half of the state's axis, checked against its half like the tensor rule
//! of an analytic density, at the rule tolerance ([`rule_tolerance`]).
//!
//! L(u) itself is smooth but for two kinds of feature, both confined to the density's
//! transitions (where its cutoff rises, below e^−(d−1) of the peak inside a ridge of depth d):
//! jumps where u crosses a boundary of the region's mask cells (the transitions at a line's
//! ends gain or lose a cell), and the tangencies at the extremes of u where a line stops
//! meeting the core. Their weight is bounded by the mass of the transitions, about
//! e^−(d−1) (2.2e−7 for vibro_duffing at degree 4, depth 16.2), the density's own stated
//! accuracy; the outer check sees them where they matter at the tolerance, and the composite
//! rule takes over when it fails.

use rayon::prelude::*;

use super::fixed::{nodes, pair};
use super::lines::{half_lines, rule_tolerance};
use super::moments::{finer_if_agreeing, moments_of_pairs, ObservableMoments};
use super::JointDensity;

/// The outer rule's number of intervals first tried, and its refinement when the check fails.
const LEVELS: [usize; 2] = [128, 256];

/// An outer node u with the line integrals over the two halves of the other state, once
/// computed.
type OuterNode = (f64, Option<[f64; 2]>);

/// For each state asked for, on each half of its axis, the line integrals over the two halves
/// of the other state at the nodes of the outer rule (the 256-interval rule's nodes; the
/// 128-interval rule's are its even ones, filled first).
pub(super) struct LineQuadrants<'a> {
    density: &'a dyn JointDensity,
    tolerance: f64,
    /// `states[a][ha]`: `(u, [L over x_b < 0, L over x_b > 0])` at each node of the 256 rule,
    /// `None` where not yet computed; empty for a half of zero length or a state not asked.
    states: [[Vec<OuterNode>; 2]; 2],
    /// The outer rule's intervals in use, per state.
    level: [usize; 2],
}

impl<'a> LineQuadrants<'a> {
    /// The line integrals for the states `wanted[a]` at the nodes of the 128-interval rule.
    pub(super) fn new(density: &'a dyn JointDensity, wanted: [bool; 2]) -> LineQuadrants<'a> {
        let mut lines = LineQuadrants {
            density,
            tolerance: rule_tolerance(density),
            states: Default::default(),
            level: [LEVELS[0]; 2],
        };
        for (a, &wanted) in wanted.iter().enumerate() {
            if wanted {
                for ha in 0..2 {
                    let [lo, hi] = lines.half(a, ha);
                    if hi > lo {
                        // The nodes alone: the 256-interval rule's weights are computed
                        // only where its check is needed.
                        lines.states[a][ha] = nodes(lo, hi, LEVELS[1])
                            .into_iter()
                            .map(|u| (u, None))
                            .collect();
                    }
                }
                lines.fill(a, LEVELS[0]);
            }
        }
        lines
    }

    /// The half `ha` (0: negative, 1: positive) of state `a`'s axis within the extent.
    fn half(&self, a: usize, ha: usize) -> [f64; 2] {
        let ext = self.density.extent();
        if ha == 0 {
            [ext[a][0].min(0.0), 0.0]
        } else {
            [0.0, ext[a][1].max(0.0)]
        }
    }

    /// Computes the line integrals at the nodes of the `n`-interval rule not yet computed.
    fn fill(&mut self, a: usize, n: usize) {
        let stride = LEVELS[1] / n;
        let b = 1 - a;
        let ranges = [self.half(b, 0), self.half(b, 1)];
        let (density, tolerance) = (self.density, self.tolerance);
        for nodes in &mut self.states[a] {
            // Each node's two half-lines on their own task: the values do not depend on the
            // number of threads.
            nodes
                .par_iter_mut()
                .enumerate()
                .filter(|(k, node)| k % stride == 0 && node.1.is_none())
                .for_each(|(_, node)| {
                    let u = node.0;
                    node.1 = Some(half_lines(density, a, u, ranges, tolerance));
                });
        }
        self.level[a] = n;
    }

    /// The moments of g = s(q)·x_state by the outer rule where it agrees with its half to the
    /// rule tolerance, refining the rule once (128 to 256 intervals) where it does not;
    /// `None` where even that fails or the state was not asked for.
    pub(super) fn signed(
        &mut self,
        state: usize,
        sign: &[[f64; 2]; 2],
    ) -> Option<ObservableMoments> {
        if self.states[state].iter().all(Vec::is_empty) {
            return None;
        }
        for n in LEVELS {
            if self.level[state] < n {
                self.fill(state, n);
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
            .map(|ha| {
                let [lo, hi] = self.half(state, ha);
                if hi > lo {
                    pair(lo, hi, n).into_iter().map(|(_, w)| w).collect()
                } else {
                    Vec::new()
                }
            })
            .collect();
        let weights = &weights;
        finer_if_agreeing(
            |rule| {
                moments_of_pairs(
                    || {
                        (0..4).flat_map(move |q| {
                            let s = sign[q / 2][q % 2];
                            // The quadrant's halves of this state's axis (ha) and the other's (hb).
                            let (ha, hb) = if state == 0 {
                                (q / 2, q % 2)
                            } else {
                                (q % 2, q / 2)
                            };
                            self.states[state][ha]
                                .iter()
                                .step_by(stride)
                                .zip(&weights[ha])
                                .map(move |(&(u, l), w)| {
                                    (s * u, w[rule] * l.map_or(f64::NAN, |l| l[hb]))
                                })
                        })
                    },
                    4,
                )
            },
            self.tolerance,
        )
    }
}
