//! The one reading of a bound model every method starts from: the Itô drift, the diffusion
//! b = G·S·Gᵀ, the mechanical form (or why not), the barriers with their jump laws, and
//! whether a stationary density can exist at all ([`check`]).
//!
//! [`Dynamics::read`] derives these once; a method that needs a quantity in its own shape (a
//! compiled tape, a lane-friendly copy) derives it from [`Dynamics`], never from the model.
//!
//! The admissibility checks look only at the bound model (numbers substituted), before any
//! solve:
//!
//! * [`check`] refuses models for which no non-degenerate stationary density exists, each
//!   for a reason that can be decided with certainty from the equations ([`Inadmissible`]):
//!   an impact that adds energy, no noise, no energy sink at all, a drift that only ever adds
//!   energy, noise that vanishes at a stable rest point, a linear drift with a mode that does
//!   not decay. What cannot be decided this way (negative linear damping that a nonlinear term
//!   may or may not contain, as in the Van der Pol oscillator) is accepted: the solvers then
//!   report what they find.
//! * [`impact_form`] says whether EPC can use the model's impact law. EPC's operator knows an
//!   impact only through the Zhuravlev term `-(1 - r)*v*abs(v)*delta(z)` in the drift (the
//!   paper's Eqs. 6–10); the `impact` line itself is what Monte Carlo uses. A reflecting law
//!   in the original coordinates (`impact x = 0: v -> -r*v`) has no such term: EPC would solve
//!   the model as if there were no barrier, so it is refused ([`UnsupportedImpact`]).
//!
//! Every admissibility decision is made on a fixed grid of probe points spanning 1e-3 to 1e4
//! in each state (both signs, 45 values each), so the checks cost a few milliseconds.
//!
//! ```
//! use fpsolve::model::{parse_model, Override};
//! use fpsolve::dynamics::{check, Inadmissible};
//! let text = "model lin
//! param c = 0.1
//! state z, v
//! drift z: v
//! drift v: -c*v - z
//! noise xi: intensity 1
//! diffusion v: xi
//! ";
//! let model = parse_model(text, None).unwrap();
//! assert!(check(&model.bind(&[]).unwrap()).is_ok());
//! let undamped = model.bind(&[Override::number("c", 0.0)]).unwrap();
//! assert!(matches!(check(&undamped), Err(Inadmissible::NoDamping { .. })));
//! ```

mod admissibility;
mod barrier;
mod form;
mod impact;
mod inadmissible;
mod ito;
mod jump;
mod probe;
mod rest;
mod sde;
mod still;
#[cfg(test)]
mod tests;

pub use admissibility::check;
pub(crate) use admissibility::check_with_drift;
pub use barrier::{Barrier, BarrierKind, Barriers};
pub use form::{Form, NotMechanical};
pub use impact::{impact_form, ImpactForm, UnsupportedImpact};
pub use inadmissible::Inadmissible;
pub use ito::DerivationError;
pub(crate) use ito::{diffusion, ito_drift};
pub use jump::JumpLaw;
pub use sde::Sde;
#[cfg(test)]
pub(crate) use tests::reads_of;

use crate::model::BoundModel;
use crate::symbolic::Expr;
use std::sync::{Arc, OnceLock};

/// Why a bound model could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// An impact law's map does not compile.
    #[error("while compiling the jump map: {source}")]
    JumpMap {
        /// The underlying failure.
        source: crate::symbolic::SymbolicError,
    },
    /// More barriers than binding admits (two, bounding a strip).
    #[error("{count} impact laws: at most two (the walls of a strip) are read")]
    TooManyBarriers {
        /// How many laws.
        count: usize,
    },
}

/// A bound model read once for every method.
///
/// Reading cannot fail: what a method may refuse (a jump map that does not compile, an Itô
/// correction with no meaning, a model with no stationary density) is kept as an outcome and
/// returned by the accessor that needs it, so that each method refuses with its own earlier
/// reasons first.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
/// assert_eq!(dynamics.form(), &fpsolve::dynamics::Form::Mechanical);
/// assert!(dynamics.ito_drift().is_ok());
/// assert!(dynamics.admissible().is_ok());
/// assert_eq!(dynamics.model(), &bound);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Dynamics {
    /// The model read (shared: a reading travels with what it read).
    model: Arc<BoundModel>,
    /// The Wong–Zakai correction and the Itô drift, or why they have no meaning.
    ito: Result<([Expr; 2], [Expr; 2]), DerivationError>,
    diffusion: [[Expr; 2]; 2],
    form: Form,
    /// The barriers, or why their laws could not be read.
    barriers: Result<Barriers, DynamicsError>,
    /// How EPC's operator knows the impact law (`None` without one).
    impact: Option<ImpactForm>,
    sde: Sde,
    /// Whether a stationary density can exist ([`check`]), decided on first use: a
    /// transient or a homotopy member never asks.
    admissible: OnceLock<Result<(), Inadmissible>>,
}

impl Dynamics {
    /// Reads `model`.
    pub fn read(model: &BoundModel) -> Dynamics {
        #[cfg(test)]
        tests::count_read(model);
        let states = model.states();
        let vars = [&*states[0], &*states[1]];
        Dynamics {
            model: Arc::new(model.clone()),
            ito: ito_drift(model),
            diffusion: diffusion(model),
            form: form::read(model),
            barriers: read_barriers(model, &vars),
            impact: impact_form(model),
            sde: Sde::read(model),
            admissible: OnceLock::new(),
        }
    }

    /// The model read.
    pub fn model(&self) -> &BoundModel {
        &self.model
    }

    /// Whether the model can have a non-degenerate stationary density ([`check`], decided
    /// once per reading).
    ///
    /// # Errors
    /// The [`Inadmissible`] reason.
    pub fn admissible(&self) -> Result<(), Inadmissible> {
        self.admissible
            .get_or_init(|| check_with_drift(&self.model, self.ito_drift().ok()))
            .clone()
    }

    /// How EPC's operator knows the impact law: the Zhuravlev term in the drift, or why the
    /// law cannot be used (`None` for a model without one; see [`impact_form`]).
    pub fn impact_form(&self) -> Option<&ImpactForm> {
        self.impact.as_ref()
    }

    /// The states (position and velocity in the mechanical form).
    pub fn states(&self) -> &[crate::symbolic::Symbol; 2] {
        self.model.states()
    }

    /// The Itô drift m = f + Wong–Zakai correction, simplified.
    ///
    /// # Errors
    /// [`DerivationError`] when the correction has no meaning (a derivative of δ).
    pub fn ito_drift(&self) -> Result<&[Expr; 2], DerivationError> {
        self.ito.as_ref().map(|(_, m)| m).map_err(Clone::clone)
    }

    /// The Wong–Zakai correction the Itô drift adds (zero for an Itô model).
    ///
    /// # Errors
    /// As [`Dynamics::ito_drift`].
    pub fn wong_zakai(&self) -> Result<&[Expr; 2], DerivationError> {
        self.ito.as_ref().map(|(wz, _)| wz).map_err(Clone::clone)
    }

    /// The diffusion matrix b = G·S·Gᵀ (symmetric), expanded and simplified.
    pub fn diffusion(&self) -> &[[Expr; 2]; 2] {
        &self.diffusion
    }

    /// The mechanical form, or why the model has none.
    pub fn form(&self) -> &Form {
        &self.form
    }

    /// The barriers.
    ///
    /// # Errors
    /// [`DynamicsError`] when an impact law's map does not compile or there are more laws
    /// than the walls of a strip.
    pub fn barriers(&self) -> Result<&Barriers, DynamicsError> {
        self.barriers.as_ref().map_err(Clone::clone)
    }

    /// The equations as written, for a method that simulates them.
    pub fn sde(&self) -> &Sde {
        &self.sde
    }
}

/// The barriers of `model`, its laws' maps compiled over `vars`.
fn read_barriers(model: &BoundModel, vars: &[&str; 2]) -> Result<Barriers, DynamicsError> {
    let mut walls = Vec::with_capacity(model.impacts().len());
    for law in model.impacts() {
        walls.push(Barrier::read(law, vars).map_err(|source| DynamicsError::JumpMap { source })?);
    }
    // Binding sorts two laws lower first and gives them the sides of a strip.
    let count = walls.len();
    let mut walls = walls.into_iter();
    match (walls.next(), walls.next(), count) {
        (None, _, _) => Ok(Barriers::None),
        (Some(one), None, _) => Ok(Barriers::One(one)),
        (Some(lo), Some(hi), 2) => Ok(Barriers::Strip { lo, hi }),
        _ => Err(DynamicsError::TooManyBarriers { count }),
    }
}
