//! The exponential-polynomial closure (EPC, the paper's Eqs. 14–22).
//!
//! For an [`FpkOperator`], find p = C·exp(Q_n) with Q_n a complete polynomial of degree n
//! (Eq. 16) such that the residual F of Eq. 18 is orthogonal to the test functions
//! H_k = x1^i x2^j f1(x1) f2(x2) of Eqs. 20–22, whose Gaussian factors come from a Gaussian
//! closure of the model. The pipeline: coefficients → Gaussian closure (σ) → quadrature (exact
//! for piecewise polynomial coefficients, checked by raising the order otherwise) → moment
//! tables → Galerkin system → Newton / homotopy continuation / Levenberg–Marquardt
//! (continuation in degree) → honest normalisation → [`EpcSolution`].
//!
//! ```
//! use fpsolve::epc::Epc;
//! use fpsolve::fpk::FpkOperator;
//! use fpsolve::model::parse_model;
//!
//! // Linear oscillator z' = v, v' = −0.1 v − z + ξ, 2πK = 1.
//! let text = "model linear
//! param c = 0.1, k = 1
//! state z, v
//! drift z: v
//! drift v: -c*v - k*z
//! noise xi: intensity 1
//! diffusion v: xi
//! ";
//! let model = parse_model(text, None).unwrap();
//! let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
//! let sol = Epc::new(&fpk).degree(2).solve().unwrap();
//! // Exact: variances πK/(ck) = 5 for z and πK/c = 5 for v.
//! assert!((sol.moments[0].variance - 5.0).abs() < 1e-6);
//! ```

mod closure;
mod coefficients;
mod continuation;
mod degrees;
mod efolds;
mod error;
mod exp;
mod galerkin;
mod gaussian;
mod normalise;
mod outcome;
mod prepare;
mod residual;
mod solution;
pub(crate) mod solver;
mod uniform;

use std::time::Instant;

use nalgebra::DVector;

pub use closure::GaussianClosure;
pub use continuation::{Branch, BranchEnd, BranchPoint};
pub use degrees::{DegreeList, DegreeListError};
pub use efolds::EFolds;
pub use error::EpcError;
pub(crate) use normalise::Stretch;
pub use normalise::{NormalisationKind, NormalisationReport, NotNormalisable, RidgeRegion};
pub use outcome::{
    Attempt, AttemptEnd, BestPoint, BestPointKind, HomotopyEnd, HomotopyPath, SolverMethod,
    StartPoint,
};
pub use solution::{EpcSolution, SolveReport};

use crate::dynamics::ImpactForm;
use crate::fpk::FpkOperator;
use galerkin::GalerkinSystem;
use normalise::Poly;
use prepare::{Prepared, Quadrature};
use solver::SolveOutcome;

/// The largest degree the engine accepts.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// assert!(Epc::new(&fpk).degree(MAX_DEGREE).solve().is_ok());
/// assert!(Epc::new(&fpk).degree(MAX_DEGREE + 2).solve().is_err());
/// ```
pub const MAX_DEGREE: usize = 12;

/// Default least ridge depth (e-folds) for normalising inside a ridge: the mass beyond a ridge
/// this deep is below e^-12 ≈ 6e-6 of the peak's neighbourhood.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol = Epc::new(&fpk).ridge_threshold(DEFAULT_RIDGE_THRESHOLD).solve().unwrap();
/// assert!(matches!(sol.normalisation.kind, NormalisationKind::Plane { .. }));
/// ```
pub const DEFAULT_RIDGE_THRESHOLD: f64 = 12.0;

/// An EPC problem: the operator (with its delta treatment) and options; [`Epc::solve`] runs it.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol = Epc::new(&fpk).degree(4).tolerance(1e-12).solve().unwrap();
/// assert!(sol.solve.residual <= sol.solve.residual_threshold);
/// ```
#[derive(Clone, Debug)]
pub struct Epc<'a> {
    fpk: &'a FpkOperator,
    degree: usize,
    tolerance: f64,
    sigma: [Option<f64>; 2],
    ridge_threshold: f64,
    quadrature_tolerance: f64,
}

/// A lower-degree solution (exponents, scaled coefficients) that starts the next degree.
type Start = (Vec<(usize, usize)>, DVector<f64>);

/// A solved degree before normalisation.
struct SolvedDegree {
    sys: GalerkinSystem,
    a: DVector<f64>,
    outcome: SolveOutcome,
    assembly_ms: f64,
    solve_ms: f64,
}

impl<'a> Epc<'a> {
    /// A problem for `fpk` (δ terms treated as [`FpkOperator::delta_treatment`] says); degree
    /// 4 and tolerance 1e−10 (see [`Epc::tolerance`]) by default.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let epc = Epc::new(&fpk);
    /// assert_eq!(epc.solve().unwrap().degree, 4);
    /// ```
    pub fn new(fpk: &'a FpkOperator) -> Epc<'a> {
        Epc {
            fpk,
            degree: 4,
            tolerance: 1e-10,
            sigma: [None, None],
            ridge_threshold: DEFAULT_RIDGE_THRESHOLD,
            quadrature_tolerance: 1e-10,
        }
    }

    /// The degree n of Q (2 ≤ n ≤ [`MAX_DEGREE`]).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// assert_eq!(Epc::new(&fpk).degree(6).solve().unwrap().exponents.len(), 27);
    /// ```
    pub fn degree(mut self, n: usize) -> Self {
        self.degree = n;
        self
    }

    /// Convergence tolerance: a solve has converged when ‖R‖ ≤ tol·max(1, ‖R(a_ref)‖), with R
    /// the Galerkin residual of Eq. 19 in scaled variables ξ_i = x_i/σ_i and a_ref the
    /// Gaussian-closure start (default 1e−10).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).tolerance(1e-8).solve().unwrap();
    /// // tol·max(1, ‖R‖ at the closure start): never below tol itself.
    /// assert!(sol.solve.residual_threshold >= 1e-8 && sol.solve.residual <= sol.solve.residual_threshold);
    /// ```
    pub fn tolerance(mut self, tol: f64) -> Self {
        self.tolerance = tol;
        self
    }

    /// Overrides the weights' σ_1, σ_2 (Eqs. 21–22); `None` keeps the Gaussian closure's.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).weights([Some(2.0), Some(2.0)]).solve().unwrap();
    /// assert_eq!(sol.sigma, [2.0, 2.0]);
    /// assert!(sol.closure.is_none());
    /// ```
    pub fn weights(mut self, sigma: [Option<f64>; 2]) -> Self {
        self.sigma = sigma;
        self
    }

    /// The least ridge depth (e-folds) accepted for normalising inside a ridge.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// // A Gaussian is normalisable on the plane whatever the threshold.
    /// assert!(Epc::new(&fpk).degree(2).ridge_threshold(30.0).solve().is_ok());
    /// ```
    pub fn ridge_threshold(mut self, e_folds: f64) -> Self {
        self.ridge_threshold = e_folds;
        self
    }

    /// Relative change of the assembled system below which a raised quadrature order is
    /// accepted (only used for coefficients that are not piecewise polynomial).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// // Polynomial coefficients: the order is exact and no check is run.
    /// let sol = Epc::new(&fpk).quadrature_tolerance(1e-12).solve().unwrap();
    /// assert!(!sol.solve.order_checked);
    /// ```
    pub fn quadrature_tolerance(mut self, tol: f64) -> Self {
        self.quadrature_tolerance = tol;
        self
    }

    /// Solves at the configured degree, by continuation through every lower even degree
    /// (starting at 2): exactly what [`Epc::solve_degrees`] gives for this degree, whatever
    /// other degrees are asked with it.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(4).solve().unwrap();
    /// // The exact density is Gaussian: the quartic coefficients vanish.
    /// assert!(sol.coefficient(4, 0).abs() < 1e-9);
    /// ```
    pub fn solve(&self) -> Result<EpcSolution, EpcError> {
        self.solve_degrees(&[self.degree])
            .pop()
            .unwrap_or(Err(EpcError::Degree {
                degree: self.degree,
                max: MAX_DEGREE,
            }))
    }

    /// Solves and normalises at each degree asked, one result per entry in the order given.
    ///
    /// Every even degree from 2 up to the largest one asked is solved in turn, each started
    /// from the last successful lower-degree solution (padded with zeros) and from the Gaussian
    /// closure, with the same fallbacks at every degree; only the degrees asked are normalised.
    /// So a degree's answer does not depend on which other degrees were asked with it
    /// (`&[6]` gives what `&[4, 6]` gives for 6).
    ///
    /// An odd or out-of-range degree gets [`EpcError::Degree`] / [`EpcError::OddDegree`] and
    /// does not stop the others.
    ///
    /// ```
    /// use fpsolve::epc::{Epc, EpcError};
    /// use fpsolve::fpk::FpkOperator;
    /// use fpsolve::model::parse_model;
    /// let model = parse_model("model lin
    /// param c = 0.1
    /// state z, v
    /// drift z: v
    /// drift v: -c*v - z
    /// noise xi: intensity 1
    /// diffusion v: xi
    /// ", None).unwrap();
    /// let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let epc = Epc::new(&fpk);
    /// let r = epc.solve_degrees(&[4, 3]);
    /// assert!(r[0].is_ok());
    /// assert!(matches!(r[1], Err(EpcError::OddDegree { degree: 3 })));
    /// ```
    pub fn solve_degrees(&self, degrees: &[usize]) -> Vec<Result<EpcSolution, EpcError>> {
        if let Err(e) = self.refuse_unsupported_impact() {
            return degrees.iter().map(|_| Err(e.clone())).collect();
        }
        let checks: Vec<Result<(), EpcError>> = degrees.iter().map(|&n| check_degree(n)).collect();
        let max_n = degrees
            .iter()
            .zip(&checks)
            .filter(|(_, c)| c.is_ok())
            .map(|(&n, _)| n)
            .max();
        let Some(max_n) = max_n else {
            return checks
                .into_iter()
                .map(|c| Err(c.expect_err("no valid degree")))
                .collect();
        };
        crate::base::timeline::mark("epc: start");
        let prep = match self.prepare() {
            Ok(p) => p,
            Err(e) => return degrees.iter().map(|_| Err(e.clone())).collect(),
        };
        crate::base::timeline::mark("epc: closure done");
        let t0 = Instant::now();
        let moments = match self.moments(&prep, max_n) {
            Ok(m) => m,
            Err(e) => return degrees.iter().map(|_| Err(e.clone())).collect(),
        };
        let moments_ms = ms(t0);
        crate::base::timeline::mark("epc: quadrature ready");
        let mut previous: Option<Start> = None;
        let mut by_degree: Vec<(usize, Result<EpcSolution, EpcError>)> = Vec::new();
        for n in (2..=max_n).step_by(2) {
            let asked = degrees.contains(&n);
            match self.solve_coefficients(&prep, &moments, n, previous.as_ref(), true) {
                Ok(c) => {
                    crate::base::timeline::mark("epc: degree solved");
                    previous = Some((c.sys.exps.clone(), c.a.clone()));
                    if asked {
                        by_degree.push((n, self.finish(&prep, &moments, moments_ms, c)));
                    }
                }
                Err(e) => {
                    if asked {
                        by_degree.push((n, Err(e)));
                    }
                }
            }
        }
        degrees
            .iter()
            .zip(checks)
            .map(|(&n, check)| match check {
                Err(e) => Err(e),
                Ok(()) => by_degree
                    .iter()
                    .find(|(d, _)| *d == n)
                    .map(|(_, r)| r.clone())
                    .expect("every valid degree asked was solved"),
            })
            .collect()
    }

    /// Follows the degree-n Galerkin solution along a family of operators `family(λ)` from
    /// λ = 0 (where it must have a real solution, found by [`Epc::solve`] with this problem's
    /// weights) to λ = 1 (normally this problem's operator) by pseudo-arclength continuation,
    /// with the weights σ of this problem held fixed. The answer says whether the branch
    /// reaches λ = 1 or folds back first, which is evidence about whether the target has a
    /// real solution connected to the λ = 0 one. The continuation may evaluate the family a
    /// little outside [0, 1], so build its members with [`FpkOperator::derive_unchecked`] when
    /// the family starts at a physical limit (r = 1, say).
    ///
    /// ```
    /// use fpsolve::epc::{BranchEnd, Epc};
    /// use fpsolve::fpk::FpkOperator;
    /// use fpsolve::model::{parse_model, Override};
    ///
    /// let model = parse_model("model lin
    /// param c = 0.1
    /// state z, v
    /// drift z: v
    /// drift v: -c*v - z
    /// noise xi: intensity 1
    /// diffusion v: xi
    /// ", None).unwrap();
    /// let at = |c: f64| FpkOperator::derive(&model.bind(&[Override::number("c", c)]).unwrap())
    ///     .map_err(|e| e.to_string());
    /// let target = at(0.2).unwrap();
    /// let family = |l: f64| at(0.1 + 0.1 * l);
    /// let branch = Epc::new(&target).degree(2).branch(&family).unwrap();
    /// assert_eq!(branch.end, BranchEnd::Reached);
    /// ```
    pub fn branch(
        &self,
        family: &dyn Fn(f64) -> Result<FpkOperator, String>,
    ) -> Result<Branch, EpcError> {
        let n = self.degree;
        check_degree(n)?;
        let sigma = self.prepare()?.sigma;
        let member = |l: f64| family(l).map_err(|reason| EpcError::Family { lambda: l, reason });
        let fixed = [Some(sigma[0]), Some(sigma[1])];
        let start = {
            let op = member(0.0)?;
            let sol = Epc {
                fpk: &op,
                ..self.clone()
            }
            .weights(fixed)
            .solve()?;
            DVector::from_vec(sol.scaled_coefficients)
        };
        let system = |l: f64| -> Result<GalerkinSystem, EpcError> {
            let op = member(l)?;
            let epc = Epc {
                fpk: &op,
                ..self.clone()
            }
            .weights(fixed);
            let prep = epc.prepare()?;
            Ok(GalerkinSystem::assemble(&epc.moments(&prep, n)?.tables, n))
        };
        continuation::follow(&system, start, n)
    }

    /// Refuses, before any work, an impact law the operator does not represent (see
    /// [`crate::dynamics::impact_form`]).
    fn refuse_unsupported_impact(&self) -> Result<(), EpcError> {
        match &self.fpk.impact {
            Some(ImpactForm::Unsupported { law, reason }) => Err(EpcError::UnsupportedImpact {
                law: law.clone(),
                reason: reason.clone(),
            }),
            _ => Ok(()),
        }
    }

    /// Assembles the degree-`n` system and solves it for Q's scaled coefficients. `full`
    /// adds the homotopy fallbacks (left out for the intermediate degrees of a continuation in
    /// degree, which only supply starts: they would slow down solves whose target degree
    /// Newton solves directly).
    fn solve_coefficients(
        &self,
        prep: &Prepared,
        moments: &Quadrature,
        n: usize,
        previous: Option<&Start>,
        full: bool,
    ) -> Result<SolvedDegree, EpcError> {
        let t0 = Instant::now();
        let sys = GalerkinSystem::assemble(&moments.tables, n);
        let assembly_ms = ms(t0);
        let mut starts = Vec::new();
        if let Some((e, a)) = previous {
            starts.push((
                StartPoint::LowerDegree {
                    degree: e.iter().map(|x| x.0 + x.1).max().unwrap_or(0),
                },
                crate::numerics::newton::pad(a, e, &sys.exps),
            ));
        }
        let closure_start = prep.closure_start(&sys.exps);
        let reference = sys.residual_and_jacobian(&closure_start).0.norm();
        starts.push((StartPoint::GaussianClosure, closure_start.clone()));
        let t1 = Instant::now();
        let family = || {
            let gauss = GalerkinSystem::assemble(&prep.gaussian_exact_moments(&moments.tables), n);
            (gauss, closure_start.clone())
        };
        let (a, outcome) = solver::solve(
            &sys,
            &starts,
            if full { Some(&family) } else { None },
            full,
            self.tolerance,
            reference,
        )
        .map_err(|f| EpcError::NoConvergence {
            degree: n,
            attempts: f.attempts,
            best: f.best,
            threshold: f.threshold,
        })?;
        Ok(SolvedDegree {
            sys,
            a,
            outcome,
            assembly_ms,
            solve_ms: ms(t1),
        })
    }

    /// Normalises a solved Q and computes what the solution reports.
    fn finish(
        &self,
        prep: &Prepared,
        moments: &Quadrature,
        moments_ms: f64,
        solved: SolvedDegree,
    ) -> Result<EpcSolution, EpcError> {
        let n = solved.sys.exps.iter().map(|e| e.0 + e.1).max().unwrap_or(0);
        let sigma = prep.sigma;
        let t2 = Instant::now();
        let q = Poly {
            exps: solved.sys.exps.clone(),
            a: solved.a.iter().copied().collect(),
            degree: n,
        };
        let (grid, norm) = normalise::normalise(&q, sigma, self.ridge_threshold)
            .map_err(|reason| EpcError::NotNormalisable { degree: n, reason })?;
        let normalise_ms = ms(t2);
        crate::base::timeline::mark("epc: normalised");
        let t3 = Instant::now();
        let fpk_residual = prep.fpk_residual(&q, &grid)?;
        let report = SolveReport {
            degree: n,
            method: solved.outcome.method,
            iterations: solved.outcome.iterations,
            residual: solved.outcome.residual,
            residual_threshold: solved.outcome.threshold,
            quadrature_order: moments.order,
            order_checked: moments.checked,
            closure_ms: prep.closure_ms,
            assembly_ms: moments_ms + solved.assembly_ms,
            solve_ms: solved.solve_ms,
            normalise_ms,
            fpk_residual_ms: ms(t3),
        };
        Ok(EpcSolution::from_parts(
            q,
            grid,
            sigma,
            prep.closure.clone(),
            norm,
            report,
            fpk_residual,
        ))
    }
}

fn check_degree(n: usize) -> Result<(), EpcError> {
    if n % 2 == 1 && (2..=MAX_DEGREE).contains(&n) {
        Err(EpcError::OddDegree { degree: n })
    } else if (2..=MAX_DEGREE).contains(&n) {
        Ok(())
    } else {
        Err(EpcError::Degree {
            degree: n,
            max: MAX_DEGREE,
        })
    }
}

impl Epc<'_> {
    /// What every degree of this problem shares ([`Prepared::new`]).
    fn prepare(&self) -> Result<Prepared, EpcError> {
        Prepared::new(self.fpk, self.sigma)
    }

    /// Moment tables good for degree `n` ([`Prepared::moments`]).
    fn moments(&self, prep: &Prepared, n: usize) -> Result<Quadrature, EpcError> {
        prep.moments(n, self.fpk, self.quadrature_tolerance)
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests;
