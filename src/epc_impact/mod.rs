//! EPC with the exact impact condition (`--method epc-impact`): the exponential-polynomial
//! closure on the domain of the model's original coordinates, the impact law entering as a
//! boundary term of the stationary weak form instead of the Zhuravlev form's δ term.
//!
//! # The equations
//!
//! A mechanical-form model x' = v, v' = m(x, v) + noise (m the Itô drift, b(x, v) the v–v
//! diffusion) lives on a domain D: x ≥ x_b above a lower barrier, x ≤ x_u below an upper one,
//! x_b ≤ x ≤ x_u on a strip, the plane without barriers. At a barrier the velocity jumps,
//! v ↦ map(v) (Newton's law: −r·v). For a smooth test function H, Itô's formula between
//! impacts and the jump of H at each impact give
//!
//! H(X_t) − H(X_0) = ∫_0^t L H(X_s) ds + M_t + Σ_{impacts before t} [H(x_b, map v⁻) − H(x_b, v⁻)],
//!
//! with L H = v ∂_x H + m ∂_v H + ½ b ∂²_v H the generator and M_t a martingale. In the
//! stationary state E[H(X_t)] does not change, and the impacts at velocities in dv occur at
//! the rate |v|·p(x_b, v) dv (the probability flux through the line x = x_b, Rice's formula),
//! for the arriving velocities only: v < 0 at a lower barrier, v > 0 at an upper one. So, for
//! every H,
//!
//! ∫∫_D p·L H dx dv + Σ_barriers ∫_{arriving v} |v|·p(x_b, v)·[H(x_b, map v) − H(x_b, v)] dv = 0.
//!
//! (Integrating ∫∫_D p·L H by parts gives the same identity from the FPK equation with the
//! boundary condition that the flux leaving at v returns at map(v).)
//!
//! The density is sought as p = C·exp(Q_n) with Q_n the complete polynomial of degree n
//! without constant term, in scaled variables ξ = x/σx, η = v/σv (σ from the Gaussian closure
//! of the model without its barrier), and the test functions are the monomials H = ξ^i η^j,
//! 1 ≤ i + j ≤ n, as many as unknowns: the stationary moment equations of the impact system.
//! They are homogeneous in C; the residual is divided by ∫∫_D exp(Q), i.e. taken for the
//! normalised density, so it does not depend on the scale of exp(Q). With r = 1 and an
//! energy-dependent damping (Caughey–Ma class) the barrier-free density exp(−φ(E)) restricted
//! to D is exact, and a root of these equations when φ is a polynomial of degree ≤ n.
//!
//! # The discrete problem
//!
//! The integrals are taken on a box of D by tensor composite Gauss–Legendre panels (8 nodes
//! each; the velocity panels break at v = 0, where the barrier integrals end), the barrier
//! integrals on the same velocity nodes. The box starts at ±9 closure standard deviations and
//! is refitted after each solve to where exp(Q) exceeds e^−40 of its peak, the root followed
//! by Newton onto it; the rule is then checked by doubling its panels: the residual of the
//! solution on the finer rule must stay below the solver's threshold (or 1e−7 of the
//! equations' scale), else the finer rule is used and checked again, up to 48 panels. Degrees
//! 2, 4, 6, … are solved in turn, each started from the last two successes below it (padded
//! with zeros) and from the Gaussian closure: damped Newton, then Levenberg–Marquardt.
//!
//! exp(Q) is a density on D when Q → −∞ along every ray of D (checked on 721 rays from
//! points across the box, as the δ-term EPC does; on a strip only v → ±∞):
//! [`Normalisation::Domain`]. Otherwise, as the δ-term EPC does, it is one only inside the
//! ridge that separates the peak from where Q grows again, if the ridge's pass is at least 12
//! e-folds below the peak ([`EpcImpact::ridge_threshold`]): the box is then the part around
//! the peak down to one e-fold above the pass, the density is exp(Q) on it and 0 beyond
//! ([`Normalisation::InsideRidge`], with the depth), and the equations are solved on that box.
//! A shallower ridge, or a second hump inside the box, is refused ([`Divergence`]).
//!
//! Without an impact law the same equations hold on the plane (EPC with monomial test
//! functions and no weights), and the method solves them; a pass-through law (the Zhuravlev
//! form) and δ terms are refused: the original-coordinates model is what this method needs.
//!
//! ```
//! use fpsolve::epc_impact::EpcImpact;
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
//! let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
//! let ladder = EpcImpact::new(&bound).solve_degrees(&[4, 6]);
//! let sol = ladder[1].as_ref().unwrap();
//! assert!(sol.report.residual <= sol.report.residual_threshold);
//! assert!(sol.moments[0].mean > 0.0); // the state lives above the barrier at y = 0
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod decay;
mod error;
mod mechanics;
mod newton;
mod residual;
mod rule;
mod solution;
#[cfg(test)]
mod tests;

use std::time::Instant;

use nalgebra::DVector;

pub use crate::model::BarrierSide;
pub use error::{Divergence, EpcImpactError, Unsupported};
pub use rule::Window;
pub use solution::{DomainBarrier, EpcImpactReport, EpcImpactSolution, Normalisation};

use crate::dynamics::Dynamics;
use crate::epc::{Epc, EpcError, StartPoint, MAX_DEGREE};
use crate::model::BoundModel;
use crate::numerics::newton::pad;
use mechanics::{Mechanics, Wall};
use rule::System;
use std::borrow::Cow;

/// Gauss–Legendre panels per axis of the first rule (8 nodes each).
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// use fpsolve::epc_impact::{EpcImpact, DEFAULT_PANELS};
/// // The Gaussian root needs no refinement of the first rule.
/// assert_eq!(EpcImpact::new(&bound).solve(2)?.report.panels, DEFAULT_PANELS);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub const DEFAULT_PANELS: [usize; 2] = [12, 12];
/// The rule is accepted when doubling its panels changes ‖R‖ at the solution by at most the
/// solver's threshold or this much relative to max(1, ‖R‖ at the Gaussian-closure start)
/// (a quadrature error of the equations 1e−7 of their scale moves the coefficients by about
/// as much, far below the method's own error).
const QUADRATURE_TOLERANCE: f64 = 1e-7;
/// Most panels per axis the quadrature check may reach.
const MAX_PANELS: usize = 48;
/// The first box reaches this many closure standard deviations (e^−40.5 for a Gaussian).
const START_SPAN: f64 = 9.0;
/// Box refits per degree at most.
const BOX_ROUNDS: usize = 3;
/// A box is refitted when it is this many times wider than needed along an axis.
const WASTE: f64 = 1.6;
/// The density at the box's free edges must be below e^−this of its peak.
const EDGE_E_FOLDS: f64 = 36.0;
/// Inside a ridge the box's free edges must lie at least the ridge threshold less this many
/// e-folds below the peak (the box is fitted one e-fold above the pass; the root moves a
/// little when it is followed onto the fitted box).
const RIDGE_EDGE_MARGIN: f64 = 3.0;

/// An `epc-impact` problem: a bound model and options; [`EpcImpact::solve`] or
/// [`EpcImpact::solve_degrees`] runs it.
///
/// ```
/// use fpsolve::epc_impact::{EpcImpact, EpcImpactError, Unsupported};
/// // The Zhuravlev form is refused: this method takes the original coordinates.
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let err = EpcImpact::new(&bound).solve(4).unwrap_err();
/// assert!(matches!(err, EpcImpactError::Unsupported { reason: Unsupported::DeltaTerms { .. }, .. }));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct EpcImpact<'a> {
    model: &'a BoundModel,
    /// The model's reading when the caller has one ([`EpcImpact::reading`]).
    dynamics: Option<&'a Dynamics>,
    tolerance: f64,
    panels: [usize; 2],
    ridge_threshold: f64,
    barriers: Option<Vec<Wall>>,
}

/// A lower-degree solution (exponents, scaled coefficients) that starts the next degree.
type Start = (Vec<(usize, usize)>, DVector<f64>);

/// A solved degree before it is reported, and what the next degree starts from.
struct Solved {
    sys: System,
    a: DVector<f64>,
    report: EpcImpactReport,
}

/// What every degree shares.
struct Prepared {
    mech: Mechanics,
    sigma: [f64; 2],
    /// The closure's exponent (exponents of degree 2, scaled variables).
    closure: DVector<f64>,
    start: Window,
    /// The closure's mean, where the search for the density's peak starts.
    mean: [f64; 2],
}

impl<'a> EpcImpact<'a> {
    /// A problem for `model`: tolerance 1e−10, [`DEFAULT_PANELS`].
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).solve(2)?;
    /// assert_eq!(sol.degree, 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new(model: &'a BoundModel) -> EpcImpact<'a> {
        EpcImpact {
            model,
            dynamics: None,
            tolerance: 1e-10,
            panels: DEFAULT_PANELS,
            ridge_threshold: crate::epc::DEFAULT_RIDGE_THRESHOLD,
            barriers: None,
        }
    }

    /// The problem of a model already read (its model is `dynamics.model()`): the reading
    /// is used instead of a new one.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
    /// let sol = fpsolve::epc_impact::EpcImpact::reading(&dynamics).solve(2)?;
    /// assert_eq!(sol.degree, 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn reading(dynamics: &'a Dynamics) -> EpcImpact<'a> {
        EpcImpact {
            dynamics: Some(dynamics),
            ..EpcImpact::new(dynamics.model())
        }
    }

    /// Convergence: ‖R‖ ≤ tol·max(1, ‖R at the Gaussian-closure start‖).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).tolerance(1e-8).solve(2)?;
    /// assert!(sol.report.residual_threshold >= 1e-8);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tolerance(mut self, tol: f64) -> Self {
        self.tolerance = tol;
        self
    }

    /// Gauss–Legendre panels per axis of the first rule (even; the check doubles them as
    /// needed, up to 48).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).panels(24, 24).solve(2)?;
    /// assert!(sol.report.panels[0] >= 24);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn panels(mut self, nx: usize, nv: usize) -> Self {
        self.panels = [nx.max(2), 2 * nv.div_ceil(2).max(1)];
        self
    }

    /// The least depth (e-folds from the peak to the pass) of a ridge inside which a Q that
    /// grows along some ray of the domain is normalised (default 12, as the δ-term EPC).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// use fpsolve::epc_impact::{EpcImpact, EpcImpactError, Normalisation};
    /// // Case 1 of the paper at degree 4: a root that is a density only inside a ridge.
    /// let sol = EpcImpact::new(&bound).solve(4)?;
    /// let Normalisation::InsideRidge { depth, .. } = sol.report.normalisation else { panic!() };
    /// let err = EpcImpact::new(&bound).ridge_threshold(depth + 1.0).solve(4).unwrap_err();
    /// assert!(matches!(err, EpcImpactError::NotNormalisable { .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn ridge_threshold(mut self, e_folds: f64) -> Self {
        self.ridge_threshold = e_folds;
        self
    }

    /// Replaces the model's barriers (tests that set barriers in code on a barrier-free
    /// model).
    #[cfg(test)]
    pub(crate) fn barriers(mut self, barriers: Vec<Wall>) -> Self {
        self.barriers = Some(barriers);
        self
    }

    /// Whether the method handles the model, without solving: the refusals
    /// [`EpcImpact::solve`] would give before any work (a few milliseconds).
    ///
    /// # Errors
    /// [`EpcImpactError::Unsupported`] for a model the method does not handle, or the error
    /// reading its coefficients.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// // The Zhuravlev form (δ terms, a pass-through law) is refused.
    /// assert!(fpsolve::epc_impact::EpcImpact::new(&bound).check().is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn check(&self) -> Result<(), EpcImpactError> {
        self.mechanics(&self.dynamics()).map(|_| ())
    }

    /// The model's reading: the caller's, else a new one.
    fn dynamics(&self) -> Cow<'a, Dynamics> {
        match self.dynamics {
            Some(d) => Cow::Borrowed(d),
            None => Cow::Owned(Dynamics::read(self.model)),
        }
    }

    /// The model's mechanical form with its barriers (the injected ones, if any), checked to
    /// be none, one, or a strip.
    fn mechanics(&self, dynamics: &Dynamics) -> Result<Mechanics, EpcImpactError> {
        let mut mech = Mechanics::new(dynamics)?;
        if let Some(b) = &self.barriers {
            mech.barriers = b.clone();
        }
        mechanics::check_strip(&mech.barriers).map_err(|reason| EpcImpactError::Unsupported {
            model: self.model.name().to_string(),
            reason,
        })?;
        Ok(mech)
    }

    /// Solves at degree `n` by continuation through every lower even degree: what
    /// [`EpcImpact::solve_degrees`] gives for `n`.
    ///
    /// # Errors
    /// [`EpcImpactError`]: a refusal of the model, no root, no density, or a quadrature that
    /// does not settle.
    pub fn solve(&self, n: usize) -> Result<EpcImpactSolution, EpcImpactError> {
        self.solve_degrees(&[n]).remove(0)
    }

    /// Solves each degree asked (every even degree from 2 up to the largest is solved in
    /// turn, each started from the last success below it), one result per entry.
    ///
    /// ```
    /// use fpsolve::epc::EpcError;
    /// use fpsolve::epc_impact::{EpcImpact, EpcImpactError};
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let r = EpcImpact::new(&bound).solve_degrees(&[4, 3]);
    /// assert!(r[0].is_ok());
    /// assert!(matches!(r[1], Err(EpcImpactError::Epc(EpcError::OddDegree { degree: 3 }))));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn solve_degrees(
        &self,
        degrees: &[usize],
    ) -> Vec<Result<EpcImpactSolution, EpcImpactError>> {
        let checks: Vec<Result<(), EpcImpactError>> =
            degrees.iter().map(|&n| check_degree(n)).collect();
        let Some(max_n) = degrees
            .iter()
            .zip(&checks)
            .filter(|(_, c)| c.is_ok())
            .map(|(&n, _)| n)
            .max()
        else {
            return checks
                .into_iter()
                .map(|c| c.map(|_| unreachable!()))
                .collect();
        };
        let prep = match self.prepare() {
            Ok(p) => p,
            Err(e) => return degrees.iter().map(|_| Err(e.clone())).collect(),
        };
        let mut window = prep.start;
        let mut previous: Vec<Start> = Vec::new();
        let mut by_degree = Vec::new();
        for n in (2..=max_n).step_by(2) {
            // Each degree starts on the first rule: its failures (Levenberg–Marquardt from
            // every start) stay cheap, and the check refines the rule as this degree needs.
            let result = self.degree(&prep, n, window, self.panels, &previous);
            if let Ok(s) = &result {
                // The last two successes start the next degree (a root of degree n − 4
                // sometimes leads to degree n where the n − 2 one does not).
                previous.insert(0, (s.sys.exps.clone(), s.a.clone()));
                previous.truncate(2);
                window = s.sys.window;
            }
            if degrees.contains(&n) {
                by_degree.push((n, result.map(|s| finish(&prep, s))));
            }
        }
        degrees
            .iter()
            .zip(checks)
            .map(|(&n, check)| {
                check?;
                by_degree
                    .iter()
                    .find(|(d, _)| *d == n)
                    .map(|(_, r)| r.clone())
                    .expect("every valid degree asked was solved")
            })
            .collect()
    }

    /// The mechanics, the closure's scales and exponent, and the first box.
    fn prepare(&self) -> Result<Prepared, EpcImpactError> {
        let dynamics = self.dynamics();
        let mech = self.mechanics(&dynamics)?;
        // The Gaussian closure of the model without its barrier gives the scales and the
        // first start.
        let mut fpk = crate::fpk::FpkOperator::of(&dynamics)?;
        fpk.impact = None;
        let gauss = Epc::new(&fpk).degree(2).solve()?;
        let closure = gauss.closure.clone().ok_or(EpcError::Closure {
            reason: "no Gaussian closure was computed".into(),
            residual: f64::NAN,
        })?;
        let sigma = closure.std_devs();
        let mu = closure.mean;
        let exps = crate::numerics::poly2d::exponents(2);
        let start = DVector::from_iterator(
            exps.len(),
            exps.iter().map(|&(i, j)| {
                gauss.coefficient(i, j) * sigma[0].powi(i as i32) * sigma[1].powi(j as i32)
            }),
        );
        let mut x = [mu[0] - START_SPAN * sigma[0], mu[0] + START_SPAN * sigma[0]];
        for b in &mech.barriers {
            match b.side {
                BarrierSide::Above => {
                    x = [b.at(), x[1].max(b.at() + START_SPAN * sigma[0])];
                }
                BarrierSide::Below => {
                    x = [x[0].min(b.at() - START_SPAN * sigma[0]), b.at()];
                }
            }
        }
        if let [lo, hi] = mech.barriers.as_slice() {
            x = [lo.at(), hi.at()];
        }
        let vmax = mu[1].abs() + START_SPAN * sigma[1];
        Ok(Prepared {
            mech,
            sigma,
            closure: start,
            mean: mu,
            start: Window {
                x,
                v: [-vmax, vmax],
            },
        })
    }

    /// Solves degree `n` on `window`, refits the box and checks the quadrature.
    fn degree(
        &self,
        prep: &Prepared,
        n: usize,
        window: Window,
        panels: [usize; 2],
        previous: &[Start],
    ) -> Result<Solved, EpcImpactError> {
        let t0 = Instant::now();
        let (mech, sigma) = (&prep.mech, prep.sigma);
        let mut sys = System::build(mech, sigma, window, panels, n)?;
        let closure = pad(
            &prep.closure,
            &crate::numerics::poly2d::exponents(2),
            &sys.exps,
        );
        let reference = sys.residual(&closure).norm();
        let threshold = self.tolerance * reference.max(1.0);
        let mut starts = Vec::new();
        for (e, a) in previous {
            let degree = e.iter().map(|x| x.0 + x.1).max().unwrap_or(0);
            starts.push((StartPoint::LowerDegree { degree }, pad(a, e, &sys.exps)));
        }
        starts.push((StartPoint::GaussianClosure, closure));
        let (mut a, converged) = newton::solve(&sys, n, &starts, threshold)?;
        let scaled: Vec<(f64, BarrierSide)> = mech
            .barriers
            .iter()
            .map(|b| (b.at() / sigma[0], b.side))
            .collect();
        let not_normalisable = |reason| EpcImpactError::NotNormalisable { degree: n, reason };
        let xs = |w: &Window| [w.x[0] / sigma[0], w.x[1] / sigma[0]];
        let rays = |sys: &System, a: &DVector<f64>| {
            decay::check(&sys.exps, a.as_slice(), &scaled, xs(&sys.window))
        };
        let mut refits = 0;
        let refit = |sys: &System, a: &DVector<f64>, what| {
            let (a, residual, _, stop) =
                crate::numerics::newton::newton(sys, a, threshold, &newton::NEWTON);
            if stop == crate::numerics::newton::NewtonStop::Converged {
                Ok(a)
            } else {
                Err(EpcImpactError::Refit {
                    degree: n,
                    what,
                    residual,
                    threshold,
                })
            }
        };
        let fit = |sys: &System, a: &DVector<f64>| -> Result<decay::Fit, EpcImpactError> {
            let decays = rays(sys, a).is_ok();
            let w = sys.window;
            let mode = [
                prep.mean[0].clamp(w.x[0], w.x[1]),
                prep.mean[1].clamp(w.v[0], w.v[1]),
            ];
            let fit = decay::fit_box(
                &sys.exps,
                a.as_slice(),
                sigma,
                &mech.barriers,
                sys.window,
                mode,
                decays,
            )
            .map_err(not_normalisable)?;
            if !decays && fit.depth < self.ridge_threshold {
                return Err(not_normalisable(Divergence::ShallowRidge {
                    depth: fit.depth,
                    threshold: self.ridge_threshold,
                }));
            }
            Ok(fit)
        };
        for _ in 0..BOX_ROUNDS {
            let fitted = fit(&sys, &a)?.window;
            let w = sys.window;
            let contained = fitted.x[0] >= w.x[0]
                && fitted.x[1] <= w.x[1]
                && fitted.v[0] >= w.v[0]
                && fitted.v[1] <= w.v[1];
            let wasteful = w.x[1] - w.x[0] > WASTE * (fitted.x[1] - fitted.x[0])
                || w.v[1] - w.v[0] > WASTE * (fitted.v[1] - fitted.v[0]);
            if contained && !wasteful {
                break;
            }
            sys = System::build(mech, sigma, fitted, sys.panels, n)?;
            a = refit(&sys, &a, "box")?;
            refits += 1;
        }
        let quadrature_change = loop {
            let p = sys.panels;
            let fine = System::build(mech, sigma, sys.window, [2 * p[0], 2 * p[1]], n)?;
            let change = fine.residual(&a).norm();
            if change <= threshold.max(QUADRATURE_TOLERANCE * reference.max(1.0)) {
                break change;
            }
            if 2 * p[0] > MAX_PANELS || 2 * p[1] > MAX_PANELS {
                return Err(EpcImpactError::Quadrature {
                    degree: n,
                    panels: p,
                    change,
                    threshold,
                });
            }
            sys = fine;
            a = refit(&sys, &a, "quadrature")?;
            refits += 1;
        };
        // The final coefficients: on the plane of D, or inside a ridge deep enough.
        let final_fit = fit(&sys, &a)?;
        let normalisation = match rays(&sys, &a) {
            Ok(()) => Normalisation::Domain,
            Err(ray) => Normalisation::InsideRidge {
                depth: final_fit.depth,
                ray,
            },
        };
        let peak = sys.peak(&a);
        let q_peak = rule::q_at(&sys.exps, a.as_slice(), peak[0], peak[1]);
        let edge_e_folds = decay::edge_e_folds(
            &sys.exps,
            a.as_slice(),
            sigma,
            &mech.barriers,
            sys.window,
            q_peak,
        );
        let least = match normalisation {
            Normalisation::Domain => EDGE_E_FOLDS,
            Normalisation::InsideRidge { .. } => self.ridge_threshold - RIDGE_EDGE_MARGIN,
        };
        if edge_e_folds < least {
            return Err(not_normalisable(Divergence::Unbounded {
                x: sys.window.x,
                v: sys.window.v,
                edge_e_folds,
                limit: least,
            }));
        }
        let residual = sys.residual(&a).norm();
        let fpk = sys.fpk_residual(mech, &a);
        let report = EpcImpactReport {
            degree: n,
            method: converged.method,
            iterations: converged.iterations,
            residual,
            residual_threshold: threshold,
            panels: sys.panels,
            quadrature_change,
            fpk_residual: fpk.map(|r| r.interior + r.boundary),
            fpk_boundary_residual: fpk.map(|r| r.boundary),
            refits,
            normalisation,
            edge_e_folds,
            solve_ms: t0.elapsed().as_secs_f64() * 1e3,
        };
        Ok(Solved { sys, a, report })
    }
}

/// The reported solution of a solved degree.
fn finish(prep: &Prepared, s: Solved) -> EpcImpactSolution {
    let sigma = prep.sigma;
    let coefficients = s
        .sys
        .exps
        .iter()
        .zip(s.a.iter())
        .map(|(&(i, j), a)| a / (sigma[0].powi(i as i32) * sigma[1].powi(j as i32)))
        .collect();
    EpcImpactSolution {
        degree: s.report.degree,
        exponents: s.sys.exps.clone(),
        coefficients,
        scaled_coefficients: s.a.iter().copied().collect(),
        sigma,
        barriers: prep
            .mech
            .barriers
            .iter()
            .map(|b| DomainBarrier {
                at: b.at(),
                side: b.side,
            })
            .collect(),
        window: s.sys.window,
        log_c: -s.sys.log_z(&s.a),
        moments: s.sys.moments(&s.a),
        report: s.report,
    }
}

fn check_degree(n: usize) -> Result<(), EpcImpactError> {
    if !(2..=MAX_DEGREE).contains(&n) {
        Err(EpcError::Degree {
            degree: n,
            max: MAX_DEGREE,
        }
        .into())
    } else if n % 2 == 1 {
        Err(EpcError::OddDegree { degree: n }.into())
    } else {
        Ok(())
    }
}
