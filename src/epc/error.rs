//! The EPC engine's error type.

use super::outcome::{self, Attempt, BestPoint};
use super::NotNormalisable;
use crate::dynamics::UnsupportedImpact;
use crate::symbolic::{EvalError, SymbolicError};

/// Why an EPC solve failed; every numeric failure carries what was tried and how far it got.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// assert_eq!(
///     Epc::new(&fpk).degree(14).solve().unwrap_err(),
///     EpcError::Degree { degree: 14, max: MAX_DEGREE }
/// );
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EpcError {
    /// The model's impact law is not one EPC's operator represents: a refusal before any work,
    /// not a numerical failure (Monte Carlo can still simulate the model).
    #[error("EPC cannot use the impact law `{law}`: {reason}. {}", remedy(reason))]
    UnsupportedImpact {
        /// The law, printed (`impact x = 0: v -> -0.95*v`).
        law: String,
        /// Why EPC cannot use it.
        reason: UnsupportedImpact,
    },
    /// The requested polynomial degree is outside what the engine supports.
    #[error("EPC degree {degree} is not supported (use 2 to {max})")]
    Degree {
        /// The degree asked for.
        degree: usize,
        /// The largest supported degree.
        max: usize,
    },
    /// An odd degree: the highest-degree part of an odd polynomial Q grows without bound in
    /// some direction, so exp(Q) is never normalisable and degree n would silently be degree
    /// n − 1.
    #[error(
        "EPC degree {degree} is odd: exp(Q) with Q of odd degree is never normalisable (use an even degree, e.g. {} or {})",
        degree - 1,
        degree + 1
    )]
    OddDegree {
        /// The degree asked for.
        degree: usize,
    },
    /// A weight override (σ) is not a positive finite number.
    #[error("weight σ{index} = {value} must be positive and finite")]
    Weight {
        /// 1 or 2.
        index: usize,
        /// The value given.
        value: f64,
    },
    /// An FPK coefficient could not be evaluated.
    #[error("cannot evaluate {what} at ({x1}, {x2}): {source}")]
    Eval {
        /// Which coefficient.
        what: String,
        /// The point.
        x1: f64,
        /// The point.
        x2: f64,
        /// The evaluator's reason.
        source: EvalError,
    },
    /// An FPK coefficient could not be compiled for evaluation.
    #[error("cannot compile {what}: {source}")]
    Compile {
        /// Which coefficients.
        what: String,
        /// The compiler's reason.
        source: SymbolicError,
    },
    /// A member of a continuation family could not be built.
    #[error("the family's operator at λ = {lambda} could not be built: {reason}")]
    Family {
        /// The family parameter.
        lambda: f64,
        /// Why.
        reason: String,
    },
    /// A coefficient was NaN or infinite at a quadrature point.
    #[error("{what} is not finite at ({x1}, {x2})")]
    NonFinite {
        /// Which quantity.
        what: String,
        /// The point.
        x1: f64,
        /// The point.
        x2: f64,
    },
    /// The quadrature order could not be raised until the assembled system settled.
    #[error(
        "quadrature did not converge: the assembled system still changed by {change:.2e} (relative) at {order} nodes per piece"
    )]
    Quadrature {
        /// Nodes per piece at the last attempt.
        order: usize,
        /// Relative change between the last two orders.
        change: f64,
    },
    /// The Gaussian closure (which supplies the weights σ) failed.
    #[error("Gaussian closure failed: {reason} (smallest residual {residual:.3e})")]
    Closure {
        /// What went wrong.
        reason: String,
        /// The smallest residual norm reached.
        residual: f64,
    },
    /// No Galerkin solution was found at this degree.
    #[error(
        "EPC degree {degree}: no solution found from these starts ({}); the best point has ‖R‖ = {:.3e} (needed ≤ {threshold:.1e}) and ‖JᵀR‖ = {:.3e}: {}{}",
        outcome::tried(attempts),
        best.residual,
        best.gradient,
        best.kind,
        outcome::continuation(attempts)
    )]
    NoConvergence {
        /// The degree.
        degree: usize,
        /// Every method and start tried, in order, with how it ended; the homotopy paths
        /// ([`AttemptEnd::Homotopy`](super::AttemptEnd::Homotopy)) are the only evidence the
        /// error gives about whether a real solution exists.
        attempts: Vec<Attempt>,
        /// The point of least ‖R‖ reached.
        best: BestPoint,
        /// The ‖R‖ a converged solve must reach.
        threshold: f64,
    },
    /// The solved exp(Q) cannot be normalised honestly.
    #[error("EPC degree {degree}: density not normalisable: {reason}")]
    NotNormalisable {
        /// The degree.
        degree: usize,
        /// Why.
        reason: NotNormalisable,
    },
}

/// What to do instead of the δ-term EPC, for each reason it cannot use an impact law: the
/// methods that do take the law (each checked against the methods' own refusals).
fn remedy(reason: &UnsupportedImpact) -> &'static str {
    match reason {
        UnsupportedImpact::NoiseInPosition { .. } => {
            "No method represents an impact on a position driven by noise: Monte Carlo, the \
             grid and `epc-impact` refuse it too"
        }
        UnsupportedImpact::Reflecting { .. } | UnsupportedImpact::TwoBarriers { .. } => {
            "`--method epc-impact` and `--method grid` solve this law with the exact impact \
             condition, and Monte Carlo (`--mc`, `fpsolve simulate`) simulates it"
        }
        UnsupportedImpact::Plastic => {
            "Neither EPC method nor the grid solves a plastic impact; Monte Carlo (`--mc`, \
             `fpsolve simulate`) simulates it"
        }
        UnsupportedImpact::NotLinear { .. } => {
            "`--method epc-impact` takes a law that reflects the velocity without adding speed \
             (the model in its original coordinates, with a `domain` line), `--method grid` \
             one that is also monotone, and Monte Carlo (`--mc`, `fpsolve simulate`) \
             simulates any law"
        }
        UnsupportedImpact::NotMechanical { .. } => {
            "Only Monte Carlo (`--mc`, `fpsolve simulate`) simulates an impact on a state \
             whose rate is not the jumping state: `epc-impact` and the grid refuse it too"
        }
        UnsupportedImpact::MissingImpactTerm { .. }
        | UnsupportedImpact::MismatchedImpactTerm { .. } => {
            "Add the term `-(1 - r)*v*abs(v)*delta(z)` with the jump's r to the drift of `v` \
             (see models/vibro_duffing.sde), or solve the law as written with `--method grid` \
             (impacts exact, pass-through laws included); Monte Carlo (`--mc`, `fpsolve \
             simulate`) simulates it"
        }
    }
}
