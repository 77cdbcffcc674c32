//! Solving R(a) = 0: Newton with a backtracking line search on ½‖R‖², then
//! Levenberg–Marquardt (globally convergent to a stationary point of ½‖R‖²) from the same and
//! from perturbed starts. A failure says what was tried and what the best point looks like: a
//! nonzero ‖R‖ with ‖JᵀR‖ ≈ 0 is a local minimum of the residual, evidence that no real
//! Galerkin solution lies nearby.
//!
//! Every method reports and judges ‖R‖ itself (the Euclidean norm of the Galerkin residual in
//! scaled variables), never the cost ½‖R‖²: a solve has converged when
//! ‖R‖ ≤ tol·max(1, ‖R(a_ref)‖), with a_ref the Gaussian-closure start, so that the test is
//! absolute for well-scaled systems and relative for systems whose entries are large.

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
    /// Final ‖R‖ (scaled variables, weights φ(ξ1)φ(ξ2)), recomputed at the returned point.
    pub residual: f64,
    /// The bound ‖R‖ had to reach: tol·max(1, ‖R(a_ref)‖), a_ref the Gaussian-closure start.
    pub threshold: f64,
}

/// The best point found when nothing converged.
#[derive(Clone, Debug)]
pub(crate) struct SolveFailure {
    pub tried: Vec<String>,
    pub threshold: f64,
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
    // ‖R‖ eight iterations ago: damped Newton that gains less than 10% over eight steps is
    // crawling along a valley towards a nonzero minimum (near a root it converges
    // quadratically), which Levenberg–Marquardt handles better.
    let mut history = std::collections::VecDeque::with_capacity(9);
    for it in 0..max_iter {
        if norm <= tol {
            return (a, norm, it, true);
        }
        history.push_back(norm);
        if history.len() > 8 {
            let old = history.pop_front().expect("non-empty");
            if norm > 0.9 * old {
                return (a, norm, it, false);
            }
        }
        let Some(step) = j.clone().lu().solve(&(-&r)) else {
            return (a, norm, it, false);
        };
        if !step.iter().all(|v| v.is_finite()) {
            return (a, norm, it, false);
        }
        let mut t = 1.0;
        let mut accepted = false;
        // t down to 2^-20: a Newton direction that only helps at shorter steps is useless here.
        for _ in 0..20 {
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

/// Why a Levenberg–Marquardt run stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
enum LmStop {
    Converged,
    /// No descent is possible any more (no damping gave a decrease, or ‖R‖ stopped
    /// decreasing): a numerical local minimum of ‖R‖.
    Stationary,
    /// The gradient JᵀR vanished: a critical point of ½‖R‖², possibly a saddle or maximum.
    Critical,
    /// The iteration limit came first.
    IterationLimit,
}

fn levenberg_marquardt(
    sys: &GalerkinSystem,
    a0: &DVector<f64>,
    tol: f64,
    max_iter: usize,
) -> (DVector<f64>, f64, usize, LmStop) {
    let mut a = a0.clone();
    let (mut r, mut j) = sys.residual_and_jacobian(&a);
    let mut norm = r.norm();
    let mut lambda = 1e-3;
    let n = a.len();
    // ‖R‖ ten iterations ago: a run that gains almost nothing over ten steps has stalled at a
    // minimum (near a root LM converges quadratically and never trips this).
    let mut history = std::collections::VecDeque::with_capacity(11);
    for it in 0..max_iter {
        if norm <= tol {
            return (a, norm, it, LmStop::Converged);
        }
        history.push_back(norm);
        if history.len() > 10 {
            let old = history.pop_front().expect("non-empty");
            if norm > (1.0 - 1e-6) * old {
                return (a, norm, it, LmStop::Stationary);
            }
        }
        let jt = j.transpose();
        let jtj = &jt * &j;
        let g = &jt * &r;
        if g.norm() <= 1e-14 * (1.0 + jtj.norm()) * norm.max(1e-300) {
            return (a, norm, it, LmStop::Critical);
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
            return (a, norm, it, LmStop::Stationary);
        }
    }
    let stop = if norm <= tol {
        LmStop::Converged
    } else {
        LmStop::IterationLimit
    };
    (a, norm, max_iter, stop)
}

/// Perturbed Levenberg–Marquardt starts tried after the given starts have failed.
const PERTURBED_STARTS: usize = 4;

/// Solves the system from the given starts (in order): Newton from each, then LM from each,
/// then LM from perturbations of the best point. `tol` is relative to
/// `max(1, reference_residual)`, where `reference_residual` is ‖R‖ at the Gaussian-closure
/// start (see the module docs).
pub(crate) fn solve(
    sys: &GalerkinSystem,
    starts: &[(String, DVector<f64>)],
    tol: f64,
    reference_residual: f64,
) -> Result<(DVector<f64>, SolveOutcome), SolveFailure> {
    let threshold = tol * reference_residual.max(1.0);
    let mut tried = Vec::new();
    // The best point so far, its ‖R‖ and whether LM stopped there for want of descent.
    type Best = Option<(DVector<f64>, f64, bool)>;
    let mut best: Best = None;
    let keep = |a: &DVector<f64>, n: f64, stationary: bool, best: &mut Best| {
        if !matches!(best, Some((_, b, _)) if *b <= n) {
            *best = Some((a.clone(), n, stationary));
        }
    };
    // The reported residual is recomputed at the returned point, whatever the method tracked.
    let done = |a: DVector<f64>, method: String, iterations: usize| {
        let residual = sys.residual_and_jacobian(&a).0.norm();
        (
            a,
            SolveOutcome {
                method,
                iterations,
                residual,
                threshold,
            },
        )
    };
    for (name, a0) in starts {
        let (a, n, it, ok) = newton(sys, a0, threshold, 60);
        tried.push(format!("Newton from {name}"));
        if ok {
            return Ok(done(a, format!("newton from {name}"), it));
        }
        keep(&a, n, false, &mut best);
    }
    // A run that ends at a stationary point whose ‖R‖ is far above the threshold has found a
    // genuine nonzero minimum: perturbing it would only find the same minimum again.
    let mut clearly_nonzero = false;
    for (name, a0) in starts {
        let (a, n, it, stop) = levenberg_marquardt(sys, a0, threshold, 400);
        tried.push(format!("Levenberg-Marquardt from {name}"));
        if stop == LmStop::Converged {
            return Ok(done(a, format!("levenberg-marquardt from {name}"), it));
        }
        clearly_nonzero |= stop == LmStop::Stationary && n > 1e3 * threshold;
        keep(&a, n, stop != LmStop::IterationLimit, &mut best);
    }
    // Multistart: deterministic perturbations of the best point, relative to its size.
    let (centre, _, _) = best.clone().expect("at least one start");
    let scale = centre.amax().max(1e-3);
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let perturbed = if clearly_nonzero { 0 } else { PERTURBED_STARTS };
    for trial in 0..perturbed {
        let amp = 0.05 * scale * (1 + trial % 4) as f64;
        let a0 = DVector::from_iterator(centre.len(), centre.iter().map(|v| v + amp * next()));
        let (a, n, it, stop) = levenberg_marquardt(sys, &a0, threshold, 400);
        if stop == LmStop::Converged {
            tried.push(format!(
                "Levenberg-Marquardt from {} perturbed starts",
                trial + 1
            ));
            return Ok(done(
                a,
                format!("levenberg-marquardt from perturbed start {}", trial + 1),
                it,
            ));
        }
        keep(&a, n, stop != LmStop::IterationLimit, &mut best);
    }
    if perturbed > 0 {
        tried.push(format!(
            "Levenberg-Marquardt from {perturbed} perturbed starts"
        ));
    }
    let (a, _, stationary) = best.expect("at least one start");
    let (r, j) = sys.residual_and_jacobian(&a);
    Err(SolveFailure {
        tried,
        threshold,
        best_residual: r.norm(),
        gradient: (j.transpose() * &r).norm(),
        local_minimum: stationary,
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// R(a) = a² − 1 in one unknown: singular at a = 0, so Newton cannot start there and only
    /// the Levenberg–Marquardt fallbacks can converge.
    fn square_minus_one() -> GalerkinSystem {
        GalerkinSystem {
            exps: vec![(1, 0)],
            c: DVector::from_vec(vec![-1.0]),
            m: DMatrix::zeros(1, 1),
            s: vec![2.0],
        }
    }

    #[test]
    fn fallback_reports_the_norm_of_r_not_the_cost() {
        let sys = square_minus_one();
        let start = DVector::from_vec(vec![0.0]);
        let (a, out) = solve(&sys, &[("zero".into(), start)], 1e-10, 1.0).unwrap();
        assert!(
            out.method.starts_with("levenberg-marquardt"),
            "{}",
            out.method
        );
        let r = (a[0] * a[0] - 1.0).abs();
        assert_eq!(out.residual, sys.residual_and_jacobian(&a).0.norm());
        approx::assert_relative_eq!(out.residual, r, max_relative = 1e-12, epsilon = 1e-300);
        assert!(out.residual <= out.threshold);
        approx::assert_relative_eq!(a[0].abs(), 1.0, max_relative = 1e-9);
    }

    #[test]
    fn threshold_scales_with_the_reference_residual() {
        // R(a) = 1e6·(a² − 1): the bound is relative to ‖R(a_ref)‖ = 1e6 at a_ref = 0.
        let mut sys = square_minus_one();
        sys.c[0] = -1e6;
        sys.s[0] = 2e6;
        let start = DVector::from_vec(vec![0.5]);
        let (a, out) = solve(&sys, &[("half".into(), start)], 1e-10, 1e6).unwrap();
        approx::assert_relative_eq!(out.threshold, 1e-4);
        assert_eq!(out.method, "newton from half");
        assert!(out.residual <= 1e-4);
        approx::assert_relative_eq!(a[0], 1.0, max_relative = 1e-9);
    }

    #[test]
    fn no_real_root_is_a_local_minimum() {
        // R(a) = a² + 1 has no real root; its least ‖R‖ = 1 at a = 0 is a stationary point.
        let mut sys = square_minus_one();
        sys.c[0] = 1.0;
        let start = DVector::from_vec(vec![0.7]);
        let f = solve(&sys, &[("0.7".into(), start)], 1e-10, 1.0).unwrap_err();
        approx::assert_relative_eq!(f.best_residual, 1.0, max_relative = 1e-6);
        assert!(f.local_minimum);
    }
}
