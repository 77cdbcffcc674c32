//! Time stepping of linear systems dp/dt = A(t) p whose columns sum to zero (a generator:
//! mass conserved) by singly diagonally implicit Runge–Kutta methods with an explicit first
//! stage (ESDIRK, `Scheme`): TR-BDF2, the second-order, L-stable method of Bank et al.
//! (1985) in the form and with the embedded error estimate of Hosea & Shampine (1996), or
//! ESDIRK4(3)6L\[2\]SA of Kennedy & Carpenter (2003), fourth order and L-stable.
//!
//! * **Stages.** Every implicit stage has the same coefficient γ (TR-BDF2: γ = 1 − √2/2,
//!   the trapezoidal stage over (2 − √2)h and the BDF2 stage over the rest; ESDIRK4:
//!   γ = 1/4), so all solve with one matrix, I − γ h A: one factorisation per distinct step
//!   size (and, for a generator that depends on t, per stage time, unless
//!   `Esdirk::reuse_across_times` lets a nearby time's factor precondition the solve).
//!   Both methods are stiffly accurate: the step's result is its last stage.
//! * **Error control.** The local error is estimated by the embedded third-order
//!   companion (TR-BDF2: weights ((1 − w)/3, (3w + 1)/3, d/3), w = √2/4; ESDIRK4: Kennedy
//!   and Carpenter's), filtered through (I − γ h A)⁻¹ as Hosea and Shampine advise for stiff problems (the stiff modes, which
//!   the L-stable method damps, do not shrink the step). Its size is a weighted L1 norm of the
//!   whole vector against `absolute + relative · ‖y‖₁` (`Tolerance`): for a density of cell
//!   averages, the L1 distance the results are judged by, not a componentwise test that would
//!   chase the far tails. By default the bound is on the error per unit time, ‖e‖/h:
//!   the global error is then proportional to the tolerance (on y' = −1.5y half of it at
//!   every tolerance from 1e−6 to 1e−9) and at most about the tolerance times the time
//!   elapsed. A bound per step (`per_step`) takes longer steps but lets the global error
//!   grow with the number of steps (117 × tol at 1e−9 over 1648 steps) and fall only as
//!   tol^(2/3).
//! * **Step sizes** are powers of two times the first step: a step grows (doubles or more)
//!   only when the error would allow at least twice the step, and shrinks by powers of two on
//!   a rejection, so that few distinct sizes occur and the factorisations of the last few are
//!   kept (`Esdirk::cache`) and reused.
//! * **Outputs** at the requested times are interpolated. For a time-invariant A, quintic
//!   Hermite on the values, A y and A²y at both ends of the step (sixth order), whose
//!   estimated error (its distance from the quartics that drop A²y at one end, O(h⁵)) may
//!   be at most the step's own estimated error (or a thousandth of the step's allowance,
//!   where that is larger) wherever an output falls inside a step: a step may serve many
//!   outputs, each as good as the step's ends, and is rejected when its interpolant is not. For an A
//!   that depends on t (A²y is not y″ there), no step is longer than the interval between
//!   the outputs it serves, and they are cubic Hermite (third order) on the values and
//!   derivatives. Both interpolants are affine combinations of the end values plus
//!   derivative terms, so they keep the mass too. The last step may end past the last
//!   output.
//! * **Mass and sign.** 1ᵀA = 0 gives 1ᵀ(I − γ h A) = 1ᵀ, so every stage keeps the mass up
//!   to the residual of its solve; for a generator (`conserve_mass`) that residual's mass
//!   defect is put back, so mass drifts only by the rounding of sums. Each output reports
//!   its mass and its negative mass (nothing is clipped).

mod error;
mod esdirk;
mod generator;
mod tableau;

pub use error::StepError;
pub(crate) use esdirk::History;
pub(crate) use esdirk::{implicit_stages, Esdirk, Tolerance};
pub(crate) use generator::{apply, apply_ref, shifted, shifted_ref, Generator};
pub(crate) use tableau::Scheme;

#[cfg(test)]
mod tests;
