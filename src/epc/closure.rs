//! Gaussian closure of the model, computed by the engine itself: the mean μ and covariance P
//! for which a Gaussian N(μ, P) satisfies the first- and second-moment equations,
//! E[m] = 0 and E[m (X−μ)ᵀ] + E[(X−μ) mᵀ] + E[b] = 0.
//!
//! The equations are taken in the equivalent weak form ∫ F(x; Q) N(x; μ, P) g(x) dx = 0 with
//! Q = −½(x−μ)ᵀP⁻¹(x−μ), F from Eq. 18 and g ∈ {y1, y2, y1², y1y2, y2²}, y = x − μ (integrating
//! the FPK operator against g gives the moment equations), so the δ lines of the operator enter
//! exactly as in the Galerkin system. Expectations use a Gauss rule in a frame ξ = (x−c)/s;
//! the frame is moved to the current estimate until it coincides with the solution, where (for
//! an uncorrelated solution) the integrands are piecewise polynomials integrated exactly.

use nalgebra::{DMatrix, DVector, Matrix2};
use serde::Serialize;

use super::coefficients::{Coefficients, Point};
use super::exp::exp_in_place;
use super::EpcError;
use crate::model::DeltaTreatment;

/// The Gaussian closure: a Gaussian whose first two moments satisfy the moment equations.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
/// let cl = sol.closure.unwrap();
/// // The linear oscillator's closure is its exact Gaussian: Var z = πK/(ck) = 5.
/// assert!((cl.covariance[0][0] - 5.0).abs() < 1e-8 && cl.covariance[0][1].abs() < 1e-10);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GaussianClosure {
    /// The mean μ.
    pub mean: [f64; 2],
    /// The covariance P.
    pub covariance: [[f64; 2]; 2],
    /// How many quadrature frames were used.
    pub frames: usize,
    /// The final residual norm of the five moment equations (relative to their scale).
    pub residual: f64,
}

impl GaussianClosure {
    /// The standard deviations √P_ii.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let cl = Epc::new(&fpk).degree(2).solve().unwrap().closure.unwrap();
    /// assert!((cl.std_devs()[1] - 5.0_f64.sqrt()).abs() < 1e-8);
    /// ```
    pub fn std_devs(&self) -> [f64; 2] {
        [self.covariance[0][0].sqrt(), self.covariance[1][1].sqrt()]
    }
}

/// A symmetric 2×2 matrix given as rows.
pub(crate) fn matrix(p: [[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(p[0][0], p[0][1], p[1][0], p[1][1])
}

/// The precision matrix P⁻¹ of a covariance P; NaN throughout for a singular P (which the
/// closure's |ρ| < 1 and the weights' σ > 0 exclude), so that nothing downstream converges.
pub(crate) fn precision(p: [[f64; 2]; 2]) -> Matrix2<f64> {
    matrix(p)
        .try_inverse()
        .unwrap_or_else(|| Matrix2::from_element(f64::NAN))
}

/// Unknowns relative to the frame: μ_i = c_i + s_i u_i, √P_ii = s_i e^{u_{2+i}}, ρ = tanh u_4.
fn decode(u: &[f64; 5], c: [f64; 2], s: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
    let mean = [c[0] + s[0] * u[0], c[1] + s[1] * u[1]];
    let sd = [s[0] * u[2].exp(), s[1] * u[3].exp()];
    let rho = u[4].tanh();
    let p12 = rho * sd[0] * sd[1];
    (mean, [[sd[0] * sd[0], p12], [p12, sd[1] * sd[1]]])
}

/// A frame's quadrature points with what the equations need of them beyond the point: the
/// frame's log-weight ½|ξ|² + ln(s1·s2) (the Gauss rule's normal weight, divided out), and a
/// buffer for the exponents of one evaluation (exponentiated together, vectorised).
struct Frame<'p> {
    pts: &'p [Point],
    /// ½|ξ|² + ln(s1·s2) at each point.
    base: Vec<f64>,
    /// The log of N(x; μ, P)/φ(ξ) at each point, then its exponential.
    ratio: Vec<f64>,
    /// y = x − μ and −Λy at each point, for the evaluation under way.
    centred: Vec<([f64; 2], [f64; 2])>,
}

impl<'p> Frame<'p> {
    fn new(pts: &'p [Point], c: [f64; 2], s: [f64; 2]) -> Frame<'p> {
        let log_s = (s[0] * s[1]).ln();
        let base = pts
            .iter()
            .map(|pt| {
                let xi = [(pt.x[0] - c[0]) / s[0], (pt.x[1] - c[1]) / s[1]];
                0.5 * (xi[0] * xi[0] + xi[1] * xi[1]) + log_s
            })
            .collect();
        Frame {
            pts,
            base,
            ratio: vec![0.0; pts.len()],
            centred: vec![([0.0; 2], [0.0; 2]); pts.len()],
        }
    }

    /// The five scaled moment equations and their scale under N(`mean`, `p`).
    fn equations(&mut self, mean: [f64; 2], p: [[f64; 2]; 2]) -> (DVector<f64>, f64) {
        let cov = matrix(p);
        let det = cov.determinant();
        let lam = precision(p);
        let sd = [p[0][0].sqrt(), p[1][1].sqrt()];
        let log_det = -0.5 * det.ln();
        for (((r, yd), pt), base) in self
            .ratio
            .iter_mut()
            .zip(&mut self.centred)
            .zip(self.pts)
            .zip(&self.base)
        {
            let y = [pt.x[0] - mean[0], pt.x[1] - mean[1]];
            // −∇ of ½ yᵀΛy.
            let dq = [
                -(lam[(0, 0)] * y[0] + lam[(0, 1)] * y[1]),
                -(lam[(1, 0)] * y[0] + lam[(1, 1)] * y[1]),
            ];
            *r = 0.5 * (y[0] * dq[0] + y[1] * dq[1]) + base + log_det;
            *yd = (y, dq);
        }
        exp_in_place(&mut self.ratio);
        let mut g = DVector::zeros(5);
        let mut scale = 0.0;
        for ((pt, r), &(y, dq)) in self.pts.iter().zip(&self.ratio).zip(&self.centred) {
            let terms = [
                pt.g[0],
                pt.g[1] * dq[0],
                pt.g[2] * dq[1],
                pt.g[3] * (dq[0] * dq[0] - lam[(0, 0)]),
                2.0 * pt.g[4] * (dq[0] * dq[1] - lam[(0, 1)]),
                pt.g[5] * (dq[1] * dq[1] - lam[(1, 1)]),
            ];
            let f: f64 = terms.iter().sum();
            let wr = pt.w * r;
            scale += wr * terms.iter().map(|t| t.abs()).sum::<f64>();
            let yh = [y[0] / sd[0], y[1] / sd[1]];
            let tests = [yh[0], yh[1], yh[0] * yh[0], yh[0] * yh[1], yh[1] * yh[1]];
            for (gk, t) in g.iter_mut().zip(tests) {
                *gk += wr * f * t;
            }
        }
        (g, scale)
    }
}

/// Solves the Gaussian closure.
pub(crate) fn gaussian_closure(
    coefs: &Coefficients,
    kinks: &[Vec<f64>; 2],
    treatment: DeltaTreatment,
    order: usize,
) -> Result<GaussianClosure, EpcError> {
    const MAX_FRAMES: usize = 80;
    const MEAN_STEP: f64 = 0.75;
    let sd_step = 1.5_f64.ln();
    let mut c = [0.0; 2];
    let mut s = [1.0; 2];
    let mut rho_u = 0.0;
    let mut best = f64::INFINITY;
    for frame in 1..=MAX_FRAMES {
        let pts = coefs.points(c, s, kinks, order, treatment)?;
        let mut frame_eqs = Frame::new(&pts, c, s);
        let mut eval = |u: &[f64; 5]| {
            let (m, p) = decode(u, c, s);
            frame_eqs.equations(m, p)
        };
        let mut u = [0.0, 0.0, 0.0, 0.0, rho_u];
        let (mut g, mut scale) = eval(&u);
        let mut clamped = false;
        let mut converged = false;
        for _ in 0..60 {
            let rel = g.norm() / scale.max(f64::MIN_POSITIVE);
            best = best.min(rel);
            if !rel.is_finite() {
                return Err(EpcError::Closure {
                    reason: format!("moment equations not finite in frame {frame}"),
                    residual: best,
                });
            }
            if rel < 1e-13 {
                converged = true;
                break;
            }
            // Forward differences from g: an error of order h in the Jacobian only slows the
            // last Newton step, whose residual the test above judges, not the root.
            let mut jac = DMatrix::zeros(5, 5);
            for j in 0..5 {
                let h = 1e-8 * u[j].abs().max(1.0);
                let mut up = u;
                up[j] += h;
                let col = (eval(&up).0 - &g) / (up[j] - u[j]);
                jac.set_column(j, &col);
            }
            let Some(step) = jac.lu().solve(&(-&g)) else {
                break;
            };
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                let mut un = u;
                for j in 0..5 {
                    un[j] += t * step[j];
                }
                let (gn, sn) = eval(&un);
                if gn.norm() < g.norm() * (1.0 - 1e-4 * t) || gn.norm() / sn < 1e-13 {
                    u = un;
                    g = gn;
                    scale = sn;
                    accepted = true;
                    break;
                }
                t *= 0.5;
            }
            if !accepted {
                break;
            }
            let lim = [MEAN_STEP, MEAN_STEP, sd_step, sd_step];
            for j in 0..4 {
                if u[j].abs() > lim[j] {
                    u[j] = u[j].clamp(-lim[j], lim[j]);
                    clamped = true;
                }
            }
            let rho_clamped = u[4].abs() > 3.0;
            u[4] = u[4].clamp(-3.0, 3.0);
            if clamped {
                break;
            }
            if rho_clamped {
                // g is the residual at the unclamped point: taken again at the clamped one.
                (g, scale) = eval(&u);
            }
        }
        let (mean, p) = decode(&u, c, s);
        let moved = u[..4].iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        if converged && !clamped && moved < 1e-9 {
            return Ok(GaussianClosure {
                mean,
                covariance: p,
                frames: frame,
                residual: g.norm() / scale,
            });
        }
        // Move the frame to the current estimate (when the Newton iteration stalls, to the
        // best point it reached) and try again.
        c = mean;
        s = [p[0][0].sqrt(), p[1][1].sqrt()];
        rho_u = u[4];
    }
    Err(EpcError::Closure {
        reason: format!("no fixed frame after {MAX_FRAMES} frames"),
        residual: best,
    })
}
