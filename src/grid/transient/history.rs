//! The transient's outputs: per requested time, marginals, moments, mass and negative mass.

use serde::Serialize;

use crate::grid::mesh::{Domain, Mesh};
use crate::grid::Marginal;

/// Mean, variance and kurtosis of one quantity. A [`Snapshot`]'s state moments are those of
/// the density's interpolant (as the stationary solver's); [`Moments::of`] is the other
/// estimator, from a marginal's cell averages with Sheppard's corrections.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Moments {
    /// E\[q\].
    pub mean: f64,
    /// E[(q − mean)²].
    pub variance: f64,
    /// E[(q − mean)⁴] / variance² (3 for a Gaussian).
    pub kurtosis: f64,
}

impl Moments {
    /// The moments of a marginal (cell averages that integrate to `mass`, which they are
    /// divided by), with Sheppard's corrections for grouping into cells of width h
    /// (variance − h²/12, fourth moment − h²μ₂/2 + 7h⁴/240). On a smooth density this is h²/4
    /// below the interpolant's variance that the transient and the stationary solver report.
    ///
    /// ```
    /// use fpsolve::grid::{Marginal, Moments};
    /// // Two cells of width 1 holding half the mass each.
    /// let m = Marginal { centres: vec![-0.5, 0.5], density: vec![0.5, 0.5], width: 1.0 };
    /// let s = Moments::of(&m);
    /// assert_eq!(s.mean, 0.0);
    /// assert!((s.variance - (0.25 - 1.0 / 12.0)).abs() < 1e-15);
    /// ```
    pub fn of(marginal: &Marginal) -> Moments {
        let h = marginal.width;
        let cells = marginal.centres.iter().zip(&marginal.density);
        let mass: f64 = marginal.density.iter().sum::<f64>() * h;
        let mean = cells.clone().map(|(c, p)| c * p).sum::<f64>() * h / mass;
        let central = |k: i32| {
            cells
                .clone()
                .map(|(c, p)| (c - mean).powi(k) * p)
                .sum::<f64>()
                * h
                / mass
        };
        let (m2, m4) = (central(2), central(4));
        let variance = m2 - h * h / 12.0;
        let fourth = m4 - 0.5 * h * h * m2 + 7.0 * h.powi(4) / 240.0;
        Moments {
            mean,
            variance,
            kurtosis: fourth / (variance * variance),
        }
    }
}

/// The density at one requested time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Snapshot {
    /// The time.
    pub t: f64,
    /// The marginal densities of the position and the velocity (as computed: negative cell
    /// values are kept, their mass reported in `negative_mass`).
    pub marginals: [Marginal; 2],
    /// Moments of the position and the velocity, from the marginals' cell averages with
    /// Sheppard's corrections ([`Moments::of`]): exact to O(h⁴) on a smooth density, where
    /// the stationary solver's moments of its interpolant read the variance h²/4 higher.
    pub moments: [Moments; 2],
    /// Moments of each of the model's observables, in its order: the density's cell
    /// averages times the observable at the cell centres (the midpoint rule, second order
    /// in the cell size; no grouping correction).
    pub observables: Vec<Moments>,
    /// ∫ p: 1 up to the rounding of the stage solves (the operator conserves mass).
    pub mass: f64,
    /// ∫ max(−p, 0): the scheme is not positive, so steep fronts leave small negative values;
    /// they are reported here, never clipped.
    pub negative_mass: f64,
    /// The mass in the outermost cells of the box (edges that are not walls): the box's
    /// zero-flux edges hold back what would leave it, so a value above the accuracy wanted
    /// says the box is too small for this time.
    pub edge_mass: f64,
    /// The cell averages (position cell i, velocity cell j at i·nv + j) when the joint density
    /// was requested ([`crate::grid::GridTransient::joint`]).
    pub joint: Option<Vec<f64>>,
    /// The discretisation error of this output's numbers, from the run on half the cells
    /// (`None` when [`crate::grid::GridTransient::estimate`] is off or the cells are too few
    /// to halve).
    pub estimate: Option<SnapshotErrors>,
}

/// The estimated error of one output's numbers: the same number from a second run on half
/// the cells per axis (its point start, a Gaussian of [`crate::grid::POINT_CELLS`] of its
/// own cells, twice as wide) differs by both runs' errors, scaled by 1.25 as the stationary
/// solver's estimate at order 1 ([`crate::grid::DiscretisationEstimate`]). It covers the
/// finite-volume error and a point start's smear over the cells, which dominates early
/// outputs on coarse cells; not the time-stepping's error, which is its own tolerance
/// ([`crate::grid::GridTransient::tolerance`]), added to the L1 errors only.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
/// use fpsolve::grid::{Domain, GridTransient};
/// let d = Domain { x: [-8.0, 8.0], v: [-8.0, 8.0] };
/// let h = GridTransient::new(&bound).cells(40, 40).domain(d).times(vec![1.0]).run().unwrap();
/// let e = h.snapshots[0].estimate.as_ref().unwrap();
/// assert!(e.moments[1].variance > 0.0 && e.l1[1] > 0.0);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SnapshotErrors {
    /// Estimated absolute errors of each state's mean, variance and kurtosis (NaN where the
    /// moment has no value, as a point start's kurtosis).
    pub moments: [Moments; 2],
    /// Likewise for each observable, in the model's order.
    pub observables: Vec<Moments>,
    /// Estimated L1 error of each state's marginal cell averages, compared on the half
    /// run's cells, plus the time-stepping's tolerance times the time elapsed. At
    /// [`UNRESOLVED_L1`] or above it says the marginal is not resolved at all rather than
    /// bounding its error (L1 distances saturate at 2, so the difference of two unresolved
    /// runs no longer grows with the cell size).
    pub l1: [f64; 2],
}

/// The L1 error estimate of a transient marginal at or above which the marginal is not
/// resolved by the cells (see [`SnapshotErrors::l1`]).
pub const UNRESOLVED_L1: f64 = 0.25;

impl SnapshotErrors {
    /// The errors of `fine` estimated from `half`, the same output of the run on half the
    /// cells, with `factor` (Richardson's and the safety factor) and the time-stepping's
    /// L1 error `stepping`.
    pub(crate) fn between(fine: &Snapshot, half: &Snapshot, factor: f64, stepping: f64) -> Self {
        let diff = |a: &Moments, b: &Moments| Moments {
            mean: factor * (a.mean - b.mean).abs(),
            variance: factor * (a.variance - b.variance).abs(),
            kurtosis: factor * (a.kurtosis - b.kurtosis).abs(),
        };
        let l1 = |axis: usize| {
            let (f, c) = (&fine.marginals[axis], &half.marginals[axis]);
            let paired = f.density.chunks_exact(2).map(|p| 0.5 * (p[0] + p[1]));
            factor
                * paired
                    .zip(&c.density)
                    .map(|(a, b)| (a - b).abs())
                    .sum::<f64>()
                * c.width
                + stepping
        };
        SnapshotErrors {
            moments: [
                diff(&fine.moments[0], &half.moments[0]),
                diff(&fine.moments[1], &half.moments[1]),
            ],
            observables: fine
                .observables
                .iter()
                .zip(&half.observables)
                .map(|(a, b)| diff(a, b))
                .collect(),
            l1: [l1(0), l1(1)],
        }
    }
}

/// What a run did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TransientReport {
    /// Cells (position, velocity).
    pub cells: [usize; 2],
    /// The box.
    pub domain: Domain,
    /// The tolerance on each step's L1 error per unit time.
    pub tolerance: f64,
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Stage matrices factorised: one per distinct step size while the cache holds it for a
    /// time-invariant model; for a time-dependent one, those stage times' matrices whose
    /// factor the other stages' solves were iterated with (56 of 875 stage times at 96x96
    /// cells under modulated noise).
    pub factorizations: usize,
    /// Whether the model's coefficients depend on the time (the operator is then assembled
    /// anew at every stage time).
    pub time_dependent: bool,
    /// Times the operator was assembled (1 for a time-invariant model).
    pub assemblies: usize,
    /// The initial density's mass inside the box before it was normalised.
    pub initial_mass_inside: f64,
    /// The cells of the run on half the cells that the outputs' error estimates come from.
    pub estimate_cells: Option<[usize; 2]>,
    /// Largest |mass − 1| over the outputs.
    pub mass_drift: f64,
    /// Largest negative mass over the outputs.
    pub negative_mass: f64,
    /// Wall-clock time of the run, in milliseconds.
    pub total_ms: f64,
}

/// The transient density at the requested times, from [`crate::grid::GridTransient::run`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TransientHistory {
    /// One per requested time, in order.
    pub snapshots: Vec<Snapshot>,
    /// How it was obtained.
    pub report: TransientReport,
}

impl Moments {
    /// The moments of values `q` weighted by `w` (normalised by their sum).
    pub(crate) fn weighted(q: &[f64], w: &[f64]) -> Moments {
        let mass: f64 = w.iter().sum();
        let mean = q.iter().zip(w).map(|(q, w)| q * w).sum::<f64>() / mass;
        let central = |k: i32| {
            q.iter()
                .zip(w)
                .map(|(q, w)| (q - mean).powi(k) * w)
                .sum::<f64>()
                / mass
        };
        let variance = central(2);
        Moments {
            mean,
            variance,
            kurtosis: central(4) / (variance * variance),
        }
    }
}

/// The values of the compiled observables `tape` at every cell centre of `mesh`, one vector
/// per observable (cell index i·nv + j).
pub(crate) fn observable_values(
    mesh: &Mesh,
    tape: &crate::symbolic::Tape,
    count: usize,
) -> Vec<Vec<f64>> {
    let n = mesh.cells();
    let (mut x, mut v) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..mesh.nx {
        for j in 0..mesh.nv {
            x.push(mesh.xc(i));
            v.push(mesh.vc(j));
        }
    }
    let mut out = vec![vec![0.0; n]; count];
    tape.eval_batch(
        &[&x, &v],
        &mut out,
        &mut crate::symbolic::TapeScratch::new(),
    );
    out
}

/// The mass in the cells on the box's edges, x ends that are walls left out.
pub(crate) fn edge_mass(mesh: &Mesh, p: &[f64]) -> f64 {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let mut sum = 0.0;
    for i in 0..nx {
        let x_edge = (i == 0 && !mesh.ends_on_wall(0)) || (i == nx - 1 && !mesh.ends_on_wall(1));
        for j in 0..nv {
            if x_edge || j == 0 || j == nv - 1 {
                sum += p[mesh.index(i, j)].abs();
            }
        }
    }
    sum * mesh.hx * mesh.hv
}
