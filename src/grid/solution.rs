//! The grid solution: cell densities, marginals, the joint density at any point, and the
//! report of how it was obtained.

use std::fmt;

use serde::Serialize;

use super::mesh::{Domain, Marginal, Mesh};
use super::reconstruct::{self, Reconstruction};
use crate::density::JointDensity;

/// The discretisation error of what a solution writes, estimated from a second solve on half
/// the cells per axis: the same curve or statistic of both solutions (each read through its
/// interpolant, [`GridSolution::pdf`]), their difference divided by 2^order − 1 (Richardson,
/// with the lowest order the scheme shows on the exact cases: an upper estimate when it does
/// better). It covers the finite-volume error and the reconstruction of point values from
/// cell averages alike, and bounds the true error on every exact case of the tests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DiscretisationEstimate {
    /// Estimated L1 error of the position marginal's curve (the clipping of negative values
    /// included: twice the clipped mass).
    pub x: f64,
    /// Estimated L1 error of the velocity marginal's curve (likewise).
    pub v: f64,
    /// Estimated absolute error of each state's mean, (position, velocity).
    pub mean: [f64; 2],
    /// Estimated absolute error of each state's standard deviation.
    pub std: [f64; 2],
    /// Largest |log10| of the ratio of the two solutions' marginal curves where the fine one
    /// is at least [`DiscretisationEstimate::tail_level`] of its peak: how far, as a factor,
    /// the tails written may be off (infinite where the coarse solution has a hole).
    pub tail: [f64; 2],
    /// The level, relative to each marginal's peak, down to which `tail` compares.
    pub tail_level: f64,
    /// The cells of the coarse solve, (position, velocity).
    pub coarse_cells: [usize; 2],
    /// The convergence order assumed for the moments, the tails and every number derived from
    /// the density ([`GridSolution::estimate_of`]).
    pub order: f64,
    /// The convergence order the L1 estimates `x` and `v` take: the order the fine, half and
    /// quarter solves show, at least `CURVE_ORDERS[0]` and at most the problem's cap
    /// ([`SMOOTH_CURVE_ORDER`](super::SMOOTH_CURVE_ORDER) on the mechanical form without a
    /// singular corner, else `CURVE_ORDERS[1]`, see [`CURVE_ORDERS`](super::CURVE_ORDERS)),
    /// and at most 2 when the quarter solve has fewer than 48 cells on an axis; `order`
    /// without a quarter solve (cells not a multiple of 4, or fewer than 64 on an axis).
    pub curve_order: [f64; 2],
    /// The order the three solves show within the problem's cap, before the limit for a
    /// coarse quarter solve (equal to `curve_order` when that limit does not apply). A
    /// tolerance's next cells aim by the scheme's order and then by the rate its estimates
    /// fell, not by this.
    pub shown_order: [f64; 2],
    /// The cells of the quarter solve, when there was one.
    pub quarter_cells: Option<[usize; 2]>,
}

/// Wall-clock times of a solve, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct GridTimings {
    /// Sizing the domain (coarse passes), 0 for a domain given explicitly.
    pub domain_ms: f64,
    /// Assembling the operator of the main solve.
    pub assemble_ms: f64,
    /// Sparse LU factorisation and solve of the main system.
    pub solve_ms: f64,
    /// The coarse solve of the error estimate (it runs alongside the main solve, so the
    /// times overlap).
    pub estimate_ms: f64,
    /// Everything.
    pub total_ms: f64,
}

/// What the box leaves at its free edges (the position's ends that are not walls, both ends
/// of the velocity), in the order x low, x high, v low, v high: a box that cuts the density
/// shows it here. A wall's side reads 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoxEdges {
    /// Probability mass in the outermost row of cells along each free edge.
    pub mass: [f64; 4],
    /// The mass estimated beyond each free edge: the outermost row's mass continued
    /// geometrically at the ratio of the last two rows (at most 1; 1 where they do not
    /// decay at an edge above [`BoxEdges::LEVEL`], the row's own mass below it). Twice their
    /// sum is added to the error estimate when the box cuts the density.
    pub beyond: [f64; 4],
    /// The largest density on that row, relative to the peak of the density.
    pub relative_density: [f64; 4],
    /// Whether the box cuts the density: some free edge holds more than
    /// [`BoxEdges::LEVEL`] of the peak. Twice the mass beyond is then added to the error
    /// estimate.
    pub cuts_density: bool,
}

impl BoxEdges {
    /// The edge density, relative to the peak, above which a box cuts the density (the
    /// automatic sizing enlarges a box beyond it).
    pub const LEVEL: f64 = 1e-6;

    /// The mass at the free edges in all.
    ///
    /// ```
    /// let e = fpsolve::grid::BoxEdges {
    ///     mass: [1e-3, 0.0, 2e-3, 0.0], beyond: [0.0; 4], relative_density: [0.0; 4], cuts_density: true,
    /// };
    /// assert_eq!(e.total_mass(), 3e-3);
    /// ```
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }
}

/// How a grid solution was obtained. `Display` prints it as a short paragraph.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GridReport {
    /// Cells (position, velocity).
    pub cells: [usize; 2],
    /// The rectangle solved on.
    pub domain: Domain,
    /// Total mass of the negative cell values that were clipped to zero (relative to the
    /// total mass before clipping).
    pub negative_mass: f64,
    /// The discretisation-error estimate (`None` when turned off).
    pub discretisation_estimate: Option<DiscretisationEstimate>,
    /// How many coarse passes sized the domain.
    pub domain_passes: usize,
    /// Whether the box was given ([`GridSolver::domain`](super::GridSolver::domain), the
    /// command line's `--domain`) rather than sized from the density.
    pub domain_given: bool,
    /// What the box leaves at its free edges.
    pub edges: BoxEdges,
    /// Times (`total_ms` covers every solve of a tolerance).
    pub timings: GridTimings,
    /// What a solve on request ([`GridSolver::tolerance`](super::GridSolver::tolerance))
    /// achieved; `None` for fixed cells.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<super::ToleranceOutcome>,
}

impl fmt::Display for GridReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.domain;
        write!(
            f,
            "grid {}x{} cells on [{:.4}, {:.4}] x [{:.4}, {:.4}]; clipped negative mass {:.1e}",
            self.cells[0], self.cells[1], d.x[0], d.x[1], d.v[0], d.v[1], self.negative_mass
        )?;
        if let Some(e) = &self.discretisation_estimate {
            write!(
                f,
                "; estimated L1 error {:.1e} (position), {:.1e} (velocity); tails above {:.0e} \
                 of the peak within a factor {} (position), {} (velocity)",
                e.x,
                e.v,
                e.tail_level,
                factor(e.tail[0]),
                factor(e.tail[1])
            )?;
        }
        write!(f, "; {:.0} ms", self.timings.total_ms)?;
        if let Some(t) = &self.tolerance {
            let tries: Vec<String> = t
                .solves
                .iter()
                .map(|(c, e)| format!("{}x{} ({e:.1e})", c[0], c[1]))
                .collect();
            write!(
                f,
                "; cells chosen for L1 tolerance {:.1e} after {}",
                t.asked,
                tries.join(", ")
            )?;
            if let Some(why) = &t.shortfall {
                write!(
                    f,
                    "\nwarning: the grid did not reach the L1 tolerance {:.1e}: achieved {:.1e} \
                     on {}x{} cells; {why}",
                    t.asked, t.achieved, self.cells[0], self.cells[1]
                )?;
            }
        }
        let e = &self.edges;
        if e.cuts_density {
            let names = ["x low", "x high", "v low", "v high"];
            let sides: Vec<String> = (0..4)
                .filter(|&k| e.relative_density[k] > BoxEdges::LEVEL)
                .map(|k| {
                    format!(
                        "{} ({:.1e} of the peak, mass {:.1e} at the edge, about {:.1e} beyond)",
                        names[k], e.relative_density[k], e.mass[k], e.beyond[k]
                    )
                })
                .collect();
            write!(
                f,
                "\nwarning: the grid's box cuts the density at {}; twice the mass beyond is \
                 counted in the error estimate (widen the box)",
                sides.join(", ")
            )?;
        }
        Ok(())
    }
}

/// A tail estimate |log10 ratio| as the factor it stands for.
fn factor(log10: f64) -> String {
    if log10.is_finite() {
        format!("{:.2}", 10f64.powf(log10))
    } else {
        "unbounded (a hole in the coarse solution)".to_string()
    }
}

/// The stationary density on a grid of cells, from [`crate::grid::GridSolver::solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct GridSolution {
    pub(crate) mesh: Mesh,
    /// Cell averages, velocity fastest, negative values clipped, unit mass.
    pub(crate) density: Vec<f64>,
    /// The point values and bicubic quads the interpolant reads ([`GridSolution::pdf`]).
    recon: Reconstruction,
    /// How it was obtained.
    pub report: GridReport,
    /// The half-resolution solve of the error estimate, kept so that any number derived from
    /// the density gets its own estimate ([`GridSolution::estimate_of`]).
    pub(crate) coarse: Option<Box<GridSolution>>,
}

/// Roache's safety factor of the grid convergence index for a known order.
pub(super) const SAFETY: f64 = 1.25;

/// The factor a difference between the fine and the half-resolution answer is scaled by
/// to bound the fine one's error, for convergence of order `order`: Richardson's
/// 1/(2^order − 1) times Roache's safety factor.
pub(super) fn richardson_factor(order: f64) -> f64 {
    SAFETY / (2f64.powf(order) - 1.0)
}

impl GridSolution {
    /// The solution of cell averages `density` (velocity fastest, none negative, unit mass)
    /// on `mesh`, with its reconstruction.
    pub(crate) fn new(
        mesh: Mesh,
        density: Vec<f64>,
        report: GridReport,
        coarse: Option<Box<GridSolution>>,
    ) -> GridSolution {
        let recon = Reconstruction::new(&mesh, &density);
        GridSolution {
            mesh,
            density,
            recon,
            report,
            coarse,
        }
    }

    /// The point value at the centre of cell (i, j) the interpolant passes through.
    fn point(&self, i: usize, j: usize) -> f64 {
        self.recon.point[self.mesh.index(i, j)]
    }

    /// The first cells of the x and v stencils of the quad between centres (i, j) and
    /// (i + 1, j + 1) when it is bicubic.
    fn cubic(&self, i: usize, j: usize) -> Option<[usize; 2]> {
        let m = &self.mesh;
        if !self.recon.cubic[i * m.nv + j] {
            return None;
        }
        Some([
            reconstruct::stencil(i, m.segment_of(i))?,
            reconstruct::stencil(j, [0, m.nv])?,
        ])
    }

    /// The 4×4 stencil of point values from cells `[sx, sv]` collapsed along `axis` by the
    /// cubic weights `w`: the values at the other axis's four nodes.
    fn collapse(&self, [sx, sv]: [usize; 2], axis: usize, w: [f64; 4]) -> [f64; 4] {
        if axis == 0 {
            [0, 1, 2, 3].map(|b| {
                (0..4)
                    .map(|a| w[a] * self.point(sx + a, sv + b))
                    .sum::<f64>()
            })
        } else {
            [0, 1, 2, 3].map(|a| {
                (0..4)
                    .map(|b| w[b] * self.point(sx + a, sv + b))
                    .sum::<f64>()
            })
        }
    }

    /// The estimated discretisation error of a number `f` derives from the density (a
    /// crossing rate, an impact rate, a moment), as the error estimate takes it for the
    /// curves it writes: `f` on the half-resolution solve differs from `f` on this one by
    /// both errors at once, scaled as [`DiscretisationEstimate`]'s (Richardson at the
    /// assumed order, Roache's safety factor), plus |f|·(twice the negative mass clipped and
    /// twice the mass beyond a box that cuts the density: restoring unit mass moves f by
    /// about that fraction). `None` for a solve without the estimate.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 160).solve().unwrap();
    /// // The density at the origin: exactly 0.2/(2π) = 0.0318…; its estimate covers the error.
    /// let at_origin = |s: &fpsolve::grid::GridSolution| s.pdf(0.0, 0.0);
    /// let error = sol.estimate_of(at_origin).unwrap();
    /// assert!((at_origin(&sol) - 0.2 / (2.0 * std::f64::consts::PI)).abs() <= error);
    /// assert!(fpsolve::grid::GridSolver::new(&bound).cells(80, 160).estimate(false)
    ///     .solve().unwrap().estimate_of(at_origin).is_none());
    /// ```
    pub fn estimate_of(&self, f: impl Fn(&GridSolution) -> f64) -> Option<f64> {
        self.estimate_of_each(&[f(self)], |s| vec![f(s)])
            .map(|e| e[0])
    }

    /// [`GridSolution::estimate_of`] for each of the numbers `f` derives at once (a curve:
    /// its values at a set of levels), given their values `fine` on this solution (which the
    /// caller has already computed: only the half-resolution solve is evaluated).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 160).solve().unwrap();
    /// let on_axis = |s: &fpsolve::grid::GridSolution| vec![s.pdf(0.0, 0.0), s.pdf(1.0, 0.0)];
    /// let errors = sol.estimate_of_each(&on_axis(&sol), on_axis).unwrap();
    /// assert_eq!(errors.len(), 2);
    /// ```
    pub fn estimate_of_each(
        &self,
        fine: &[f64],
        f: impl Fn(&GridSolution) -> Vec<f64>,
    ) -> Option<Vec<f64>> {
        let coarse = self.coarse.as_deref()?;
        let order = self.report.discretisation_estimate.as_ref()?.order;
        let half = f(coarse);
        let edges = &self.report.edges;
        let cut = if edges.cuts_density {
            2.0 * edges.beyond.iter().sum::<f64>()
        } else {
            0.0
        };
        let renormalised = 2.0 * self.report.negative_mass + cut;
        let factor = richardson_factor(order);
        Some(
            fine.iter()
                .zip(&half)
                .map(|(f, h)| factor * (f - h).abs() + f.abs() * renormalised)
                .collect(),
        )
    }

    /// The cell-average density of cell (i, j) (position cell i, velocity cell j).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 80).estimate(false).solve().unwrap();
    /// assert!(sol.cell(40, 40) > 0.0);
    /// ```
    pub fn cell(&self, i: usize, j: usize) -> f64 {
        self.density[self.mesh.index(i, j)]
    }

    /// The rectangle solved on.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 80).estimate(false).solve().unwrap();
    /// assert!(sol.domain().x[0] < 0.0 && sol.domain().v[1] > 0.0);
    /// ```
    pub fn domain(&self) -> Domain {
        self.mesh.domain()
    }

    /// The marginal density of the position (`axis` 0) or the velocity (`axis` 1).
    ///
    /// # Panics
    /// If `axis > 1`.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 80).estimate(false).solve().unwrap();
    /// let px = sol.marginal(0);
    /// let mass: f64 = px.density.iter().sum::<f64>() * px.width;
    /// assert!((mass - 1.0).abs() < 1e-12);
    /// ```
    pub fn marginal(&self, axis: usize) -> Marginal {
        self.mesh.marginal(&self.density, axis)
    }

    /// The joint density at (x, v), through the fourth-order point values at the cell
    /// centres (the averages less h²/24 of their second differences): bicubic between the
    /// centres where the 4×4 stencil around them is positive and within a factor 2 (the
    /// interpolant is then positive), bilinear elsewhere (the far tails, beside clipped
    /// cells); never across the barrier (the density may jump there); from the last centre to a wall (or another edge of a run
    /// of cells in x) the quadratic through the last three centres where each two agree
    /// within a factor 2 and it stays positive, else the line through the last two, clipped
    /// at 0, where those agree (else the last value held), so that the value at a wall is
    /// its one-sided limit from inside (third order; holding the last centre's value is first
    /// order: 4.5e−3 off the exact wall density of `barrier_caughey_lower` at 200 cells,
    /// against 1e−4 for the line); constant from the last centre to
    /// an edge in v (the far field); zero outside the domain.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 80).estimate(false).solve().unwrap();
    /// assert!(sol.pdf(0.0, 0.0) > sol.pdf(1.0, 1.0));
    /// assert_eq!(sol.pdf(1e3, 0.0), 0.0);
    /// ```
    pub fn pdf(&self, x: f64, v: f64) -> f64 {
        let m = &self.mesh;
        let d = m.domain();
        if !(d.x[0] <= x && x <= d.x[1] && d.v[0] <= v && v <= d.v[1]) {
            return 0.0;
        }
        let cell_of = |u: f64, lo: f64, h: f64, n: usize| {
            ((((u - lo) / h).floor()).max(0.0) as usize).min(n - 1)
        };
        let seg = m.segment_of(cell_of(x, m.x0, m.hx, m.nx));
        let (i0, i1, tx) = reach(x, m.x0, m.hx, seg);
        let (j0, j1, tv) = bracket(v, m.v0, m.hv, [0, m.nv]);
        if (0.0..=1.0).contains(&tx) {
            if let Some([sx, sv]) = (j1 > j0).then(|| self.cubic(i0, j0)).flatten() {
                let wx = reconstruct::weights((x - m.xc(sx)) / m.hx);
                let wv = reconstruct::weights((v - m.vc(sv)) / m.hv);
                let rows = self.collapse([sx, sv], 1, wv);
                return (0..4).map(|a| wx[a] * rows[a]).sum();
            }
            let row = |i: usize| (1.0 - tv) * self.point(i, j0) + tv * self.point(i, j1);
            return (1.0 - tx) * row(i0) + tx * row(i1);
        }
        // Beyond the last centre of the run: each velocity node's line through the last
        // two centres, clipped at 0, then linear in v (what `line_integral` integrates).
        let column = |j: usize| self.edge(seg, tx < 0.0, j).at(beyond(tx));
        (1.0 - tv) * column(j0) + tv * column(j1)
    }
}

impl GridSolution {
    /// ∫ p dx_other over `range` on the line x_axis = `at`, exactly for the interpolant
    /// [`GridSolution::pdf`] evaluates.
    pub(super) fn line_integral(&self, axis: usize, at: f64, [a, b]: [f64; 2]) -> f64 {
        let m = &self.mesh;
        let d = m.domain();
        if axis == 0 {
            if !(d.x[0] <= at && at <= d.x[1]) {
                return 0.0;
            }
            let i = (((at - m.x0) / m.hx).floor().max(0.0) as usize).min(m.nx - 1);
            let seg = m.segment_of(i);
            let (i0, i1, tx) = reach(at, m.x0, m.hx, seg);
            // Clipping is a no-op between centres (convex weights of values ≥ 0).
            let f = |j: usize| {
                if (0.0..=1.0).contains(&tx) {
                    let (a, b) = (self.point(i0, j), self.point(i1, j));
                    ((1.0 - tx) * a + tx * b).max(0.0)
                } else {
                    self.edge(seg, tx < 0.0, j).at(beyond(tx))
                }
            };
            let linear = run_integral(&[(1.0, &f)], m.v0, m.hv, [0, m.nv], d.v, [a, b], false);
            if !(0.0..=1.0).contains(&tx) || i1 != i0 + 1 {
                return linear;
            }
            // The bicubic quads along the line: their cubic in v less the linear piece
            // `run_integral` took.
            // The x stencil and its weights are those of the line's x interval in every quad.
            let mut cubic = 0.0;
            let mut wx = None;
            for j in 0..m.nv.saturating_sub(1) {
                let Some([sx, sv]) = self.cubic(i0, j) else {
                    continue;
                };
                let wx = *wx.get_or_insert_with(|| reconstruct::weights((at - m.xc(sx)) / m.hx));
                let g = self.collapse([sx, sv], 0, wx);
                cubic +=
                    m.hv * cubic_less_linear(g, j - sv, [f(j), f(j + 1)], m.vc(j), m.hv, [a, b]);
            }
            linear + cubic
        } else {
            if !(d.v[0] <= at && at <= d.v[1]) {
                return 0.0;
            }
            let (j0, j1, tv) = bracket(at, m.v0, m.hv, [0, m.nv]);
            let (f0, f1) = (|i: usize| self.point(i, j0), |i: usize| self.point(i, j1));
            let columns: [(f64, &dyn Fn(usize) -> f64); 2] = [(1.0 - tv, &f0), (tv, &f1)];
            let linear: f64 = self
                .runs()
                .into_iter()
                .map(|(cells, edges)| {
                    run_integral(&columns, m.x0, m.hx, cells, edges, [a, b], true)
                })
                .sum();
            if j1 != j0 + 1 {
                return linear;
            }
            let row = |i: usize| (1.0 - tv) * f0(i) + tv * f1(i);
            // The v stencil and its weights are those of the line's v interval in every quad.
            let mut cubic = 0.0;
            let mut wv = None;
            for i in 0..m.nx.saturating_sub(1) {
                let Some([sx, sv]) = self.cubic(i, j0) else {
                    continue;
                };
                let wv = *wv.get_or_insert_with(|| reconstruct::weights((at - m.vc(sv)) / m.hv));
                let g = self.collapse([sx, sv], 1, wv);
                cubic += m.hx
                    * cubic_less_linear(g, i - sx, [row(i), row(i + 1)], m.xc(i), m.hx, [a, b]);
            }
            linear + cubic
        }
    }
}

impl GridSolution {
    /// The interpolant in x beyond the first (`low`) or last centre of the run `seg`, on
    /// velocity row `j`.
    fn edge(&self, [start, end]: [usize; 2], low: bool, j: usize) -> Edge {
        let at = |k: usize| self.point(k, j);
        let n = end - start;
        let (near, next, third) = if low {
            (at(start), at(start + 1), (n >= 3).then(|| at(start + 2)))
        } else {
            (at(end - 1), at(end - 2), (n >= 3).then(|| at(end - 3)))
        };
        Edge::new(near, next, third)
    }

    /// The runs of cells in x the interpolant does not cross (one, or two either side of a
    /// barrier), each with its edges: the domain's ends or the barrier's face.
    fn runs(&self) -> Vec<([usize; 2], [f64; 2])> {
        let m = &self.mesh;
        let d = m.domain();
        let whole = [[0, m.nx]];
        let runs: &[[usize; 2]] = if m.segments.is_empty() {
            &whole
        } else {
            &m.segments
        };
        runs.iter()
            .map(|&[s0, s1]| {
                let lo = if s0 == 0 {
                    d.x[0]
                } else {
                    m.x0 + s0 as f64 * m.hx
                };
                let hi = if s1 == m.nx {
                    d.x[1]
                } else {
                    m.x0 + s1 as f64 * m.hx
                };
                ([s0, s1], [lo, hi])
            })
            .collect()
    }
}

/// ∫ over [a, b] of the function that is Σ w·f(k) over the weighted `columns` (w, f) at the
/// centres lo + (k + ½)·h of the run [start, end), linear between them; from the end centres
/// to the run's edges `[e0, e1]` either constant (`extrapolate` false) or, per column, the
/// line through its last two centres clipped at 0 (as [`GridSolution::pdf`] in x); zero
/// outside the edges.
fn run_integral(
    columns: &[(f64, &dyn Fn(usize) -> f64)],
    lo: f64,
    h: f64,
    [start, end]: [usize; 2],
    [e0, e1]: [f64; 2],
    [a, b]: [f64; 2],
    extrapolate: bool,
) -> f64 {
    let centre = |k: usize| lo + (k as f64 + 0.5) * h;
    let f = |k: usize| columns.iter().map(|(w, f)| w * f(k)).sum::<f64>();
    // The integral of the linear piece through (p, fp), (q, fq), clipped at 0, over
    // [p, q] ∩ [a, b].
    let piece = |p: f64, fp: f64, q: f64, fq: f64| {
        let (u, w) = (p.max(a), q.min(b));
        if w <= u {
            return 0.0;
        }
        let at = |t: f64| {
            if q > p {
                fp + (fq - fp) * (t - p) / (q - p)
            } else {
                fp
            }
        };
        let (fu, fw) = (at(u), at(w));
        if fu >= 0.0 && fw >= 0.0 {
            return 0.5 * (fu + fw) * (w - u);
        }
        // One end below 0 (only past an end centre): the triangle above 0.
        let (top, other) = if fu > 0.0 { (fu, fw) } else { (fw, fu) };
        if top <= 0.0 {
            return 0.0;
        }
        0.5 * top * (w - u) * top / (top - other)
    };
    let (first, last) = (f(start), f(end - 1));
    let mut total = 0.0;
    if extrapolate && end - start >= 2 {
        let (c0, c1) = (centre(start), centre(end - 1));
        let third = end - start >= 3;
        for (w, g) in columns {
            // [u, w] ∩ [a, b] in cells beyond the end centre.
            let lower = Edge::new(g(start), g(start + 1), third.then(|| g(start + 2)));
            let (u, v) = (a.max(e0), b.min(c0));
            if v > u {
                total += w * h * lower.integral((c0 - v) / h, (c0 - u) / h);
            }
            let upper = Edge::new(g(end - 1), g(end - 2), third.then(|| g(end - 3)));
            let (u, v) = (a.max(c1), b.min(e1));
            if v > u {
                total += w * h * upper.integral((u - c1) / h, (v - c1) / h);
            }
        }
    } else {
        total += piece(e0, first, centre(start).max(e0), first);
        total += piece(centre(end - 1).min(e1), last, e1, last);
    }
    let mut prev = first;
    for k in start + 1..end {
        let next = f(k);
        total += piece(centre(k - 1), prev, centre(k), next);
        prev = next;
    }
    total
}

/// ∫ (cubic − linear) over the interval between the centres `k` and `k + 1` of a cubic's
/// stencil (nodes 0…3, `values` there), in cells, within [a, b]: the centre of node `k` is
/// at `from`, the nodes `h` apart, and the linear piece runs between `ends` at the two
/// centres.
fn cubic_less_linear(
    values: [f64; 4],
    k: usize,
    ends: [f64; 2],
    from: f64,
    h: f64,
    [a, b]: [f64; 2],
) -> f64 {
    let t0 = ((a - from) / h).max(0.0);
    let t1 = ((b - from) / h).min(1.0);
    if t1 <= t0 {
        return 0.0;
    }
    let linear = (t1 - t0) * (ends[0] + (ends[1] - ends[0]) * 0.5 * (t0 + t1));
    let k = k as f64;
    let cubic = if t0 == 0.0 && t1 == 1.0 {
        reconstruct::segment_integral(values, k as usize)
    } else {
        reconstruct::integral(values, k + t0, k + t1)
    };
    cubic - linear
}

/// How far beyond the end centre of a run, in cells, is the point at weight `tx` of
/// [`reach`] (below 0 or above 1).
fn beyond(tx: f64) -> f64 {
    if tx < 0.0 {
        -tx
    } else {
        tx - 1.0
    }
}

/// The interpolant between a run's end centre and its edge, as a function of the distance
/// s ≥ 0 beyond that centre in cells: the quadratic through the run's last three point
/// values where each pair is [`resolved`] and it stays positive up to the edge (s = ½),
/// third order, so that the value at a wall, its one-sided limit from inside, is off by
/// O(h³) (the line through two centres is off by 3h²p″/8: 1.2e−3 of the exact density at
/// the Zhuravlev barrier of the elastic Duffing case at 168×336 cells); else the line
/// through the last two, clipped at 0, where they are resolved; else the end value held.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Edge {
    /// p0 + b·s + c·s².
    Quadratic { p0: f64, b: f64, c: f64 },
    /// (p0 + b·s)⁺.
    Linear { p0: f64, b: f64 },
    /// p0.
    Held(f64),
}

impl Edge {
    /// From the end centre's point value `near`, the next one inwards and, when the run
    /// has three cells, the one after.
    fn new(near: f64, next: f64, third: Option<f64>) -> Edge {
        if !resolved(near, next) {
            return Edge::Held(near);
        }
        if let Some(p2) = third.filter(|&p2| resolved(next, p2)) {
            let b = 0.5 * (3.0 * near - 4.0 * next + p2);
            let c = 0.5 * (near - 2.0 * next + p2);
            let q = Edge::Quadratic { p0: near, b, c };
            // Positive on [0, ½]: at the edge and, for a minimum inside, at the vertex.
            let vertex = if c > 0.0 { -b / (2.0 * c) } else { -1.0 };
            if q.at(0.5) > 0.0 && !((0.0..0.5).contains(&vertex) && q.at(vertex) <= 0.0) {
                return q;
            }
        }
        Edge::Linear {
            p0: near,
            b: near - next,
        }
    }

    /// The value at `s` cells beyond the end centre.
    fn at(&self, s: f64) -> f64 {
        match *self {
            Edge::Quadratic { p0, b, c } => p0 + s * (b + s * c),
            Edge::Linear { p0, b } => (p0 + b * s).max(0.0),
            Edge::Held(p0) => p0,
        }
    }

    /// ∫ over [s0, s1] (in cells, 0 ≤ s0 ≤ s1) of the value.
    fn integral(&self, s0: f64, s1: f64) -> f64 {
        match *self {
            Edge::Quadratic { p0, b, c } => {
                let f = |s: f64| s * (p0 + s * (b / 2.0 + s * c / 3.0));
                f(s1) - f(s0)
            }
            Edge::Linear { p0, b } => {
                // Clipped at 0 beyond s = −p0/b when the line falls.
                let end = if b < 0.0 { s1.min(-p0 / b) } else { s1 };
                if end <= s0 {
                    return 0.0;
                }
                (end - s0) * (p0 + b * 0.5 * (s0 + end))
            }
            Edge::Held(p0) => p0 * (s1 - s0),
        }
    }
}

/// Whether the density is resolved at the end of a run, so that the line through its last
/// two centres (values `near`, then `next`) may be continued to the edge: both positive and
/// within a factor 2 of each other. Elsewhere (a solution that is not resolved there, as one
/// clipping much negative mass) the last centre's value is held, as extrapolating its
/// jumps would only add noise.
fn resolved(near: f64, next: f64) -> bool {
    near > 0.0 && next > 0.0 && near <= 2.0 * next && next <= 2.0 * near
}

/// The two cell centres of the run [start, end) nearest `u` and the weight of the second:
/// within [0, 1] between them, outside it beyond an end centre (linear extrapolation to the
/// run's edge; a run of one cell holds its value).
fn reach(u: f64, lo: f64, h: f64, [start, end]: [usize; 2]) -> (usize, usize, f64) {
    let s = (u - lo) / h - 0.5;
    if end - start < 2 {
        return (start, start, 0.0);
    }
    if s <= start as f64 {
        return (start, start + 1, s - start as f64);
    }
    if s >= (end - 1) as f64 {
        return (end - 2, end - 1, s - (end - 2) as f64);
    }
    bracket(u, lo, h, [start, end])
}

/// The two cell centres of the run [start, end) around `u` and the weight of the second.
fn bracket(u: f64, lo: f64, h: f64, [start, end]: [usize; 2]) -> (usize, usize, f64) {
    let s = (u - lo) / h - 0.5;
    if s <= start as f64 {
        return (start, start, 0.0);
    }
    if s >= (end - 1) as f64 {
        return (end - 1, end - 1, 0.0);
    }
    let i = s.floor() as usize;
    (i, i + 1, s - i as f64)
}

impl JointDensity for GridSolution {
    fn pdf(&self, x: [f64; 2]) -> f64 {
        GridSolution::pdf(self, x[0], x[1])
    }

    /// Exact: along a line the interpolant of [`GridSolution::pdf`] is piecewise cubic or
    /// linear between cell centres (constant from the last centre to the run's edge), so its
    /// integral is a sum of trapezoids and two-point Gauss rules; adaptive quadrature of this
    /// kinked function would subdivide at every cell.
    fn line_integral(&self, axis: usize, at: f64, range: [f64; 2]) -> Option<f64> {
        Some(self.line_integral(axis, at, range))
    }

    /// The interpolant is cubic or linear between cell centres along each axis, and from the end
    /// centres to the edges of a run (a line through two centres, or a held value, never
    /// clipped: the line is continued only between values within a factor 2, which stays
    /// above half the end value over the half cell to the edge): the breakpoints are the
    /// centres and the runs' edges.
    fn breakpoints(&self, axis: usize) -> Option<Vec<f64>> {
        let m = &self.mesh;
        let d = m.domain();
        let mut out = Vec::new();
        if axis == 0 {
            for ([s0, s1], [lo, hi]) in self.runs() {
                if out.last() != Some(&lo) {
                    out.push(lo);
                }
                out.extend((s0..s1).map(|i| m.xc(i)).filter(|&c| lo < c && c < hi));
                out.push(hi);
            }
        } else {
            out.push(d.v[0]);
            out.extend(
                (0..m.nv)
                    .map(|j| m.vc(j))
                    .filter(|&c| d.v[0] < c && c < d.v[1]),
            );
            out.push(d.v[1]);
        }
        Some(out)
    }

    /// The domain: the density is zero outside it.
    fn extent(&self) -> [[f64; 2]; 2] {
        let d = self.domain();
        [d.x, d.v]
    }
}

#[cfg(test)]
mod tests {
    /// Beyond a run's end: the quadratic through three resolved values is exact on a
    /// quadratic, its integral that of its values; a quadratic that would dip below 0 gives
    /// way to the line, and values more than a factor 2 apart to the end value held.
    #[test]
    fn the_edge_is_quadratic_where_resolved() {
        let q = |s: f64| 1.0 + 0.2 * s - 0.05 * s * s;
        let e = Edge::new(q(0.0), q(-1.0), Some(q(-2.0)));
        assert!(matches!(e, Edge::Quadratic { .. }));
        for s in [0.0, 0.2, 0.5] {
            assert!((e.at(s) - q(s)).abs() < 1e-15);
        }
        let exact = |s: f64| s + 0.1 * s * s - 0.05 * s.powi(3) / 3.0;
        assert!((e.integral(0.1, 0.5) - (exact(0.5) - exact(0.1))).abs() < 1e-15);
        // Falling fast to the edge: 1, 1.9, 1.2 make a quadratic at −0.05 at s = ½.
        let steep = Edge::new(1.0, 1.9, Some(1.2));
        assert!(matches!(steep, Edge::Linear { .. }), "{steep:?}");
        assert!(steep.at(0.5) >= 0.0);
        assert_eq!(Edge::new(1.0, 3.0, Some(3.0)), Edge::Held(1.0));
        assert_eq!(Edge::new(1.0, 1.5, None), Edge::Linear { p0: 1.0, b: -0.5 });
    }

    use super::Edge;
    use crate::density::JointDensity;
    use crate::grid::GridSolver;
    use crate::model::parse_model;

    /// The exact line integrals equal adaptive quadrature of the interpolant, on both axes,
    /// over whole lines and half-lines, for a pass-through barrier (two runs in x) and a wall.
    #[test]
    fn line_integrals_are_those_of_the_interpolant() {
        for (impact, domain) in [
            ("impact x = 0: v -> 0.9*v", ""),
            ("impact x = -0.3: v -> -0.8*v", "domain x >= -0.3"),
        ] {
            let text = format!(
                "model m\nstate x, v\ndrift x: v\ndrift v: -0.3*v - x - 0.2*x^3\n\
                 noise xi: intensity 0.5\ndiffusion v: xi\n{impact}\n{domain}\n"
            );
            let bound = parse_model(&text, None).unwrap().bind(&[]).unwrap();
            // With its error estimate: at 24×30 cells it clips 1.1e−2 of the mass, which
            // only a stated error covers.
            let sol = GridSolver::new(&bound).cells(24, 30).solve().unwrap();
            let ext = JointDensity::extent(&sol);
            for axis in 0..2 {
                let other = 1 - axis;
                let [lo, hi] = ext[other];
                for frac in [0.0, 0.13, 0.5, 0.77, 1.0] {
                    let at = ext[axis][0] + frac * (ext[axis][1] - ext[axis][0]);
                    for range in [
                        [lo, hi],
                        [lo.min(0.0), 0.0],
                        [0.0, hi.max(0.0)],
                        [lo - 1.0, 0.4],
                    ] {
                        let exact = JointDensity::line_integral(&sol, axis, at, range).unwrap();
                        let f = |t: f64| {
                            let mut x = [0.0; 2];
                            x[axis] = at;
                            x[other] = t;
                            sol.pdf(x[0], x[1])
                        };
                        // Integrate run by run so the adaptive rule sees every kink at a node.
                        let h = (hi - lo) / 4000.0;
                        let (a, b) = (range[0].max(lo), range[1].min(hi));
                        let mut quad = 0.0;
                        if b > a {
                            let n = ((b - a) / h).ceil() as usize;
                            for k in 0..n {
                                let (u, w) = (
                                    a + k as f64 * (b - a) / n as f64,
                                    a + (k + 1) as f64 * (b - a) / n as f64,
                                );
                                quad +=
                                    crate::observe::quadrature::integrate_adaptive(&f, u, w, 1e-13);
                            }
                        }
                        assert!(
                            (exact - quad).abs() <= 1e-6 * quad.abs().max(1e-3),
                            "{impact}: axis {axis} at {at} over {range:?}: {exact} vs {quad}"
                        );
                    }
                }
            }
        }
    }
}
