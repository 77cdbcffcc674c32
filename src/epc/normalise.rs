//! Normalising C·exp(Q) honestly: on the plane when the top-degree part of Q is negative
//! definite; otherwise inside the ridge that separates the mode from where exp(Q) grows again,
//! if that ridge is deep enough; otherwise not at all.
//!
//! Inside a ridge the density is exp(Q) on the region (the connected component of
//! {Q > floor} holding the mode, the floor one e-fold above the pass) times a C^∞ cutoff that
//! falls from 1 to 0 across the last e-fold above the floor: the region's edge is the smooth
//! level set Q = floor and the density is continuous there, so that integrals of it (the
//! normalisation here, line integrals in `observe`) converge fast.
//!
//! Everything here works in scaled variables ξ; the integral uses the trapezoid rule on a
//! tensor grid reaching exp(Q − Qmax) < e^−40 on the plane, or the ridge region's edge
//! (spectrally accurate for a smooth, decaying integrand). The spacing starts at 0.2 and is
//! halved until the sums on spacings h and 2h agree to 1e−9 (inside a ridge, to the larger of
//! 1e−9 and e^-(depth−1), the share of the mass near the region's edge); |Z_h − Z_2h|/Z_h is
//! reported as the error estimate.

use serde::Serialize;

/// Below this many e-folds from the mode the density is treated as zero when choosing the box.
const TAIL_E_FOLDS: f64 = 40.0;
/// Number of rays used to explore Q around the mode (half a degree apart).
const RAYS: usize = 720;
/// First trapezoid spacing tried (scaled units: the weights' σ are 1).
const START_SPACING: f64 = 0.2;
/// Fewest cells per axis of the normalisation grid (even).
const MIN_CELLS: usize = 48;
/// Most cells per axis: refinement stops there and reports its error estimate as it is.
const MAX_CELLS: usize = 1600;
/// Relative agreement of Z_h and Z_2h at which the grid is accepted.
const NORMALISATION_TOLERANCE: f64 = 1e-9;

/// A polynomial Q(ξ) = Σ a_s ξ1^i ξ2^j.
#[derive(Clone, Debug)]
pub(crate) struct Poly {
    pub exps: Vec<(usize, usize)>,
    pub a: Vec<f64>,
    pub degree: usize,
}

impl Poly {
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
    fn along_ray(&self, m: [f64; 2], u: [f64; 2]) -> Vec<f64> {
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

fn horner(q: &[f64], r: f64) -> f64 {
    q.iter().rev().fold(0.0, |acc, c| acc * r + c)
}

/// How the density was normalised.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NormalisationKind {
    /// exp(Q) is integrable on the whole plane: the top-degree part of Q is negative definite
    /// (`top_degree_max` < 0), or it is only semidefinite and along every one of 720 rays from
    /// the mode the highest non-vanishing power of Q(mode + r·u) has a negative coefficient.
    Plane {
        /// max over the unit circle of the degree-n part.
        top_degree_max: f64,
    },
    /// exp(Q) is not integrable on the plane; it was normalised inside the ridge around the
    /// mode: over the connected component of {Q > pass value + 1} that holds the mode, with a
    /// smooth cutoff across the last e-fold above that level (the pass
    /// is the highest saddle on the way from the mode to where Q rises above Q(mode)).
    InsideRidge {
        /// Q(mode) − (highest pass value), in e-folds.
        depth: f64,
        /// The threshold the depth had to reach.
        threshold: f64,
        /// Where the highest pass is (original units).
        pass_at: [f64; 2],
        /// How the region is bounded.
        region: String,
    },
}

/// The normalisation's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NormalisationReport {
    /// Plane or inside a ridge.
    pub kind: NormalisationKind,
    /// The mode (original units).
    pub mode: [f64; 2],
    /// ln C, with p(x) = C·exp(Q(x)) in original units.
    pub log_c: f64,
    /// Grid points per axis and the spacing (scaled units).
    pub grid: [usize; 2],
    /// Trapezoid spacing in scaled units.
    pub spacing: [f64; 2],
    /// |Z_h − Z_2h| / Z_h: the estimated relative error of the normalising integral.
    pub error_estimate: f64,
}

/// The normalised density on a grid in scaled variables.
#[derive(Clone, Debug)]
pub(crate) struct DensityGrid {
    pub g1: Vec<f64>,
    pub g2: Vec<f64>,
    pub h: [f64; 2],
    /// Density in ξ (∫ p dξ = 1), row-major in ξ1; zero outside the region.
    pub p: Vec<f64>,
    /// Inside a ridge: the grid points of the connected component of {Q ≥ floor} holding the
    /// mode, dilated by one point (4-neighbours); `None` on the plane. The region is
    /// {Q ≥ floor} ∩ (cells of these points), so its edge is the smooth level set Q = floor
    /// wherever the component is more than a cell away from others (no staircase along the
    /// cell boundaries), and at grid points it is exactly the component.
    pub mask: Option<Vec<bool>>,
    /// The pass value (Q below it is outside the region).
    pub floor: f64,
    /// max Q on the region (the reference of `p`).
    pub q_max: f64,
    /// ln ∫ exp(Q) dξ over the region.
    pub log_z: f64,
}

impl DensityGrid {
    /// The factor (0 to 1) that multiplies exp(Q) at ξ, where Q = `q`: 1 on the plane; inside
    /// a ridge 0 outside the region and, within it, the smooth cutoff [`taper`] across the
    /// last [`TAPER_E_FOLDS`] above the floor, so that the density falls continuously (with
    /// all its derivatives) to 0 at the region's edge instead of jumping there.
    pub(crate) fn weight(&self, x: [f64; 2], q: f64) -> f64 {
        let Some(mask) = &self.mask else {
            return 1.0;
        };
        // The same bound on Q as the flood fill that built the mask (the mode is the region's
        // maximum; what rises above it lies beyond the ridge).
        if q <= self.floor || q > self.q_max + 1e-9 * (1.0 + self.q_max.abs()) {
            return 0.0;
        }
        let i = ((x[0] - self.g1[0]) / self.h[0]).round();
        let j = ((x[1] - self.g2[0]) / self.h[1]).round();
        if i < 0.0 || j < 0.0 || i as usize >= self.g1.len() || j as usize >= self.g2.len() {
            return 0.0;
        }
        if mask[i as usize * self.g2.len() + j as usize] {
            taper((q - self.floor) / TAPER_E_FOLDS)
        } else {
            0.0
        }
    }
}

/// Width (e-folds of Q) of the smooth cutoff inside a ridge region, above its floor.
pub(crate) const TAPER_E_FOLDS: f64 = 1.0;

/// A C^∞ step: 0 for t ≤ 0, 1 for t ≥ 1, e^{−1/t}/(e^{−1/t} + e^{−1/(1−t)}) between.
pub(crate) fn taper(t: f64) -> f64 {
    if t <= 0.0 {
        0.0
    } else if t >= 1.0 {
        1.0
    } else {
        let a = (-1.0 / t).exp();
        let b = (-1.0 / (1.0 - t)).exp();
        a / (a + b)
    }
}

/// Why normalisation failed.
pub(crate) struct NotNormalisable(pub String);

/// Finds a local maximum of Q by Newton ascent from the best point of a coarse grid.
fn find_mode(q: &Poly) -> Result<[f64; 2], NotNormalisable> {
    let mut best = ([0.0, 0.0], q.eval([0.0, 0.0]));
    for i in -16..=16 {
        for j in -16..=16 {
            let x = [i as f64 * 0.25, j as f64 * 0.25];
            let v = q.eval(x);
            if v > best.1 {
                best = (x, v);
            }
        }
    }
    let mut x = best.0;
    for _ in 0..100 {
        let (g, h) = q.derivs(x);
        let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
        let newton_ok = h[0][0] < 0.0 && det > 0.0;
        let step = if newton_ok {
            [
                -(h[1][1] * g[0] - h[0][1] * g[1]) / det,
                -(-h[1][0] * g[0] + h[0][0] * g[1]) / det,
            ]
        } else {
            [0.05 * g[0], 0.05 * g[1]]
        };
        let mut t = 1.0;
        let q0 = q.eval(x);
        while t > 1e-12 {
            let xn = [x[0] + t * step[0], x[1] + t * step[1]];
            if q.eval(xn) >= q0 {
                x = xn;
                break;
            }
            t *= 0.5;
        }
        if g[0].hypot(g[1]) < 1e-12 {
            break;
        }
    }
    let (g, h) = q.derivs(x);
    let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
    let strict = h[0][0] < 0.0 && det > 0.0 && g[0].hypot(g[1]) < 1e-8 * (1.0 + h[0][0].abs());
    // A degenerate maximum (e.g. Q = −c(ξ1² + ξ2²)², whose Hessian vanishes at the mode):
    // a stationary point above every point of small circles around it.
    let degenerate = || {
        let q0 = q.eval(x);
        g[0].hypot(g[1]) < 1e-9
            && [1e-3, 1e-2, 1e-1].iter().all(|&rho| {
                (0..64).all(|k| {
                    let th = k as f64 / 64.0 * std::f64::consts::TAU;
                    q.eval([x[0] + rho * th.cos(), x[1] + rho * th.sin()]) < q0
                })
            })
    };
    if !(strict || degenerate()) {
        return Err(NotNormalisable(format!(
            "Q has no local maximum near the origin (stopped at ξ = ({:.3}, {:.3}))",
            x[0], x[1]
        )));
    }
    Ok(x)
}

/// The cut radius along a ray: either where Q falls TAIL_E_FOLDS below `q_max` for good, or
/// (if Q rises above `q_max` again) the lowest point before that rise.
enum RayEnd {
    Decays(f64),
    Pass { r: f64, value: f64 },
}

fn explore_ray(q: &Poly, mode: [f64; 2], th: f64, q_max: f64) -> Result<RayEnd, NotNormalisable> {
    let u = [th.cos(), th.sin()];
    let mut c = q.along_ray(mode, u);
    // Leading coefficients that vanish to rounding (e.g. along a direction the top-degree
    // part does not involve) are dropped, so that the next term decides.
    let big = c.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    while c.len() > 2 && c[c.len() - 1].abs() <= 1e-12 * big {
        c.pop();
    }
    let n = c.len() - 1;
    let lead = c[n];
    // Beyond r_dom (Fujiwara's bound on the roots of dQ/dr) dQ/dr has the leading sign.
    let b: Vec<f64> = (1..=n).map(|d| d as f64 * c[d]).collect();
    let m = b.len() - 1;
    let r_dom = if m == 0 {
        1.0
    } else {
        (1..=m)
            .map(|k| {
                let ratio = (b[m - k] / b[m]).abs() / if k == m { 2.0 } else { 1.0 };
                2.0 * ratio.powf(1.0 / k as f64)
            })
            .fold(1.0, f64::max)
    };
    let r_stop = r_dom.min(1e6) * 1.05 + 1.0;
    let (mut r, mut last_above) = (0.0_f64, 0.0);
    let (mut min_r, mut min_v) = (0.0, q_max);
    loop {
        r += 0.01 * (1.0 + r);
        let v = horner(&c, r);
        // Past r_dom Q is monotone along the ray: stop once it has also fallen below the tail.
        if r > 1e6 || (r >= r_stop && (lead > 0.0 || v < q_max - TAIL_E_FOLDS)) {
            break;
        }
        if v > q_max + 1e-9 * (1.0 + q_max.abs()) {
            return Ok(RayEnd::Pass {
                r: min_r,
                value: min_v,
            });
        }
        if v < min_v {
            min_v = v;
            min_r = r;
        }
        if v >= q_max - TAIL_E_FOLDS {
            last_above = r;
        }
    }
    if lead < 0.0 {
        Ok(RayEnd::Decays(last_above))
    } else if lead > 0.0 {
        // Rises eventually (beyond the scan only if it is enormously far): the lowest point
        // seen bounds the pass along this ray.
        Ok(RayEnd::Pass {
            r: min_r,
            value: min_v,
        })
    } else {
        Err(NotNormalisable(format!(
            "Q is flat to leading order along the direction θ = {th:.3} rad"
        )))
    }
}

/// Normalises exp(Q) (Q in scaled variables). `threshold` is the least ridge depth accepted.
pub(crate) fn normalise(
    q: &Poly,
    sigma: [f64; 2],
    threshold: f64,
) -> Result<(DensityGrid, NormalisationReport), NotNormalisable> {
    let n = q.degree;
    let top = Poly {
        exps: q.exps.clone(),
        a: q.exps
            .iter()
            .zip(&q.a)
            .map(|(&(i, j), a)| if i + j == n { *a } else { 0.0 })
            .collect(),
        degree: n,
    };
    let top_max = (0..RAYS)
        .map(|k| {
            let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
            top.eval([th.cos(), th.sin()])
        })
        .fold(f64::NEG_INFINITY, f64::max);
    let mode = find_mode(q)?;
    let q_mode = q.eval(mode);
    let mut ends = Vec::with_capacity(RAYS);
    for k in 0..RAYS {
        let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
        ends.push(explore_ray(q, mode, th, q_mode)?);
    }
    let plane = ends.iter().all(|e| matches!(e, RayEnd::Decays(_)));
    let mut cut = vec![0.0; RAYS];
    let kind;
    if plane {
        for (c, e) in cut.iter_mut().zip(&ends) {
            if let RayEnd::Decays(r) = e {
                *c = *r;
            }
        }
        kind = NormalisationKind::Plane {
            top_degree_max: top_max,
        };
    } else {
        let mut pass = (f64::NEG_INFINITY, [0.0; 2]);
        for (k, (c, e)) in cut.iter_mut().zip(&ends).enumerate() {
            let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
            match e {
                RayEnd::Decays(r) => *c = *r,
                RayEnd::Pass { r, value } => {
                    *c = *r;
                    if *value > pass.0 {
                        pass = (*value, [mode[0] + r * th.cos(), mode[1] + r * th.sin()]);
                    }
                }
            }
        }
        // Rays only bound the pass from below; the saddle point of Q near the best ray's
        // lowest point is the true pass when Newton finds it.
        if let Some((x, v)) = saddle_near(q, pass.1) {
            // The sampled ray minima are coarse (steps of 1% of r): a saddle next to the best
            // one is the exact pass.
            let near = (x[0] - pass.1[0]).hypot(x[1] - pass.1[1])
                < 0.05 * (1.0 + pass.1[0].hypot(pass.1[1]));
            if (v > pass.0 || near) && v < q_mode {
                pass = (v, x);
            }
        }
        let depth = q_mode - pass.0;
        if depth < threshold {
            return Err(NotNormalisable(format!(
                "exp(Q) grows without bound (degree-{n} part max {top_max:.3e} on the unit circle) and the ridge around the mode is only {depth:.2} e-folds deep (threshold {threshold})"
            )));
        }
        kind = NormalisationKind::InsideRidge {
            depth,
            threshold,
            pass_at: [pass.1[0] * sigma[0], pass.1[1] * sigma[1]],
            region: "the connected component of {Q > pass value + 1} that holds the mode, exp(Q) cut off smoothly across the last e-fold above that level".into(),
        };
    }
    // The region's reach along each ray: where Q last stands above the floor (the region's
    // edge inside a ridge; TAIL_E_FOLDS below the peak on the plane), up to the ray's cut.
    let floor = match &kind {
        NormalisationKind::InsideRidge { depth, .. } => q_mode - depth + 1.0,
        NormalisationKind::Plane { .. } => q_mode - TAIL_E_FOLDS,
    };
    let mut lo = mode;
    let mut hi = mode;
    for (k, &limit) in cut.iter().enumerate() {
        let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
        let u = [th.cos(), th.sin()];
        let c = q.along_ray(mode, u);
        let (mut r, mut reach) = (0.0_f64, 0.0);
        while r < limit {
            r = (r + 0.01 * (1.0 + r)).min(limit);
            if horner(&c, r) >= floor {
                reach = r;
            }
        }
        for a in 0..2 {
            let p = mode[a] + (reach + 0.01 * (1.0 + reach)) * u[a];
            lo[a] = lo[a].min(p);
            hi[a] = hi[a].max(p);
        }
    }
    // Trapezoid sums on grids of halving spacing until Z_h and Z_2h agree to
    // NORMALISATION_TOLERANCE (spectral convergence on the plane; first order at a ridge's
    // edge, where the density is below e^-(depth-1) of the peak).
    let mut cells = [0, 1].map(|a| {
        let c = ((hi[a] - lo[a] + 0.4) / START_SPACING).ceil() as usize;
        (c + c % 2).max(MIN_CELLS)
    });
    loop {
        let (grid, z, z2) = integrate(q, &kind, mode, q_mode, floor, lo, hi, cells)?;
        let err = ((z - z2) / z).abs();
        // Inside a ridge the mass near the edge, where the cutoff makes the integrand vary on
        // a short scale, is of order e^-(depth-1) of the total: resolving it beyond that level
        // would cost a much finer grid (8x per axis for Table 1 case 1) and buy nothing.
        let tolerance = match &kind {
            NormalisationKind::InsideRidge { depth, .. } => {
                NORMALISATION_TOLERANCE.max((1.0 - depth).exp())
            }
            NormalisationKind::Plane { .. } => NORMALISATION_TOLERANCE,
        };
        let at_cap = cells.iter().any(|c| 2 * c > MAX_CELLS);
        if err <= tolerance || at_cap {
            let report = NormalisationReport {
                kind,
                mode: [mode[0] * sigma[0], mode[1] * sigma[1]],
                log_c: -grid.log_z - (sigma[0] * sigma[1]).ln(),
                grid: [grid.g1.len(), grid.g2.len()],
                spacing: grid.h,
                error_estimate: err,
            };
            return Ok((grid, report));
        }
        cells = cells.map(|c| 2 * c);
    }
}

/// The largest normalisation grid, in points (64 MB of f64 per array).
const MAX_GRID_POINTS: f64 = 8.0e6;

/// The trapezoid sum of exp(Q) on a grid of `cells` over the box (widened by 0.2), inside the
/// ridge's region when there is one: the normalised grid, Z_h and Z_2h.
#[allow(clippy::too_many_arguments)]
fn integrate(
    q: &Poly,
    kind: &NormalisationKind,
    mode: [f64; 2],
    q_mode: f64,
    floor: f64,
    lo: [f64; 2],
    hi: [f64; 2],
    cells: [usize; 2],
) -> Result<(DensityGrid, f64, f64), NotNormalisable> {
    // A density spread over a box this many cells wide (scaled units, where the weights'
    // σ is 1) is not one the grid can resolve: refuse rather than allocate without bound.
    let points = (cells[0] as f64 + 1.0) * (cells[1] as f64 + 1.0);
    if !(points.is_finite() && points <= MAX_GRID_POINTS) {
        return Err(NotNormalisable(format!(
            "the density spreads over [{:.3e}, {:.3e}] x [{:.3e}, {:.3e}] (scaled units): \
             normalising it would take a grid of {points:.2e} points (limit {MAX_GRID_POINTS:.0e})",
            lo[0], hi[0], lo[1], hi[1]
        )));
    }
    let axis = |a: usize| -> (Vec<f64>, f64) {
        let (l, u) = (lo[a] - 0.2, hi[a] + 0.2);
        let h = (u - l) / cells[a] as f64;
        ((0..=cells[a]).map(|i| l + i as f64 * h).collect(), h)
    };
    let (g1, h1) = axis(0);
    let (g2, h2) = axis(1);
    let mut grid = DensityGrid {
        g1,
        g2,
        h: [h1, h2],
        p: vec![],
        mask: None,
        floor: f64::NEG_INFINITY,
        q_max: q_mode,
        log_z: 0.0,
    };
    let qv = q.on_grid(&grid.g1, &grid.g2);
    let n2 = grid.g2.len();
    let plane = matches!(kind, NormalisationKind::Plane { .. });
    if !plane {
        // The region: the connected component of {Q ≥ floor} that holds the mode, the floor
        // one e-fold above the pass so that the grid cannot leak across the saddle (what lies
        // below the floor inside the region carries less than e^-(depth-1) of the peak).
        let mut mask = vec![false; qv.len()];
        let i0 = ((mode[0] - grid.g1[0]) / h1).round() as usize;
        let j0 = ((mode[1] - grid.g2[0]) / h2).round() as usize;
        let mut stack = vec![(i0, j0)];
        while let Some((i, j)) = stack.pop() {
            let idx = i * n2 + j;
            if mask[idx] || qv[idx] < floor || qv[idx] > q_mode + 1e-9 * (1.0 + q_mode.abs()) {
                continue;
            }
            mask[idx] = true;
            if i > 0 {
                stack.push((i - 1, j));
            }
            if i + 1 < grid.g1.len() {
                stack.push((i + 1, j));
            }
            if j > 0 {
                stack.push((i, j - 1));
            }
            if j + 1 < n2 {
                stack.push((i, j + 1));
            }
        }
        // Dilation: a grid point next to the component with Q ≥ floor is in it already (the
        // fill is 4-connected), so at grid points membership is unchanged and the trapezoid
        // sum below integrates exactly the density `contains` admits.
        let n1 = grid.g1.len();
        let mut dilated = mask.clone();
        for i in 0..n1 {
            for j in 0..n2 {
                if mask[i * n2 + j] {
                    if i > 0 {
                        dilated[(i - 1) * n2 + j] = true;
                    }
                    if i + 1 < n1 {
                        dilated[(i + 1) * n2 + j] = true;
                    }
                    if j > 0 {
                        dilated[i * n2 + j - 1] = true;
                    }
                    if j + 1 < n2 {
                        dilated[i * n2 + j + 1] = true;
                    }
                }
            }
        }
        grid.mask = Some(dilated);
        grid.floor = floor;
    }
    let q_ref = if plane {
        qv.iter().copied().fold(q_mode, f64::max)
    } else {
        q_mode
    };
    let mut p = vec![0.0; qv.len()];
    let (mut z, mut z2) = (0.0, 0.0);
    for i in 0..grid.g1.len() {
        for j in 0..n2 {
            let idx = i * n2 + j;
            // The points `contains` admits: on the plane all, inside a ridge the component.
            let inside = grid.mask.as_ref().is_none_or(|m| {
                m[idx] && qv[idx] >= floor && qv[idx] <= q_mode + 1e-9 * (1.0 + q_mode.abs())
            });
            if inside {
                let w = if plane {
                    1.0
                } else {
                    taper((qv[idx] - floor) / TAPER_E_FOLDS)
                };
                let v = (qv[idx] - q_ref).exp() * w;
                p[idx] = v;
                z += v;
                if i % 2 == 0 && j % 2 == 0 {
                    z2 += v;
                }
            }
        }
    }
    // The box edges lie where the density is negligible: the trapezoid end corrections vanish.
    let zh = z * h1 * h2;
    if !(zh.is_finite() && zh > 0.0) {
        return Err(NotNormalisable(format!(
            "the normalising integral is not finite ({zh:e}) on the region"
        )));
    }
    let z2h = z2 * 4.0 * h1 * h2;
    p.iter_mut().for_each(|v| *v /= zh);
    grid.p = p;
    grid.q_max = q_ref;
    grid.log_z = zh.ln() + q_ref;
    Ok((grid, zh, z2h))
}

/// Newton on ∇Q = 0 from `x`; returns a saddle (indefinite Hessian) if it converges to one.
fn saddle_near(q: &Poly, mut x: [f64; 2]) -> Option<([f64; 2], f64)> {
    for _ in 0..60 {
        let (g, h) = q.derivs(x);
        let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
        if det.abs() < 1e-300 {
            return None;
        }
        let step = [
            -(h[1][1] * g[0] - h[0][1] * g[1]) / det,
            -(-h[1][0] * g[0] + h[0][0] * g[1]) / det,
        ];
        x = [x[0] + step[0], x[1] + step[1]];
        if step[0].hypot(step[1]) < 1e-12 * (1.0 + x[0].hypot(x[1])) {
            let (_, h) = q.derivs(x);
            let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
            return (det < 0.0).then(|| (x, q.eval(x)));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn gaussian_normalises_on_the_plane() {
        // Q = −ξ1²/2 − ξ2²/2 + 0.3 ξ1: mode at (0.3, 0), Z = 2π e^{0.045}.
        let q = Poly {
            exps: vec![(1, 0), (0, 1), (2, 0), (1, 1), (0, 2)],
            a: vec![0.3, 0.0, -0.5, 0.0, -0.5],
            degree: 2,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 12.0) else {
            panic!("normalisable")
        };
        assert!(matches!(rep.kind, NormalisationKind::Plane { .. }));
        assert_relative_eq!(rep.mode[0], 0.3, epsilon = 1e-10);
        assert_relative_eq!(
            grid.log_z,
            (std::f64::consts::TAU).ln() + 0.045,
            epsilon = 1e-10
        );
    }

    #[test]
    fn growing_q_is_cut_at_its_ridge_or_refused() {
        // Q = −ξ1²/2 − ξ2²/2 + b ξ1³: unbounded along +ξ1 when b > 0; saddle at ξ1 = 1/(3b),
        // depth 1/(54 b²).
        for (b, ok) in [(0.02, true), (0.1, false)] {
            let q = Poly {
                exps: vec![(2, 0), (0, 2), (3, 0)],
                a: vec![-0.5, -0.5, b],
                degree: 3,
            };
            match normalise(&q, [1.0, 1.0], 12.0) {
                Ok((_, rep)) => {
                    assert!(ok);
                    let NormalisationKind::InsideRidge { depth, .. } = rep.kind else {
                        panic!("ridge expected")
                    };
                    assert_relative_eq!(depth, 1.0 / (54.0 * b * b), max_relative = 1e-9);
                }
                Err(NotNormalisable(msg)) => {
                    assert!(!ok, "{msg}");
                    assert!(msg.contains("e-folds"));
                }
            }
        }
    }

    #[test]
    fn purely_quartic_q_has_a_degenerate_mode_and_normalises() {
        // Q = −(ξ1² + ξ2²)²: zero Hessian at the mode; Z = ∫ e^{−r⁴} dξ = π^{3/2}/2.
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (4, 0), (2, 2), (0, 4)],
            a: vec![0.0, 0.0, -1.0, -2.0, -1.0],
            degree: 4,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 12.0) else {
            panic!("normalisable")
        };
        assert!(matches!(rep.kind, NormalisationKind::Plane { .. }));
        assert_relative_eq!(rep.mode[0], 0.0, epsilon = 1e-12);
        assert_relative_eq!(
            grid.log_z,
            (std::f64::consts::PI.powf(1.5) / 2.0).ln(),
            epsilon = 1e-8
        );
    }

    #[test]
    fn a_saddle_is_not_a_mode() {
        // Q = ξ1² − ξ2² − ξ1⁴ − ξ2⁴ has a saddle at the origin and modes at (±1/√2, 0).
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (4, 0), (0, 4)],
            a: vec![1.0, -1.0, -1.0, -1.0],
            degree: 4,
        };
        let mode = find_mode(&q).ok().expect("a mode");
        assert_relative_eq!(mode[0].abs(), 0.5_f64.sqrt(), epsilon = 1e-8);
    }

    #[test]
    fn density_inside_a_ridge_integrates_to_one_and_vanishes_continuously_at_the_edge() {
        // Q = −ξ1²/2 − ξ2²/2 + b ξ1³ with a shallow ridge (depth 1/(54 b²) ≈ 3.8 e-folds, so
        // the density at the edge is a few % of the peak and any mismatch between the region
        // of the sum and the region of `weight` would show).
        let b = 0.07;
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (3, 0)],
            a: vec![-0.5, -0.5, b],
            degree: 3,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 3.0) else {
            panic!("normalisable")
        };
        let NormalisationKind::InsideRidge { depth, .. } = rep.kind else {
            panic!("ridge expected")
        };
        let density = |x: [f64; 2]| {
            let v = q.eval(x);
            (v - grid.log_z).exp() * grid.weight(x, v)
        };
        // Midpoint rule on a grid unrelated to the normalisation grid.
        let (n, lo, hi) = (1500, [-5.0, -4.0], [6.0, 4.0]);
        let h = [(hi[0] - lo[0]) / n as f64, (hi[1] - lo[1]) / n as f64];
        let mut total = 0.0;
        for i in 0..n {
            for j in 0..n {
                total += density([
                    lo[0] + (i as f64 + 0.5) * h[0],
                    lo[1] + (j as f64 + 0.5) * h[1],
                ]);
            }
        }
        total *= h[0] * h[1];
        assert!(
            (total - 1.0).abs() < 1e-4,
            "∫ p = {total} (error estimate {:e})",
            rep.error_estimate
        );
        // Along ξ2 = 0 towards the pass the density falls continuously to 0: the last positive
        // value is far below the density at the floor, e^-(depth-1) of the peak.
        let peak = density([0.0, 0.0]);
        let at_floor = peak * (1.0 - depth).exp();
        let mut last = peak;
        let mut x = 0.0;
        while density([x, 0.0]) > 0.0 {
            last = density([x, 0.0]);
            x += 1e-4;
        }
        assert!(
            x < 1.0 / (3.0 * b),
            "the region stops before the pass at {x}"
        );
        assert!(
            last < 1e-3 * at_floor,
            "jump of {last:e} at the edge ({at_floor:e} at the floor)"
        );
    }
}
