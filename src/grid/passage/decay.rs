//! The slowest decay of the killed generator K: its eigenvalue −λ of least magnitude, with
//! the right eigenvector φ (the quasi-stationary density: the law of the paths not yet
//! absorbed, long after the start) and the left one ψ (how much a start point weighs in the
//! long-time survival). Beyond the transients, R(t) ≈ A e^{−λt} with A = ψ(start)·Σφ/⟨ψ, φ⟩.
//!
//! Both come by inverse iteration from the one factorisation of Kᵀ the mean times use (its
//! transposed solve is K's), each from a start close to its answer (φ from the stationary
//! density restricted to the safe set, ψ from the mean first-passage time): the iteration
//! converges as (λ/|λ₂|)^k, fast when the slowest decay is well apart from the next.

use serde::Serialize;

use crate::numerics::sparse::faer_lu::FaerLu;
use crate::numerics::sparse::Factorization;

/// The most inverse iterations for each eigenvector.
pub const MAX_DECAY_ITERATIONS: usize = 500;

/// The relative change of λ between two iterations below which it has converged (with the
/// residual below [`DECAY_RESIDUAL`]).
const CONVERGED: f64 = 1e-12;

/// The largest relative residual ‖Kφ + λφ‖₁ / (λ‖φ‖₁) of an accepted eigenpair.
pub const DECAY_RESIDUAL: f64 = 1e-8;

/// The slowest decay of the survival probability.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Decay {
    /// λ: R(t) ∝ e^{−λt} at long times (from the forward iteration on K).
    pub rate: f64,
    /// λ from the backward iteration on Kᵀ: equal to `rate` up to the iterations' tolerance
    /// (the same eigenvalue), a check on both.
    pub rate_backward: f64,
    /// A in R(t) ≈ A e^{−λt}, for the start cell's point mass.
    pub amplitude: f64,
    /// 1/λ weighed against the mean first-passage time from the quasi-stationary density
    /// (equal for the exact generator: from the quasi-stationary law the passage time is
    /// exponential with rate λ).
    pub mean_from_quasi_stationary: f64,
    /// Inverse iterations (forward, backward).
    pub iterations: [usize; 2],
    /// The relative residuals ‖Kφ + λφ‖₁/(λ‖φ‖₁) and ‖Kᵀψ + λψ‖₁/(λ‖ψ‖₁).
    pub residuals: [f64; 2],
}

/// Why the slowest decay was not found: R(t) and the mean times stand without it.
#[derive(Clone, Debug, PartialEq, Serialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DecayFailure {
    /// The iteration did not settle (the eigenvalue of least magnitude is complex or not
    /// apart from the next one, as an oscillation that decays as slowly as the survival).
    #[error(
        "inverse iteration did not converge in {iterations} steps (residual {residual:.1e}): \
         the slowest decay is not apart from the next"
    )]
    NotConverged {
        /// Iterations made.
        iterations: usize,
        /// The last relative residual.
        residual: f64,
    },
    /// The eigenvalue found is not a decay (λ ≤ 0 or not finite).
    #[error("the eigenvalue found, {rate}, is not a decay rate")]
    NotDecaying {
        /// The rate found.
        rate: f64,
    },
}

/// One eigenpair by inverse iteration: `solve` applies A⁻¹ in place, `apply` computes A x.
/// Returns (λ, x normalised to Σx = 1, iterations, residual), −λ the eigenvalue of A of
/// least magnitude.
fn inverse_iteration(
    mut x: Vec<f64>,
    solve: impl Fn(&mut [f64]),
    apply: impl Fn(&[f64], &mut [f64]),
) -> Result<(f64, Vec<f64>, usize, f64), DecayFailure> {
    let normalise = |x: &mut [f64]| {
        let s: f64 = x.iter().sum();
        x.iter_mut().for_each(|v| *v /= s);
    };
    normalise(&mut x);
    let mut ax = vec![0.0; x.len()];
    let mut last = f64::NAN;
    let mut residual = f64::INFINITY;
    for k in 1..=MAX_DECAY_ITERATIONS {
        let mut y = x.clone();
        solve(&mut y);
        // y = A⁻¹x ≈ x/(−λ): with Σx = 1, −1/λ ≈ Σy.
        let rate = -1.0 / y.iter().sum::<f64>();
        normalise(&mut y);
        apply(&y, &mut ax);
        let norm: f64 = y.iter().map(|v| v.abs()).sum();
        residual = ax
            .iter()
            .zip(&y)
            .map(|(a, v)| (a + rate * v).abs())
            .sum::<f64>()
            / (rate.abs() * norm);
        x = y;
        if !rate.is_finite() {
            return Err(DecayFailure::NotDecaying { rate });
        }
        if (rate - last).abs() <= CONVERGED * rate.abs() && residual <= DECAY_RESIDUAL {
            if rate <= 0.0 {
                return Err(DecayFailure::NotDecaying { rate });
            }
            return Ok((rate, x, k, residual));
        }
        last = rate;
    }
    Err(DecayFailure::NotConverged {
        iterations: MAX_DECAY_ITERATIONS,
        residual,
    })
}

/// The slowest decay of K from the factorisation `lu` of Kᵀ (`backward`), φ started from
/// `density` (non-negative on the safe cells), ψ from `mean_time`; the amplitude for a start
/// in safe cell `start`. Also returns φ (Σφ = 1).
pub(super) fn decay(
    lu: &FaerLu,
    forward: &faer::sparse::SparseColMat<usize, f64>,
    backward: &faer::sparse::SparseColMat<usize, f64>,
    density: Vec<f64>,
    mean_time: &[f64],
    start: usize,
) -> Result<(Decay, Vec<f64>), DecayFailure> {
    let (rate, phi, n_fwd, r_fwd) = inverse_iteration(
        density,
        |b| lu.solve_transpose_in_place(b),
        |y, out| super::apply(forward, y, out),
    )?;
    let (rate_backward, psi, n_bwd, r_bwd) = inverse_iteration(
        mean_time.to_vec(),
        |b| lu.solve_in_place(b),
        |y, out| super::apply(backward, y, out),
    )?;
    let overlap: f64 = psi.iter().zip(&phi).map(|(a, b)| a * b).sum();
    let mean_from_quasi_stationary = phi.iter().zip(mean_time).map(|(p, t)| p * t).sum::<f64>();
    Ok((
        Decay {
            rate,
            rate_backward,
            amplitude: psi[start] / overlap,
            mean_from_quasi_stationary,
            iterations: [n_fwd, n_bwd],
            residuals: [r_fwd, r_bwd],
        },
        phi,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagonal A = −diag(1, 3, 10): the slowest decay is 1, its eigenvector e₁.
    #[test]
    fn inverse_iteration_finds_the_slowest_decay() {
        let d = [1.0, 3.0, 10.0];
        let (rate, x, _, residual) = inverse_iteration(
            vec![1.0, 1.0, 1.0],
            |b| b.iter_mut().zip(&d).for_each(|(b, d)| *b /= -d),
            |y, out| {
                out.iter_mut()
                    .zip(y.iter().zip(&d))
                    .for_each(|(o, (y, d))| *o = -d * y)
            },
        )
        .unwrap();
        assert!((rate - 1.0).abs() < 1e-12, "{rate}");
        assert!((x[0] - 1.0).abs() < 1e-10 && residual < 1e-8);
    }

    /// A rotation-dominated A (eigenvalues −1 ± 5i): no real slowest decay, said so.
    #[test]
    fn a_complex_pair_does_not_converge() {
        let solve = |b: &mut [f64]| {
            // A = [[-1, -5], [5, -1]], A⁻¹ = [[-1, 5], [-5, -1]] / 26.
            let (x, y) = (b[0], b[1]);
            b[0] = (-x + 5.0 * y) / 26.0;
            b[1] = (-5.0 * x - y) / 26.0;
        };
        let apply = |y: &[f64], out: &mut [f64]| {
            out[0] = -y[0] - 5.0 * y[1];
            out[1] = 5.0 * y[0] - y[1];
        };
        let err = inverse_iteration(vec![1.0, 0.5], solve, apply).unwrap_err();
        assert!(matches!(
            err,
            DecayFailure::NotConverged { .. } | DecayFailure::NotDecaying { .. }
        ));
    }
}
