//! One damped Newton and one Levenberg–Marquardt for square systems R(a) = 0 given with their
//! Jacobian (`Equations`): the nonlinear solver of both closure methods. Each run reports
//! its end point, ‖R‖ there, the iterations taken and why it stopped.
//!
//! Newton's details that the methods choose differently are `NewtonOptions`: the iteration
//! limit, polishing past the threshold, whether a non-finite step counts as singular, and
//! whether the line search evaluates the Jacobian with each trial residual.

use nalgebra::{DMatrix, DVector};

/// A square system R(a) = 0 with its Jacobian: what [`newton`] and [`levenberg_marquardt`]
/// solve (the δ-term Galerkin system, and the exact-impact moment equations).
pub(crate) trait Equations {
    /// R(a) and ∂R/∂a.
    fn residual_and_jacobian(&self, a: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>);

    /// R(a) alone, for line searches that need no Jacobian at rejected trials.
    fn residual(&self, a: &DVector<f64>) -> DVector<f64> {
        self.residual_and_jacobian(a).0
    }
}

/// Why a damped Newton run stopped.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// use fpsolve::numerics::newton::NewtonStop;
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// assert!(matches!(attempts[0].end, AttemptEnd::Newton { stop: NewtonStop::Crawling | NewtonStop::NoDescent | NewtonStop::Singular | NewtonStop::IterationLimit, .. }));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NewtonStop {
    /// ‖R‖ reached the threshold.
    Converged,
    /// The Jacobian was singular or the step not finite.
    Singular,
    /// No step length down to 2^−20 decreased ½‖R‖² enough.
    NoDescent,
    /// Less than 10% gained over eight iterations: crawling towards a nonzero minimum.
    Crawling,
    /// The iteration limit came first.
    IterationLimit,
}

/// Why a Levenberg–Marquardt run stopped.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// use fpsolve::numerics::newton::LmStop;
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// let lm = attempts.iter().find_map(|a| match a.end {
///     AttemptEnd::LevenbergMarquardt { stop, .. } => Some(stop),
///     _ => None,
/// });
/// assert!(lm.is_some_and(|s| s != LmStop::Converged));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LmStop {
    /// ‖R‖ reached the threshold.
    Converged,
    /// No descent is possible any more (no damping gave a decrease, or ‖R‖ stopped
    /// decreasing): a numerical local minimum of ‖R‖.
    Stationary,
    /// The gradient JᵀR vanished: a critical point of ½‖R‖², possibly a saddle or maximum.
    Critical,
    /// The iteration limit came first.
    IterationLimit,
}

/// What the line search of [`newton`] evaluates at a trial point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Trial {
    /// R and its Jacobian together, the Jacobian kept when the trial is accepted (cheap when
    /// both come from one pass over the quadrature points).
    WithJacobian,
    /// R alone, the Jacobian computed once at the accepted point (cheaper when the Jacobian
    /// costs much more than R and trials are often rejected).
    ResidualOnly,
}

/// The details of one [`newton`] run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NewtonOptions {
    /// Iterations at most.
    pub(crate) max_iter: usize,
    /// Steps taken after ‖R‖ first reaches the threshold, each kept only while it halves
    /// ‖R‖², so the root is as accurate as the rounding of R allows (0: stop at the
    /// threshold).
    pub(crate) polish: usize,
    /// Whether a step with a non-finite entry ends the run as [`NewtonStop::Singular`]
    /// (otherwise the line search rejects it).
    pub(crate) reject_non_finite_step: bool,
    /// What a line-search trial evaluates.
    pub(crate) trial: Trial,
}

/// Damped Newton from `a0` to ‖R‖ ≤ `tol`, with a backtracking line search on ½‖R‖² (steps
/// down to 2⁻²⁰; a Newton direction that only helps at shorter steps is useless here).
pub(crate) fn newton<S: Equations + ?Sized>(
    sys: &S,
    a0: &DVector<f64>,
    tol: f64,
    options: &NewtonOptions,
) -> (DVector<f64>, f64, usize, NewtonStop) {
    let mut a = a0.clone();
    let (mut r, mut j) = sys.residual_and_jacobian(&a);
    let mut norm = r.norm();
    // ‖R‖ eight iterations ago: damped Newton that gains less than 10% over eight steps is
    // crawling along a valley towards a nonzero minimum (near a root it converges
    // quadratically), which Levenberg–Marquardt handles better.
    let mut history = std::collections::VecDeque::with_capacity(9);
    let mut polish = 0;
    // A run that ends early after reaching the threshold (while polishing) has converged.
    let ended = |norm: f64, stop: NewtonStop| {
        if norm <= tol {
            NewtonStop::Converged
        } else {
            stop
        }
    };
    for it in 0..options.max_iter {
        if norm <= tol {
            if polish == options.polish {
                return (a, norm, it, NewtonStop::Converged);
            }
            polish += 1;
        }
        history.push_back(norm);
        if history.len() > 8 {
            let old = history.pop_front().expect("non-empty");
            if norm > 0.9 * old {
                return (a, norm, it, ended(norm, NewtonStop::Crawling));
            }
        }
        let Some(step) = j.clone().lu().solve(&(-&r)) else {
            return (a, norm, it, ended(norm, NewtonStop::Singular));
        };
        if options.reject_non_finite_step && !step.iter().all(|v| v.is_finite()) {
            return (a, norm, it, ended(norm, NewtonStop::Singular));
        }
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..20 {
            let an = &a + t * &step;
            let (rn, jn) = match options.trial {
                Trial::WithJacobian => {
                    let (rn, jn) = sys.residual_and_jacobian(&an);
                    (rn, Some(jn))
                }
                Trial::ResidualOnly => (sys.residual(&an), None),
            };
            let nn = rn.norm();
            // Armijo on ½‖R‖² (the Newton direction's slope is −‖R‖²); a polishing step
            // must halve it.
            let gain = if polish > 0 { 0.5 } else { 1.0 - 2e-4 * t };
            if nn.is_finite() && nn * nn <= norm * norm * gain {
                a = an;
                norm = nn;
                if let Some(jn) = jn {
                    r = rn;
                    j = jn;
                }
                accepted = true;
                break;
            }
            if polish > 0 {
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            return (a, norm, it, ended(norm, NewtonStop::NoDescent));
        }
        if options.trial == Trial::ResidualOnly {
            (r, j) = sys.residual_and_jacobian(&a);
            norm = r.norm();
        }
    }
    (
        a,
        norm,
        options.max_iter,
        ended(norm, NewtonStop::IterationLimit),
    )
}

/// Levenberg–Marquardt on ‖R‖² from `a0`, at most `max_iter` steps: the end point, its ‖R‖,
/// the steps taken and why it stopped.
pub(crate) fn levenberg_marquardt<S: Equations + ?Sized>(
    sys: &S,
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
