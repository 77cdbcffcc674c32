//! The initial density as cell averages.

use crate::grid::mesh::Mesh;
use crate::numerics::quadrature::gauss_legendre;

/// Where the transient starts.
///
/// ```
/// use fpsolve::grid::Initial;
/// let start = Initial::Gaussian { mean: [1.0, 0.0], covariance: [[0.04, 0.0], [0.0, 0.04]] };
/// assert_ne!(start, Initial::Rest);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum Initial {
    /// At rest, (x, v) = (0, 0): a Gaussian of [`POINT_CELLS`] cells' standard deviation on
    /// each axis (a point is not a cell density; this is the narrowest start the cells
    /// resolve, and its exact evolution is that Gaussian's), narrower on an axis where the
    /// box's edge (a wall) is closer than [`EDGE_SDS`] of them, so that the box holds it.
    Rest,
    /// A point (x, v), as [`Initial::Rest`] is at the origin.
    Point([f64; 2]),
    /// A Gaussian with this mean and covariance (symmetric, positive definite), integrated
    /// over each cell.
    Gaussian {
        /// (x, v).
        mean: [f64; 2],
        /// [[var x, cov], [cov, var v]].
        covariance: [[f64; 2]; 2],
    },
    /// Cell averages on the transient's own mesh (position cell i, velocity cell j at
    /// index i·nv + j, as [`crate::grid::GridSolution::cell`]; with an explicit domain, so the
    /// cells are known), normalised to unit mass.
    Cells(Vec<f64>),
}

/// The standard deviation, in cells of each axis, of the Gaussian that stands for a point.
pub const POINT_CELLS: f64 = 2.0;

/// A point's Gaussian keeps this many standard deviations between its centre and the box's
/// edges (a wall) on each axis, narrower than [`POINT_CELLS`] where it must: its mass
/// beyond an edge is then below 1.3e−12 (a point at y = 1 beside a wall at 0 on cells
/// 0.1 wide lost 2.9e−7 through it at 2 cells and was refused as outside the box).
pub const EDGE_SDS: f64 = 7.0;

/// Gauss–Legendre points per panel and axis; a cell is cut into panels no wider than half
/// the Gaussian's (conditional) standard deviation along the axis, so that the rule's error
/// on a cell integral stays below 1e−12 of its mass even for a start narrower than a cell.
const NODES: usize = 6;

/// The most panels per cell and axis (a Gaussian 128 times narrower than a cell is a point
/// the cells do not resolve; the mass check then refuses what the rule misses).
const MAX_PANELS: usize = 64;

impl Initial {
    /// The Gaussian this start stands for on `mesh` (`None` for cell values).
    pub(crate) fn gaussian(&self, mesh: &Mesh) -> Option<([f64; 2], [[f64; 2]; 2])> {
        let d = mesh.domain();
        let point = |at: [f64; 2]| {
            // A point on or beyond an edge keeps the full width: the mass check refuses it.
            let width = |h: f64, p: f64, [lo, hi]: [f64; 2]| {
                let room = (p - lo).min(hi - p);
                let full = POINT_CELLS * h;
                if room > 0.0 {
                    full.min(room / EDGE_SDS)
                } else {
                    full
                }
            };
            let (sx, sv) = (width(mesh.hx, at[0], d.x), width(mesh.hv, at[1], d.v));
            (at, [[sx * sx, 0.0], [0.0, sv * sv]])
        };
        match self {
            Initial::Rest => Some(point([0.0, 0.0])),
            Initial::Point(at) => Some(point(*at)),
            Initial::Gaussian { mean, covariance } => Some((*mean, *covariance)),
            Initial::Cells(_) => None,
        }
    }
}

/// Whether a covariance is symmetric positive definite and everything finite.
pub(crate) fn valid_gaussian(mean: [f64; 2], c: [[f64; 2]; 2]) -> bool {
    let finite = mean.iter().chain(c.iter().flatten()).all(|u| u.is_finite());
    finite && c[0][1] == c[1][0] && c[0][0] > 0.0 && c[0][0] * c[1][1] - c[0][1] * c[1][0] > 0.0
}

/// The cell averages of N(`mean`, `c`) on `mesh` (Gauss–Legendre on each cell); their mass
/// is the Gaussian's mass inside the mesh.
pub(crate) fn gaussian_cells(mesh: &Mesh, mean: [f64; 2], c: [[f64; 2]; 2]) -> Vec<f64> {
    let (nodes, weights) = gauss_legendre(NODES);
    let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    let inv = [
        [c[1][1] / det, -c[0][1] / det],
        [-c[1][0] / det, c[0][0] / det],
    ];
    let norm = 1.0 / (2.0 * std::f64::consts::PI * det.sqrt());
    let density = |x: f64, v: f64| {
        let (dx, dv) = (x - mean[0], v - mean[1]);
        let q = inv[0][0] * dx * dx + 2.0 * inv[0][1] * dx * dv + inv[1][1] * dv * dv;
        norm * (-0.5 * q).exp()
    };
    // Skip cells beyond 40 standard deviations, whose mass is below e^−800.
    let reach = 40.0;
    let (sx, sv) = (c[0][0].sqrt(), c[1][1].sqrt());
    // The narrowest widths: the conditional standard deviations.
    let panels = |h: f64, s: f64| ((2.0 * h / s).ceil() as usize).clamp(1, MAX_PANELS);
    let (kx, kv) = (
        panels(mesh.hx, (det / c[1][1]).sqrt()),
        panels(mesh.hv, (det / c[0][0]).sqrt()),
    );
    let (px, pv) = (mesh.hx / kx as f64, mesh.hv / kv as f64);
    let mut p = vec![0.0; mesh.cells()];
    for i in 0..mesh.nx {
        let xc = mesh.xc(i);
        if (xc - mean[0]).abs() > reach * sx + mesh.hx {
            continue;
        }
        for j in 0..mesh.nv {
            let vc = mesh.vc(j);
            if (vc - mean[1]).abs() > reach * sv + mesh.hv {
                continue;
            }
            let mut sum = 0.0;
            for a in 0..kx {
                let xm = xc - 0.5 * mesh.hx + (a as f64 + 0.5) * px;
                for b in 0..kv {
                    let vm = vc - 0.5 * mesh.hv + (b as f64 + 0.5) * pv;
                    for (s, ws) in nodes.iter().zip(&weights) {
                        for (u, wu) in nodes.iter().zip(&weights) {
                            sum += ws * wu * density(xm + 0.5 * px * s, vm + 0.5 * pv * u);
                        }
                    }
                }
            }
            // The rule's weights sum to 2 per axis and panel: the mean over the cell.
            p[mesh.index(i, j)] = 0.25 * sum / (kx * kv) as f64;
        }
    }
    p
}

impl From<crate::model::InitialState> for Initial {
    /// The grid's start for a model's `initial` line.
    ///
    /// ```
    /// use fpsolve::grid::Initial;
    /// use fpsolve::model::InitialState;
    /// assert_eq!(Initial::from(InitialState::Point([1.0, 0.0])), Initial::Point([1.0, 0.0]));
    /// ```
    fn from(s: crate::model::InitialState) -> Initial {
        use crate::model::InitialState;
        match s {
            InitialState::Rest => Initial::Rest,
            InitialState::Point(at) => Initial::Point(at),
            InitialState::Gaussian { mean, covariance } => Initial::Gaussian { mean, covariance },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::mesh::Domain;

    /// The mass and mean x of a start's cells.
    fn mass_and_mean(mesh: &Mesh, start: &Initial) -> (f64, f64) {
        let (mean, c) = start.gaussian(mesh).expect("a Gaussian start");
        let p = gaussian_cells(mesh, mean, c);
        let area = mesh.hx * mesh.hv;
        let mass = p.iter().sum::<f64>() * area;
        let mx = (0..mesh.cells())
            .map(|k| p[k] * mesh.xc(k / mesh.nv))
            .sum::<f64>()
            * area;
        (mass, mx / mass)
    }

    #[test]
    fn a_point_beside_the_box_edge_stays_in_the_box() {
        // Cells 0.1 wide in x from 0: two cells' width put 2.9e-7 of the mass below 0.
        let d = Domain {
            x: [0.0, 10.0],
            v: [-10.0, 10.0],
        };
        let mesh = Mesh::new(d, 100, 200, &[], 1);
        let (mass, mean) = mass_and_mean(&mesh, &Initial::Point([1.0, 0.0]));
        assert!((mass - 1.0).abs() < 1e-11, "{mass}");
        assert!((mean - 1.0).abs() < 1e-9, "{mean}");
        // Far from the edges the point keeps its two cells.
        let (mean, c) = Initial::Point([5.0, 0.0]).gaussian(&mesh).unwrap();
        assert_eq!(mean, [5.0, 0.0]);
        assert!((c[0][0].sqrt() - POINT_CELLS * mesh.hx).abs() < 1e-15);
        // On the edge: the full width, and the mass check refuses it.
        let (_, c) = Initial::Point([0.0, 0.0]).gaussian(&mesh).unwrap();
        assert!((c[0][0].sqrt() - POINT_CELLS * mesh.hx).abs() < 1e-15);
        assert!(mass_and_mean(&mesh, &Initial::Point([0.0, 0.0])).0 < 0.6);
    }
}
