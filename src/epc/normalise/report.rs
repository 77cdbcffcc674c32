//! What a normalisation reports, and why one failed, as data.

use std::fmt;

use serde::{Serialize, Serializer};

/// How the density was normalised.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
/// let NormalisationKind::Plane { top_degree_max } = sol.normalisation.kind else { panic!() };
/// // −ξ²/2 on the unit circle in the weights' scaled variables.
/// assert!((top_degree_max + 0.5).abs() < 1e-9);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NormalisationKind {
    /// exp(Q) is integrable on the whole plane: the top-degree part of Q is negative definite
    /// (`top_degree_max` < 0), or it is only semidefinite and along every one of 720 rays from
    /// the mode the highest non-vanishing power of Q(mode + r·u) has a negative coefficient.
    Plane {
        /// max over the unit circle of the degree-n part.
        top_degree_max: f64,
    },
    /// exp(Q) is not integrable on the plane; it was normalised inside the ridge around the
    /// mode: over the connected component of {Q > pass value + 1} that holds the mode, with a
    /// smooth cutoff across the last e-fold above that level (the pass
    /// is the highest saddle on the way from the mode to where Q rises above Q(mode)).
    InsideRidge {
        /// Q(mode) − (highest pass value), in e-folds.
        depth: f64,
        /// The threshold the depth had to reach.
        threshold: f64,
        /// Where the highest pass is (original units).
        pass_at: [f64; 2],
        /// How the region is bounded.
        region: RidgeRegion,
    },
}

/// The normalisation's report.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let n = Epc::new(&fpk).degree(2).solve().unwrap().normalisation;
/// assert!(n.error_estimate < 1e-9 && n.mode[0].abs() < 1e-9);
/// assert!((n.log_c + (10.0 * std::f64::consts::PI).ln()).abs() < 1e-8);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NormalisationReport {
    /// Plane or inside a ridge.
    pub kind: NormalisationKind,
    /// The mode (original units).
    pub mode: [f64; 2],
    /// ln C, with p(x) = C·exp(Q(x)) in original units.
    pub log_c: f64,
    /// Grid points per axis and the spacing (scaled units).
    pub grid: [usize; 2],
    /// Trapezoid spacing in scaled units.
    pub spacing: [f64; 2],
    /// |Z_h − Z_2h| / Z_h: the estimated relative error of the normalising integral.
    pub error_estimate: f64,
}

impl NormalisationReport {
    /// The relative accuracy this normalisation states for the density, and so for every
    /// marginal and moment taken from it: the larger of the tolerance its grid was accepted
    /// at (1e−9 on the plane; inside a ridge of depth d the larger of 1e−9 and e^−(d−1), the
    /// order of the mass in the cutoff near the region's edge) and its
    /// [`error_estimate`](NormalisationReport::error_estimate) (which exceeds the tolerance
    /// only when refinement stopped at the largest grid).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let n = Epc::new(&fpk).degree(2).solve().unwrap().normalisation;
    /// assert_eq!(n.stated_accuracy(), 1e-9); // on the plane
    /// ```
    pub fn stated_accuracy(&self) -> f64 {
        self.kind.tolerance().max(self.error_estimate)
    }
}

/// How the region inside a ridge is bounded.
///
/// ```
/// use fpsolve::epc::RidgeRegion;
/// assert!(RidgeRegion::ModeComponent.to_string().contains("pass value + 1"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RidgeRegion {
    /// The connected component of {Q > pass value + 1} that holds the mode, exp(Q) cut off
    /// smoothly (C^∞) across the last e-fold above that level.
    ModeComponent,
}

impl fmt::Display for RidgeRegion {
    /// ```
    /// use fpsolve::epc::RidgeRegion;
    /// assert!(RidgeRegion::ModeComponent.to_string().starts_with("the connected component"));
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RidgeRegion::ModeComponent => f.write_str(
                "the connected component of {Q > pass value + 1} that holds the mode, exp(Q) cut off smoothly across the last e-fold above that level",
            ),
        }
    }
}

/// Serialised as its `Display` string (the `region` field of `summary.json`).
impl Serialize for RidgeRegion {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Why a solved exp(Q) could not be normalised honestly (scaled variables ξ).
///
/// ```
/// use fpsolve::epc::NotNormalisable;
/// let e = NotNormalisable::ShallowRidge { degree: 6, top_degree_max: 0.1, depth: 3.0, threshold: 12.0 };
/// assert!(e.to_string().contains("only 3.00 e-folds deep (threshold 12)"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NotNormalisable {
    /// Newton ascent found no local maximum of Q.
    #[error("Q has no local maximum near the origin (stopped at ξ = ({:.3}, {:.3}))", at[0], at[1])]
    NoMode {
        /// Where the ascent stopped (scaled units).
        at: [f64; 2],
    },
    /// Q neither rises nor falls to leading order along a direction from the mode.
    #[error("Q is flat to leading order along the direction θ = {theta:.3} rad")]
    FlatDirection {
        /// The direction (radians).
        theta: f64,
    },
    /// exp(Q) grows without bound and the ridge around the mode is shallower than the
    /// threshold.
    #[error(
        "exp(Q) grows without bound (degree-{degree} part max {top_degree_max:.3e} on the unit circle) and the ridge around the mode is only {depth:.2} e-folds deep (threshold {threshold})"
    )]
    ShallowRidge {
        /// The degree n of Q.
        degree: usize,
        /// max over the unit circle of the degree-n part of Q.
        top_degree_max: f64,
        /// Q(mode) − (highest pass value), in e-folds.
        depth: f64,
        /// The least depth accepted.
        threshold: f64,
    },
    /// The density spreads over a box too wide for the normalisation grid.
    #[error(
        "the density spreads over [{:.3e}, {:.3e}] x [{:.3e}, {:.3e}] (scaled units): normalising it would take a grid of {points:.2e} points (limit {limit:.0e})",
        lo[0], hi[0], lo[1], hi[1]
    )]
    TooWide {
        /// The box's lower corner (scaled units).
        lo: [f64; 2],
        /// Its upper corner.
        hi: [f64; 2],
        /// Grid points it would take.
        points: f64,
        /// The most grid points allowed.
        limit: f64,
    },
    /// The trapezoid sum of exp(Q) over the region is zero, infinite or NaN.
    #[error("the normalising integral is not finite ({value:e}) on the region")]
    IntegralNotFinite {
        /// The sum.
        value: f64,
    },
}
