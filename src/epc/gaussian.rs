//! The Gaussian of the closure in the solver's scaled variables: the start it gives every
//! degree, and the Galerkin tables of the operator for which it is exact (the λ = 0 end of
//! the operator homotopy).

use nalgebra::{DVector, Matrix2};

use super::closure;
use super::galerkin::MomentTables;
use super::Prepared;

impl Prepared {
    /// The moment tables of an affine-drift, constant-diffusion operator (in scaled
    /// variables) whose exact stationary density is the closure Gaussian N(μ, Λ⁻¹): diffusion
    /// B̄ = the weighted mean of the real B, drift A(ξ) = (B̄ + W)Λ(ξ − μ) with W the
    /// antisymmetric part of the weighted mean of A(ξ)ξᵀ (the circulation an oscillator's
    /// drift carries), and A0 = B̄:Λ, so that F of Eq. 18 vanishes identically for Q = −½(ξ−μ)ᵀΛ(ξ−μ).
    pub(super) fn gaussian_exact_moments(&self, real: &MomentTables) -> MomentTables {
        let (mu, lam) = self.closure_scaled();
        let b = Matrix2::new(
            real.get(3, 0, 0),
            real.get(4, 0, 0),
            real.get(4, 0, 0),
            real.get(5, 0, 0),
        );
        let x = Matrix2::new(
            real.get(1, 1, 0),
            real.get(1, 0, 1),
            real.get(2, 1, 0),
            real.get(2, 0, 1),
        );
        let w = 0.5 * (x[(0, 1)] - x[(1, 0)]);
        let beta = (b + Matrix2::new(0.0, w, -w, 0.0)) * lam;
        let affine = |i: usize| {
            [
                -(beta[(i, 0)] * mu[0] + beta[(i, 1)] * mu[1]),
                beta[(i, 0)],
                beta[(i, 1)],
            ]
        };
        let a0 = b[(0, 0)] * lam[(0, 0)] + 2.0 * b[(0, 1)] * lam[(0, 1)] + b[(1, 1)] * lam[(1, 1)];
        let k = [
            [a0, 0.0, 0.0],
            affine(0),
            affine(1),
            [b[(0, 0)], 0.0, 0.0],
            [b[(0, 1)], 0.0, 0.0],
            [b[(1, 1)], 0.0, 0.0],
        ];
        MomentTables::affine(&k, real.max_degree())
    }

    /// The closure Gaussian (or the weights' Gaussian when σ were overridden) in scaled
    /// variables ξ = x/σ: mean μ/σ and precision matrix (covariance/(σσ))⁻¹.
    fn closure_scaled(&self) -> ([f64; 2], Matrix2<f64>) {
        let s = self.sigma;
        let (mean, p) = match &self.closure {
            Some(c) => (c.mean, c.covariance),
            None => ([0.0; 2], [[s[0] * s[0], 0.0], [0.0, s[1] * s[1]]]),
        };
        let m = [mean[0] / s[0], mean[1] / s[1]];
        let p = [
            [p[0][0] / (s[0] * s[0]), p[0][1] / (s[0] * s[1])],
            [p[0][1] / (s[0] * s[1]), p[1][1] / (s[1] * s[1])],
        ];
        (m, closure::precision(p))
    }

    /// The closure Gaussian (or the weights' Gaussian when σ were overridden) as a start.
    pub(super) fn closure_start(&self, exps: &[(usize, usize)]) -> DVector<f64> {
        let (m, l) = self.closure_scaled();
        // −½(ξ−m)ᵀΛ(ξ−m) without its constant.
        DVector::from_iterator(
            exps.len(),
            exps.iter().map(|&e| match e {
                (1, 0) => l[(0, 0)] * m[0] + l[(0, 1)] * m[1],
                (0, 1) => l[(1, 0)] * m[0] + l[(1, 1)] * m[1],
                (2, 0) => -0.5 * l[(0, 0)],
                (1, 1) => -l[(0, 1)],
                (0, 2) => -0.5 * l[(1, 1)],
                _ => 0.0,
            }),
        )
    }
}
