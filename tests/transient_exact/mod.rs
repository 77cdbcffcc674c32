//! The exact law of the linear oscillator x' = v, v' = −c v − k x + e(t) ξ from a Gaussian
//! start (E[ξ(t)ξ(t+τ)] = δ(τ) times the intensity): the density stays Gaussian, its mean
//! solving m' = A m and its covariance the Lyapunov equation Σ' = AΣ + ΣAᵀ + B(t),
//! B(t) = diag(0, e(t)²·intensity), both integrated by RK4 on a step (1e−3) whose error is
//! far below what the tests compare; the same for any linear SDE with a time-dependent
//! force and noise ([`linear_law`]); and the L1 distance of a marginal's cell averages to a
//! Gaussian's.

#![allow(dead_code)] // each test file uses its own subset

use fpsolve::grid::Marginal;

/// Mean and covariance at each of `times`, from (m0, s0) at t = 0, for
/// damping `c`, stiffness `k` and the diffusion's square b(t) = e(t)²·intensity.
pub fn lyapunov(
    c: f64,
    k: f64,
    b: impl Fn(f64) -> f64,
    m0: [f64; 2],
    s0: [[f64; 2]; 2],
    times: &[f64],
) -> Vec<([f64; 2], [[f64; 2]; 2])> {
    linear_law(
        [[0.0, 1.0], [-k, -c]],
        |_| [0.0, 0.0],
        |t| [[0.0, 0.0], [0.0, b(t)]],
        m0,
        s0,
        times,
    )
}

/// Mean and covariance at each of `times` (non-decreasing), from (m0, s0) at t = 0, of
/// the linear SDE dX = (A X + f(t)) dt + G(t) dW with B(t) = G S Gᵀ: m' = A m + f(t),
/// Σ' = AΣ + ΣAᵀ + B(t), by RK4 on a step of 1e−3 (its error is far below what the tests
/// compare).
pub fn linear_law(
    a: [[f64; 2]; 2],
    f: impl Fn(f64) -> [f64; 2],
    b: impl Fn(f64) -> [[f64; 2]; 2],
    m0: [f64; 2],
    s0: [[f64; 2]; 2],
    times: &[f64],
) -> Vec<([f64; 2], [[f64; 2]; 2])> {
    // State: m (2) and Σ's three distinct entries (xx, xv, vv).
    let rhs = |t: f64, y: [f64; 5]| {
        let [m0, m1, sxx, sxv, svv] = y;
        let (f, b) = (f(t), b(t));
        [
            a[0][0] * m0 + a[0][1] * m1 + f[0],
            a[1][0] * m0 + a[1][1] * m1 + f[1],
            2.0 * (a[0][0] * sxx + a[0][1] * sxv) + b[0][0],
            a[0][0] * sxv + a[0][1] * svv + a[1][0] * sxx + a[1][1] * sxv + b[0][1],
            2.0 * (a[1][0] * sxv + a[1][1] * svv) + b[1][1],
        ]
    };
    let add = |y: [f64; 5], k: [f64; 5], s: f64| std::array::from_fn(|i| y[i] + s * k[i]);
    let mut y = [m0[0], m0[1], s0[0][0], s0[0][1], s0[1][1]];
    let (mut t, dt) = (0.0f64, 1e-3f64);
    let mut out = Vec::new();
    for &target in times {
        while t < target - 1e-12 {
            let h = dt.min(target - t);
            let k1 = rhs(t, y);
            let k2 = rhs(t + h / 2.0, add(y, k1, h / 2.0));
            let k3 = rhs(t + h / 2.0, add(y, k2, h / 2.0));
            let k4 = rhs(t + h, add(y, k3, h));
            y = std::array::from_fn(|i| {
                y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
            t += h;
        }
        out.push(([y[0], y[1]], [[y[2], y[3]], [y[3], y[4]]]));
    }
    out
}

/// L1 between a marginal's cell averages and the cell averages of N(mean, var) (8-point
/// Gauss–Legendre on each cell).
pub fn l1_gaussian(m: &Marginal, mean: f64, var: f64) -> f64 {
    const NODES: [(f64, f64); 4] = [
        (0.183_434_642_495_65, 0.362_683_783_378_362),
        (0.525_532_409_916_329, 0.313_706_645_877_887),
        (0.796_666_477_413_627, 0.222_381_034_453_374),
        (0.960_289_856_497_536, 0.101_228_536_290_376),
    ];
    let pdf = |u: f64| {
        (-(u - mean).powi(2) / (2.0 * var)).exp() / (2.0 * std::f64::consts::PI * var).sqrt()
    };
    let h = m.width;
    m.centres
        .iter()
        .zip(&m.density)
        .map(|(c, p)| {
            let avg: f64 = NODES
                .iter()
                .map(|(t, w)| w * (pdf(c + t * h / 2.0) + pdf(c - t * h / 2.0)))
                .sum::<f64>()
                / 2.0;
            (p - avg).abs() * h
        })
        .sum()
}
