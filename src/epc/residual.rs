//! The FPK residual indicator ∫|F|·p dx of a normalised solution (F of Eq. 18).

use super::normalise::{self, Poly};
use super::{EpcError, Prepared};
use crate::symbolic::TapeScratch;

impl Prepared {
    /// ∫|F|·p dx with F of Eq. 18 as a measure: the regular part on (a sub-grid of) the
    /// normalisation grid, the δ lines as line integrals.
    pub(super) fn fpk_residual(
        &self,
        q: &Poly,
        grid: &normalise::DensityGrid,
    ) -> Result<f64, EpcError> {
        let s = self.sigma;
        let chan = [
            1.0,
            1.0 / s[0],
            1.0 / s[1],
            1.0 / (s[0] * s[0]),
            1.0 / (s[0] * s[1]),
            1.0 / (s[1] * s[1]),
        ];
        let f_of = |g: [f64; 6], xi: [f64; 2]| {
            let (d, h) = q.derivs(xi);
            chan[0] * g[0]
                + chan[1] * g[1] * d[0]
                + chan[2] * g[2] * d[1]
                + chan[3] * g[3] * (h[0][0] + d[0] * d[0])
                + 2.0 * chan[4] * g[4] * (h[0][1] + d[0] * d[1])
                + chan[5] * g[5] * (h[1][1] + d[1] * d[1])
        };
        let n2 = grid.g2.len();
        let stride = [grid.g1.len().div_ceil(80), n2.div_ceil(80)];
        let p_floor = 1e-14 * grid.p.iter().copied().fold(0.0, f64::max);
        // The sub-grid points that carry mass, evaluated in one batch.
        let (mut xi1, mut xi2, mut x1, mut x2, mut pw) = (vec![], vec![], vec![], vec![], vec![]);
        for i in (0..grid.g1.len()).step_by(stride[0]) {
            for j in (0..n2).step_by(stride[1]) {
                let p = grid.p[i * n2 + j];
                if p >= p_floor {
                    xi1.push(grid.g1[i]);
                    xi2.push(grid.g2[j]);
                    x1.push(grid.g1[i] * s[0]);
                    x2.push(grid.g2[j] * s[1]);
                    pw.push(p);
                }
            }
        }
        let mut scratch = TapeScratch::new();
        let g = self.coefs.regular_batch(&x1, &x2, &mut scratch)?;
        let mut total = 0.0;
        for k in 0..pw.len() {
            let gk = std::array::from_fn(|c| g[c][k]);
            total += f_of(gk, [xi1[k], xi2[k]]).abs() * pw[k];
        }
        total *= grid.h[0] * stride[0] as f64 * grid.h[1] * stride[1] as f64;
        for (c, k, line) in self.coefs.lines() {
            let a = line.axis;
            let o = 1 - a;
            let (other, ho) = if o == 0 {
                (&grid.g1, grid.h[0])
            } else {
                (&grid.g2, grid.h[1])
            };
            let xi_at = line.at / s[a];
            let along: Vec<f64> = other.iter().map(|t| t * s[o]).collect();
            let w = self.coefs.line_weights(c, k, &along, &mut scratch)?;
            for (&t, wt) in other.iter().zip(&w) {
                let mut xi = [0.0; 2];
                xi[a] = xi_at;
                xi[o] = t;
                let qx = q.eval(xi);
                let wq = grid.weight(xi, qx);
                if wq == 0.0 {
                    continue;
                }
                let p = (qx - grid.log_z).exp() * wq;
                let mut g = [0.0; 6];
                g[c] = *wt;
                // δ(x_a − at) = δ(ξ_a − ξ_at)/σ_a.
                total += f_of(g, xi).abs() * p * ho / s[a];
            }
        }
        Ok(total)
    }
}
