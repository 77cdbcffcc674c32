//! The polynomial Q(ξ) of a solution in scaled variables, with the evaluations the
//! normalisation needs (values, derivatives, restrictions to rays, tensor grids).

/// A polynomial Q(ξ) = Σ a_s ξ1^i ξ2^j.
#[derive(Clone, Debug)]
pub(crate) struct Poly {
    /// Exponents (i, j) of the monomials.
    pub exps: Vec<(usize, usize)>,
    /// Their coefficients.
    pub a: Vec<f64>,
    /// The total degree n.
    pub degree: usize,
}

impl Poly {
    /// Q(x).
    pub(crate) fn eval(&self, x: [f64; 2]) -> f64 {
        self.exps
            .iter()
            .zip(&self.a)
            .map(|(&(i, j), a)| a * x[0].powi(i as i32) * x[1].powi(j as i32))
            .sum()
    }

    /// Gradient and Hessian.
    pub(crate) fn derivs(&self, x: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let p = |v: f64, k: usize, d: usize| -> f64 {
            if k < d {
                0.0
            } else {
                let c: f64 = ((k - d + 1)..=k).map(|t| t as f64).product();
                c * v.powi((k - d) as i32)
            }
        };
        let mut g = [0.0; 2];
        let mut h = [[0.0; 2]; 2];
        for (&(i, j), a) in self.exps.iter().zip(&self.a) {
            g[0] += a * p(x[0], i, 1) * p(x[1], j, 0);
            g[1] += a * p(x[0], i, 0) * p(x[1], j, 1);
            h[0][0] += a * p(x[0], i, 2) * p(x[1], j, 0);
            h[0][1] += a * p(x[0], i, 1) * p(x[1], j, 1);
            h[1][1] += a * p(x[0], i, 0) * p(x[1], j, 2);
        }
        h[1][0] = h[0][1];
        (g, h)
    }

    /// Coefficients q_d of Q(m + r u) as a polynomial in r.
    pub(crate) fn along_ray(&self, m: [f64; 2], u: [f64; 2]) -> Vec<f64> {
        let mut q = vec![0.0; self.degree + 1];
        let binom = |n: usize, k: usize| -> f64 {
            (0..k).fold(1.0, |acc, t| acc * (n - t) as f64 / (t + 1) as f64)
        };
        for (&(i, j), a) in self.exps.iter().zip(&self.a) {
            // (m0 + r u0)^i (m1 + r u1)^j
            for k in 0..=i {
                let ck = binom(i, k) * m[0].powi((i - k) as i32) * u[0].powi(k as i32);
                for l in 0..=j {
                    let cl = binom(j, l) * m[1].powi((j - l) as i32) * u[1].powi(l as i32);
                    q[k + l] += a * ck * cl;
                }
            }
        }
        q
    }

    /// Values on a tensor grid, row-major in ξ1 (index i·n2 + j).
    pub(crate) fn on_grid(&self, g1: &[f64], g2: &[f64]) -> Vec<f64> {
        let n = self.degree;
        let mut out = Vec::with_capacity(g1.len() * g2.len());
        let mut cj = vec![0.0; n + 1];
        for &x1 in g1 {
            cj.iter_mut().for_each(|v| *v = 0.0);
            for (&(i, j), a) in self.exps.iter().zip(&self.a) {
                cj[j] += a * x1.powi(i as i32);
            }
            for &x2 in g2 {
                let mut v = 0.0;
                for c in cj.iter().rev() {
                    v = v * x2 + c;
                }
                out.push(v);
            }
        }
        out
    }
}

/// q(r) = Σ_d q_d r^d by Horner's rule.
pub(crate) fn horner(q: &[f64], r: f64) -> f64 {
    q.iter().rev().fold(0.0, |acc, c| acc * r + c)
}
