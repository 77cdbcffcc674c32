//! The solved density p(x) = C·exp(Q(x)) and what users read from it.

use serde::Serialize;

use super::closure::GaussianClosure;
use super::normalise::{DensityGrid, NormalisationReport, Poly};
use super::outcome::Method;
use crate::moments::Moments;

/// Timings and convergence of one solve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolveReport {
    /// The degree n.
    pub degree: usize,
    /// The method that converged and its start (`summary.json` and the CLI print its
    /// `Display`).
    pub method: Method,
    /// Its iterations.
    pub iterations: usize,
    /// Final ‖R‖ in scaled variables (test functions ξ^e·φ(ξ1)φ(ξ2)), recomputed from the
    /// returned coefficients.
    pub residual: f64,
    /// The bound ‖R‖ had to reach: tolerance·max(1, ‖R‖ at the Gaussian-closure start).
    pub residual_threshold: f64,
    /// Gauss nodes per piece of each axis.
    pub quadrature_order: usize,
    /// Whether the order came from a convergence check (non-polynomial coefficients).
    pub order_checked: bool,
    /// Milliseconds for the Gaussian closure (shared by all degrees of one problem).
    pub closure_ms: f64,
    /// Milliseconds for the quadrature moment tables (shared) and this degree's assembly.
    pub assembly_ms: f64,
    /// Milliseconds in the nonlinear solver at this degree.
    pub solve_ms: f64,
    /// Milliseconds for the normalisation (region, grid, normalising integral).
    pub normalise_ms: f64,
    /// Milliseconds for the FPK residual indicator ∫|F|·p dx.
    pub fpk_residual_ms: f64,
}

/// An EPC solution.
#[derive(Clone, Debug, Serialize)]
pub struct EpcSolution {
    /// The degree n of Q.
    pub degree: usize,
    /// Exponents (i, j) of the monomials x1^i x2^j.
    pub exponents: Vec<(usize, usize)>,
    /// Coefficients of Q in original variables.
    pub coefficients: Vec<f64>,
    /// Coefficients of Q in scaled variables ξ_i = x_i/σ_i.
    pub scaled_coefficients: Vec<f64>,
    /// The weights' σ_i (Eqs. 21–22).
    pub sigma: [f64; 2],
    /// The Gaussian closure (None when both σ were given).
    pub closure: Option<GaussianClosure>,
    /// How the density was normalised.
    pub normalisation: NormalisationReport,
    /// How it was solved.
    pub solve: SolveReport,
    /// Moments of each state, from its marginal on the normalisation grid (raw moments
    /// E\[x^k\], k ≤ 4; mean, variance and kurtosis computed as central moments on the grid).
    pub moments: [Moments; 2],
    /// FPK residual indicator ∫|F|·p dx, with F of Eq. 18 as a measure (regular part on the
    /// normalisation grid plus the δ lines' line integrals): 0 for an exact solution.
    pub fpk_residual: f64,
    #[serde(skip)]
    pub(crate) q: Poly,
    #[serde(skip)]
    pub(crate) grid: DensityGrid,
}

impl EpcSolution {
    pub(crate) fn from_parts(
        q: Poly,
        grid: DensityGrid,
        sigma: [f64; 2],
        closure: Option<GaussianClosure>,
        normalisation: NormalisationReport,
        solve: SolveReport,
        fpk_residual: f64,
    ) -> EpcSolution {
        let exps = q.exps.clone();
        let coefficients = exps
            .iter()
            .zip(&q.a)
            .map(|(&(i, j), a)| a / (sigma[0].powi(i as i32) * sigma[1].powi(j as i32)))
            .collect();
        let mut s = EpcSolution {
            degree: q.degree,
            exponents: exps,
            coefficients,
            scaled_coefficients: q.a.clone(),
            sigma,
            closure,
            normalisation,
            solve,
            moments: [Moments::from_raw([0.0; 4]); 2],
            fpk_residual,
            q,
            grid,
        };
        s.moments = [0, 1].map(|a| s.state_moments(a));
        s
    }

    /// The moments of state `axis` by the trapezoid rule on the normalisation grid (the
    /// marginal vanishes at the grid's ends). Mean, variance and kurtosis are the grid's
    /// central moments, not recombined from the raw ones (which would cancel digits).
    fn state_moments(&self, axis: usize) -> Moments {
        let (x, p) = self.marginal_grid(axis);
        let h = x[1] - x[0];
        let m = |f: &dyn Fn(f64) -> f64| x.iter().zip(&p).map(|(x, p)| f(*x) * p).sum::<f64>() * h;
        let mean = m(&|x| x);
        let var = m(&|x| (x - mean).powi(2));
        let m4 = m(&|x| (x - mean).powi(4));
        Moments {
            raw: [1, 2, 3, 4].map(|k| m(&|x| x.powi(k))),
            mean,
            variance: var,
            kurtosis: m4 / (var * var),
        }
    }

    /// The coefficient of x1^i x2^j in Q (original variables), 0 if not in the basis.
    pub fn coefficient(&self, i: usize, j: usize) -> f64 {
        self.exponents
            .iter()
            .position(|&e| e == (i, j))
            .map_or(0.0, |k| self.coefficients[k])
    }

    /// ln C, with p(x) = C·exp(Q(x)).
    pub fn log_c(&self) -> f64 {
        self.normalisation.log_c
    }

    /// The joint density at a point: C·exp(Q) on the plane; inside a ridge
    /// ([`NormalisationKind::InsideRidge`](super::NormalisationKind::InsideRidge)) 0 outside
    /// the region and cut off smoothly to 0 across the last e-fold above its edge, the same
    /// density the normalising integral integrates.
    pub fn pdf(&self, x1: f64, x2: f64) -> f64 {
        let xi = [x1 / self.sigma[0], x2 / self.sigma[1]];
        let q = self.q.eval(xi);
        let w = self.grid.weight(xi, q);
        if w == 0.0 {
            return 0.0;
        }
        (q + self.log_c()).exp() * w
    }

    /// The marginal density of state `axis` (0 or 1) on the normalisation grid (original
    /// units), trimmed to where it is at least 1e−8 of its peak (plus one point).
    pub fn marginal(&self, axis: usize) -> (Vec<f64>, Vec<f64>) {
        let (x, p) = self.marginal_grid(axis);
        let peak = p.iter().copied().fold(0.0, f64::max);
        let first = p.iter().position(|v| *v >= 1e-8 * peak).unwrap_or(0);
        let last = p
            .iter()
            .rposition(|v| *v >= 1e-8 * peak)
            .unwrap_or(p.len() - 1);
        let (a, b) = (first.saturating_sub(1), (last + 1).min(p.len() - 1));
        (x[a..=b].to_vec(), p[a..=b].to_vec())
    }

    /// The full-grid marginal (original units).
    fn marginal_grid(&self, axis: usize) -> (Vec<f64>, Vec<f64>) {
        let g = &self.grid;
        let (n1, n2) = (g.g1.len(), g.g2.len());
        let mut p = vec![0.0; if axis == 0 { n1 } else { n2 }];
        for i in 0..n1 {
            for j in 0..n2 {
                let v = g.p[i * n2 + j];
                if axis == 0 {
                    p[i] += v * g.h[1];
                } else {
                    p[j] += v * g.h[0];
                }
            }
        }
        let (grid, s) = if axis == 0 {
            (&g.g1, self.sigma[0])
        } else {
            (&g.g2, self.sigma[1])
        };
        (
            grid.iter().map(|t| t * s).collect(),
            p.iter().map(|v| v / s).collect(),
        )
    }

    /// The marginal density of state `axis` at `x` (original units), by the trapezoid rule
    /// over the other state on the normalisation grid.
    pub fn marginal_at(&self, axis: usize, x: f64) -> f64 {
        let g = &self.grid;
        let t = x / self.sigma[axis];
        let (other, h) = if axis == 0 {
            (&g.g2, g.h[1])
        } else {
            (&g.g1, g.h[0])
        };
        let mut sum = 0.0;
        for &u in other {
            let xi = if axis == 0 { [t, u] } else { [u, t] };
            let q = self.q.eval(xi);
            let w = g.weight(xi, q);
            if w > 0.0 {
                sum += (q - g.log_z).exp() * w;
            }
        }
        sum * h / self.sigma[axis]
    }

    /// P(|x_axis| > a), from the marginal on the grid.
    pub fn tail_probability(&self, axis: usize, a: f64) -> f64 {
        let (x, p) = self.marginal_grid(axis);
        let h = x[1] - x[0];
        let mut s = 0.0;
        for w in 0..x.len() - 1 {
            // Trapezoid cell [x_w, x_w+1], clipped to |x| > a by linear interpolation.
            let (x0, x1, p0, p1) = (x[w], x[w + 1], p[w], p[w + 1]);
            for (lo, hi) in [(f64::NEG_INFINITY, -a), (a, f64::INFINITY)] {
                let l = x0.max(lo);
                let u = x1.min(hi);
                if u > l {
                    let f = |t: f64| p0 + (p1 - p0) * (t - x0) / h;
                    s += 0.5 * (f(l) + f(u)) * (u - l);
                }
            }
        }
        s
    }
}
