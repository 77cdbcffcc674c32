//! Why a grid solve was refused or failed.

use crate::dynamics::Inadmissible;
use crate::fpk::FpkError;
use crate::symbolic::SymbolicError;

/// What the grid solver does not handle: a refusal before any work, never a wrong number.
/// As JSON, a `kind` tag (`not_mechanical`, …) beside the variant's fields.
#[derive(Clone, Debug, PartialEq, thiserror::Error, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Unsupported {
    /// The rate of the first state is not the second state (`drift x: v`): the solver needs
    /// the mechanical form x' = v.
    #[error("the drift of `{position}` is `{rate}`, not `{velocity}` (mechanical form x' = v)")]
    NotMechanical {
        /// The first state.
        position: String,
        /// The second state.
        velocity: String,
        /// The drift of the first state, printed.
        rate: String,
    },
    /// Noise enters the equation of the position (b_xx or b_xv would not be zero).
    #[error(
        "noise `{noise}` enters the equation of `{position}`; only the velocity may be excited"
    )]
    NoiseInPosition {
        /// The first state.
        position: String,
        /// The noise source.
        noise: String,
    },
    /// The impact law's barrier is on the velocity, or it changes the position.
    #[error("the impact law must put the barrier on `{position}` and change `{velocity}`")]
    ImpactNotOnPosition {
        /// The first state.
        position: String,
        /// The second state.
        velocity: String,
    },
    /// The jump map neither keeps nor reverses the sign of every velocity, or is not finite.
    #[error(
        "the jump `{map}` must map every velocity to one of the same sign (pass-through) or of \
         the opposite sign (reflection), monotonically, with |map(v)| <= |v|"
    )]
    ImpactMap {
        /// The map, printed.
        map: String,
    },
    /// `delta(·)` terms in the velocity's drift or diffusion with no impact law: the solver
    /// represents an impact by re-injecting the flux at the barrier and leaves δ terms out
    /// (they are the paper's approximation of that impact), so without an impact law it would
    /// solve a different model.
    #[error(
        "the {coefficient} of `{velocity}` has delta(...) terms and the model has no impact law: \
         the grid solver treats impacts exactly (an `impact` statement) and does not solve delta \
         terms; use EPC for this model"
    )]
    DeltaWithoutImpact {
        /// The second state.
        velocity: String,
        /// `drift` or `diffusion`.
        coefficient: &'static str,
    },
    /// `delta(·)` in the diffusion, which no impact law accounts for.
    #[error("the diffusion of `{velocity}` has delta(...) terms, which the grid solver cannot represent")]
    DeltaInDiffusion {
        /// The second state.
        velocity: String,
    },
    /// Two impact laws that do not bound a strip (both reflecting, the lower one with the
    /// state above it, the upper one with the state below it), or more than two laws.
    #[error(
        "{count} impact laws at {at:?} do not bound a strip of the position (two reflecting walls)"
    )]
    NotAStrip {
        /// How many laws.
        count: usize,
        /// Where they are.
        at: Vec<f64>,
    },
    /// An impact law on a model that is not of the mechanical form: the grid re-injects the
    /// flux leaving through a wall at the mapped velocity, which needs x' = v.
    #[error(
        "the model has an impact law but not the mechanical form x' = v ({form}); the grid \
         solver treats impacts only in that form: Monte Carlo (`fpsolve simulate MODEL`, or \
         `--mc` in the main job) solves this model, and EPC (`--method epc`) where it applies"
    )]
    ImpactOfGeneralForm {
        /// Why the form is not mechanical, in words.
        form: String,
    },
    /// A periodic state that is the model's second: the grid wraps its first axis.
    #[error(
        "`{state}` is periodic and is the second state; the grid solver takes a periodic \
         first state: list `{state}` first on the `state` line"
    )]
    PeriodicSecondState {
        /// The periodic state.
        state: String,
    },
    /// A periodic state in a problem the grid does not wrap yet.
    #[error("{what} with a periodic state is not supported by the grid solver yet")]
    PeriodicProblem {
        /// The problem (`a first passage`, `a transient`).
        what: &'static str,
    },
    /// A domain given explicitly whose range of the periodic state is not its window.
    #[error(
        "the domain's range {lo}..{hi} of the periodic state `{state}` must be its window \
         {:.6}..{:.6} (one period centred on 0, to 1e-5)",
        window[0],
        window[1]
    )]
    PeriodicWindow {
        /// The periodic state.
        state: String,
        /// The range given.
        lo: f64,
        /// Its upper end.
        hi: f64,
        /// The window.
        window: [f64; 2],
    },
    /// A domain given explicitly whose end on a wall's side is not the wall (a reflecting
    /// barrier is where the state's range ends; a strip's ends may be inside it, not beyond).
    #[error("the domain's {end} end {given} of the position must {relation} the wall at {at}")]
    WallNotAnEnd {
        /// `lower` or `upper`.
        end: &'static str,
        /// The end given.
        given: f64,
        /// The wall.
        at: f64,
        /// `be` (one wall) or `not go beyond` (a strip).
        relation: &'static str,
    },
    /// A domain given explicitly does not contain the barrier (or, for a reflecting barrier,
    /// does not start at it on the domain's side).
    #[error("the domain {lo}..{hi} of the position does not fit the barrier at {at}")]
    BarrierOutsideDomain {
        /// The barrier position.
        at: f64,
        /// The domain's lower end.
        lo: f64,
        /// The domain's upper end.
        hi: f64,
    },
}

/// Why a grid solve failed. Numeric failures carry what was tried.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GridError {
    /// The model is outside what the method handles ([`Unsupported`]).
    #[error("the grid solver cannot solve model `{model}`: {reason}")]
    Unsupported {
        /// The model's name.
        model: String,
        /// Why.
        reason: Unsupported,
    },
    /// The model has no stationary density at all.
    #[error(transparent)]
    Inadmissible(#[from] Inadmissible),
    /// The Itô drift could not be derived.
    #[error(transparent)]
    Derivation(#[from] FpkError),
    /// A coefficient could not be differentiated or compiled.
    #[error("while preparing {what}: {source}")]
    Symbolic {
        /// The coefficient (`b_vv`, `d b_vv / dv`, the jump map).
        what: String,
        /// The underlying failure.
        source: SymbolicError,
    },
    /// A builder setting is out of range.
    #[error("grid setting `{setting}` = {value} is invalid: {expected}")]
    Setting {
        /// The setting (`cells`, `domain`).
        setting: &'static str,
        /// The value given, printed.
        value: String,
        /// What is accepted.
        expected: &'static str,
    },
    /// A coefficient is NaN or infinite at a point the grid needs.
    #[error("{what} is not finite at ({x}, {v})")]
    NotFinite {
        /// The coefficient.
        what: &'static str,
        /// The position.
        x: f64,
        /// The velocity.
        v: f64,
    },
    /// The sparse LU factorisation found the discrete operator singular.
    #[error(
        "the discrete FPK operator on {nx}x{nv} cells is singular (sparse LU failed: {detail})"
    )]
    Singular {
        /// Cells along the position.
        nx: usize,
        /// Cells along the velocity.
        nv: usize,
        /// faer's message.
        detail: String,
    },
    /// The solution has no positive mass or is not finite: the cells do not resolve the
    /// density (a thin limit cycle or a deep double well defeats the sizing passes).
    #[error(
        "the discrete solution on {nx}x{nv} cells has no finite positive mass: the grid does not \
         resolve this density (a thin limit cycle or a deep double well defeats its sizing \
         passes); Monte Carlo answers any model (`fpsolve simulate MODEL`, or `--mc` in the \
         main job), and `--method epc` or `--method epc-impact` may where they apply"
    )]
    Degenerate {
        /// Cells along the position.
        nx: usize,
        /// Cells along the velocity.
        nv: usize,
    },
    /// The discrete solution has negative cell values holding more of its mass than
    /// [`negative_mass_tolerance`](super::negative_mass_tolerance) allows: clipping them would
    /// change the density by more than its stated error, so the cells do not resolve it.
    #[error(
        "the discrete solution on {nx}x{nv} cells has negative values holding {negative_mass:.1e} \
         of its mass (more than the {tolerance:.1e} its stated error covers): the cells do not \
         resolve the density; use more cells (--cells)"
    )]
    NegativeMass {
        /// Cells along the position.
        nx: usize,
        /// Cells along the velocity.
        nv: usize,
        /// The negative values' mass relative to the total absolute mass.
        negative_mass: f64,
        /// The largest relative negative mass accepted
        /// ([`negative_mass_tolerance`](super::negative_mass_tolerance)).
        tolerance: f64,
    },
    /// The automatic domain kept growing: the density does not decay within `width` of the
    /// origin (no stationary density, or one too wide for the grid).
    #[error(
        "no domain found: after {tries} enlargements the density still has {edge:.1e} of its \
         peak at the edge of a {width:.3e} wide box"
    )]
    DomainNotFound {
        /// Enlargements tried.
        tries: usize,
        /// Largest edge density relative to the peak.
        edge: f64,
        /// The widest side of the last box.
        width: f64,
    },
    /// The run's flag was set ([`RunControl`](crate::base::run::RunControl)) between two of
    /// its factorisations: nothing of the solve is returned.
    #[error(transparent)]
    Cancelled(#[from] crate::base::cancel::Cancelled),
}
