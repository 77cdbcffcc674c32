//! Solving R(a) = 0: damped Newton (backtracking on ½‖R‖²) from each start, then
//! Levenberg–Marquardt from each start. The outcomes are the δ-term EPC's
//! ([`crate::epc::SolverMethod`], [`crate::epc::Attempt`], [`crate::epc::BestPoint`]), so a
//! failure reads the same whichever EPC produced it. (The homotopies of the δ-term EPC are
//! not used: the continuation in degree starts each degree from the previous one.)

use nalgebra::DVector;

use super::rule::System;
use crate::epc::{
    Attempt, AttemptEnd, BestPoint, BestPointKind, EpcError, SolverMethod, StartPoint,
};
use crate::numerics::newton::{
    levenberg_marquardt, newton, LmStop, NewtonOptions, NewtonStop, Trial,
};

/// Newton as the exact-impact EPC runs it: 60 iterations, then polished while ‖R‖ still
/// halves (at most three more steps) so that the root is as accurate as the rounding of R
/// allows; line-search trials evaluate R alone, the Jacobian once at each accepted point.
pub(crate) const NEWTON: NewtonOptions = NewtonOptions {
    max_iter: 60,
    polish: 3,
    reject_non_finite_step: false,
    trial: Trial::ResidualOnly,
};
/// Levenberg–Marquardt iterations at most (each costs one Jacobian).
const LM_ITERATIONS: usize = 60;

/// How a converged solve ended.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Converged {
    pub(crate) method: SolverMethod,
    pub(crate) iterations: usize,
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
        let (a, n, it, stop) = newton(sys, a0, threshold, &NEWTON);
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
            let (a, _, more, _) = newton(sys, &a, threshold, &NEWTON);
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
