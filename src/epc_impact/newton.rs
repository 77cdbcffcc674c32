//! Solving R(a) = 0: damped Newton (backtracking on ½‖R‖²) from each start, then
//! Levenberg–Marquardt from each start. The outcomes are the δ-term EPC's
//! ([`crate::epc::SolverMethod`], [`crate::epc::Attempt`], [`crate::epc::BestPoint`]), so a
//! failure reads the same whichever EPC produced it. (The homotopies of the δ-term EPC are
//! not used: the continuation in degree starts each degree from the previous one.)

use nalgebra::DVector;

use super::rule::System;
use crate::epc::solver::levenberg_marquardt;
use crate::epc::{
    Attempt, AttemptEnd, BestPoint, BestPointKind, EpcError, LmStop, NewtonStop, SolverMethod,
    StartPoint,
};

/// Newton iterations at most.
const NEWTON_ITERATIONS: usize = 60;
/// Levenberg–Marquardt iterations at most (each costs one Jacobian).
const LM_ITERATIONS: usize = 60;

/// How a converged solve ended.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Converged {
    pub(crate) method: SolverMethod,
    pub(crate) iterations: usize,
}

/// Damped Newton from `a0` to ‖R‖ ≤ `tol`, then polished while ‖R‖ still halves (at most
/// three more steps), so that the root is as accurate as the rounding of R allows.
pub(crate) fn newton(
    sys: &System,
    a0: &DVector<f64>,
    tol: f64,
) -> (DVector<f64>, f64, usize, NewtonStop) {
    let mut a = a0.clone();
    let (mut r, mut j) = sys.residual_and_jacobian(&a);
    let mut norm = r.norm();
    let mut history = std::collections::VecDeque::with_capacity(9);
    let mut polish = 0;
    for it in 0..NEWTON_ITERATIONS {
        if norm <= tol {
            if polish == 3 {
                return (a, norm, it, NewtonStop::Converged);
            }
            polish += 1;
        }
        history.push_back(norm);
        if history.len() > 8 {
            let old = history.pop_front().expect("non-empty");
            if norm > 0.9 * old {
                let stop = if norm <= tol {
                    NewtonStop::Converged
                } else {
                    NewtonStop::Crawling
                };
                return (a, norm, it, stop);
            }
        }
        let Some(step) = j.clone().lu().solve(&(-&r)) else {
            let stop = if norm <= tol {
                NewtonStop::Converged
            } else {
                NewtonStop::Singular
            };
            return (a, norm, it, stop);
        };
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..20 {
            let an = &a + t * &step;
            let rn = sys.residual(&an);
            let nn = rn.norm();
            let gain = if polish > 0 { 0.5 } else { 1.0 - 2e-4 * t };
            if nn.is_finite() && nn * nn <= norm * norm * gain {
                a = an;
                norm = nn;
                accepted = true;
                break;
            }
            if polish > 0 {
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            let stop = if norm <= tol {
                NewtonStop::Converged
            } else {
                NewtonStop::NoDescent
            };
            return (a, norm, it, stop);
        }
        (r, j) = sys.residual_and_jacobian(&a);
        norm = r.norm();
    }
    let stop = if norm <= tol {
        NewtonStop::Converged
    } else {
        NewtonStop::IterationLimit
    };
    (a, norm, NEWTON_ITERATIONS, stop)
}

/// Newton from each start in order, then Levenberg–Marquardt from each; the first to reach
/// ‖R‖ ≤ `threshold` wins. A failure is [`EpcError::NoConvergence`] with every attempt.
pub(crate) fn solve(
    sys: &System,
    degree: usize,
    starts: &[(StartPoint, DVector<f64>)],
    threshold: f64,
) -> Result<(DVector<f64>, Converged), EpcError> {
    let mut attempts = Vec::new();
    let mut best: Option<(DVector<f64>, f64, bool)> = None;
    let mut keep = |a: &DVector<f64>, n: f64, stationary: bool| {
        if !matches!(&best, Some((_, b, _)) if *b <= n) {
            best = Some((a.clone(), n, stationary));
        }
    };
    for (from, a0) in starts {
        let method = SolverMethod::Newton { from: *from };
        let (a, n, it, stop) = newton(sys, a0, threshold);
        if stop == NewtonStop::Converged {
            return Ok((
                a,
                Converged {
                    method,
                    iterations: it,
                },
            ));
        }
        attempts.push(Attempt {
            method,
            end: AttemptEnd::Newton { stop, residual: n },
        });
        keep(&a, n, false);
    }
    for (from, a0) in starts {
        let method = SolverMethod::LevenbergMarquardt { from: *from };
        let (a, n, it, stop) = levenberg_marquardt(sys, a0, threshold, LM_ITERATIONS);
        if stop == LmStop::Converged {
            // Polish the LM root by Newton (quadratic convergence near a regular root).
            let (a, _, more, _) = newton(sys, &a, threshold);
            return Ok((
                a,
                Converged {
                    method,
                    iterations: it + more,
                },
            ));
        }
        attempts.push(Attempt {
            method,
            end: AttemptEnd::LevenbergMarquardt { stop, residual: n },
        });
        keep(&a, n, stop != LmStop::IterationLimit);
    }
    let (a, _, stationary) = best.expect("at least one start");
    let (r, j) = sys.residual_and_jacobian(&a);
    Err(EpcError::NoConvergence {
        degree,
        attempts,
        best: BestPoint {
            residual: r.norm(),
            gradient: j.tr_mul(&r).norm(),
            kind: if stationary {
                BestPointKind::LocalMinimum
            } else {
                BestPointKind::Stalled
            },
        },
        threshold,
    })
}
