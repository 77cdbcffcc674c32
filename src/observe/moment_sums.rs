//! The moments of one quantity as the quadratures report them ([`ObservableMoments`]) and the
//! two passes that form them from (g, weight) pairs in a fixed order, shared by every rule.

use serde::Serialize;

use crate::stats::Moments;

/// Moments of one quantity g under a joint density p, by composite 8-point Gauss–Legendre
/// quadrature of g^k·p over the density's extent (64 panels per axis, with a panel edge on
/// each axis at 0, where `abs` and `sgn` of a state have their kinks, and the panels next to 0
/// graded geometrically down to 1e−14 of their width, for singularities such as log|z|).
///
/// ± a state under an analytic density ([`JointDensity::analytic`](crate::density::JointDensity::analytic)) takes instead a tensor
/// Clenshaw–Curtis rule (129 nodes per half-axis) on each quadrant, accepted where it agrees
/// with its half-rule to 1e−10 (on the scale of E\[g⁴\]^(k/4)), the composite rule otherwise;
/// under a density smooth piecewise along lines ([`JointDensity::smooth_pieces`](crate::density::JointDensity::smooth_pieces), EPC inside a
/// ridge) line integrals under an outer Clenshaw–Curtis rule (128 intervals per half-axis, 256
/// when that fails its check), accepted at the density's rule tolerance (a tenth of
/// [`JointDensity::stated_accuracy`](crate::density::JointDensity::stated_accuracy)), the composite rule otherwise.
///
/// Accuracy: where p and g are smooth the rule is exact to rounding (relative 1e−12 on the
/// tests' Gaussian and double-well densities); a kink of g away from the axes costs O(h²) with
/// h ≈ 1/30 of the extent.
///
/// When g has no finite value on part of the support (`log(z)` for z ≤ 0, `1/z` at 0), that
/// probability is [`ObservableMoments::undefined_mass`], and the moments are those of g *given* that it
/// is defined (divided by 1 − undefined_mass): a defective observable is flagged, never
/// silently renormalised.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{moments, ObservableMap};
/// use fpsolve::symbolic::{Expr, Func};
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
/// let log_z = ObservableMap::classify(&Expr::call(Func::Log, Expr::sym("z")), &states);
/// let m = moments(&Normal, &log_z);
/// assert!((m.undefined_mass - 0.5).abs() < 1e-12); // log z is undefined for z ≤ 0
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObservableMoments {
    /// E\[g\], …, E\[g⁴\] (given g defined), mean, variance and kurtosis (by a second pass
    /// about the mean, or from the raw moments where the quadrature gives those alone: ± the
    /// state integrated along the lines under a density smooth piecewise along them); a
    /// moment beyond [`ObservableMoments::existing`] is NaN.
    pub moments: Moments,
    /// P(g has no finite value): 0 for an observable defined everywhere.
    pub undefined_mass: f64,
    /// How many of E|g|, E|g|², E|g|³, E|g|⁴ are established as finite (two different
    /// quadrature rules agree on them): 4 for a bounded or light-tailed g. Moments beyond it
    /// are NaN, never a number the quadrature happened to give (E[1/z²] is infinite when
    /// p(0, v) > 0). A convergent integral with a singularity off the axes (log|z − 1|) may
    /// also be left undetermined: flagged, not guessed.
    pub existing: usize,
    /// The values g takes with positive probability (g constant on a region of the plane,
    /// as `max(z, 0)` is 0 on z < 0), by value: there g has no density, and its PDF is the
    /// density of the rest, integrating to 1 − Σ probability (see [`PointMass`]). Empty for
    /// ± a state.
    pub point_masses: Vec<PointMass>,
}

/// A value that an observable takes with positive probability: g is constant on a region of
/// the plane (a `min` or `max` that clips, a `sgn`), so its distribution has an atom there
/// and no density. The probability is that of the rule's nodes where g and its values a step
/// of 1e−6 of the extent away along each axis are all equal: its error is that of a
/// Gauss–Legendre rule across the region's edge, where the weight jumps (4e−3 for a normal
/// density cut along a diagonal, less along an axis).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PointMass {
    /// The value.
    pub value: f64,
    /// P(g = value), at least [`POINT_MASS_FLOOR`].
    pub probability: f64,
}

/// The smallest point mass reported: below the accuracy the observables' PDFs claim (1e−8
/// relative), a missing mass changes no written number.
pub const POINT_MASS_FLOOR: f64 = 1e-9;

/// The moments by a fixed rule (`by(0)`) where they agree with those by its half (`by(1)`)
/// to `tolerance` (the raw moments and the mean on the scale of E[g⁴]^(k/4), the variance and
/// kurtosis relative), `None` where they do not.
pub(super) fn finer_if_agreeing(
    by: impl Fn(usize) -> ObservableMoments,
    tolerance: f64,
) -> Option<ObservableMoments> {
    let (fine, coarse) = (by(0), by(1));
    let (f, c) = (&fine.moments, &coarse.moments);
    let scale = |k: i32| f.raw[3].abs().powf(f64::from(k) / 4.0);
    let close = |a: f64, b: f64, scale: f64| {
        a.is_finite() && b.is_finite() && (a - b).abs() <= tolerance * scale
    };
    let agree = (1..=4).all(|k| close(f.raw[k - 1], c.raw[k - 1], scale(k as i32)))
        && close(f.mean, c.mean, scale(1))
        && close(f.variance, c.variance, f.variance.abs())
        && close(f.kurtosis, c.kurtosis, f.kurtosis.abs());
    agree.then_some(fine)
}

/// The moments from (g, weight·p) pairs (g NaN where undefined), the first `existing` of them
/// established (the others NaN). `pairs` gives the same sequence each time it is called. Every
/// sum is its own, taken in the order of the pairs: the four raw moments, the total and the
/// defined mass in one pass, the two central moments in a second.
pub(super) fn moments_of_pairs<I: Iterator<Item = (f64, f64)>>(
    pairs: impl Fn() -> I,
    existing: usize,
) -> ObservableMoments {
    let mut raw = RawSums::EMPTY;
    for (g, w) in pairs() {
        raw.add(g, w);
    }
    let mean = raw.mean(existing);
    let mut central = CentralSums::EMPTY;
    for (g, w) in pairs() {
        central.add(g, mean, w);
    }
    raw.moments(&central, existing)
}

/// The first pass of [`moments_of_pairs`]: the total and the defined mass and the four raw
/// sums Σ g^k·w, each taken in the order the pairs are added.
#[derive(Clone, Copy)]
pub(super) struct RawSums {
    total: f64,
    defined: f64,
    s: [f64; 4],
}

impl RawSums {
    /// −0 is where `Iterator::sum` starts, so that these sums are its sums bit for bit.
    pub(super) const EMPTY: RawSums = RawSums {
        total: -0.0,
        defined: -0.0,
        s: [-0.0; 4],
    };

    /// Adds the pair (g, w) (g NaN where undefined: in the total only).
    #[inline(always)]
    pub(super) fn add(&mut self, g: f64, w: f64) {
        self.total += w;
        if g.is_finite() {
            self.defined += w;
            self.s[0] += g * w;
            self.s[1] += (g * g) * w;
            self.s[2] += g.powi(3) * w;
            self.s[3] += g.powi(4) * w;
        }
    }

    /// The raw moments E[g^k], the first `existing` of them (the others NaN).
    fn raw(&self, existing: usize) -> [f64; 4] {
        [1, 2, 3, 4].map(|k| upto(existing, k, self.s[k - 1] / self.defined))
    }

    /// The mean, NaN unless it is established: `raw(existing)[0]`.
    pub(super) fn mean(&self, existing: usize) -> f64 {
        upto(existing, 1, self.s[0] / self.defined)
    }

    /// The moments from these sums and the second pass's `central`.
    pub(super) fn moments(&self, central: &CentralSums, existing: usize) -> ObservableMoments {
        let raw = self.raw(existing);
        let var = upto(existing, 2, central.0[0] / self.defined);
        let m4 = upto(existing, 4, central.0[1] / self.defined);
        ObservableMoments {
            moments: Moments {
                raw,
                mean: raw[0],
                variance: var,
                kurtosis: m4 / (var * var),
            },
            undefined_mass: ((self.total - self.defined) / self.total).max(0.0),
            existing,
            point_masses: Vec::new(),
        }
    }
}

/// The second pass of [`moments_of_pairs`]: Σ (g − mean)²·w and Σ (g − mean)⁴·w over the
/// defined pairs, in the order they are added.
#[derive(Clone, Copy)]
pub(super) struct CentralSums([f64; 2]);

impl CentralSums {
    pub(super) const EMPTY: CentralSums = CentralSums([-0.0; 2]);

    /// Adds the pair (g, w) when g is defined.
    #[inline(always)]
    pub(super) fn add(&mut self, g: f64, mean: f64, w: f64) {
        if g.is_finite() {
            self.0[0] += (g - mean).powi(2) * w;
            self.0[1] += (g - mean).powi(4) * w;
        }
    }
}

/// `v` where the k-th moment is established (k ≤ `existing`), NaN otherwise.
fn upto(existing: usize, k: usize, v: f64) -> f64 {
    if existing >= k {
        v
    } else {
        f64::NAN
    }
}
