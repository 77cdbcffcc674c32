//! The general method: the co-area (level-set) integral p_g(u) = ∮_{g=u} p / |∇g| ds.
//!
//! The level set is never traced as a curve. It is cut by the lines x1 = s and x2 = s, and the
//! co-area integral is split between the two families by the smooth partition of unity
//! w1 + w2 = 1, w1 = |∂2 g|^m / (|∂1 g|^m + |∂2 g|^m), w2 = 1 − w1 (m = 8):
//!
//! p_g(u) = ∫ ds Σ_{g(s, t) = u} p w1 / |∂2 g| + ∫ ds Σ_{g(t, s) = u} p w2 / |∂1 g|,
//!
//! the sums running over the roots t of g = u on each line. Each integrand is bounded (the
//! weight vanishes where the line is tangent to the level set, so no 1/√ singularity) and
//! behaves like (distance)^3.5 where roots appear or disappear, so adaptive Gauss–Kronrod
//! quadrature over s converges fast. The roots on a line are bracketed with a precomputed grid
//! of g (cells whose corner range, widened by the local curvature of g, holds u), and refined by
//! safeguarded Newton with ∂g from the symbolic derivative compiled to a [`Tape`]; a cell whose
//! ends lie on one side of u but whose slope changes sign is searched for the extremum between
//! them, so two nearby roots are not lost. A sign change that is a jump of g (sgn) is not a
//! root and is dropped. Where g has a kink (an `abs`/`sgn` argument h is 0) the level set has
//! corners at which the line sums jump; those corners (on the axes, and on the curves h = 0
//! found as level sets of h) are break points of the quadrature.
//!
//! Critical points of g (∇g = 0, found by Newton from the grid) are handled explicitly:
//! - a non-degenerate minimum or maximum x* with value u* bounds a small closed component of
//!   the level set for u near u*. Its size is known from the Hessian H, and the quadrature
//!   gets break points there; once it is smaller than 1e−5 of the extent, its exact limit
//!   p(x*)·2π/√det H is used instead (relative error O(|u − u*|)). At u = u* the value is this
//!   one-sided limit (so the energy of a linear oscillator has p(0) = 1/mean, not 0);
//! - at a saddle or a degenerate critical value (a line of minima, as v² has at 0) the density
//!   of g is infinite, and +∞ is returned there; nearby it has a logarithmic (saddle) or
//!   inverse-power singularity, which the quadrature resolves with reduced accuracy.

use super::critical::{in_component, Critical, CriticalSearch, Kind};
use super::quadrature::{integrate_panels, integrate_panels_by, Rule};
use super::{JointDensity, ObservableMap};
use crate::symbolic::{diff, simplify, DeltaPolicy, Expr, Func, Symbol, SymbolicError, Tape};

/// Exponent of the partition of unity between the two families of lines.
const M: i32 = 8;
/// Grid points per axis of the bracketing grid.
const GRID: usize = 129;
/// Cells per run of [`LevelSet::blocks`]; divides GRID − 1.
const BLOCK: usize = 8;
const _: () = assert!((GRID - 1).is_multiple_of(BLOCK));
/// Relative tolerance of the adaptive quadrature over the lines.
const REL_TOL: f64 = 1e-10;
/// Relative tolerance of that quadrature for a piecewise density, whose panels are cut at its
/// pieces (the grid's own error is 1e−6 of the density or more, so 1e−8 is ample).
const PIECEWISE_REL_TOL: f64 = 1e-8;

/// The co-area method, prepared for one observable under one joint density.
pub(crate) struct LevelSet {
    /// Outputs g, ∂1 g, ∂2 g (δ terms of the derivatives dropped).
    tape: Tape,
    ext: [[f64; 2]; 2],
    /// The bracketing grid's first node and spacing per axis.
    lo: [f64; 2],
    h: [f64; 2],
    /// Per axis a, the cells of each column x_a ∈ [s_i, s_i+1] in order along it (cell (i, j)
    /// at `i·(GRID − 1) + j` for a = 0, cell (j, i) there for a = 1, so that a line's cells
    /// are contiguous): min and max of g over the cell's corners, widened by the local
    /// curvature (−∞, +∞ when g is undefined at some corners but not all; +∞, −∞ when
    /// undefined at all).
    bounds: [Vec<[f64; 2]>; 2],
    /// The same bounds over runs of [`BLOCK`] consecutive cells of a column: a line skips a
    /// run whose cells cannot hold the level in one test.
    blocks: [Vec<[f64; 2]>; 2],
    /// Spread of g over the support (max − min), the scale of "g − u is zero".
    gscale: f64,
    /// The least and greatest g at the bracketing grid's nodes where the density is positive.
    range: [f64; 2],
    critical: Vec<Critical>,
    /// The kink curves {h = 0} of g off the axes: one level set per argument h of an `abs` or
    /// `sgn` in g that is not ± a state (those are the axes, handled directly).
    kinks: Vec<LevelSet>,
    /// Per kink curve and axis, g at its roots on every grid line ([`LevelSet::kink_lines`]).
    kink_lines: Vec<[Vec<Vec<f64>>; 2]>,
    /// The lines of the density's pieces per axis ([`JointDensity::breakpoints`]), read once:
    /// none for a smooth density.
    pieces: [Option<Vec<f64>>; 2],
}

/// The bracketing grid and the density sampled on it: the same for an observable and its
/// kink curves, so sampled once.
struct Sampled {
    ext: [[f64; 2]; 2],
    /// The grid's first node and spacing per axis.
    lo: [f64; 2],
    h: [f64; 2],
    /// The density at node (i, j), `i·GRID + j`.
    p: Vec<f64>,
}

impl Sampled {
    fn new(density: &dyn JointDensity) -> Sampled {
        let ext = density.extent();
        // The bracketing grid covers the extent with one cell to spare, shifted by a golden
        // fraction of a cell, so that its nodes do not fall on 0 (where common observables
        // take round values exactly, and a zero at a cell's end would be a degenerate case).
        let h = [0, 1].map(|a| (ext[a][1] - ext[a][0]) / (GRID - 2) as f64);
        let lo = [0, 1].map(|a| ext[a][0] - 0.381_966_011_250_105 * h[a]);
        let n = GRID;
        let mut p = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                p[i * n + j] = density.pdf([lo[0] + i as f64 * h[0], lo[1] + j as f64 * h[1]]);
            }
        }
        Sampled { ext, lo, h, p }
    }
}

/// One evaluation on a line: g, ∂g across the line, ∂g along it.
#[derive(Clone, Copy)]
struct Val {
    g: f64,
    across: f64,
    along: f64,
}

impl LevelSet {
    /// Compiles g and its derivatives and prepares the bracketing grid and critical points.
    pub(crate) fn new(
        density: &dyn JointDensity,
        expr: &Expr,
        states: &[Symbol; 2],
    ) -> Result<LevelSet, SymbolicError> {
        let grid = Sampled::new(density);
        let mut set = LevelSet::bare(density, expr, states, &grid, true)?;
        set.pieces = [0, 1].map(|a| density.breakpoints(a));
        let mut args: Vec<Expr> = Vec::new();
        expr.walk(&mut |e| {
            if let Expr::Call(Func::Abs | Func::Sgn, a) = e {
                let h = simplify(&a[0]);
                let on_axis = matches!(
                    ObservableMap::classify(&h, states),
                    ObservableMap::SignedState { .. }
                );
                let depends = states.iter().any(|s| h.mentions(s));
                if depends && !on_axis && !args.contains(&h) {
                    args.push(h);
                }
            }
        });
        for h in args.iter().take(8) {
            // A kink curve only brackets roots: the same sampled density, no critical points.
            set.kinks
                .push(LevelSet::bare(density, h, states, &grid, false)?);
        }
        set.kink_lines = set
            .kinks
            .iter()
            .map(|k| [set.kink_lines(k, 0), set.kink_lines(k, 1)])
            .collect();
        Ok(set)
    }

    /// The level set without kink curves, on the sampled bracketing grid; its critical points
    /// only when `with_critical`.
    fn bare(
        density: &dyn JointDensity,
        expr: &Expr,
        states: &[Symbol; 2],
        grid: &Sampled,
        with_critical: bool,
    ) -> Result<LevelSet, SymbolicError> {
        let names = [&*states[0], &*states[1]];
        // The δ parts of the derivatives (jumps of sgn) are dropped: they live on lines of
        // measure zero and carry no level set of g.
        let d1 = simplify(&diff(expr, names[0])?.without_deltas());
        let d2 = simplify(&diff(expr, names[1])?.without_deltas());
        let d11 = diff(&d1, names[0])?;
        let d12 = diff(&d1, names[1])?;
        let d22 = diff(&d2, names[1])?;
        let tape = Tape::compile(&[expr.clone(), d1, d2], &names, DeltaPolicy::Zero)?;
        let hess = Tape::compile(&[d11, d12, d22], &names, DeltaPolicy::Zero)?;
        let Sampled {
            ext,
            lo: grid_lo,
            h,
            p,
        } = grid;
        let (ext, grid_lo, h) = (*ext, *grid_lo, *h);
        let n = GRID;
        let mut g = vec![0.0; n * n];
        let mut grad2 = vec![0.0; n * n];
        let mut scratch = Vec::new();
        let mut out = [0.0; 3];
        for i in 0..n {
            for j in 0..n {
                let x = [grid_lo[0] + i as f64 * h[0], grid_lo[1] + j as f64 * h[1]];
                tape.eval(&x, &mut scratch, &mut out);
                let k = i * n + j;
                g[k] = if out[0].is_finite() { out[0] } else { f64::NAN };
                grad2[k] = out[1] * out[1] + out[2] * out[2];
            }
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..n * n {
            if p[k] > 0.0 && g[k].is_finite() {
                lo = lo.min(g[k]);
                hi = hi.max(g[k]);
            }
        }
        let gscale = if hi > lo { hi - lo } else { lo.abs().max(1.0) };
        // Curvature at each grid point: |second differences| along both axes and across; g on
        // a cell strays from its corners' range by at most about a quarter of this (exactly so
        // for a quadratic), so the cell's range is widened by half of the largest at its
        // corners. NaN (g undefined nearby) widens it to everything.
        let at = |i: usize, j: usize| g[i.min(n - 1) * n + j.min(n - 1)];
        let mut curv = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let (im, ip) = (i.max(1) - 1, (i + 1).min(n - 1));
                let (jm, jp) = (j.max(1) - 1, (j + 1).min(n - 1));
                let c = at(i, j);
                let d11 = if ip > im + 1 {
                    at(ip, j) - 2.0 * c + at(im, j)
                } else {
                    0.0
                };
                let d22 = if jp > jm + 1 {
                    at(i, jp) - 2.0 * c + at(i, jm)
                } else {
                    0.0
                };
                let d12 = at(ip, jp) - at(ip, jm) - at(im, jp) + at(im, jm);
                let v = d11.abs() + d22.abs() + 0.5 * d12.abs();
                curv[i * n + j] = if v.is_finite() { v } else { f64::INFINITY };
            }
        }
        let mut bounds = [
            vec![[0.0; 2]; (n - 1) * (n - 1)],
            vec![[0.0; 2]; (n - 1) * (n - 1)],
        ];
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                let corners = [
                    i * n + j,
                    i * n + j + 1,
                    (i + 1) * n + j,
                    (i + 1) * n + j + 1,
                ];
                let c = corners.map(|k| g[k]);
                let margin =
                    0.5 * corners.iter().map(|&k| curv[k]).fold(0.0, f64::max) + 1e-12 * gscale;
                let finite = c.iter().filter(|v| v.is_finite()).count();
                let (a, b) = match finite {
                    0 => (f64::INFINITY, f64::NEG_INFINITY),
                    4 if margin.is_finite() => (
                        c.iter().copied().fold(f64::INFINITY, f64::min) - margin,
                        c.iter().copied().fold(f64::NEG_INFINITY, f64::max) + margin,
                    ),
                    _ => (f64::NEG_INFINITY, f64::INFINITY),
                };
                bounds[0][i * (n - 1) + j] = [a, b];
                bounds[1][j * (n - 1) + i] = [a, b];
            }
        }
        let blocks = bounds.each_ref().map(|cells| {
            cells
                .chunks(BLOCK)
                .map(|run| {
                    run.iter()
                        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &[a, b]| {
                            [lo.min(a), hi.max(b)]
                        })
                })
                .collect()
        });
        let mut set = LevelSet {
            range: [lo, hi],
            tape,
            ext,
            lo: grid_lo,
            h,
            bounds,
            blocks,
            gscale,
            critical: Vec::new(),
            kinks: Vec::new(),
            kink_lines: Vec::new(),
            pieces: [None, None],
        };
        if with_critical {
            let search = CriticalSearch {
                tape: &set.tape,
                hess: &hess,
                ext: set.ext,
                lo: set.lo,
                h: set.h,
                gscale: set.gscale,
                nodes: GRID,
            };
            set.critical = search.find(density, &grad2, p);
        }
        Ok(set)
    }

    /// The values of g where p_g is infinite: its saddle and degenerate critical values
    /// (a log singularity at a saddle's, an inverse power at a degenerate one's, e.g. v² at 0).
    pub(crate) fn singular_values(&self) -> Vec<f64> {
        self.critical
            .iter()
            .filter(|c| matches!(c.kind, Kind::Saddle | Kind::Degenerate))
            .map(|c| c.value)
            .collect()
    }

    /// p_g(u). At an end of g's range that g takes on a curve without a critical point (the
    /// fold of |h| at h = 0, as |z + v| at 0) the level set is that curve, which no line
    /// crosses: its value is the one-sided limit, p_g a hair inside the range.
    pub(crate) fn pdf(&self, density: &dyn JointDensity, u: f64) -> f64 {
        let p = self.pdf_at(density, u);
        let [lo, hi] = self.range;
        if p != 0.0 || (u > lo && u < hi) {
            return p;
        }
        let hair = 1e-9 * self.gscale;
        self.pdf_at(density, if u <= lo { u + hair } else { u - hair })
    }

    fn pdf_at(&self, density: &dyn JointDensity, u: f64) -> f64 {
        let width = (self.ext[0][1] - self.ext[0][0]).max(self.ext[1][1] - self.ext[1][0]);
        let mut total = 0.0;
        let mut excluded: Vec<&Critical> = Vec::new();
        let mut breaks: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        for c in &self.critical {
            let d = u - c.value;
            match c.kind {
                Kind::Saddle | Kind::Degenerate => {
                    if d.abs() <= 1e-12 * self.gscale {
                        return f64::INFINITY;
                    }
                    if c.kind == Kind::Saddle {
                        for (a, b) in breaks.iter_mut().enumerate() {
                            b.push(c.x[a]);
                        }
                    }
                }
                Kind::Min | Kind::Max => {
                    let active = if c.kind == Kind::Min {
                        d >= 0.0
                    } else {
                        d <= 0.0
                    };
                    if !active {
                        continue;
                    }
                    let r = [0, 1].map(|a| (2.0 * d.abs() * c.hinv[(a, a)].abs()).sqrt());
                    if r[0].max(r[1]) < 1e-5 * width {
                        total += c.limit;
                        excluded.push(c);
                    } else {
                        for (a, b) in breaks.iter_mut().enumerate() {
                            b.extend([c.x[a] - r[a], c.x[a], c.x[a] + r[a]]);
                        }
                    }
                }
            }
        }
        // A kink of g along an axis (abs or sgn of a state) gives the level set corners there,
        // where the roots on the other family's lines appear or vanish abruptly: the points of
        // {g = u} on the axis x_b = 0 are break points of the integral over x_a.
        let mut scratch = Vec::new();
        for (a, axis_breaks) in breaks.iter_mut().enumerate() {
            let b = 1 - a;
            if self.ext[b][0] < 0.0 && self.ext[b][1] > 0.0 {
                let mut roots = Vec::new();
                self.line_roots(b, 0.0, u, &mut roots, &mut scratch);
                axis_breaks.extend_from_slice(&roots);
            }
        }
        for (k, lines) in self.kinks.iter().zip(&self.kink_lines) {
            for (a, axis_breaks) in breaks.iter_mut().enumerate() {
                self.kink_corners(k, &lines[a], a, u, axis_breaks, &mut scratch);
            }
        }
        // A piecewise density (the grid's interpolant) has kinks along the lines of its
        // pieces: across them (x_a = c) the line sum kinks in s, and where the level set
        // crosses the other family's lines (x_b = c) the density along it kinks. Both are
        // break points, so that every panel's integrand is smooth; only the lines near the
        // level set are looked at.
        let pieces = [0, 1].map(|a| self.near_level(a, u));
        for a in 0..2 {
            let b = 1 - a;
            breaks[a].extend_from_slice(&pieces[a]);
            let mut roots = Vec::new();
            for &c in &pieces[b] {
                self.line_roots(b, c, u, &mut roots, &mut scratch);
                breaks[a].extend_from_slice(&roots);
            }
        }
        let piecewise = pieces.iter().any(|p| !p.is_empty());
        for (a, axis_breaks) in breaks.iter().enumerate() {
            let [lo, hi] = self.ext[a];
            let mut edges: Vec<f64> = (0..=16)
                .map(|k| lo + (hi - lo) * k as f64 / 16.0)
                .chain(axis_breaks.iter().copied().filter(|&s| s > lo && s < hi))
                .collect();
            edges.sort_by(f64::total_cmp);
            edges.dedup_by(|x, y| (*x - *y).abs() <= 1e-12 * (hi - lo));
            // `integrate_panels` takes a `Fn`: the roots' buffer and the tape's working memory
            // are shared through a `RefCell`, so that no line allocates.
            let buffers = std::cell::RefCell::new((Vec::new(), Vec::new()));
            let f = |s: f64| {
                let (roots, scratch) = &mut *buffers.borrow_mut();
                self.line_sum(density, a, s, u, &excluded, (roots, scratch))
            };
            total += if piecewise {
                let batch = |t: &[f64], out: &mut [f64]| {
                    for (o, &t) in out.iter_mut().zip(t) {
                        *o = f(t);
                    }
                };
                integrate_panels_by(Rule::Kronrod7, &batch, &edges, PIECEWISE_REL_TOL)
            } else {
                integrate_panels(&f, &edges, REL_TOL)
            };
        }
        total
    }

    /// Of the density's piece lines x_a = c, those in a column of the bracketing grid where
    /// some cell may hold the level u (none for a smooth density).
    fn near_level(&self, a: usize, u: f64) -> Vec<f64> {
        let Some(lines) = &self.pieces[a] else {
            return Vec::new();
        };
        let n = GRID - 1;
        // A column holds the level when one of its cells does: first the runs' bounds.
        let active: Vec<bool> = self.blocks[a]
            .chunks(n / BLOCK)
            .zip(self.bounds[a].chunks(n))
            .map(|(runs, column)| {
                runs.iter().enumerate().any(|(r, &[lo, hi])| {
                    u >= lo
                        && u <= hi
                        && column[r * BLOCK..(r + 1) * BLOCK]
                            .iter()
                            .any(|&[lo, hi]| u >= lo && u <= hi)
                })
            })
            .collect();
        lines
            .iter()
            .copied()
            .filter(|&c| {
                let i = ((c - self.lo[a]) / self.h[a]).floor();
                // A line on a column's edge belongs to both columns.
                let near = |i: f64| i >= 0.0 && (i as usize) < n && active[i as usize];
                near(i) || near(i - 1.0)
            })
            .collect()
    }

    /// g at the roots of the kink curve {h = 0} of `kink` on every grid line x_a = s_i (the
    /// j-th root t_j of h on the line, in order): independent of u, so computed once.
    fn kink_lines(&self, kink: &LevelSet, a: usize) -> Vec<Vec<f64>> {
        let mut roots = Vec::new();
        let mut scratch = Vec::new();
        (0..GRID)
            .map(|i| {
                let s = self.lo[a] + i as f64 * self.h[a];
                kink.line_roots(a, s, 0.0, &mut roots, &mut scratch);
                roots
                    .iter()
                    .map(|&t| self.eval(a, s, t, &mut scratch).1.g)
                    .collect()
            })
            .collect()
    }

    /// The positions s (along x_a) of the points of {g = u} on the kink curve {h = 0} of
    /// `kink`: where the level set has corners and the line sums jump. Found on the grid's
    /// lines x_a = s_i (the j-th root of h on neighbouring lines paired when their counts
    /// agree, `lines` from [`LevelSet::kink_lines`]) and refined by bisection.
    fn kink_corners(
        &self,
        kink: &LevelSet,
        lines: &[Vec<f64>],
        a: usize,
        u: f64,
        out: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
    ) {
        let mut roots = Vec::new();
        let s_of = |i: usize| self.lo[a] + i as f64 * self.h[a];
        for i in 1..GRID {
            let (prev, next) = (&lines[i - 1], &lines[i]);
            if next.len() != prev.len() {
                continue;
            }
            // G_j(s) = g(s, t_j(s)) − u on the j-th root t_j of h on the line x_a = s.
            for j in 0..next.len() {
                let (gp, gn) = (prev[j] - u, next[j] - u);
                if gp * gn >= 0.0 || gp.is_nan() || gn.is_nan() {
                    continue;
                }
                let (mut l, mut r, fl) = (s_of(i - 1), s_of(i), gp);
                for _ in 0..60 {
                    let m = 0.5 * (l + r);
                    let n = kink.line_roots(a, m, 0.0, &mut roots, scratch);
                    if n != next.len() {
                        break;
                    }
                    let v = self.eval(a, m, roots[j], scratch).1.g - u;
                    if v * fl > 0.0 {
                        l = m;
                    } else {
                        r = m;
                    }
                    if r - l <= 1e-13 * self.h[a] {
                        break;
                    }
                }
                out.push(0.5 * (l + r));
            }
        }
    }

    fn eval(&self, a: usize, s: f64, t: f64, scratch: &mut Vec<f64>) -> ([f64; 2], Val) {
        let x = if a == 0 { [s, t] } else { [t, s] };
        let mut out = [0.0; 3];
        self.tape.eval(&x, scratch, &mut out);
        (
            x,
            Val {
                g: if out[0].is_finite() { out[0] } else { f64::NAN },
                across: out[1 + a],
                along: out[2 - a],
            },
        )
    }

    /// Σ over the roots t of g = u on the line x_a = s of p·w/|∂_along g|.
    fn line_sum(
        &self,
        density: &dyn JointDensity,
        a: usize,
        s: f64,
        u: f64,
        excluded: &[&Critical],
        (roots, scratch): (&mut Vec<f64>, &mut Vec<f64>),
    ) -> f64 {
        self.line_roots(a, s, u, roots, scratch);
        let mut total = 0.0;
        for &t in roots.iter() {
            let (x, v) = self.eval(a, s, t, scratch);
            if v.along == 0.0 || !v.along.is_finite() || !v.across.is_finite() {
                continue;
            }
            if excluded.iter().any(|c| in_component(c, x, u)) {
                continue;
            }
            let r = (v.across / v.along).abs();
            let w = 1.0 / (1.0 + r.powi(M));
            total += density.pdf(x) * w / v.along.abs();
        }
        total
    }

    /// The roots t of g = u on the line x_a = s, into `out` (emptied first); returns how many.
    fn line_roots(
        &self,
        a: usize,
        s: f64,
        u: f64,
        out: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
    ) -> usize {
        out.clear();
        let b = 1 - a;
        let n = GRID;
        let ia = (((s - self.lo[a]) / self.h[a]).floor().max(0.0) as usize).min(n - 2);
        let t_of = |j: usize| self.lo[b] + j as f64 * self.h[b];
        let column = &self.bounds[a][ia * (n - 1)..(ia + 1) * (n - 1)];
        let runs = &self.blocks[a][ia * (n - 1) / BLOCK..(ia + 1) * (n - 1) / BLOCK];
        // g at the last node evaluated: the cells are visited in order, so a cell's left node
        // is the previous cell's right one when both hold the level.
        let mut last: Option<(usize, Val)> = None;
        let cells = runs
            .iter()
            .enumerate()
            .filter(|(_, &[lo, hi])| u >= lo && u <= hi)
            .flat_map(|(r, _)| r * BLOCK..(r + 1) * BLOCK);
        for jb in cells {
            let [lo, hi] = column[jb];
            if !(u >= lo && u <= hi) {
                continue;
            }
            let va = match last {
                Some((j, v)) if j == jb => v,
                _ => self.eval(a, s, t_of(jb), scratch).1,
            };
            let vb = self.eval(a, s, t_of(jb + 1), scratch).1;
            last = Some((jb + 1, vb));
            let mut roots = [f64::NAN; 2];
            self.cell_roots(
                a,
                s,
                u,
                (t_of(jb), va),
                (t_of(jb + 1), vb),
                &mut roots,
                scratch,
            );
            out.extend(roots.into_iter().filter(|t| !t.is_nan()));
        }
        out.len()
    }

    /// The roots of g = u in the cell [ta, tb] of the line x_a = s (at most two).
    #[allow(clippy::too_many_arguments)]
    fn cell_roots(
        &self,
        a: usize,
        s: f64,
        u: f64,
        (ta, va): (f64, Val),
        (tb, vb): (f64, Val),
        roots: &mut [f64; 2],
        scratch: &mut Vec<f64>,
    ) {
        let (fa, fb) = (va.g - u, vb.g - u);
        if fa.is_nan() && fb.is_nan() {
            return;
        }
        if fa.is_nan() || fb.is_nan() {
            // g undefined at one end: move that end to the edge of where g is defined.
            let (mut good, mut bad) = if fa.is_nan() { (tb, ta) } else { (ta, tb) };
            let mut vg = if fa.is_nan() { vb } else { va };
            for _ in 0..64 {
                let mid = 0.5 * (good + bad);
                let (_, v) = self.eval(a, s, mid, scratch);
                if v.g.is_nan() {
                    bad = mid;
                } else {
                    good = mid;
                    vg = v;
                }
                if (good - bad).abs() <= 1e-13 * self.h[1 - a] {
                    break;
                }
            }
            let other = if fa.is_nan() { (tb, vb) } else { (ta, va) };
            if (good - other.0).abs() <= 1e-13 * self.h[1 - a] || vg.g.is_nan() {
                return;
            }
            let (l, r) = if good < other.0 {
                ((good, vg), other)
            } else {
                (other, (good, vg))
            };
            return self.cell_roots(a, s, u, l, r, roots, scratch);
        }
        if fa == 0.0 || fb == 0.0 {
            // A root on a node: counted here when it is the cell's left end (the right end is
            // the next cell's left end). Another root strictly inside is bracketed by the sign
            // of g − u just inside the cell from the zero end, −(or +) the slope there.
            if fa == 0.0 {
                roots[0] = ta;
            }
            let (inner, other) = if fa == 0.0 {
                (va.along, fb)
            } else {
                (-vb.along, fa)
            };
            if inner != 0.0 && other != 0.0 && inner * other < 0.0 {
                let flo = if fa == 0.0 { inner } else { fa };
                roots[1] = self
                    .refine(a, s, u, ta, tb, flo, 0.5 * (ta + tb), scratch)
                    .filter(|t| *t > ta && *t < tb)
                    .unwrap_or(f64::NAN);
            }
            return;
        }
        if fa * fb < 0.0 {
            // Start from the secant through the cell's ends.
            let guess = ta + (tb - ta) * fa / (fa - fb);
            roots[0] = self
                .refine(a, s, u, ta, tb, fa, guess, scratch)
                .unwrap_or(f64::NAN);
            return;
        }
        // Same side at both ends: an extremum between them may cross u.
        let towards = if fa > 0.0 {
            va.along < 0.0 && vb.along > 0.0
        } else {
            va.along > 0.0 && vb.along < 0.0
        };
        if !towards {
            return;
        }
        let (mut l, mut r) = (ta, tb);
        let dl = va.along;
        let mut tm = 0.5 * (l + r);
        let mut vm = va;
        for _ in 0..80 {
            tm = 0.5 * (l + r);
            vm = self.eval(a, s, tm, scratch).1;
            if vm.g.is_nan() {
                return;
            }
            if (vm.g - u) * fa <= 0.0 || vm.along == 0.0 {
                break;
            }
            if vm.along * dl > 0.0 {
                l = tm;
            } else {
                r = tm;
            }
            if r - l <= 1e-14 * self.h[1 - a] {
                break;
            }
        }
        let fm = vm.g - u;
        if fm * fa < 0.0 {
            roots[0] = self
                .refine(a, s, u, ta, tm, fa, 0.5 * (ta + tm), scratch)
                .unwrap_or(f64::NAN);
            roots[1] = self
                .refine(a, s, u, tm, tb, fm, 0.5 * (tm + tb), scratch)
                .unwrap_or(f64::NAN);
        }
    }

    /// The root of g = u in [lo, hi] (g − u has the sign of `flo` at `lo` and the opposite at
    /// `hi`) by safeguarded Newton; `None` when the sign change is a jump of g, not a root.
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        a: usize,
        s: f64,
        u: f64,
        lo: f64,
        hi: f64,
        flo: f64,
        guess: f64,
        scratch: &mut Vec<f64>,
    ) -> Option<f64> {
        let (mut l, mut r) = (lo, hi);
        let mut t = if guess > lo && guess < hi {
            guess
        } else {
            0.5 * (l + r)
        };
        let tol = 1e-15 * (lo.abs() + hi.abs()) + 1e-14 * (hi - lo);
        for _ in 0..200 {
            let v = self.eval(a, s, t, scratch).1;
            let f = v.g - u;
            if f.is_nan() {
                return None;
            }
            if f == 0.0 {
                return Some(t);
            }
            if f * flo > 0.0 {
                l = t;
            } else {
                r = t;
            }
            let newton = t - f / v.along;
            if newton > l && newton < r && (newton - t).abs() <= tol {
                // Converged (quadratically): the next step would not move it.
                return Some(newton);
            }
            let next = if newton > l && newton < r {
                newton
            } else {
                0.5 * (l + r)
            };
            if r - l <= tol {
                // The bracket has collapsed: a root, or a jump of g (then g − u is not small).
                let v = self.eval(a, s, next, scratch).1;
                return ((v.g - u).abs() <= 1e-8 * self.gscale).then_some(next);
            }
            t = next;
        }
        let v = self.eval(a, s, t, scratch).1;
        ((v.g - u).abs() <= 1e-8 * self.gscale).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Independent standard normals on [−10, 10]².
    struct Normal;
    impl JointDensity for Normal {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * PI)
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            [[-10.0, 10.0], [-10.0, 10.0]]
        }
    }

    #[test]
    fn roots_on_grid_nodes_are_counted_once_and_their_neighbours_kept() {
        // g = |z − v| + v with u chosen so that the level set passes exactly through grid
        // nodes: u = g at a node. Exact: p(u) = ∫_{v<u} φ(v) (φ(u) + φ(2v − u)) dv.
        let states: [Symbol; 2] = ["z".into(), "v".into()];
        let (z, v) = (Expr::sym("z"), Expr::sym("v"));
        let g = Expr::call(Func::Abs, z - v.clone()) + v;
        let set = LevelSet::new(&Normal, &g, &states).unwrap();
        let phi = |x: f64| (-x * x / 2.0).exp() / (2.0 * PI).sqrt();
        for (i, j) in [(64, 60), (70, 70), (50, 80)] {
            let (zn, vn) = (
                set.lo[0] + i as f64 * set.h[0],
                set.lo[1] + j as f64 * set.h[1],
            );
            let u = (zn - vn).abs() + vn;
            let n = 200_000;
            let (a, h) = (-12.0, (u + 12.0) / n as f64);
            let f = |v: f64| phi(v) * (phi(u) + phi(2.0 * v - u));
            let mut exact = f(a) + f(u);
            for k in 1..n {
                exact += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            exact *= h / 3.0;
            let p = set.pdf(&Normal, u);
            assert!((p - exact).abs() <= 1e-7 * exact, "u={u}: {p} vs {exact}");
        }
    }
}
