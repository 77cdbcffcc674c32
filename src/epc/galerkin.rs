//! The Galerkin system of Eq. 19 in scaled variables ξ_i = x_i/σ_i, precomputed so that the
//! residual R_k(a) = c_k + Σ_s M_ks a_s + ½ Σ_st S_kst a_s a_t and its Jacobian are plain array
//! contractions.
//!
//! With Q = Σ_s a_s ξ^{e_s} (Eq. 16), test functions H_k = ξ^{e_k} φ(ξ1)φ(ξ2) (Eqs. 20–22) and
//! F from Eq. 18, every entry is a combination of the moment tables
//! m_c[α] = ∫ g_c(ξ) ξ^α φ(ξ1)φ(ξ2) dξ of the six scaled coefficient channels g_c
//! (A0, A_i/σ_i, B_ij/(σ_iσ_j)), so the quadrature is done once per channel and monomial.

use nalgebra::{DMatrix, DVector};

use super::coefficients::{Point, CHANNELS};
use crate::numerics::poly2d::exponents;

/// Moment tables of the six channels, up to total degree `max`.
pub(crate) struct MomentTables {
    max: usize,
    table: Vec<[f64; CHANNELS]>,
}

impl MomentTables {
    /// Accumulates the moments from quadrature points; `scale` is σ and `channel_scale` the
    /// factor that makes each channel dimensionless in ξ.
    pub(crate) fn new(points: &[Point], sigma: [f64; 2], max: usize) -> MomentTables {
        let chan = [
            1.0,
            1.0 / sigma[0],
            1.0 / sigma[1],
            1.0 / (sigma[0] * sigma[0]),
            1.0 / (sigma[0] * sigma[1]),
            1.0 / (sigma[1] * sigma[1]),
        ];
        let stride = max + 1;
        let mut table = vec![[0.0; CHANNELS]; stride * stride];
        let mut p1 = vec![0.0; stride];
        let mut p2 = vec![0.0; stride];
        for p in points {
            let xi = [p.x[0] / sigma[0], p.x[1] / sigma[1]];
            let mut wg = [0.0; CHANNELS];
            for c in 0..CHANNELS {
                wg[c] = p.w * p.g[c] * chan[c];
            }
            if wg.iter().all(|v| *v == 0.0) {
                continue;
            }
            p1[0] = 1.0;
            p2[0] = 1.0;
            for k in 1..stride {
                p1[k] = p1[k - 1] * xi[0];
                p2[k] = p2[k - 1] * xi[1];
            }
            for i in 0..=max {
                let row = &mut table[i * stride..];
                for j in 0..=(max - i) {
                    let m = p1[i] * p2[j];
                    let cell = &mut row[j];
                    for c in 0..CHANNELS {
                        cell[c] += wg[c] * m;
                    }
                }
            }
        }
        MomentTables { max, table }
    }

    /// The moment tables of channels that are affine in ξ, ĝ_c(ξ) = k_c[0] + k_c[1] ξ1 +
    /// k_c[2] ξ2, computed exactly from the standard normal moments.
    pub(crate) fn affine(k: &[[f64; 3]; CHANNELS], max: usize) -> MomentTables {
        // E[t^m] for t ~ N(0, 1): (m − 1)!! for even m, 0 for odd m.
        let mut nm = vec![0.0; max + 2];
        nm[0] = 1.0;
        for m in 2..max + 2 {
            nm[m] = (m - 1) as f64 * nm[m - 2];
        }
        let stride = max + 1;
        let mut table = vec![[0.0; CHANNELS]; stride * stride];
        for i in 0..=max {
            for j in 0..=(max - i) {
                for (c, kc) in k.iter().enumerate() {
                    table[i * stride + j][c] = kc[0] * nm[i] * nm[j]
                        + kc[1] * nm[i + 1] * nm[j]
                        + kc[2] * nm[i] * nm[j + 1];
                }
            }
        }
        MomentTables { max, table }
    }

    /// The highest total degree tabulated.
    pub(crate) fn max_degree(&self) -> usize {
        self.max
    }

    pub(crate) fn get(&self, c: usize, i: usize, j: usize) -> f64 {
        debug_assert!(i + j <= self.max);
        self.table[i * (self.max + 1) + j][c]
    }
}

/// The assembled system R(a) = c + M a + ½ (S a) a in scaled variables.
#[derive(Clone, Debug)]
pub(crate) struct GalerkinSystem {
    pub exps: Vec<(usize, usize)>,
    pub c: DVector<f64>,
    pub m: DMatrix<f64>,
    /// S_kst = T_kst + T_kts, stored k-major: `s[(k·n + s)·n + t]`.
    pub s: Vec<f64>,
}

impl GalerkinSystem {
    /// Assembles the system of degree `degree` from the moment tables (needs `max ≥ 3n − 2`).
    pub(crate) fn assemble(mom: &MomentTables, degree: usize) -> GalerkinSystem {
        let exps = exponents(degree);
        let np = exps.len();
        let (a0, a1, a2, b11, b12, b22) = (0, 1, 2, 3, 4, 5);
        let c = DVector::from_iterator(np, exps.iter().map(|&(i, j)| mom.get(a0, i, j)));
        let mut m = DMatrix::zeros(np, np);
        for (k, &(ki, kj)) in exps.iter().enumerate() {
            for (s, &(p, q)) in exps.iter().enumerate() {
                let (pf, qf) = (p as f64, q as f64);
                let mut v = 0.0;
                if p >= 1 {
                    v += pf * mom.get(a1, ki + p - 1, kj + q);
                }
                if q >= 1 {
                    v += qf * mom.get(a2, ki + p, kj + q - 1);
                }
                if p >= 2 {
                    v += pf * (pf - 1.0) * mom.get(b11, ki + p - 2, kj + q);
                }
                if p >= 1 && q >= 1 {
                    v += 2.0 * pf * qf * mom.get(b12, ki + p - 1, kj + q - 1);
                }
                if q >= 2 {
                    v += qf * (qf - 1.0) * mom.get(b22, ki + p, kj + q - 2);
                }
                m[(k, s)] = v;
            }
        }
        // T_kst = Σ_ij ∫ B_ij ∂_iφ_s ∂_jφ_t H_k; S = T + Tᵀ(s,t), symmetric in (s, t).
        let mut sarr = vec![0.0; np * np * np];
        for (k, &(ki, kj)) in exps.iter().enumerate() {
            for (s, &(ps, qs)) in exps.iter().enumerate() {
                for (t, &(pt, qt)) in exps.iter().enumerate().skip(s) {
                    let (psf, qsf, ptf, qtf) = (ps as f64, qs as f64, pt as f64, qt as f64);
                    let mut v = 0.0;
                    if ps >= 1 && pt >= 1 {
                        v += 2.0 * psf * ptf * mom.get(b11, ki + ps + pt - 2, kj + qs + qt);
                    }
                    if qs >= 1 && qt >= 1 {
                        v += 2.0 * qsf * qtf * mom.get(b22, ki + ps + pt, kj + qs + qt - 2);
                    }
                    // B12 ∂1φs ∂2φt + B21 ∂2φs ∂1φt, doubled by the symmetrisation.
                    let cross = psf * qtf + qsf * ptf;
                    if cross != 0.0 {
                        v += 2.0 * cross * mom.get(b12, ki + ps + pt - 1, kj + qs + qt - 1);
                    }
                    sarr[(k * np + s) * np + t] = v;
                    sarr[(k * np + t) * np + s] = v;
                }
            }
        }
        GalerkinSystem {
            exps,
            c,
            m,
            s: sarr,
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.exps.len()
    }

    /// (S a)_ks = Σ_t S_kst a_t, each sum taken in the order t = 0, 1, … from −0 (as
    /// `Iterator::sum`), but over all s at once: S is symmetric in (s, t), so S_kst for fixed
    /// k, t is the contiguous row `s[(k·n + t)·n ..]`, and the n sums of a row k are n
    /// independent accumulators the compiler vectorises (the sum per (k, s) was one chain
    /// of dependent additions: 60 % of a degree-8 solve). The same additions in the same
    /// order, so the same bits.
    fn s_times(&self, a: &DVector<f64>) -> DMatrix<f64> {
        let n = self.len();
        let mut out = DMatrix::zeros(n, n);
        let mut acc = vec![-0.0; n];
        for k in 0..n {
            acc.fill(-0.0);
            for (t, &at) in a.iter().enumerate() {
                let row = &self.s[(k * n + t) * n..(k * n + t + 1) * n];
                for (x, &st) in acc.iter_mut().zip(row) {
                    *x += st * at;
                }
            }
            for (s, &x) in acc.iter().enumerate() {
                out[(k, s)] = x;
            }
        }
        out
    }

    /// The residual R(a) and the Jacobian ∂R/∂a.
    pub(crate) fn residual_and_jacobian(&self, a: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let sa = self.s_times(a);
        let r = &self.c + &self.m * a + 0.5 * &sa * a;
        (r, &self.m + sa)
    }

    /// The residual R(a) alone.
    #[cfg(test)]
    pub(crate) fn residual(&self, a: &DVector<f64>) -> DVector<f64> {
        self.residual_and_jacobian(a).0
    }

    /// The largest absolute entry of c, M and S (for relative comparisons).
    pub(crate) fn scale(&self) -> f64 {
        self.c
            .iter()
            .chain(self.m.iter())
            .chain(self.s.iter())
            .fold(0.0_f64, |a, v| a.max(v.abs()))
    }

    /// The system as text for a snapshot: every entry of c and M and the nonzero entries of S
    /// (s ≤ t), in a fixed format with 10 significant digits; entries below 1e−12 of the
    /// largest are printed as 0 (rounding noise of odd moments that vanish).
    #[cfg(test)]
    pub(crate) fn snapshot(&self) -> String {
        use std::fmt::Write;
        let floor = 1e-12 * self.scale();
        let f = |v: f64| {
            if v.abs() < floor {
                "0".to_string()
            } else {
                format!("{v:.9e}")
            }
        };
        let n = self.len();
        let mut out = String::new();
        let _ = writeln!(out, "unknowns {n}: exponents {:?}", self.exps);
        let _ = writeln!(out, "c:");
        for k in 0..n {
            let _ = writeln!(out, "  {:?} {}", self.exps[k], f(self.c[k]));
        }
        let _ = writeln!(out, "M (rows k, columns s):");
        for k in 0..n {
            let row: Vec<String> = (0..n).map(|s| f(self.m[(k, s)])).collect();
            let _ = writeln!(out, "  {:?} {}", self.exps[k], row.join(" "));
        }
        let _ = writeln!(out, "S (k; s <= t), nonzero entries:");
        for k in 0..n {
            for s in 0..n {
                for t in s..n {
                    let v = self.s[(k * n + s) * n + t];
                    if v.abs() >= floor {
                        let e = &self.exps;
                        let _ = writeln!(out, "  {:?}; {:?} {:?} {}", e[k], e[s], e[t], f(v));
                    }
                }
            }
        }
        out
    }

    /// The largest absolute difference to another assembly of the same degree.
    pub(crate) fn max_difference(&self, other: &GalerkinSystem) -> f64 {
        let d = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .fold(0.0_f64, |a, (u, v)| a.max((u - v).abs()))
        };
        d(self.c.as_slice(), other.c.as_slice())
            .max(d(self.m.as_slice(), other.m.as_slice()))
            .max(d(&self.s, &other.s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::epc::Epc;
    use crate::fpk::FpkOperator;
    use crate::model::load_model;

    /// The assembled systems of `models/linear.sde` (c = 0.1, k = 1, 2πK = 1) at degrees 2
    /// and 4, pinned by snapshots under `src/epc/snapshots/`.
    #[test]
    fn linear_oscillator_galerkin_systems_are_pinned() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
        let bound = load_model(&path).unwrap().bind(&[]).unwrap();
        let fpk = FpkOperator::derive(&bound).unwrap();
        let epc = Epc::new(&fpk);
        let prep = epc.prepare().unwrap();
        for n in [2, 4] {
            let quadrature = epc.moments(&prep, n).unwrap();
            let sys = GalerkinSystem::assemble(&quadrature.tables, n);
            let text = format!(
                "sigma {:.9e} {:.9e}, quadrature order {}\n{}",
                prep.sigma[0],
                prep.sigma[1],
                quadrature.order,
                sys.snapshot()
            );
            insta::assert_snapshot!(format!("linear_degree_{n}"), text);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        // Points of an arbitrary smooth coefficient set on a small grid.
        let mut pts = Vec::new();
        for i in 0..7 {
            for j in 0..7 {
                let x = [i as f64 * 0.4 - 1.2, j as f64 * 0.3 - 0.9];
                let g = [
                    0.3 + x[0],
                    x[1] - x[0] * x[0],
                    0.2 * x[0] + x[1],
                    0.5 + x[1] * x[1],
                    0.1 * x[0],
                    1.0 + 0.3 * x[0].abs(),
                ];
                pts.push(Point {
                    x,
                    w: 0.01 * (1.0 + i as f64 * 0.1),
                    g,
                });
            }
        }
        let mom = MomentTables::new(&pts, [1.3, 0.7], 3 * 3 - 2);
        let sys = GalerkinSystem::assemble(&mom, 3);
        let n = sys.len();
        let a = DVector::from_iterator(n, (0..n).map(|k| 0.1 * (k as f64 + 1.0).sin()));
        let (r, j) = sys.residual_and_jacobian(&a);
        for s in 0..n {
            let h = 1e-6;
            let mut ap = a.clone();
            ap[s] += h;
            let mut am = a.clone();
            am[s] -= h;
            let fd = (sys.residual(&ap) - sys.residual(&am)) / (2.0 * h);
            for k in 0..n {
                approx::assert_relative_eq!(j[(k, s)], fd[k], epsilon = 1e-7, max_relative = 1e-6);
            }
        }
        assert!(r.norm() > 0.0);
    }
}
