//! What a study's reader must know about its numbers beyond each method's own report: a
//! δ-term EPC whose Zhuravlev transform is not smooth, and a stationary mean velocity that is
//! not zero.
//!
//! For a mechanical model (x' = v) every stationary density has E\[v\] = dE\[x\]/dt = 0
//! exactly, so a mean velocity a method computes is an error of its density that the method
//! can be held to: beyond what the method states for its own numbers it is flagged.

use std::fmt;

use serde::Serialize;

use crate::model::BoundModel;
use crate::solve::{Density, MethodName, Problem, QuantityMoments, Solution};
use crate::symbolic::{expand, simplify, Expr, Func};

/// How many times its stated accuracy a method's mean velocity may be before it is flagged:
/// a margin for the quadrature's error estimate, which is a tolerance met, not a bound.
pub const MEAN_VELOCITY_MARGIN: f64 = 10.0;

/// The mean velocity, as a fraction of the velocity's standard deviation, below which EPC and
/// EPC-impact (which state no error of their density) are not flagged: an approximate
/// closure is never exactly stationary, and at 1e−3 σ_v the departure is below the
/// closure's own error on every model where that is known (L1 ≥ 1e−3 against exact
/// densities), while the δ-term EPC at an offset wall (E\[v\] ≈ −3e−3 σ_v at degree 4) is
/// above it. The paper's own oscillator at degree 4 gives 2e−4 σ_v.
pub const MEAN_VELOCITY_RELATIVE: f64 = 1e-3;

/// Something a study's reader must know. [`StudyWarning::flags`] tells which ones make the
/// run's numbers untrustworthy (exit 1); `Display` is the sentence.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "warning", rename_all = "kebab-case")]
#[non_exhaustive]
pub enum StudyWarning {
    /// The Zhuravlev transform of a wall has |z| or sgn z terms in its drift or noise
    /// (k·(|z| + y_b) from a spring k·y and a wall away from 0; (εz + sgn z)·ξ from the
    /// paper's (1 + εy)·ξ at a wall at 0): the δ-term EPC closes them with polynomials,
    /// which are smooth at z = 0 where these are not, so its density is approximate there
    /// (L1 1e−2 to 4e−2 at degree 8 on an elastic wall at ±0.5). `epc-impact` and the grid
    /// treat the wall exactly.
    NonSmoothTransform {
        /// The wall's position in the model's coordinates.
        wall: f64,
        /// The non-smooth terms, printed (`sgn(z)`, `abs(z)`).
        terms: Vec<String>,
    },
    /// A method's stationary mean velocity E\[v\] differs from 0 by more than
    /// [`MEAN_VELOCITY_MARGIN`] times the accuracy the method states for it: the grid's
    /// estimate of its mean's discretisation error; for EPC and EPC-impact, which state no
    /// error of their density, the larger of their quadrature's relative accuracy times the
    /// standard deviation of v (E\[v\] is a difference of two half-line moments, each at most
    /// that) and [`MEAN_VELOCITY_RELATIVE`] of it.
    MeanVelocity {
        /// The method.
        method: MethodName,
        /// Its degree (`None` for the grid).
        degree: Option<usize>,
        /// The velocity's name.
        velocity: String,
        /// E\[v\] as computed.
        mean: f64,
        /// The velocity's standard deviation.
        std_dev: f64,
        /// The largest |E\[v\]| the method's stated accuracy allows.
        tolerance: f64,
    },
}

impl StudyWarning {
    /// Whether the run is flagged for it (exit 1): a mean velocity is; a non-smooth transform
    /// is a property of the method on this model, said once.
    pub fn flags(&self) -> bool {
        matches!(self, StudyWarning::MeanVelocity { .. })
    }
}

impl fmt::Display for StudyWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StudyWarning::NonSmoothTransform { wall, terms } => write!(
                f,
                "epc: the Zhuravlev transform of the wall at {wall} has {} in its \
                 coefficients, not smooth at the wall, which EPC's polynomial closure is: its \
                 density is approximate near the wall (use epc-impact or the grid, which treat \
                 the wall exactly)",
                terms.join(", ")
            ),
            StudyWarning::MeanVelocity {
                method,
                degree,
                velocity,
                mean,
                std_dev,
                tolerance,
            } => {
                let who = match degree {
                    Some(n) => format!("{method} n = {n}"),
                    None => method.to_string(),
                };
                write!(
                    f,
                    "{who}: the stationary mean of `{velocity}` is {mean:.3e} ({:.1e} of its \
                     standard deviation), beyond the {tolerance:.1e} the method's accuracy \
                     allows; it is 0 for every stationary density, so the density is off by \
                     at least that much",
                    mean.abs() / std_dev
                )
            }
        }
    }
}

/// A [`StudyWarning::NonSmoothTransform`] when EPC solves `problem` through a Zhuravlev
/// transform with |z| or sgn z terms in its drift or noise (δ terms aside).
pub(crate) fn non_smooth_transform(problem: &Problem) -> Option<StudyWarning> {
    let t = problem.zhuravlev()?;
    let mut terms: Vec<String> = Vec::new();
    let model = &t.model;
    // The diffusion is made of products of noise coefficients: the sgn z every coefficient
    // gets from the transform squares to 1 there (additive noise stays smooth), while the
    // paper's (εz + sgn z)² = ε²z² + 2ε|z| + 1 does not.
    let noise: Vec<&Expr> = model.noise_matrix().iter().flatten().collect();
    let products = noise.iter().flat_map(|a| {
        noise
            .iter()
            .map(move |b| simplify(&expand(&((*a).clone() * (*b).clone()))))
    });
    let all: Vec<Expr> = model.drift().iter().cloned().chain(products).collect();
    for e in &all {
        e.without_deltas().walk(&mut |node| {
            if let Expr::Call(Func::Abs | Func::Sgn, args) = node {
                if args.iter().any(|a| a.mentions(&t.position)) {
                    let printed = node.to_string();
                    if !terms.contains(&printed) {
                        terms.push(printed);
                    }
                }
            }
        });
    }
    let wall = problem.model().impacts().first()?.at;
    (!terms.is_empty()).then_some(StudyWarning::NonSmoothTransform { wall, terms })
}

/// The index of the model's velocity state when it is mechanical (the drift of the first
/// state is the second state), else `None`: only then is E\[v\] = 0 an identity.
fn velocity_state(model: &BoundModel) -> Option<usize> {
    let [x, v] = model.states();
    let _ = x;
    matches!(&model.drift()[0], Expr::Sym(s) if s == v).then_some(1)
}

/// A [`StudyWarning::MeanVelocity`] for `solution` (with its moments `stats`, states first)
/// when its mean velocity is beyond its stated accuracy.
pub(crate) fn mean_velocity(
    model: &BoundModel,
    method: MethodName,
    degree: Option<usize>,
    solution: &Solution,
    stats: &[QuantityMoments],
) -> Option<StudyWarning> {
    let k = velocity_state(model)?;
    let m = stats.get(k)?;
    let (mean, std_dev) = (m.moments.mean, m.std_dev());
    if !(mean.is_finite() && std_dev.is_finite()) {
        // Undefined moments are flagged where they are written.
        return None;
    }
    let quadrature = solution.joint().stated_accuracy().max(1e-10) * std_dev;
    let stated = match solution.density() {
        Density::Grid(g) => g
            .report
            .discretisation_estimate
            .map_or(quadrature, |e| e.mean[k].max(quadrature)),
        _ => quadrature.max(MEAN_VELOCITY_RELATIVE * std_dev / MEAN_VELOCITY_MARGIN),
    };
    let tolerance = MEAN_VELOCITY_MARGIN * stated;
    (mean.abs() > tolerance).then(|| StudyWarning::MeanVelocity {
        method,
        degree,
        velocity: m.name.clone(),
        mean,
        std_dev,
        tolerance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::load_model;

    fn problem_of(file: &str) -> Problem<'static> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
        Problem::owning(load_model(&path).unwrap().bind(&[]).unwrap()).unwrap()
    }

    /// A wall at 0 folds the Duffing spring into a smooth one (sgn(z)·(k|z| + μ|z|³) =
    /// kz + μz³) and additive noise stays additive (sgn(z)² = 1): no warning; the paper's
    /// parametric noise does not ((εz + sgn z)² has 2ε|z|). A wall at −0.5 leaves sgn z
    /// terms in the drift: warned, with the wall.
    #[test]
    fn only_an_offset_wall_is_non_smooth() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/vibro_impact_duffing.sde");
        let model = load_model(&path).unwrap();
        let eps = [crate::model::Override::number("eps", 0.0)];
        let additive = model.bind(&eps).unwrap();
        let at_zero = Problem::new(&additive).unwrap();
        assert!(at_zero.zhuravlev().is_some());
        assert_eq!(non_smooth_transform(&at_zero), None);
        let parametric = problem_of("models/vibro_impact_duffing.sde");
        assert!(matches!(
            non_smooth_transform(&parametric),
            Some(StudyWarning::NonSmoothTransform { wall, .. }) if wall == 0.0
        ));
        let offset = problem_of("tests/models/barrier_caughey_lower.sde");
        let Some(StudyWarning::NonSmoothTransform { wall, terms }) = non_smooth_transform(&offset)
        else {
            panic!("an offset wall is warned about");
        };
        assert_eq!(wall, -0.5);
        assert!(terms.iter().any(|t| t.contains("sgn(z)")), "{terms:?}");
        // No transform, no warning: a model without walls.
        assert_eq!(
            non_smooth_transform(&problem_of("models/duffing.sde")),
            None
        );
    }
}
