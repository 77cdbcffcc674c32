//! Physical admissibility of a bound model: whether it can have a stationary density at all,
//! and which impact laws the EPC operator represents.
//!
//! Both checks look only at the bound model (numbers substituted), before any solve:
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
//! Every decision is made on a fixed grid of probe points spanning 1e-3 to 1e4 in each state
//! (both signs, 45 values each), so the checks cost a few milliseconds.
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
mod impact;
mod inadmissible;
mod jump;
mod probe;
mod rest;
#[cfg(test)]
mod tests;

pub use admissibility::check;
pub(crate) use admissibility::check_with_drift;
pub use impact::{impact_form, ImpactForm, UnsupportedImpact};
pub use inadmissible::Inadmissible;
pub(crate) use jump::Jump;
