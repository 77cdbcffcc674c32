//! The solved density p = C·exp(Q) on the domain of the original coordinates, and its report.

use serde::Serialize;

use super::rule::{powers, q_at, Window};
use crate::density::JointDensity;
use crate::epc::SolverMethod;
use crate::epc::MAX_DEGREE;
use crate::model::BarrierSide;
use crate::stats::Moments;

/// A barrier of the solved domain.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).solve(2)?;
/// assert_eq!(sol.barriers.len(), 1);
/// assert_eq!(sol.barriers[0].at, 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DomainBarrier {
    /// Its position.
    pub at: f64,
    /// The side of it the state lives on.
    pub side: BarrierSide,
}

/// How the solved exp(Q) is a density.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// use fpsolve::epc_impact::{EpcImpact, Normalisation};
/// // The degree-2 (Gaussian) root decays along every ray of y ≥ 0.
/// let sol = EpcImpact::new(&bound).solve(2)?;
/// assert_eq!(sol.report.normalisation, Normalisation::Domain);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Normalisation {
    /// Q → −∞ along every ray of the domain: exp(Q) is integrable on all of it (the window
    /// holds all but e^−36 of the peak value).
    Domain,
    /// Q grows again beyond a ridge `depth` e-folds below the peak (along `ray`): the density
    /// is exp(Q) on the window, the part of the domain inside the ridge, whose free edges lie
    /// about `depth` − 1 e-folds below the peak; zero beyond it.
    InsideRidge {
        /// e-folds from the peak to the ridge's pass.
        depth: f64,
        /// A ray of the domain along which Q does not decay.
        #[serde(skip)]
        ray: super::Divergence,
    },
}

impl std::fmt::Display for Normalisation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Normalisation::Domain => f.write_str("on the whole domain"),
            Normalisation::InsideRidge { depth, .. } => {
                write!(
                    f,
                    "inside a ridge {} e-folds deep",
                    crate::epc::EFolds(*depth)
                )
            }
        }
    }
}

/// How one degree was solved.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let r = fpsolve::epc_impact::EpcImpact::new(&bound).solve(4)?.report;
/// assert!(r.residual <= r.residual_threshold);
/// assert!(r.quadrature_change < 1e-7);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EpcImpactReport {
    /// The degree n.
    pub degree: usize,
    /// The method that converged on the first box, with its start.
    pub method: SolverMethod,
    /// Its iterations.
    pub iterations: usize,
    /// ‖R‖ at the returned coefficients, on the final box and quadrature (scaled variables,
    /// density normalised on the box).
    pub residual: f64,
    /// The bound ‖R‖ had to reach: tolerance·max(1, ‖R‖ at the Gaussian-closure start).
    pub residual_threshold: f64,
    /// Gauss–Legendre panels of the final rule, [position, velocity] (8 nodes each).
    pub panels: [usize; 2],
    /// ‖R‖ at the solution on a rule with twice the panels per axis: the quadrature error
    /// of the equations, below `residual_threshold` or 1e−7 of their scale.
    pub quadrature_change: f64,
    /// How far the density is from solving the FPK equation: ∫∫_D |F|·p dx dv, F = (L*p)/p
    /// with L* the FPK operator (as the δ-term EPC reports it), plus the boundary residual
    /// [`fpk_boundary_residual`](Self::fpk_boundary_residual). `None` when the drift's or
    /// diffusion's velocity derivatives have δ terms (sgn(v) in the drift, say).
    pub fpk_residual: Option<f64>,
    /// The impact condition's part of `fpk_residual`: Σ_barriers ∫_{arriving v}
    /// | |v|·p(x_b, v) − |map v|·p(x_b, map v)·|map′(v)| | dv, the mismatch between the flux
    /// arriving at each velocity and the flux the law sends back.
    pub fpk_boundary_residual: Option<f64>,
    /// Times the root was followed by Newton onto a refitted box or a finer rule.
    pub refits: usize,
    /// Whether exp(Q) decays along every ray of the domain, or is a density only inside a
    /// ridge.
    pub normalisation: Normalisation,
    /// ln(peak/largest value on the box's free edges): at least 36 (the density is below
    /// about 2e−16 of its peak outside the box) when Q decays along every ray of the domain;
    /// inside a ridge at least the ridge threshold less 3.
    pub edge_e_folds: f64,
    /// Milliseconds for this degree (assembly, solves, checks).
    pub solve_ms: f64,
}

/// An `epc-impact` solution: p(x, v) = C·exp(Q_n(x, v)) on the domain (zero outside).
///
/// ```
/// use fpsolve::epc_impact::EpcImpact;
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// let set = ["r=1".parse()?, "eps=0".parse()?];
/// let bound = fpsolve::model::load_model(&path)?.bind(&set)?;
/// let sol = EpcImpact::new(&bound).solve(4)?;
/// // Elastic impacts: the Duffing density restricted to y > 0,
/// // exp(−0.2(v²/2 + y²/2 + 0.1 y⁴/4)).
/// assert!((sol.coefficient(0, 2) + 0.1).abs() < 1e-9);
/// assert!((sol.coefficient(4, 0) + 0.005).abs() < 1e-9);
/// assert_eq!(sol.pdf(-0.1, 0.0), 0.0); // below the barrier
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Serialize)]
pub struct EpcImpactSolution {
    /// The degree n of Q.
    pub degree: usize,
    /// Exponents (i, j) of the monomials x^i v^j.
    pub exponents: Vec<(usize, usize)>,
    /// Coefficients of Q in original variables.
    pub coefficients: Vec<f64>,
    /// Coefficients of Q in scaled variables ξ = x/σx, η = v/σv.
    pub scaled_coefficients: Vec<f64>,
    /// The scales σx, σv (the Gaussian closure's standard deviations).
    pub sigma: [f64; 2],
    /// The barriers bounding the domain (none: the plane).
    pub barriers: Vec<DomainBarrier>,
    /// The box of the domain holding all but e^−36 of the density's peak value.
    pub window: Window,
    /// ln C.
    pub log_c: f64,
    /// Moments of each state (E\[x^k\], k ≤ 4; mean, variance and kurtosis as central
    /// moments), by the method's quadrature.
    pub moments: [Moments; 2],
    /// How it was solved.
    pub report: EpcImpactReport,
}

impl EpcImpactSolution {
    /// The coefficient of x^i v^j in Q (original variables), 0 if not in the basis.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).solve(2)?;
    /// assert!(sol.coefficient(0, 2) < 0.0 && sol.coefficient(5, 0) == 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn coefficient(&self, i: usize, j: usize) -> f64 {
        self.exponents
            .iter()
            .position(|&e| e == (i, j))
            .map_or(0.0, |k| self.coefficients[k])
    }

    /// Whether (x, v) lies in the domain (and, inside a ridge, in the window).
    fn admits(&self, x: f64, v: f64) -> bool {
        let window = match self.report.normalisation {
            Normalisation::Domain => true,
            Normalisation::InsideRidge { .. } => {
                let w = &self.window;
                w.x[0] <= x && x <= w.x[1] && w.v[0] <= v && v <= w.v[1]
            }
        };
        window
            && self.barriers.iter().all(|b| match b.side {
                BarrierSide::Above => x >= b.at,
                BarrierSide::Below => x <= b.at,
            })
    }

    /// The joint density at (x, v): C·exp(Q) in the domain, 0 outside (and, inside a ridge,
    /// 0 outside the window).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).solve(4)?;
    /// assert!(sol.pdf(0.5, 0.0) > 0.0 && sol.pdf(-0.5, 0.0) == 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn pdf(&self, x: f64, v: f64) -> f64 {
        if !self.admits(x, v) {
            return 0.0;
        }
        let q = q_at(
            &self.exponents,
            &self.scaled_coefficients,
            x / self.sigma[0],
            v / self.sigma[1],
        );
        (q + self.log_c).exp()
    }
}

impl EpcImpactSolution {
    /// [`EpcImpactSolution::pdf`] on the tensor grid `x1` × `x2` into `out` (row-major in x1),
    /// bit for bit: the same monomials (c·ξ^i)·η^j summed in the same order as `q_at`, with
    /// c·ξ^i taken once per row and the powers of η once per column.
    fn pdf_on_grid(&self, x1: &[f64], x2: &[f64], out: &mut [f64]) {
        assert_eq!(out.len(), x1.len() * x2.len(), "pdf_on_grid: output size");
        let (exps, a) = (&self.exponents, &self.scaled_coefficients);
        let n = exps.iter().map(|e| e.0 + e.1).max().unwrap_or(0);
        let columns: Vec<[f64; MAX_DEGREE + 1]> = x2
            .iter()
            .map(|v| {
                let mut p = [0.0; MAX_DEGREE + 1];
                powers(v / self.sigma[1], n, &mut p);
                p
            })
            .collect();
        let mut row = vec![0.0; exps.len()];
        let mut p1 = [0.0; MAX_DEGREE + 1];
        for (i, &x) in x1.iter().enumerate() {
            powers(x / self.sigma[0], n, &mut p1);
            for (r, (&(e1, _), c)) in row.iter_mut().zip(exps.iter().zip(a)) {
                *r = c * p1[e1];
            }
            for ((o, &v), p2) in out[i * x2.len()..].iter_mut().zip(x2).zip(&columns) {
                *o = if self.admits(x, v) {
                    let q: f64 = row.iter().zip(exps).map(|(r, &(_, e2))| r * p2[e2]).sum();
                    (q + self.log_c).exp()
                } else {
                    0.0
                };
            }
        }
    }
}

impl JointDensity for EpcImpactSolution {
    fn pdf(&self, x: [f64; 2]) -> f64 {
        EpcImpactSolution::pdf(self, x[0], x[1])
    }

    /// Bit for bit `pdf` at each point, with the powers shared along rows and columns.
    fn pdf_on_grid(&self, x1: &[f64], x2: &[f64], out: &mut [f64]) {
        EpcImpactSolution::pdf_on_grid(self, x1, x2, out);
    }

    /// The solution's window: its barrier edges are the barriers, its free edges lie where
    /// the density is below e^−36 of its peak.
    fn extent(&self) -> [[f64; 2]; 2] {
        [self.window.x, self.window.v]
    }
}
