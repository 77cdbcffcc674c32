//! The grid solution: cell densities, marginals, the joint density at any point, and the
//! report of how it was obtained.

use std::fmt;

use serde::Serialize;

use super::mesh::{Domain, Mesh};
use crate::observe::JointDensity;

/// The discretisation error estimated from a second solve on half the cells per axis:
/// L1 distance of the marginals of the two solves, divided by 2^order − 1 (Richardson, with
/// the order the scheme reaches on the exact cases: an upper estimate when it does better).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DiscretisationEstimate {
    /// Estimated L1 error of the position marginal.
    pub x: f64,
    /// Estimated L1 error of the velocity marginal.
    pub v: f64,
    /// The cells of the coarse solve, (position, velocity).
    pub coarse_cells: [usize; 2],
    /// The convergence order assumed.
    pub order: f64,
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
    /// The coarse solve of the error estimate.
    pub estimate_ms: f64,
    /// Everything.
    pub total_ms: f64,
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
    /// Times.
    pub timings: GridTimings,
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
                "; estimated L1 error {:.1e} (position), {:.1e} (velocity)",
                e.x, e.v
            )?;
        }
        write!(f, "; {:.0} ms", self.timings.total_ms)
    }
}

/// A marginal density on the cells of one axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Marginal {
    /// Cell centres.
    pub centres: Vec<f64>,
    /// Cell-average densities (they integrate to one).
    pub density: Vec<f64>,
    /// The cell width.
    pub width: f64,
}

/// The stationary density on a grid of cells, from [`crate::grid::GridSolver::solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct GridSolution {
    pub(crate) mesh: Mesh,
    /// Cell averages, velocity fastest, negative values clipped, unit mass.
    pub(crate) density: Vec<f64>,
    /// How it was obtained.
    pub report: GridReport,
}

impl GridSolution {
    /// The cell-average density of cell (i, j) (position cell i, velocity cell j).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(24, 24).estimate(false).solve().unwrap();
    /// assert!(sol.cell(12, 12) > 0.0);
    /// ```
    pub fn cell(&self, i: usize, j: usize) -> f64 {
        self.density[self.mesh.index(i, j)]
    }

    /// The rectangle solved on.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(24, 24).estimate(false).solve().unwrap();
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
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(24, 24).estimate(false).solve().unwrap();
    /// let px = sol.marginal(0);
    /// let mass: f64 = px.density.iter().sum::<f64>() * px.width;
    /// assert!((mass - 1.0).abs() < 1e-12);
    /// ```
    pub fn marginal(&self, axis: usize) -> Marginal {
        let m = &self.mesh;
        let (n, other, h, ho) = match axis {
            0 => (m.nx, m.nv, m.hx, m.hv),
            1 => (m.nv, m.nx, m.hv, m.hx),
            _ => panic!("axis {axis} of a two-state model"),
        };
        let density = (0..n)
            .map(|a| {
                let s: f64 = (0..other)
                    .map(|b| match axis {
                        0 => self.cell(a, b),
                        _ => self.cell(b, a),
                    })
                    .sum();
                s * ho
            })
            .collect();
        let centres = (0..n)
            .map(|a| if axis == 0 { m.xc(a) } else { m.vc(a) })
            .collect();
        Marginal {
            centres,
            density,
            width: h,
        }
    }

    /// The joint density at (x, v): bilinear between cell centres, never across the barrier
    /// (the density may jump there), constant from the last centre to a wall, zero outside
    /// the domain.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(24, 24).estimate(false).solve().unwrap();
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
        let (i0, i1, tx) = bracket(x, m.x0, m.hx, seg);
        let (j0, j1, tv) = bracket(v, m.v0, m.hv, [0, m.nv]);
        let row = |i: usize| (1.0 - tv) * self.cell(i, j0) + tv * self.cell(i, j1);
        (1.0 - tx) * row(i0) + tx * row(i1)
    }
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

    /// The domain: the density is zero outside it.
    fn extent(&self) -> [[f64; 2]; 2] {
        let d = self.domain();
        [d.x, d.v]
    }
}
