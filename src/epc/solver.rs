//! Solving R(a) = 0: Newton with a backtracking line search on ½‖R‖² from each start; then
//! globally convergent homotopies followed by pseudo-arclength continuation through folds in λ
//! (the paper recommends homotopy methods when Newton's start is poor, Section 2): first the
//! operator homotopy (1 − λ)R_G + λR, where R_G is the Galerkin system of an operator whose
//! exact density is the Gaussian-closure start, then the Newton homotopy R(a) − (1 − λ)R(a0)
//! from each start; then Levenberg–Marquardt (globally convergent to a stationary point of
//! ½‖R‖²) from the same and from perturbed starts. A failure says what was tried, what the best
//! point looks like, and what each homotopy path showed: a fold in the operator homotopy is the
//! only evidence it gives that the real solution connected to the Gaussian one does not reach
//! the model; a nonzero local minimum of ‖R‖ by itself shows nothing about solutions elsewhere.
//!
//! Every method reports and judges ‖R‖ itself (the Euclidean norm of the Galerkin residual in
//! scaled variables), never the cost ½‖R‖²: a solve has converged when
//! ‖R‖ ≤ tol·max(1, ‖R(a_ref)‖), with a_ref the Gaussian-closure start, so that the test is
//! absolute for well-scaled systems and relative for systems whose entries are large.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::continuation::{self, PathEnd, TraceOptions};
use super::galerkin::GalerkinSystem;
use super::outcome::{
    Attempt, AttemptEnd, BestPoint, BestPointKind, HomotopyEnd, HomotopyPath, SolverMethod,
    StartPoint, HOMOTOPY_NORM_FACTOR, HOMOTOPY_STEPS,
};
use super::EpcError;
use crate::numerics::newton::{
    levenberg_marquardt, newton, Equations, LmStop, NewtonOptions, NewtonStop, Trial,
};

/// Newton as the δ-term EPC runs it: 60 iterations, stopping at the threshold (the homotopies
/// and Levenberg–Marquardt that follow judge by the same threshold), a non-finite step
/// counted as a singular Jacobian, and the Jacobian kept from each accepted trial.
const NEWTON: NewtonOptions = NewtonOptions {
    max_iter: 60,
    polish: 0,
    reject_non_finite_step: true,
    trial: Trial::WithJacobian,
};

/// How a solve ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct SolveOutcome {
    /// The method that converged, with its start.
    pub method: SolverMethod,
    /// Iterations of the successful method.
    pub iterations: usize,
    /// Final ‖R‖ (scaled variables, weights φ(ξ1)φ(ξ2)), recomputed at the returned point.
    pub residual: f64,
    /// The bound ‖R‖ had to reach: tol·max(1, ‖R(a_ref)‖), a_ref the Gaussian-closure start.
    pub threshold: f64,
}

/// Every attempt and the best point found when nothing converged.
#[derive(Clone, Debug)]
pub(crate) struct SolveFailure {
    /// Every method tried, in order, with how it ended.
    pub attempts: Vec<Attempt>,
    /// The ‖R‖ a converged solve must reach.
    pub threshold: f64,
    /// The point of least ‖R‖.
    pub best: BestPoint,
}

/// Follows a homotopy through folds in λ from (a0, 0) towards λ = 1.
fn homotopy(
    eval: &continuation::Homotopy,
    a0: &DVector<f64>,
    method: SolverMethod,
) -> (HomotopyPath, Option<DVector<f64>>) {
    let scale = 1.0 + a0.norm();
    let opts = TraceOptions {
        stop_at_fold: false,
        max_steps: HOMOTOPY_STEPS,
        first_step: 0.05 * scale,
        max_step: 0.5 * scale,
        max_norm: HOMOTOPY_NORM_FACTOR * scale,
        min_lambda: 0.0,
    };
    match continuation::trace(eval, a0.clone(), opts) {
        Ok(path) => {
            let (end, root) = match path.end {
                PathEnd::Reached(a) => (HomotopyEnd::Reached, Some(a)),
                PathEnd::Fold { lambda } => (HomotopyEnd::TurnedBack { lambda }, None),
                PathEnd::Stalled { lambda } => (HomotopyEnd::Stalled { lambda }, None),
                PathEnd::Escaped { lambda } => (HomotopyEnd::Escaped { lambda }, None),
                PathEnd::Budget { lambda } => (HomotopyEnd::Budget { lambda }, None),
            };
            let followed = HomotopyPath {
                method,
                steps: path.points.len() - 1,
                end,
                lambda_max: path.lambda_max,
                folds: path.folds,
            };
            (followed, root)
        }
        // The evaluations of this module cannot fail; an error would end the path at its start.
        Err(_) => (
            HomotopyPath {
                method,
                end: HomotopyEnd::Stalled { lambda: 0.0 },
                lambda_max: 0.0,
                folds: Vec::new(),
                steps: 0,
            },
            None,
        ),
    }
}

/// Follows the Newton homotopy H(a, λ) = R(a) − (1 − λ) R(a0) from (a0, 0), through folds in
/// λ, towards λ = 1 where H = R. Unlike damped Newton, the path does not stop where ‖R‖ has a
/// nonzero local minimum: it turns back in λ there and goes on.
fn newton_homotopy(
    sys: &GalerkinSystem,
    a0: &DVector<f64>,
    from: StartPoint,
) -> (HomotopyPath, Option<DVector<f64>>) {
    let r0 = sys.residual_and_jacobian(a0).0;
    let eval = |a: &DVector<f64>, l: f64| -> Result<continuation::Linearised, EpcError> {
        let (r, j) = sys.residual_and_jacobian(a);
        Ok((r - (1.0 - l) * &r0, j, r0.clone()))
    };
    homotopy(&eval, a0, SolverMethod::NewtonHomotopy { from })
}

/// Follows the family R_λ = (1 − λ) R_G + λ R from its exact root `a_g` of R_G at λ = 0 (the
/// Galerkin system of an operator for which the Gaussian exp(Q(a_g)) is exact) through folds
/// in λ towards λ = 1.
fn operator_homotopy(
    sys: &GalerkinSystem,
    gauss: &GalerkinSystem,
    a_g: &DVector<f64>,
) -> (HomotopyPath, Option<DVector<f64>>) {
    let eval = |a: &DVector<f64>, l: f64| -> Result<continuation::Linearised, EpcError> {
        let (r, j) = sys.residual_and_jacobian(a);
        let (rg, jg) = gauss.residual_and_jacobian(a);
        let dl = &r - &rg;
        Ok((rg + l * &dl, &jg + l * (j - &jg), dl))
    };
    homotopy(&eval, a_g, SolverMethod::OperatorHomotopy)
}

impl Equations for GalerkinSystem {
    fn residual_and_jacobian(&self, a: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        GalerkinSystem::residual_and_jacobian(self, a)
    }
}

/// Perturbed Levenberg–Marquardt starts tried after the given starts have failed.
const PERTURBED_STARTS: usize = 4;

/// The Gaussian-exact system and its exact root, built only when Newton has failed.
pub(crate) type GaussianFamily<'a> = dyn Fn() -> (GalerkinSystem, DVector<f64>) + 'a;

/// Solves the system from the given starts (in order): Newton from each, then the operator
/// homotopy from `family` (when given) and, if `newton_homotopy`, a Newton homotopy from the
/// first start, then LM from each start and from perturbations of the best point. `tol` is
/// relative to `max(1, reference_residual)`, where `reference_residual` is ‖R‖ at the
/// Gaussian-closure start (see the module docs).
pub(crate) fn solve(
    sys: &GalerkinSystem,
    starts: &[(StartPoint, DVector<f64>)],
    family: Option<&GaussianFamily>,
    newton_homotopy_too: bool,
    tol: f64,
    reference_residual: f64,
) -> Result<(DVector<f64>, SolveOutcome), SolveFailure> {
    let threshold = tol * reference_residual.max(1.0);
    let mut attempts = Vec::new();
    // The best point so far, its ‖R‖ and whether LM stopped there for want of descent.
    type Best = Option<(DVector<f64>, f64, bool)>;
    let mut best: Best = None;
    let keep = |a: &DVector<f64>, n: f64, stationary: bool, best: &mut Best| {
        if !matches!(best, Some((_, b, _)) if *b <= n) {
            *best = Some((a.clone(), n, stationary));
        }
    };
    // The reported residual is recomputed at the returned point, whatever the method tracked.
    let done = |a: DVector<f64>, method: SolverMethod, iterations: usize| {
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
    for &(from, ref a0) in starts {
        let method = SolverMethod::Newton { from };
        let (a, n, it, stop) = newton(sys, a0, threshold, &NEWTON);
        if stop == NewtonStop::Converged {
            return Ok(done(a, method, it));
        }
        attempts.push(Attempt {
            method,
            end: AttemptEnd::Newton { stop, residual: n },
        });
        keep(&a, n, false, &mut best);
    }
    // Globally convergent fallbacks (the paper's recommendation for poor starts): homotopy
    // paths followed by pseudo-arclength continuation through folds in λ. The operator
    // homotopy comes first: it starts at an exact solution and deforms the operator, so the
    // root it reaches is the one connected to the Gaussian closure.
    let first_newton = usize::from(family.is_some());
    // One Newton homotopy, from the first start (the lower-degree solution when there is
    // one): further ones rarely reach a root the others miss and each costs as much as a
    // failed LM run.
    let newton_paths = if newton_homotopy_too {
        starts.len().min(1)
    } else {
        0
    };
    for k in 0..first_newton + newton_paths {
        let (path, root) = match family {
            Some(build) if k == 0 => {
                let (gauss, a_g) = build();
                operator_homotopy(sys, &gauss, &a_g)
            }
            _ => {
                let (from, a0) = &starts[k - first_newton];
                newton_homotopy(sys, a0, *from)
            }
        };
        if let Some(a) = &root {
            let n = sys.residual_and_jacobian(a).0.norm();
            if n <= threshold {
                return Ok(done(a.clone(), path.method, path.steps));
            }
            keep(a, n, false, &mut best);
        }
        attempts.push(Attempt {
            method: path.method,
            end: AttemptEnd::Homotopy(path),
        });
    }
    // A run that ends at a stationary point whose ‖R‖ is far above the threshold has found a
    // genuine nonzero minimum: perturbing it would only find the same minimum again.
    let mut clearly_nonzero = false;
    for &(from, ref a0) in starts {
        let method = SolverMethod::LevenbergMarquardt { from };
        let (a, n, it, stop) = levenberg_marquardt(sys, a0, threshold, 400);
        if stop == LmStop::Converged {
            return Ok(done(a, method, it));
        }
        attempts.push(Attempt {
            method,
            end: AttemptEnd::LevenbergMarquardt { stop, residual: n },
        });
        clearly_nonzero |= stop == LmStop::Stationary && n > 1e3 * threshold;
        keep(&a, n, stop != LmStop::IterationLimit, &mut best);
    }
    // Multistart: deterministic perturbations of the best point, relative to its size.
    let (centre, _, _) = best.clone().expect("at least one start");
    let scale = centre.amax().max(1e-3);
    let mut uniform = super::uniform::Uniform::new(0x9E37_79B9_7F4A_7C15);
    let mut next = || uniform.next() * 2.0 - 1.0;
    let perturbed = if clearly_nonzero { 0 } else { PERTURBED_STARTS };
    for trial in 0..perturbed {
        let method = SolverMethod::PerturbedLevenbergMarquardt { start: trial + 1 };
        let amp = 0.05 * scale * (1 + trial % 4) as f64;
        let a0 = DVector::from_iterator(centre.len(), centre.iter().map(|v| v + amp * next()));
        let (a, n, it, stop) = levenberg_marquardt(sys, &a0, threshold, 400);
        if stop == LmStop::Converged {
            return Ok(done(a, method, it));
        }
        attempts.push(Attempt {
            method,
            end: AttemptEnd::LevenbergMarquardt { stop, residual: n },
        });
        keep(&a, n, stop != LmStop::IterationLimit, &mut best);
    }
    let (a, _, stationary) = best.expect("at least one start");
    let (r, j) = sys.residual_and_jacobian(&a);
    Err(SolveFailure {
        attempts,
        threshold,
        best: BestPoint {
            residual: r.norm(),
            gradient: (j.transpose() * &r).norm(),
            kind: if stationary {
                BestPointKind::LocalMinimum
            } else {
                BestPointKind::Stalled
            },
        },
    })
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
        let gauss = StartPoint::GaussianClosure;
        let (a, out) = solve(&sys, &[(gauss, start)], None, true, 1e-10, 1.0).unwrap();
        assert!(
            matches!(
                out.method,
                SolverMethod::PerturbedLevenbergMarquardt { .. }
                    | SolverMethod::LevenbergMarquardt { .. }
            ),
            "{:?}",
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
        let from = StartPoint::LowerDegree { degree: 2 };
        let (a, out) = solve(&sys, &[(from, start)], None, true, 1e-10, 1e6).unwrap();
        approx::assert_relative_eq!(out.threshold, 1e-4);
        assert_eq!(out.method, SolverMethod::Newton { from });
        assert!(out.residual <= 1e-4);
        approx::assert_relative_eq!(a[0], 1.0, max_relative = 1e-9);
    }

    #[test]
    fn no_real_root_is_a_local_minimum() {
        // R(a) = a² + 1 has no real root; its least ‖R‖ = 1 at a = 0 is a stationary point.
        let mut sys = square_minus_one();
        sys.c[0] = 1.0;
        let start = DVector::from_vec(vec![0.7]);
        let from = StartPoint::GaussianClosure;
        let f = solve(&sys, &[(from, start)], None, true, 1e-10, 1.0).unwrap_err();
        approx::assert_relative_eq!(f.best.residual, 1.0, max_relative = 1e-6);
        assert_eq!(f.best.kind, BestPointKind::LocalMinimum);
        // The Newton homotopy R(a) = (1 − λ)R(0.7) folds where R' = 0 and never reaches λ = 1;
        // not an operator deformation, so it claims nothing about solutions elsewhere.
        let paths: Vec<&HomotopyPath> = f
            .attempts
            .iter()
            .filter_map(|a| match &a.end {
                AttemptEnd::Homotopy(p) => Some(p),
                _ => None,
            })
            .collect();
        assert_eq!(paths.len(), 1);
        assert_eq!(paths[0].method, SolverMethod::NewtonHomotopy { from });
        assert!(!paths[0].folds.is_empty(), "{:?}", paths[0]);
        assert_ne!(paths[0].end, HomotopyEnd::Reached);
        // Newton from 0.7 and, last, LM from 0.7 stopped (no perturbed starts at a clear minimum).
        assert!(matches!(f.attempts[0].end, AttemptEnd::Newton { .. }));
        assert!(matches!(
            f.attempts.last().map(|a| &a.end),
            Some(AttemptEnd::LevenbergMarquardt { .. })
        ));
    }
}
