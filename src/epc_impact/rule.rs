//! The discrete equations: composite Gauss–Legendre panels on a box of the domain, the
//! barrier lines' nodes, and the residual R(a) and its Jacobian.
//!
//! With e_q = exp(Q_a(node q)) and, per node, the row G_q of test-function values (interior
//! nodes: w_q·(L H_k)(x_q, v_q); barrier nodes: w_q·|v_q|·[H_k(x_b, map v_q) − H_k(x_b, v_q)])
//! and the weight w^Z_q of the normalising integral (0 on barrier nodes),
//!
//! R(a) = Σ_q G_q e_q / Z(a),   Z(a) = Σ_q w^Z_q e_q,
//!
//! the stationary moment equations of the impact system with the density normalised, so that
//! R does not depend on the scale of exp(Q). Its Jacobian is exact:
//! ∂R/∂a_s = Σ_q G_q e_q Φ_qs / Z − R·Σ_q w^Z_q e_q Φ_qs / Z, Φ_qs the basis monomials.

use nalgebra::{DMatrix, DVector};

use super::error::EpcImpactError;
use super::mechanics::{BarrierSide, Mechanics, Wall};
use crate::epc::MAX_DEGREE;
use crate::numerics::quadrature::gauss_legendre;

/// Gauss–Legendre nodes per panel.
pub(crate) const NODES_PER_PANEL: usize = 8;

/// A box [x_lo, x_hi] × [v_lo, v_hi] (original units) with v_lo < 0 < v_hi.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let sol = fpsolve::epc_impact::EpcImpact::new(&bound).solve(2)?;
/// // The barrier at y = 0 is the window's lower position edge.
/// assert_eq!(sol.window.x[0], 0.0);
/// assert!(sol.window.v[0] < 0.0 && sol.window.v[1] > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Window {
    /// The position range.
    pub x: [f64; 2],
    /// The velocity range.
    pub v: [f64; 2],
}

/// Composite Gauss–Legendre nodes and weights on [a, b] with `panels` panels.
fn composite(a: f64, b: f64, panels: usize) -> (Vec<f64>, Vec<f64>) {
    let (t, w) = gauss_legendre(NODES_PER_PANEL);
    let h = (b - a) / panels as f64;
    let mut x = Vec::with_capacity(panels * NODES_PER_PANEL);
    let mut wt = Vec::with_capacity(panels * NODES_PER_PANEL);
    for p in 0..panels {
        let mid = a + (p as f64 + 0.5) * h;
        for (ti, wi) in t.iter().zip(&w) {
            x.push(mid + 0.5 * h * ti);
            wt.push(0.5 * h * wi);
        }
    }
    (x, wt)
}

/// The monomials ξ^i η^j of the basis at one point, and x^i up to `n` in `out`.
pub(crate) fn powers(t: f64, n: usize, out: &mut [f64]) {
    out[0] = 1.0;
    for k in 1..=n {
        out[k] = out[k - 1] * t;
    }
}

/// Q(ξ, η) = Σ a_s ξ^i η^j (scaled variables).
pub(crate) fn q_at(exps: &[(usize, usize)], a: &[f64], xi: f64, eta: f64) -> f64 {
    let n = exps.iter().map(|e| e.0 + e.1).max().unwrap_or(0);
    let mut p1 = [0.0; MAX_DEGREE + 1];
    let mut p2 = [0.0; MAX_DEGREE + 1];
    powers(xi, n, &mut p1);
    powers(eta, n, &mut p2);
    exps.iter()
        .zip(a)
        .map(|(&(i, j), c)| c * p1[i] * p2[j])
        .sum()
}

/// The discrete equations of one degree on one box and rule.
#[derive(Clone, Debug)]
pub(crate) struct System {
    pub(crate) exps: Vec<(usize, usize)>,
    pub(crate) window: Window,
    pub(crate) panels: [usize; 2],
    pub(crate) sigma: [f64; 2],
    /// Basis monomials at the nodes (interior nodes first, then barrier nodes).
    phi: DMatrix<f64>,
    /// Test-function rows G_q.
    g: DMatrix<f64>,
    /// Weights of Z (0 on barrier nodes).
    wz: DVector<f64>,
    /// Interior nodes (original units), for moments.
    pub(crate) nodes: Vec<[f64; 2]>,
    /// Weights of the interior nodes (original units, dx dv).
    pub(crate) node_weights: Vec<f64>,
    /// The barrier nodes: arriving velocities and their images, for the boundary residual.
    pub(crate) boundary: Vec<BoundaryNode>,
}

/// An arriving velocity at a barrier, its weight in the barrier integral, and where the
/// impact law sends it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoundaryNode {
    /// The barrier's position.
    pub(crate) at: f64,
    /// The arriving velocity.
    pub(crate) v: f64,
    /// Its quadrature weight (dv).
    pub(crate) weight: f64,
    /// map(v).
    pub(crate) image: f64,
    /// |d map / dv| at v (central difference).
    pub(crate) slope: f64,
}

impl System {
    /// Builds the equations of degree `n` in scaled variables ξ = x/σx, η = v/σv.
    pub(crate) fn build(
        mech: &Mechanics,
        sigma: [f64; 2],
        window: Window,
        panels: [usize; 2],
        n: usize,
    ) -> Result<System, EpcImpactError> {
        let exps = crate::numerics::poly2d::exponents(n);
        let np = exps.len();
        let (xs, wx) = composite(window.x[0], window.x[1], panels[0]);
        let half = panels[1] / 2;
        let (mut vs, mut wv) = composite(window.v[0], 0.0, half);
        let (vp, wp) = composite(0.0, window.v[1], half);
        vs.extend(vp);
        wv.extend(wp);
        let mut px = Vec::with_capacity(xs.len() * vs.len());
        let mut pv = Vec::with_capacity(xs.len() * vs.len());
        for &x in &xs {
            for &v in &vs {
                px.push(x);
                pv.push(v);
            }
        }
        let [m, b] = mech.eval_batch(&px, &pv)?;
        let mut arriving: Vec<(&Wall, usize)> = Vec::new();
        for bar in &mech.barriers {
            for (k, v) in vs.iter().enumerate() {
                if v * bar.arriving() > 0.0 {
                    arriving.push((bar, k));
                }
            }
        }
        let total = px.len() + arriving.len();
        let mut phi = DMatrix::zeros(total, np);
        let mut g = DMatrix::zeros(total, np);
        let mut wz = DVector::zeros(total);
        let mut p1 = vec![0.0; n + 1];
        let mut p2 = vec![0.0; n + 1];
        let mut p3 = vec![0.0; n + 1];
        let (sx, sv) = (sigma[0], sigma[1]);
        // x^(i−1) etc. with the convention x^(−1)·0 = 0.
        let pw = |p: &[f64], k: isize| if k < 0 { 0.0 } else { p[k as usize] };
        for q in 0..px.len() {
            let w = wx[q / vs.len()] * wv[q % vs.len()];
            powers(px[q] / sx, n, &mut p1);
            powers(pv[q] / sv, n, &mut p2);
            wz[q] = w;
            for (s, &(i, j)) in exps.iter().enumerate() {
                let (ii, jj) = (i as isize, j as isize);
                phi[(q, s)] = p1[i] * p2[j];
                let lh = pv[q] * (i as f64 / sx) * pw(&p1, ii - 1) * p2[j]
                    + m[q] * (j as f64 / sv) * p1[i] * pw(&p2, jj - 1)
                    + 0.5 * b[q] * (j * j.saturating_sub(1)) as f64 / (sv * sv)
                        * p1[i]
                        * pw(&p2, jj - 2);
                g[(q, s)] = w * lh;
            }
        }
        let mut boundary = Vec::with_capacity(arriving.len());
        for (r, (bar, k)) in arriving.iter().enumerate() {
            let q = px.len() + r;
            let v = vs[*k];
            let image = bar.map(v);
            let h = 1e-6 * v.abs().max(sv);
            boundary.push(BoundaryNode {
                at: bar.at(),
                v,
                weight: wv[*k],
                image,
                slope: ((bar.map(v + h) - bar.map(v - h)) / (2.0 * h)).abs(),
            });
            if !image.is_finite() {
                return Err(EpcImpactError::NotFinite {
                    what: "the jump map",
                    x: bar.at(),
                    v,
                });
            }
            let w = wv[*k] * v.abs();
            powers(bar.at() / sx, n, &mut p1);
            powers(v / sv, n, &mut p2);
            powers(image / sv, n, &mut p3);
            for (s, &(i, j)) in exps.iter().enumerate() {
                phi[(q, s)] = p1[i] * p2[j];
                g[(q, s)] = w * p1[i] * (p3[j] - p2[j]);
            }
        }
        Ok(System {
            exps,
            window,
            panels,
            sigma,
            phi,
            g,
            wz,
            nodes: px.iter().zip(&pv).map(|(x, v)| [*x, *v]).collect(),
            node_weights: (0..px.len())
                .map(|q| wx[q / vs.len()] * wv[q % vs.len()])
                .collect(),
            boundary,
        })
    }

    /// exp(Q − max Q) at every node.
    fn weights(&self, a: &DVector<f64>) -> DVector<f64> {
        let q = &self.phi * a;
        let top = q.max();
        q.map(|v| (v - top).exp())
    }

    /// R(a).
    pub(crate) fn residual(&self, a: &DVector<f64>) -> DVector<f64> {
        let e = self.weights(a);
        let z = self.wz.dot(&e);
        self.g.tr_mul(&e) / z
    }

    /// R(a) and its Jacobian.
    pub(crate) fn residual_and_jacobian(&self, a: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let e = self.weights(a);
        let z = self.wz.dot(&e);
        let r = self.g.tr_mul(&e) / z;
        let mut ge = self.g.clone();
        for mut col in ge.column_iter_mut() {
            col.component_mul_assign(&e);
        }
        let we = self.wz.component_mul(&e);
        let dz = self.phi.tr_mul(&we) / z;
        let j = ge.tr_mul(&self.phi) / z - &r * dz.transpose();
        (r, j)
    }

    /// ln ∫∫ exp(Q) dx dv over the box (original units).
    pub(crate) fn log_z(&self, a: &DVector<f64>) -> f64 {
        let q = &self.phi * a;
        let top = q.max();
        top + self.wz.dot(&q.map(|v| (v - top).exp())).ln()
    }

    /// Raw moments E[x^k], E[v^k] (k = 1..4) and the central moments, by the rule.
    pub(crate) fn moments(&self, a: &DVector<f64>) -> [crate::stats::Moments; 2] {
        let q = &self.phi * a;
        let top = q.max();
        let mut p: Vec<f64> = (0..self.nodes.len())
            .map(|k| self.wz[k] * (q[k] - top).exp())
            .collect();
        let z: f64 = p.iter().sum();
        p.iter_mut().for_each(|v| *v /= z);
        [0, 1].map(|axis| {
            let e = |f: &dyn Fn(f64) -> f64| {
                self.nodes
                    .iter()
                    .zip(&p)
                    .map(|(x, w)| f(x[axis]) * w)
                    .sum::<f64>()
            };
            let mean = e(&|x| x);
            let var = e(&|x| (x - mean).powi(2));
            let m4 = e(&|x| (x - mean).powi(4));
            crate::stats::Moments {
                raw: [1, 2, 3, 4].map(|k| e(&|x| x.powi(k))),
                mean,
                variance: var,
                kurtosis: m4 / (var * var),
            }
        })
    }

    /// The interior node where Q is largest (scaled variables).
    pub(crate) fn peak(&self, a: &DVector<f64>) -> [f64; 2] {
        let q = &self.phi * a;
        let k = (0..self.nodes.len())
            .max_by(|&i, &j| q[i].total_cmp(&q[j]))
            .unwrap_or(0);
        [
            self.nodes[k][0] / self.sigma[0],
            self.nodes[k][1] / self.sigma[1],
        ]
    }
}

/// Which edges of a box are free (not a barrier): [x_lo, x_hi]; both v edges are free.
pub(crate) fn free_x_edges(barriers: &[Wall]) -> [bool; 2] {
    let mut free = [true, true];
    for b in barriers {
        match b.side {
            BarrierSide::Above => free[0] = false,
            BarrierSide::Below => free[1] = false,
        }
    }
    free
}

impl crate::numerics::newton::Equations for System {
    fn residual_and_jacobian(&self, a: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        System::residual_and_jacobian(self, a)
    }

    fn residual(&self, a: &DVector<f64>) -> DVector<f64> {
        System::residual(self, a)
    }
}
