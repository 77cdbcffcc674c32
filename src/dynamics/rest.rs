//! Noise that vanishes at a rest point which attracts in mean square: the second-moment
//! operator of the linearised response, and its stability by Routh–Hurwitz.

use nalgebra::{Matrix2, Matrix3};

use super::probe::{at, diffusion, jacobian, max_abs};
use super::Inadmissible;
use crate::model::BoundModel;
use crate::symbolic::Expr;

/// Refuses noise that vanishes at a rest point of the drift where the linearised response
/// (drift Jacobian J, noise slopes B_k = ∂G_k/∂x) decays in mean square: there the second
/// moments P obey P' = J P + P Jᵀ + Σ_kl S_kl B_k P B_lᵀ, and when that operator is stable the
/// rest point attracts almost every trajectory (mean-square stability implies almost-sure
/// stability for a linear system). Only the origin is examined.
pub(super) fn vanishing_diffusion_at_rest(
    model: &BoundModel,
    m: &[Expr; 2],
) -> Result<(), Inadmissible> {
    let states = model.states();
    let origin = [0.0, 0.0];
    let rest = (0..2).all(|i| at(&m[i], states, origin).abs() <= 1e-12);
    if !rest {
        return Ok(());
    }
    // The diffusion next to the origin (8 directions), against its size a thousand times
    // farther out: noise vanishing at the origin (diffusion O(r²)) has a ratio of 1e−6, noise
    // that does not vanish a ratio near 1. Unit distance is too far to compare with: a
    // diffusion growing fast with the state, (1 + z²)^40·ξ, is 2^80 times larger there than
    // at the origin, where it is 1.
    let ring = |r: f64| {
        (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4 + 0.1;
                max_abs(&diffusion(model, [r * a.cos(), r * a.sin()]))
            })
            .fold(0.0, f64::max)
    };
    let near = ring(1e-6);
    let farther = ring(1e-3);
    if !(near.is_finite() && farther.is_finite() && farther > 0.0 && near <= 1e-4 * farther) {
        return Ok(());
    }
    let jac = jacobian(m, states, origin);
    let g = model.noise_matrix();
    let s = model.intensity();
    let n = s.len();
    let slopes: Vec<Matrix2<f64>> = (0..n)
        .map(|k| jacobian(&[g[0][k].clone(), g[1][k].clone()], states, origin))
        .collect();
    // The operator on symmetric P, in the basis (p00, p01, p11).
    let basis = [
        Matrix2::new(1.0, 0.0, 0.0, 0.0),
        Matrix2::new(0.0, 1.0, 1.0, 0.0),
        Matrix2::new(0.0, 0.0, 0.0, 1.0),
    ];
    let mut op = Matrix3::zeros();
    for (c, e) in basis.iter().enumerate() {
        let jp = jac * e;
        let mut r = jp + jp.transpose();
        for k in 0..n {
            for l in 0..n {
                if s[k][l] != 0.0 {
                    r += (slopes[k] * e * slopes[l].transpose()) * s[k][l];
                }
            }
        }
        op[(0, c)] = r[(0, 0)];
        op[(1, c)] = r[(0, 1)];
        op[(2, c)] = r[(1, 1)];
    }
    // Routh–Hurwitz for λ³ + a2 λ² + a1 λ + a0.
    let tr = op.trace();
    let minors = op[(0, 0)] * op[(1, 1)] - op[(0, 1)] * op[(1, 0)] + op[(0, 0)] * op[(2, 2)]
        - op[(0, 2)] * op[(2, 0)]
        + op[(1, 1)] * op[(2, 2)]
        - op[(1, 2)] * op[(2, 1)];
    let det = op.determinant();
    let (a2, a1, a0) = (-tr, minors, -det);
    if a2 > 0.0 && a0 > 0.0 && a2 * a1 > a0 {
        let decay_rate = smallest_decay_rate(a2, a1, a0);
        return Err(Inadmissible::VanishingDiffusionAtRest {
            states: [states[0].to_string(), states[1].to_string()],
            point: origin,
            decay_rate,
        });
    }
    Ok(())
}

/// The slowest decay rate −max Re λ of a Hurwitz-stable cubic λ³ + a2 λ² + a1 λ + a0, found
/// as the largest σ with the shifted cubic (λ − σ) still stable, by bisection.
fn smallest_decay_rate(a2: f64, a1: f64, a0: f64) -> f64 {
    // p(λ) shifted by −σ: coefficients of p(μ − σ) in μ.
    let stable = |s: f64| {
        let b2 = a2 - 3.0 * s;
        let b1 = a1 - 2.0 * a2 * s + 3.0 * s * s;
        let b0 = a0 - a1 * s + a2 * s * s - s * s * s;
        b2 > 0.0 && b0 > 0.0 && b2 * b1 > b0
    };
    let (mut lo, mut hi) = (0.0, a2 / 3.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}
