//! Solving R(a) = 0: Newton with a backtracking line search on ½‖R‖², then
//! Levenberg–Marquardt (globally convergent to a stationary point of ½‖R‖²) from the same and
//! from perturbed starts. A failure says what was tried and what the best point looks like: a
//! nonzero ‖R‖ with ‖JᵀR‖ ≈ 0 is a local minimum of the residual, evidence that no real
//! Galerkin solution lies nearby.

use nalgebra::DVector;
use serde::Serialize;

use super::galerkin::GalerkinSystem;

/// How a solve ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolveOutcome {
    /// `"newton"` or `"levenberg-marquardt"`, with the start used.
    pub method: String,
    /// Iterations of the successful method.
    pub iterations: usize,
    /// Final ‖R‖ (scaled variables, weights φ(ξ1)φ(ξ2)).
    pub residual: f64,
}

/// The best point found when nothing converged.
#[derive(Clone, Debug)]
pub(crate) struct SolveFailure {
    pub tried: Vec<String>,
    pub best_residual: f64,
    pub gradient: f64,
    pub local_minimum: bool,
}

fn newton(
    sys: &GalerkinSystem,
    a0: &DVector<f64>,
    tol: f64,
    max_iter: usize,
) -> (DVector<f64>, f64, usize, bool) {
    let mut a = a0.clone();
    let (mut r, mut j) = sys.residual_and_jacobian(&a);
    let mut norm = r.norm();
    for it in 0..max_iter {
        if norm <= tol {
            return (a, norm, it, true);
        }
        let Some(step) = j.clone().lu().solve(&(-&r)) else {
            return (a, norm, it, false);
        };
        if !step.iter().all(|v| v.is_finite()) {
            return (a, norm, it, false);
        }
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..40 {
            let an = &a + t * &step;
            let (rn, jn) = sys.residual_and_jacobian(&an);
            let nn = rn.norm();
            // Armijo on ½‖R‖²: the Newton direction's slope is −‖R‖².
            if nn.is_finite() && nn * nn <= norm * norm * (1.0 - 2e-4 * t) {
                a = an;
                r = rn;
                j = jn;
                norm = nn;
                accepted = true;
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            return (a, norm, it, false);
        }
    }
    (a.clone(), norm, max_iter, norm <= tol)
}

fn levenberg_marquardt(
    sys: &GalerkinSystem,
    a0: &DVector<f64>,
    tol: f64,
    max_iter: usize,
) -> (DVector<f64>, f64, f64, usize, bool) {
    let mut a = a0.clone();
    let (mut r, mut j) = sys.residual_and_jacobian(&a);
    let mut norm = r.norm();
    let mut lambda = 1e-3;
    let n = a.len();
    let mut grad = (j.transpose() * &r).norm();
    for it in 0..max_iter {
        if norm <= tol {
            return (a, norm, grad, it, true);
        }
        let jt = j.transpose();
        let jtj = &jt * &j;
        let g = &jt * &r;
        grad = g.norm();
        if grad <= 1e-14 * (1.0 + jtj.norm()) * norm.max(1e-300) {
            return (a, norm, grad, it, false);
        }
        let mut improved = false;
        for _ in 0..30 {
            let mut mat = jtj.clone();
            for d in 0..n {
                mat[(d, d)] += lambda * (jtj[(d, d)] + 1e-12);
            }
            if let Some(step) = mat.cholesky().map(|c| c.solve(&(-&g))) {
                let an = &a + &step;
                let (rn, jn) = sys.residual_and_jacobian(&an);
                let nn = rn.norm();
                if nn.is_finite() && nn < norm {
                    a = an;
                    r = rn;
                    j = jn;
                    norm = nn;
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = true;
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !improved {
            return (a, norm, grad, it, false);
        }
    }
    (a.clone(), norm, grad, max_iter, norm <= tol)
}

/// Solves the system from the given starts (in order): Newton from each, then LM from each,
/// then LM from perturbations of the best point.
pub(crate) fn solve(
    sys: &GalerkinSystem,
    starts: &[(String, DVector<f64>)],
    tol: f64,
) -> Result<(DVector<f64>, SolveOutcome), SolveFailure> {
    let mut tried = Vec::new();
    let mut best: Option<(DVector<f64>, f64)> = None;
    let keep = |a: &DVector<f64>, n: f64, best: &mut Option<(DVector<f64>, f64)>| {
        if !matches!(best, Some((_, b)) if *b <= n) {
            *best = Some((a.clone(), n));
        }
    };
    for (name, a0) in starts {
        let (a, n, it, ok) = newton(sys, a0, tol, 60);
        tried.push(format!("Newton from {name}"));
        if ok {
            return Ok((
                a,
                SolveOutcome {
                    method: format!("newton from {name}"),
                    iterations: it,
                    residual: n,
                },
            ));
        }
        keep(&a, n, &mut best);
    }
    for (name, a0) in starts {
        let (a, n, _, it, ok) = levenberg_marquardt(sys, a0, tol, 400);
        tried.push(format!("Levenberg-Marquardt from {name}"));
        if ok {
            return Ok((
                a,
                SolveOutcome {
                    method: format!("levenberg-marquardt from {name}"),
                    iterations: it,
                    residual: n,
                },
            ));
        }
        keep(&a, n, &mut best);
    }
    // Multistart: deterministic perturbations of the best point, relative to its size.
    let (centre, _) = best.clone().expect("at least one start");
    let scale = centre.amax().max(1e-3);
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for trial in 0..12 {
        let amp = 0.05 * scale * (1 + trial % 4) as f64;
        let a0 = DVector::from_iterator(centre.len(), centre.iter().map(|v| v + amp * next()));
        let (a, n, _, it, ok) = levenberg_marquardt(sys, &a0, tol, 400);
        if ok {
            tried.push(format!(
                "Levenberg-Marquardt from {} perturbed starts",
                trial + 1
            ));
            return Ok((
                a,
                SolveOutcome {
                    method: format!("levenberg-marquardt from perturbed start {}", trial + 1),
                    iterations: it,
                    residual: n,
                },
            ));
        }
        keep(&a, n, &mut best);
    }
    tried.push("Levenberg-Marquardt from 12 perturbed starts".into());
    let (a, n) = best.expect("at least one start");
    let (r, j) = sys.residual_and_jacobian(&a);
    let gradient = (j.transpose() * &r).norm();
    let jn = j.norm();
    Err(SolveFailure {
        tried,
        best_residual: n,
        gradient,
        // Stationary: the gradient is tiny against ‖J‖‖R‖, the size it would have on a slope.
        local_minimum: gradient <= 1e-6 * jn * n,
    })
}

/// Pads a solution of a lower degree (exponents `from`) to the exponents `to`.
pub(crate) fn pad(
    a: &DVector<f64>,
    from: &[(usize, usize)],
    to: &[(usize, usize)],
) -> DVector<f64> {
    DVector::from_iterator(
        to.len(),
        to.iter()
            .map(|e| from.iter().position(|f| f == e).map_or(0.0, |i| a[i])),
    )
}
