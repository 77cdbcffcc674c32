//! The probe grid every decision is made on, and the numbers read off the bound model there:
//! values, the diffusion matrix, Jacobians, the mechanical form.

use nalgebra::Matrix2;

use crate::model::BoundModel;
use crate::symbolic::{DeltaPolicy, Expr, Symbol};

/// Probe values of each state: both signs, 1e-3 to 1e4, and 0. A sign decided on these
/// (no dissipation anywhere, say) could miss a region narrower than their spacing.
pub(super) const PROBE_MAGNITUDES: [f64; 22] = [
    1e-3, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.3, 1.7, 2.2, 3.0, 4.0, 5.5, 7.0, 10.0, 20.0,
    30.0, 100.0, 1e3, 1e4,
];
/// How many of the smallest probe magnitudes test a jump map or an impact term (up to 1.7).
pub(super) const JUMP_PROBES: usize = 11;

pub(super) fn probe_values() -> Vec<f64> {
    let mut out = vec![0.0];
    for m in PROBE_MAGNITUDES {
        out.push(m);
        out.push(-m);
    }
    out
}

pub(super) fn probe_points() -> Vec<[f64; 2]> {
    let vals = probe_values();
    let mut out = Vec::with_capacity(vals.len() * vals.len());
    for &a in &vals {
        for &b in &vals {
            out.push([a, b]);
        }
    }
    out
}

/// `e` at `x`, deltas as zero (their value off the lines), NaN where undefined.
pub(super) fn at(e: &Expr, states: &[Symbol; 2], x: [f64; 2]) -> f64 {
    e.eval_states(states, x, DeltaPolicy::Zero)
        .unwrap_or(f64::NAN)
}

/// The diffusion matrix b = G·S·Gᵀ at `x`.
pub(super) fn diffusion(model: &BoundModel, x: [f64; 2]) -> Matrix2<f64> {
    let g = model.noise_matrix();
    let s = model.intensity();
    let m = s.len();
    let gv: Vec<[f64; 2]> = (0..m)
        .map(|k| {
            [
                at(&g[0][k], model.states(), x),
                at(&g[1][k], model.states(), x),
            ]
        })
        .collect();
    let mut b = Matrix2::zeros();
    for i in 0..2 {
        for j in 0..2 {
            for k in 0..m {
                for l in 0..m {
                    if s[k][l] != 0.0 {
                        b[(i, j)] += gv[k][i] * s[k][l] * gv[l][j];
                    }
                }
            }
        }
    }
    b
}

/// The largest |entry|, NaN entries ignored.
pub(super) fn max_abs(b: &Matrix2<f64>) -> f64 {
    b.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Jacobian of `m` at `x` by central differences (deltas as zero).
pub(super) fn jacobian(m: &[Expr; 2], states: &[Symbol; 2], x: [f64; 2]) -> Matrix2<f64> {
    let h = 1e-6;
    let mut jac = Matrix2::zeros();
    for j in 0..2 {
        let mut p = x;
        let mut q = x;
        p[j] += h;
        q[j] -= h;
        for i in 0..2 {
            jac[(i, j)] = (at(&m[i], states, p) - at(&m[i], states, q)) / (2.0 * h);
        }
    }
    jac
}

/// The largest real part of the eigenvalues of a 2×2 matrix.
pub(super) fn max_real_part(j: &Matrix2<f64>) -> f64 {
    let tr = j.trace();
    let det = j.determinant();
    let disc = 0.25 * tr * tr - det;
    if disc < 0.0 {
        0.5 * tr
    } else {
        0.5 * tr + disc.sqrt()
    }
}

/// (position, velocity) when the model has the mechanical form: the rate of the position is
/// the velocity and the noise enters only the velocity's equation.
pub(super) fn mechanical(model: &BoundModel, m: &[Expr; 2]) -> Option<(usize, usize)> {
    let states = model.states();
    let points = probe_points();
    (0..2).map(|p| (p, 1 - p)).find(|&(p, q)| {
        let quiet = model.noise_matrix()[p]
            .iter()
            .all(|g| points.iter().all(|x| at(g, states, *x) == 0.0));
        quiet && rate_is(&m[p], q, states, &points)
    })
}

/// Whether the rate `rate` of a state equals state `q` at every probe point (to rounding).
pub(super) fn rate_is(rate: &Expr, q: usize, states: &[Symbol; 2], points: &[[f64; 2]]) -> bool {
    points.iter().all(|x| {
        let r = at(rate, states, *x);
        (r - x[q]).abs() <= 1e-12 * (1.0 + x[q].abs())
    })
}
