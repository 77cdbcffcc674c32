//! The solved density p(x) = C·exp(Q(x)) and what users read from it.

use serde::Serialize;

use super::closure::GaussianClosure;
use super::exp::{exp, exp_in_place};
use super::normalise::{
    horner, powers, DensityGrid, NormalisationReport, Poly, Stretch, MAX_POWER, TRANSITION_CHUNK,
};
use super::outcome::SolverMethod;
use crate::stats::Moments;

/// Timings and convergence of one solve.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let r = Epc::new(&fpk).degree(2).solve().unwrap().solve;
/// assert_eq!(r.method.to_string(), "newton from the Gaussian closure");
/// assert!(r.residual <= r.residual_threshold);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolveReport {
    /// The degree n.
    pub degree: usize,
    /// The method that converged and its start (`summary.json` and the CLI print its
    /// `Display`).
    pub method: SolverMethod,
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
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol: EpcSolution = Epc::new(&fpk).degree(4).solve().unwrap();
/// assert!((sol.moments[0].variance - 5.0).abs() < 1e-6);
/// assert!((sol.moments[0].raw[3] - 75.0).abs() < 1e-4); // E z⁴ = 3·5²
/// assert!(sol.fpk_residual < 1e-6);
/// ```
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
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// assert!((sol.coefficient(2, 0) + 0.1).abs() < 1e-9); // −z²/(2·5)
    /// assert_eq!(sol.coefficient(7, 0), 0.0);
    /// ```
    pub fn coefficient(&self, i: usize, j: usize) -> f64 {
        self.exponents
            .iter()
            .position(|&e| e == (i, j))
            .map_or(0.0, |k| self.coefficients[k])
    }

    /// ln C, with p(x) = C·exp(Q(x)).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// assert!((sol.log_c() + (10.0 * std::f64::consts::PI).ln()).abs() < 1e-8); // C = 1/(2π·5)
    /// ```
    pub fn log_c(&self) -> f64 {
        self.normalisation.log_c
    }

    /// The joint density at a point: C·exp(Q) on the plane; inside a ridge
    /// ([`NormalisationKind::InsideRidge`](super::NormalisationKind::InsideRidge)) 0 outside
    /// the region and cut off smoothly to 0 across the last e-fold above its edge, the same
    /// density the normalising integral integrates.
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// let exact = (-0.1_f64 * (1.0 + 4.0)).exp() / (10.0 * std::f64::consts::PI);
    /// assert!((sol.pdf(1.0, 2.0) / exact - 1.0).abs() < 1e-8);
    /// ```
    pub fn pdf(&self, x1: f64, x2: f64) -> f64 {
        let xi = [x1 / self.sigma[0], x2 / self.sigma[1]];
        let q = self.q.eval(xi);
        let w = self.grid.weight(xi, q);
        if w == 0.0 {
            return 0.0;
        }
        // The exp of the vectorised evaluations (`pdf_on_grid`, `pdf_on_piece`), for the same
        // bits.
        exp(q + self.log_c()) * w
    }

    /// [`EpcSolution::pdf`] on the tensor grid `x1` × `x2` into `out` (row-major in x1), each
    /// value bit for bit `pdf`'s: the same monomials a·ξ1^i·ξ2^j summed in the same order, with
    /// the powers of ξ2 taken once per column and a·ξ1^i once per row and block of columns, the
    /// sums of four columns side by side (independent, so the processor overlaps them). No
    /// allocation beyond one row of products: the observables' quadrature calls this once per
    /// 15-node panel.
    pub(crate) fn pdf_on_grid(&self, x1: &[f64], x2: &[f64], out: &mut [f64]) {
        const LANES: usize = 4;
        const BLOCK: usize = 4 * LANES;
        assert_eq!(out.len(), x1.len() * x2.len(), "pdf_on_grid: output size");
        let (exps, a) = (&self.q.exps, &self.q.a);
        let n2 = x2.len();
        if exps.is_empty() {
            for (i, &u) in x1.iter().enumerate() {
                for (j, &v) in x2.iter().enumerate() {
                    out[i * n2 + j] = self.pdf(u, v);
                }
            }
            return;
        }
        let log_c = self.log_c();
        let g = &self.grid;
        let mut row = vec![0.0; exps.len()];
        for b0 in (0..n2).step_by(BLOCK) {
            let width = BLOCK.min(n2 - b0);
            // power_of[j][c] = ξ2^j at column b0 + c, contiguous across columns.
            let mut xi2 = [0.0; BLOCK];
            let mut weights = [0.0; BLOCK];
            let mut power_of = [[0.0; BLOCK]; MAX_POWER + 1];
            for c in 0..width {
                xi2[c] = x2[b0 + c] / self.sigma[1];
                for (j, p) in powers(xi2[c]).iter().enumerate() {
                    power_of[j][c] = *p;
                }
            }
            for (i, &u) in x1.iter().enumerate() {
                let t = u / self.sigma[0];
                // The mask's nodes only where it is looked up (see `weight_with`).
                let mut node1 = None;
                let p1 = powers(t);
                for (r, (&(e1, _), a)) in row.iter_mut().zip(exps.iter().zip(a)) {
                    *r = a * p1[e1];
                }
                for l0 in (0..width).step_by(LANES) {
                    // The first monomial starts each sum, as in `Poly::eval` (whose `sum`
                    // starts from −0, and −0 + x = x).
                    let mut q = [0.0; LANES];
                    for (q, p) in q.iter_mut().zip(&power_of[exps[0].1][l0..l0 + LANES]) {
                        *q = row[0] * p;
                    }
                    for (r, &(_, e2)) in row.iter().zip(exps).skip(1) {
                        for (q, p) in q.iter_mut().zip(&power_of[e2][l0..l0 + LANES]) {
                            *q += r * p;
                        }
                    }
                    for (l, &q) in q.iter().enumerate().take(width - l0) {
                        let c = l0 + l;
                        weights[c] = g.weight_with(q, || {
                            [
                                *node1.get_or_insert_with(|| g.node(0, t)),
                                g.node(1, xi2[c]),
                            ]
                        });
                        out[i * n2 + b0 + c] = q + log_c;
                    }
                }
                // exp(Q + ln C) along the block's row at once (vectorised), then the weights
                // (0 where the density is cut off, whatever exp gave).
                let block = &mut out[i * n2 + b0..i * n2 + b0 + width];
                exp_in_place(block);
                for (o, &w) in block.iter_mut().zip(&weights) {
                    *o = if w == 0.0 { 0.0 } else { *o * w };
                }
            }
        }
    }

    /// Whether the density is C·exp(Q) everywhere (normalised on the plane), not cut off to a
    /// ridge's region.
    pub(crate) fn on_plane(&self) -> bool {
        self.grid.mask.is_none()
    }

    /// The pieces of the line x_axis = `at` within `range` of the other state (original
    /// units) on which the density is smooth, zero between them, into `out`: `range` itself
    /// on the plane (C·exp(Q), analytic); inside a ridge the runs of masked cells of the
    /// normalisation grid on that line ([`DensityGrid::mask_runs`]), split where Q crosses
    /// the cutoff's levels (see `normalise::line`) into core stretches, where the density is
    /// C·exp(Q), and transitions, where the cutoff rises (C^∞, not analytic) and the density
    /// is at most C·exp(floor + 1).
    pub(crate) fn smooth_pieces(
        &self,
        axis: usize,
        at: f64,
        range: [f64; 2],
        out: &mut Vec<([f64; 2], Stretch)>,
    ) {
        out.clear();
        let s = self.sigma[1 - axis];
        let scaled = [range[0] / s, range[1] / s];
        thread_local! {
            // The runs of a line, kept between calls (a line integral allocates nothing).
            static RUNS: std::cell::Cell<Vec<[f64; 2]>> = const { std::cell::Cell::new(Vec::new()) };
        }
        let mut runs = RUNS.take();
        let xi = at / self.sigma[axis];
        if !self.grid.mask_runs(axis, xi, scaled, &mut runs) {
            RUNS.set(runs);
            out.push((range, Stretch::Core));
            return;
        }
        let c = self.q.on_line(axis, xi);
        self.grid.stretches(&c[..=self.q.degree], &runs, out);
        RUNS.set(runs);
        for (piece, _) in out.iter_mut() {
            // The range's own ends exactly (not rescaled), so that pieces tile it.
            *piece = piece.map(|t| {
                if t == scaled[0] {
                    range[0]
                } else if t == scaled[1] {
                    range[1]
                } else {
                    t * s
                }
            });
        }
    }

    /// The largest density on a transition piece of [`EpcSolution::smooth_pieces`]:
    /// C·exp(floor + 1) (0 on the plane, which has none).
    pub(crate) fn transition_max(&self) -> f64 {
        if self.on_plane() {
            0.0
        } else {
            (self.grid.transition_max_q() + self.log_c()).exp()
        }
    }

    /// The density on one piece of [`EpcSolution::smooth_pieces`] of kind `kind` at the
    /// points `t` of the other state (original units), into `out`: C·exp(Q) times the
    /// piece's cutoff (1 on the plane and on a core piece), with Q restricted to the line
    /// once (a polynomial in t by Horner's rule, n multiply-adds a point where the whole Q
    /// takes a product and a sum per monomial): equal to [`EpcSolution::pdf`] in the piece's
    /// interior up to rounding, and at its ends the limit from inside.
    pub(crate) fn pdf_on_piece(
        &self,
        axis: usize,
        at: f64,
        kind: Stretch,
        t: &[f64],
        out: &mut [f64],
    ) {
        let c = self.q.on_line(axis, at / self.sigma[axis]);
        let c = &c[..=self.q.degree];
        let (s, log_c) = (self.sigma[1 - axis], self.log_c());
        for (o, &t) in out.iter_mut().zip(t) {
            *o = horner(c, t / s);
        }
        if kind == Stretch::Core {
            for o in out.iter_mut() {
                *o += log_c;
            }
            exp_in_place(out);
            return;
        }
        // Q itself is kept for a transition's cutoff (on a core piece the cutoff is 1), a
        // chunk at a time on the stack.
        let mut q = [0.0; TRANSITION_CHUNK];
        for out in out.chunks_mut(TRANSITION_CHUNK) {
            let q = &mut q[..out.len()];
            q.copy_from_slice(out);
            for o in out.iter_mut() {
                *o += log_c;
            }
            exp_in_place(out);
            self.grid.times_transition(q, out);
        }
    }

    /// The marginal density of state `axis` (0 or 1) on the normalisation grid (original
    /// units), trimmed to where it is at least 1e−8 of its peak (plus one point).
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// let (x, p) = sol.marginal(1);
    /// let mass: f64 = p.iter().sum::<f64>() * (x[1] - x[0]);
    /// assert!((mass - 1.0).abs() < 1e-6);
    /// ```
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
    ///
    /// ```
    /// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// let peak = 1.0 / (10.0 * std::f64::consts::PI).sqrt(); // N(0, 5) at 0
    /// assert!((sol.marginal_at(0, 0.0) / peak - 1.0).abs() < 1e-8);
    /// ```
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

    /// The box `[[lo1, hi1], [lo2, hi2]]` (original units) of the normalisation grid: on the
    /// plane it reaches e^−40 of the peak, inside a ridge the region's edge, so the density is
    /// negligible (below about 1e−17 of its peak) or zero outside it.
    ///
    /// ```
    /// # use fpsolve::{epc::Epc, fpk::FpkOperator, model::parse_model};
    /// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    /// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    /// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    /// let [[lo, hi], _] = sol.extent();
    /// // Var z = 5: e^−40 of the peak lies at |z| = √(80·5) = 20.
    /// assert!(lo < -20.0 && hi > 20.0);
    /// ```
    pub fn extent(&self) -> [[f64; 2]; 2] {
        let g = &self.grid;
        let ends = |v: &[f64], s: f64| [v[0] * s, v[v.len() - 1] * s];
        [ends(&g.g1, self.sigma[0]), ends(&g.g2, self.sigma[1])]
    }
}
