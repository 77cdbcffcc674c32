//! Why `epc-impact` refused a model or found no density: typed, with the context a user needs.

use crate::epc::EpcError;
use crate::fpk::FpkError;
use crate::symbolic::SymbolicError;

/// What the method does not handle: a refusal before any work, never a wrong number.
///
/// ```
/// use fpsolve::epc_impact::{EpcImpact, EpcImpactError, Unsupported};
/// let text = "model m\nstate x, v\ndrift x: v\ndrift v: -0.2*v - x\nnoise xi: intensity 1\n\
///             diffusion v: xi\nimpact x = 0: v -> 0.9*v\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let err = EpcImpact::new(&bound).solve(2).unwrap_err();
/// assert!(matches!(err, EpcImpactError::Unsupported { reason: Unsupported::PassThrough { .. }, .. }));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Unsupported {
    /// The rate of the first state is not the second state: the method needs x' = v.
    #[error("the drift of `{position}` is `{rate}`, not `{velocity}` (mechanical form x' = v)")]
    NotMechanical {
        /// The first state.
        position: String,
        /// The second state.
        velocity: String,
        /// The Itô drift of the first state, printed.
        rate: String,
    },
    /// Noise enters the equation of the position (b_xx or b_xv is not zero).
    #[error("noise enters the equation of `{position}` (b = `{diffusion}`); only the velocity may be excited")]
    NoiseInPosition {
        /// The first state.
        position: String,
        /// The offending entry of the diffusion matrix, printed.
        diffusion: String,
    },
    /// `delta(·)` terms in the drift or diffusion: they are the Zhuravlev form's approximation
    /// of an impact, which this method replaces by the exact impact condition.
    #[error(
        "the {coefficient} of `{velocity}` has delta(...) terms: epc-impact takes the impact law \
         itself in the model's original coordinates (`impact y = 0: v -> -r*v`), not its \
         Zhuravlev δ-term approximation; use `--method epc` for this model"
    )]
    DeltaTerms {
        /// The second state.
        velocity: String,
        /// `drift` or `diffusion`.
        coefficient: &'static str,
    },
    /// The law keeps the sign of the velocity (`v -> r*v`): the Zhuravlev form, in which the
    /// state passes through the barrier.
    #[error(
        "the impact law `{law}` keeps the sign of the velocity (the Zhuravlev form, a state that \
         passes through the barrier): epc-impact needs the original-coordinates model, with a \
         reflecting law `v -> -r*v` at a barrier the state stays on one side of (e.g. \
         models/vibro_impact_duffing.sde)"
    )]
    PassThrough {
        /// The law, printed.
        law: String,
    },
    /// The law sends every velocity to zero (`v -> 0`): the motion stops at the barrier, and
    /// the method needs a law that sends the velocity back into the domain.
    #[error(
        "the impact law `{law}` stops the motion at the barrier (a plastic impact, r = 0): \
         epc-impact needs a reflecting law that sends the velocity back into the domain \
         (`v -> -r*v` with 0 < r <= 1); Monte Carlo (`fpsolve simulate`) handles a plastic impact"
    )]
    Plastic {
        /// The law, printed.
        law: String,
    },
    /// The barrier is on the velocity, or the jump changes the position.
    #[error("the impact law must put the barrier on `{position}` and change `{velocity}`")]
    ImpactNotOnPosition {
        /// The first state.
        position: String,
        /// The second state.
        velocity: String,
    },
    /// The map does not send every arriving velocity back into the domain without adding
    /// speed, or is not finite.
    #[error(
        "the jump `{map}` must send every velocity arriving at the barrier at {at} back into the \
         domain (opposite sign, 0 < |map(v)| <= |v|); at v = {velocity} it gives {image}"
    )]
    ImpactMap {
        /// The map, printed.
        map: String,
        /// The barrier.
        at: f64,
        /// The probe velocity.
        velocity: f64,
        /// map(velocity).
        image: f64,
    },
    /// Two barriers that do not bound a strip (both on the same side, or crossed).
    #[error("barriers at {lower} (state above) and {upper} (state below) do not bound a strip")]
    NotAStrip {
        /// The barrier the state lives above.
        lower: f64,
        /// The barrier the state lives below.
        upper: f64,
    },
}

/// How exp(Q) fails to be a density on the domain.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// use fpsolve::epc_impact::{Divergence, EpcImpact, EpcImpactError};
/// // Case 1 at degree 4 grows beyond a ridge 16 e-folds deep: refused with a higher threshold.
/// let err = EpcImpact::new(&bound).ridge_threshold(30.0).solve(4).unwrap_err();
/// assert!(matches!(
///     err,
///     EpcImpactError::NotNormalisable { reason: Divergence::ShallowRidge { .. }, .. }
/// ));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum Divergence {
    /// Along the ray from `from` in direction `direction` (inside the domain) the highest
    /// non-vanishing power `power` of the distance has a coefficient `coefficient` ≥ 0 (scaled
    /// variables ξ = x/σx, η = v/σv): exp(Q) does not decay along it.
    #[error(
        "exp(Q) does not decay along the ray from ({}, {}) in direction ({:.3}, {:.3}) (scaled \
         variables): its t^{power} coefficient is {coefficient:.3e}",
        from[0], from[1], direction[0], direction[1]
    )]
    Ray {
        /// The ray's start (scaled variables).
        from: [f64; 2],
        /// Its unit direction (scaled variables).
        direction: [f64; 2],
        /// The highest power of t with a coefficient that does not vanish.
        power: usize,
        /// Its coefficient.
        coefficient: f64,
    },
    /// Q grows again beyond a ridge only `depth` e-folds below the peak (less than the
    /// `threshold` required to normalise inside it).
    #[error(
        "exp(Q) grows without bound beyond a ridge only {} e-folds below its peak \
         (normalising inside a ridge needs at least {threshold})",
        crate::epc::EFolds(*depth)
    )]
    ShallowRidge {
        /// e-folds from the peak to the pass.
        depth: f64,
        /// The least depth accepted.
        threshold: f64,
    },
    /// Inside the box around the peak there is a second region where exp(Q) is as large as
    /// near the peak's edge (beyond a ridge): the peak's part cannot be cut out by a box.
    #[error(
        "beyond a ridge, exp(Q) rises again to e^-{e_folds:.1} of its peak at ({x:.3}, {v:.3}), \
         inside the box around the peak"
    )]
    SecondHump {
        /// The position.
        x: f64,
        /// The velocity.
        v: f64,
        /// e-folds below the peak there.
        e_folds: f64,
    },
    /// The density does not fall to `e^-limit` of its peak inside the largest box tried: at
    /// the box's free edge it is still e^-`edge_e_folds` of its peak.
    #[error(
        "the density is still e^-{edge_e_folds:.1} of its peak at the edge of the box \
         {x:?} × {v:?} (needed below e^-{limit})"
    )]
    Unbounded {
        /// The position range of the box (original units).
        x: [f64; 2],
        /// The velocity range.
        v: [f64; 2],
        /// ln(peak/edge).
        edge_e_folds: f64,
        /// The e-folds required.
        limit: f64,
    },
}

/// Why `epc-impact` has no density for a model at some degree.
///
/// ```
/// use fpsolve::epc::EpcError;
/// use fpsolve::epc_impact::{EpcImpact, EpcImpactError};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let err = EpcImpact::new(&bound).solve(14).unwrap_err();
/// assert!(matches!(err, EpcImpactError::Epc(EpcError::Degree { degree: 14, .. })));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EpcImpactError {
    /// The model is outside what the method handles ([`Unsupported`]).
    #[error("epc-impact cannot solve model `{model}`: {reason}")]
    Unsupported {
        /// The model's name.
        model: String,
        /// Why.
        reason: Unsupported,
    },
    /// The FPK operator (Itô drift, diffusion) could not be derived, or the model has no
    /// stationary density at all.
    #[error(transparent)]
    Fpk(#[from] FpkError),
    /// The degree is not supported, the Gaussian closure that starts the ladder failed, or
    /// the equations had no solution from any start ([`EpcError::NoConvergence`], with every
    /// attempt and the best point reached). Printed after `epc-impact:`, so a failure of
    /// this method never reads as one of the δ-term EPC.
    #[error("epc-impact: {0}")]
    Epc(#[from] EpcError),
    /// A coefficient or the jump map could not be compiled.
    #[error("while preparing {what}: {source}")]
    Symbolic {
        /// What was compiled.
        what: String,
        /// The underlying failure.
        source: SymbolicError,
    },
    /// A coefficient is NaN or infinite at a quadrature node.
    #[error("{what} is not finite at ({x}, {v})")]
    NotFinite {
        /// The coefficient.
        what: &'static str,
        /// The position.
        x: f64,
        /// The velocity.
        v: f64,
    },
    /// The solved exp(Q) is not a density on the domain.
    #[error("epc-impact degree {degree}: density not normalisable: {reason}")]
    NotNormalisable {
        /// The degree.
        degree: usize,
        /// How it fails.
        reason: Divergence,
    },
    /// The quadrature could not be refined until the root stopped moving.
    #[error(
        "epc-impact degree {degree}: the quadrature did not settle: at {panels:?} panels the \
         residual of the solution still changed by {change:.2e} on refinement (threshold \
         {threshold:.1e})"
    )]
    Quadrature {
        /// The degree.
        degree: usize,
        /// Panels per axis at the last attempt.
        panels: [usize; 2],
        /// ‖R_fine − R‖ at the solution.
        change: f64,
        /// The solver's threshold on ‖R‖.
        threshold: f64,
    },
    /// The root, followed by Newton onto a larger box or a finer quadrature, was lost.
    #[error(
        "epc-impact degree {degree}: Newton lost the root when the {what} was refined (‖R‖ = \
         {residual:.3e}, needed ≤ {threshold:.1e})"
    )]
    Refit {
        /// The degree.
        degree: usize,
        /// `box` or `quadrature`.
        what: &'static str,
        /// ‖R‖ where Newton stopped.
        residual: f64,
        /// The threshold.
        threshold: f64,
    },
}
