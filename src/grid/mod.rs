//! A grid solver of the stationary FPK equation of any 2-D model without δ terms. A model of
//! general form (drift in both equations, correlated noise in both) has its own operator
//! (`general`, `assemble_general`: the same upwind-biased advection in both directions and
//! a corner-averaged cross diffusion) and box sizing (`general_box`: a pilot of the SDE, then
//! each side on its own), and no impact laws; what follows describes the mechanical form
//! (x' = v, noise in the velocity equation only), whose path is its own:
//!
//! 0 = −∂x(v p) − ∂v(m(x, v) p) + ½ ∂v²(b(x, v) p),
//!
//! with m the Itô drift of v and b the v–v diffusion, by conservative finite volumes:
//!
//! * a rectangle the solver sizes itself from where the density lives (a first guess from the
//!   energy box, the linearised scale or a short Monte Carlo pilot; coarse solves enlarged
//!   while the density is not negligible at an edge, cut on each free side where it falls
//!   below 1e−9 of its peak; cut again from the main solve when its tails end far inside;
//!   symmetric about x = 0 for a point-symmetric model), or one given
//!   ([`GridSolver::domain`]), zero-flux outer boundaries;
//! * advective face fluxes with third-order upwind-biased (κ = 1/3) face values in both
//!   directions: first-order upwinding adds a numerical diffusion as large as the physical
//!   noise of these lightly damped oscillators; the diffusion in flux form,
//!   (m − ½∂v b) p − ½ b ∂v p with b at the faces, ∂v p to fourth order;
//! * each flux the average over its face, to third order: a row's x-flux is
//!   v_j p̄ + (hv²/12) ∂v p, a column's v-flux carries the x-variation of its coefficients
//!   across the column ((hx²/12) a′p′ + (hx²/24) a″p); so the cell masses converge at order
//!   3 (order 1.5 to 2 with midpoint fluxes); a model with a wall whose law is not elastic
//!   (the density jumps at the wall's v = 0, order about 1.6 whichever the fluxes) keeps
//!   the midpoint fluxes, as accurate there and cheaper;
//! * the impact law as a re-injection: what leaves through the barrier at velocity v comes
//!   back in the cells at the mapped velocity (r·v across z = 0 in the Zhuravlev form, −r·v
//!   off a wall in original coordinates), split over the cells the mapped interval covers,
//!   mass conserved exactly. The δ terms of the drift (the paper's Eq. 8, an approximation
//!   of that same impact) are ignored, as Monte Carlo ignores them;
//! * one sparse linear system (the scheme is linear), solved by faer's sparse LU (COLAMD
//!   ordering) with one equation replaced by fixing one cell, then scaled to unit mass;
//! * negative cell values (the scheme is not a Markov chain) clipped, their mass reported; a
//!   solution that clipped more than its stated error covers ([`negative_mass_tolerance`]) is
//!   refused ([`GridError::NegativeMass`]): the cells do not resolve the density;
//!   a discretisation-error estimate from a second solve on half the cells per axis, run
//!   alongside the main solve on the second core.
//!
//! A reflecting barrier (`impact y = 0: v -> -r*v`) keeps the state on the side the model's
//! `domain` line says (`domain y >= 0`, the paper's y > 0). Two reflecting walls bound a strip: the domain is the strip
//! exactly (cell faces on both walls), the flux leaving the lower wall at v < 0 re-enters at
//! its map, the flux leaving the upper wall at v > 0 at its; the automatic sizing then
//! chooses the velocity range, and cuts the position range only where the density's reach
//! ends inside the strip.
//!
//! ```
//! use fpsolve::grid::GridSolver;
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
//! let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
//! let sol = GridSolver::new(&bound).cells(60, 80).solve()?;
//! // The exact velocity marginal is N(0, πK/c) = N(0, 5).
//! let pv = sol.marginal(1);
//! let exact = |v: f64| (-v * v / 10.0).exp() / (10.0 * std::f64::consts::PI).sqrt();
//! let l1: f64 = pv.centres.iter().zip(&pv.density).map(|(v, p)| (p - exact(*v)).abs()).sum::<f64>() * pv.width;
//! assert!(l1 < 1e-2);
//! // The estimate of the written curve (3.7e-2 at these few cells) covers that error.
//! assert!(l1 < sol.report.discretisation_estimate.unwrap().v);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub(crate) mod assemble;
mod assemble_general;
mod cells;
mod domain;
mod domain_flag;
mod error;
mod estimate;
mod general;
mod general_box;
mod memory;
pub(crate) mod mesh;
pub(crate) mod nested;
mod passage;
mod pilot;
pub(crate) mod problem;
mod read;
mod reconstruct;
mod solution;
#[cfg(test)]
mod strip_tests;
mod tolerance;
mod transient;

use std::time::Instant;

pub use cells::{Cells, CellsError};
pub use domain_flag::DomainError;
pub use error::{GridError, Unsupported};
pub use estimate::{CURVE_ORDERS, SMOOTH_CURVE_ORDER, TAIL_LEVEL};
pub use mesh::{Domain, Marginal};
pub(crate) use passage::evenly_spaced;
pub use passage::{
    Decay, DecayFailure, DecayOutcome, GridPassage, PassageError, PassageErrors, PassageReport,
    PassageSolution, DECAY_RESIDUAL, MAX_DECAY_ITERATIONS, MIN_SAFE_MASS,
};
pub use solution::{BoxEdges, DiscretisationEstimate, GridReport, GridSolution, GridTimings};
pub use tolerance::{
    check_tolerance, front_end_tolerance, tolerance_cell_limit, Shortfall, ToleranceOutcome,
    DEFAULT_TOLERANCE, MAX_TOLERANCE, MAX_TOLERANCE_CELLS, MAX_TOLERANCE_SOLVES,
};
pub use transient::{
    GridPeriodic, GridTransient, Initial, Moments, PeriodicOutcome, PeriodicReport, PeriodicState,
    Snapshot, SnapshotErrors, TransientError, TransientHistory, TransientReport, EDGE_SDS,
    INITIAL_MASS_LOSS, MAX_PERIOD_MAPS, PERIODIC_RESIDUAL, PERIOD_STEPS, POINT_CELLS,
    TRANSIENT_TOLERANCE, UNRESOLVED_L1,
};

use crate::base::run::RunControl;
use crate::dynamics::BarrierKind;
use crate::model::BoundModel;
use mesh::Mesh;
use problem::Mechanical;
use read::Problem;

/// Cells (position, velocity) used unless [`GridSolver::cells`] says otherwise: on the
/// paper's vibro-impact cases within 1e−3 (L1) of a 10⁹-sample Monte Carlo of the original
/// impact system (140×280 was 1.2e−3 in p_ẏ on case 1), in under a second.
pub const DEFAULT_CELLS: [usize; 2] = [200, 400];

/// How many times the main solve is repeated on a larger automatic domain at most.
const MAX_GROWTH: usize = 3;

/// The order the discretisation-error estimate assumes ([`estimate`]). Measured: 1.4 to 2.4
/// on the exact cases (lower with walls, where the density has a corner), and about 1.5
/// against a 10⁹-sample Monte Carlo of the paper's case 1. Order 1, the lowest seen, makes
/// the estimate a bound rather than a guess whenever the scheme does at least that well.
const ASSUMED_ORDER: f64 = 1.0;

pub use crate::model::BarrierSide;

/// The grid solver of one bound model: a builder, then [`GridSolver::solve`].
///
/// ```
/// use fpsolve::grid::{Domain, GridSolver};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let box_ = Domain { x: [-15.0, 15.0], v: [-15.0, 15.0] };
/// let sol = GridSolver::new(&bound).cells(60, 60).domain(box_).estimate(false).solve()?;
/// assert_eq!(sol.report.cells, [60, 60]);
/// assert_eq!(sol.report.domain, box_);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct GridSolver<'a> {
    model: &'a BoundModel,
    /// The model's reading when the caller has one ([`GridSolver::reading`]).
    dynamics: Option<&'a crate::dynamics::Dynamics>,
    cells: [usize; 2],
    domain: Option<Domain>,
    barriers: Option<crate::dynamics::Barriers>,
    estimate: bool,
    tolerance: Option<f64>,
    cells_given: bool,
    run: RunControl,
}

impl<'a> GridSolver<'a> {
    /// A solver with the default cells, an automatic domain and the error estimate on.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let _solver = fpsolve::grid::GridSolver::new(&bound);
    /// ```
    pub fn new(model: &'a BoundModel) -> GridSolver<'a> {
        GridSolver {
            model,
            dynamics: None,
            cells: DEFAULT_CELLS,
            domain: None,
            barriers: None,
            estimate: true,
            tolerance: None,
            cells_given: false,
            run: RunControl::new(),
        }
    }

    /// [`GridSolver::new`] of a model already read (its model is `dynamics.model()`): the
    /// reading is used instead of a new one.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
    /// let sol = fpsolve::grid::GridSolver::reading(&dynamics).cells(40, 80).solve()?;
    /// assert_eq!(sol.report.cells, [40, 80]);
    /// # Ok::<(), fpsolve::grid::GridError>(())
    /// ```
    pub fn reading(dynamics: &'a crate::dynamics::Dynamics) -> GridSolver<'a> {
        GridSolver {
            dynamics: Some(dynamics),
            ..GridSolver::new(dynamics.model())
        }
    }

    /// The model's reading: the caller's, else a new one.
    fn dynamics(&self) -> std::borrow::Cow<'a, crate::dynamics::Dynamics> {
        match self.dynamics {
            Some(d) => std::borrow::Cow::Borrowed(d),
            None => std::borrow::Cow::Owned(crate::dynamics::Dynamics::read(self.model)),
        }
    }

    /// Cells along the position and the velocity: even numbers, at least 8 (16 for the
    /// error estimate, which halves them).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridError, GridSolver};
    /// let err = GridSolver::new(&bound).cells(41, 40).solve().unwrap_err();
    /// assert!(matches!(err, GridError::Setting { setting: "cells", .. }));
    /// ```
    pub fn cells(mut self, nx: usize, nv: usize) -> Self {
        self.cells = [nx, nv];
        self.cells_given = true;
        self
    }

    /// Chooses the cells itself and refines until the discretisation estimate (the larger
    /// of the two marginals' L1 estimates, clipped mass and mass beyond the box included) is
    /// at most `l1`. It starts at 64×128 cells and predicts each next resolution from the
    /// order of convergence the last solve's curves show (its half and quarter solves, see
    /// [`DiscretisationEstimate::curve_order`]), aiming below the tolerance with a margin,
    /// in counts that are multiples of 4; each solve sizes its own box
    /// unless [`domain`](Self::domain) fixed it. Exclusive with [`cells`](Self::cells)
    /// ([`GridError::Setting`]). A tolerance not reached within the cells this machine's
    /// memory allows ([`tolerance_cell_limit`], at most [`MAX_TOLERANCE_CELLS`]) or
    /// [`MAX_TOLERANCE_SOLVES`] is not an error: the solution with the smallest estimate is
    /// returned, and its [`GridReport::tolerance`] says `reached: false` and why (the
    /// report's `Display` prints a warning).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridError, GridSolver};
    /// let sol = GridSolver::new(&bound).tolerance(1e-2).solve()?;
    /// let outcome = sol.report.tolerance.as_ref().unwrap();
    /// assert!(outcome.reached && outcome.achieved <= 1e-2);
    /// let e = sol.report.discretisation_estimate.as_ref().unwrap();
    /// assert!(e.x.max(e.v) <= 1e-2);
    /// let both = GridSolver::new(&bound).cells(40, 80).tolerance(1e-3).solve().unwrap_err();
    /// assert!(matches!(both, GridError::Setting { setting: "tolerance", .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tolerance(mut self, l1: f64) -> Self {
        self.tolerance = Some(l1);
        self
    }

    /// Solves on `domain` instead of sizing one (checked by [`solve`](Self::solve): finite,
    /// x_lo < x_hi, v_lo < 0 < v_hi). The velocity range is made symmetric (the larger of its
    /// two ends). A reflecting barrier's side must end on the wall and a strip's ends may not
    /// go beyond its walls ([`Unsupported::WallNotAnEnd`]); a pass-through barrier must be
    /// inside. After the solve, [`GridReport::edges`] says whether the box cuts the density
    /// (and the error estimate then counts the mass at its edges).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{Domain, GridSolver};
    /// let d = Domain { x: [-12.0, 12.0], v: [-10.0, 12.0] };
    /// let sol = GridSolver::new(&bound).cells(80, 80).domain(d).estimate(false).solve().unwrap();
    /// assert_eq!(sol.domain().v, [-12.0, 12.0]);
    /// ```
    pub fn domain(mut self, domain: Domain) -> Self {
        self.domain = Some(domain);
        self
    }

    /// Solves with the barriers `barriers` in place of the model's own.
    #[cfg(test)]
    pub(crate) fn barriers(mut self, barriers: crate::dynamics::Barriers) -> Self {
        self.barriers = Some(barriers);
        self
    }

    /// Whether to estimate the discretisation error by a second solve on half the cells
    /// (default on; it costs about an eighth of the main solve, and runs alongside it).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let sol = fpsolve::grid::GridSolver::new(&bound).cells(80, 80).estimate(false).solve().unwrap();
    /// assert!(sol.report.discretisation_estimate.is_none());
    /// ```
    pub fn estimate(mut self, on: bool) -> Self {
        self.estimate = on;
        self
    }

    /// Runs under `run`: each solve on a mesh (the main one with its half- and quarter-cell
    /// estimates beside it; again when the box grows) is reported as it starts, `done` solves
    /// of `done + 1`, and the end as `done` of `done`; with a
    /// [`tolerance`](Self::tolerance) the units are its solves at each resolution. The flag
    /// is checked before every solve on a mesh. A factorisation under way runs to its end:
    /// the grid stops within one solve of the flag.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::base::{cancel::Cancel, run::RunControl};
    /// use fpsolve::grid::{GridError, GridSolver};
    /// let cancel = Cancel::new();
    /// cancel.cancel();
    /// let run = RunControl::new().cancelled_by(cancel);
    /// let err = GridSolver::new(&bound).cells(40, 40).run_control(run).solve().unwrap_err();
    /// assert!(matches!(err, GridError::Cancelled(_)));
    /// ```
    pub fn run_control(mut self, run: RunControl) -> Self {
        self.run = run;
        self
    }

    /// Whether the solver applies to the model, without solving (milliseconds: it reads the
    /// mechanical form and the barrier, as [`GridSolver::solve`] does first).
    ///
    /// ```
    /// use fpsolve::grid::{GridError, GridSolver};
    /// let general = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: -x + y\n\
    ///     drift y: -y\nnoise xi: intensity 1\ndiffusion y: xi\n", None).unwrap().bind(&[]).unwrap();
    /// assert!(GridSolver::new(&general).check().is_ok());
    /// let impact = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: -x + y\n\
    ///     drift y: -y\nnoise xi: intensity 1\ndiffusion y: xi\nimpact x = 0: y -> -0.9*y\n\
    ///     domain x >= 0\n", None).unwrap().bind(&[]).unwrap();
    /// assert!(matches!(GridSolver::new(&impact).check(), Err(GridError::Unsupported { .. })));
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve) before it discretises: [`GridError::Setting`] (the cells),
    /// [`GridError::Unsupported`], [`GridError::Inadmissible`], [`GridError::Derivation`],
    /// [`GridError::Symbolic`]; with a [`domain`](Self::domain), [`GridError::Setting`] and
    /// [`Unsupported::WallNotAnEnd`] for a box that is not one or does not fit the walls.
    pub fn check(&self) -> Result<(), GridError> {
        if let Some(tol) = self.tolerance {
            self.check_tolerance(tol)?;
        }
        check_cells(self.cells)?;
        let problem = Problem::read(&self.dynamics())?;
        if let Some(d) = &self.domain {
            checked_domain(d, &problem, self.model)?;
        }
        Ok(())
    }

    /// Solves. Refuses models it cannot represent ([`GridError::Unsupported`]: an impact law
    /// outside the mechanical form, δ terms without an impact law, …) and models without a
    /// stationary density ([`GridError::Inadmissible`]).
    ///
    /// ```
    /// use fpsolve::grid::{GridError, GridSolver, Unsupported};
    /// let bound = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: -x + y\n\
    ///     drift y: -y\nnoise xi: intensity 1\ndiffusion y: xi\nimpact x = 0: y -> -0.9*y\n\
    ///     domain x >= 0\n", None).unwrap().bind(&[]).unwrap();
    /// let err = GridSolver::new(&bound).solve().unwrap_err();
    /// assert!(matches!(err, GridError::Unsupported { reason: Unsupported::ImpactOfGeneralForm { .. }, .. }));
    /// ```
    pub fn solve(&self) -> Result<GridSolution, GridError> {
        if let Some(tol) = self.tolerance {
            return self.solve_to(tol);
        }
        let start = Instant::now();
        let [nx, nv] = self.cells;
        check_cells(self.cells)?;
        let problem = self.problem()?;
        let (mut domain, mut passes, guess) = match self.domain {
            Some(d) => {
                let d = checked_domain(&d, &problem, self.model)?;
                (d, 0, problem.centre(&d))
            }
            None => problem.size()?,
        };
        let guess = [guess[0].clamp(domain.x[0], domain.x[1]), guess[1]];
        let domain_ms = ms(start);
        let t = Instant::now();
        let with_estimate = self.estimate && nx >= 16 && nv >= 16;
        // A third solve on a quarter of the cells gives the estimate the order of convergence
        // the curves show (about a sixteenth of the main solve's work).
        let with_quarter = with_estimate && quarter_cells(self.cells).is_some();
        let (mut mesh, mut p, mut assemble_ms, mut coarse);
        let mut recut = false;
        let mut solves = 0;
        loop {
            self.run.report(solves, solves + 1);
            self.run.check()?;
            mesh = problem.mesh(domain, nx, nv, 4);
            // The error estimate's half-cells solve runs alongside the main one, pinned
            // where the main one is (a solve is a function of its mesh and pin alone, so
            // the result does not depend on which finishes first); wasted only when the
            // domain grows.
            let main = || domain::solve_pinned(&mesh, &problem, guess);
            let half = || {
                with_estimate.then(|| {
                    let t = Instant::now();
                    let solve = |n: usize| {
                        let coarse = problem.mesh(mesh.domain(), nx / n, nv / n, 4 / n);
                        domain::solve_pinned(&coarse, &problem, guess).map(|(q, _)| (coarse, q))
                    };
                    let (half, quarter) =
                        rayon::join(|| solve(2), || with_quarter.then(|| solve(4)));
                    Ok::<_, GridError>((half?, quarter.transpose()?, ms(t)))
                })
            };
            let solved;
            (solved, coarse) = rayon::join(main, half);
            (p, assemble_ms) = solved?;
            solves += 1;
            // An automatic domain that cut into the density is enlarged and solved again;
            // one whose density ends far inside it is cut once from this solution.
            if self.domain.is_some() || passes >= MAX_GROWTH {
                break;
            }
            match problem.grow(&mesh, &p) {
                Some(bigger) => domain = bigger,
                None => match problem.recut(&mesh, &p).filter(|_| !recut) {
                    Some(smaller) => {
                        domain = smaller;
                        recut = true;
                    }
                    None => break,
                },
            }
            passes += 1;
        }
        let solve_ms = ms(t) - assemble_ms;
        let negative_mass = clip(&mut p, mesh.hx * mesh.hv);
        let edges = box_edges(&mesh, &p);
        let mut report = GridReport {
            cells: [nx, nv],
            domain: mesh.domain(),
            negative_mass,
            discretisation_estimate: None,
            domain_passes: passes,
            domain_given: self.domain.is_some(),
            edges,
            tolerance: None,
            timings: GridTimings {
                domain_ms,
                assemble_ms,
                solve_ms,
                estimate_ms: 0.0,
                total_ms: 0.0,
            },
        };
        let mut solution = GridSolution::new(mesh, p, report.clone(), None);
        if let Some(((coarse, q), quarter, estimate_ms)) = coarse.transpose()? {
            let t = Instant::now();
            let clipped = |mesh: Mesh, mut q: Vec<f64>| {
                let negative_mass = clip(&mut q, mesh.hx * mesh.hv);
                let report = GridReport {
                    cells: [mesh.nx, mesh.nv],
                    negative_mass,
                    ..report.clone()
                };
                GridSolution::new(mesh, q, report, None)
            };
            let half = clipped(coarse, q);
            let quarter = quarter.map(|(mesh, q)| clipped(mesh, q));
            report.discretisation_estimate = Some(estimate::estimate(
                &solution,
                &half,
                quarter.as_ref(),
                ASSUMED_ORDER,
                problem.curve_order_cap(),
            ));
            report.timings.estimate_ms = estimate_ms + ms(t);
            solution.coarse = Some(Box::new(half));
        }
        let tolerance = negative_mass_tolerance(report.discretisation_estimate.as_ref());
        if negative_mass.is_nan() || negative_mass > tolerance {
            return Err(GridError::NegativeMass {
                nx,
                nv,
                negative_mass,
                tolerance,
            });
        }
        // The clipping moved about twice its mass (L1): the stated errors of the curves
        // include it.
        // A box that cuts the density misses the mass beyond its edges; restoring unit mass
        // moves about twice that (L1).
        let cut = if edges.cuts_density {
            2.0 * edges.beyond.iter().sum::<f64>()
        } else {
            0.0
        };
        if let Some(e) = report.discretisation_estimate.as_mut() {
            e.x += 2.0 * negative_mass + cut;
            e.v += 2.0 * negative_mass + cut;
        }
        report.timings.total_ms = ms(start);
        solution.report = report;
        self.run.report(solves, solves);
        Ok(solution)
    }

    /// The problem this solver solves: the model's, or with the barriers given in its place.
    fn problem(&self) -> Result<Problem, GridError> {
        let dynamics = self.dynamics();
        match &self.barriers {
            Some(barriers) => Ok(Problem::Mechanical(Mechanical::with_barriers(
                self.model, &dynamics, barriers,
            )?)),
            None => Problem::read(&dynamics),
        }
    }

    /// A tolerance is positive and finite, and excludes [`cells`](Self::cells).
    fn check_tolerance(&self, tol: f64) -> Result<(), GridError> {
        tolerance::check_tolerance(tol)?;
        if self.cells_given {
            return Err(GridError::Setting {
                setting: "tolerance",
                value: format!("{tol} with cells {}x{}", self.cells[0], self.cells[1]),
                expected: "either cells or a tolerance, not both (cells fix the resolution)",
            });
        }
        Ok(())
    }

    /// [`solve`](Self::solve) with the cells chosen for the tolerance `tol`.
    fn solve_to(&self, tol: f64) -> Result<GridSolution, GridError> {
        use tolerance::{next_cells, NextCells};
        self.check_tolerance(tol)?;
        let start = Instant::now();
        let mut cells = FIRST_CELLS;
        let mut solves: Vec<([usize; 2], f64)> = Vec::new();
        let mut best: Option<GridSolution> = None;
        let mut last_error = None;
        // The first refinement aims at the scheme's order: the first solve's own observed
        // order comes from a quarter solve of 16x32 cells.
        let order = self.problem()?.scheme_order();
        let mut not_falling = 0;
        // No refinement beyond what this machine's memory lets a solve on given cells use.
        let limit = tolerance_cell_limit(crate::base::limits::memory_limit_bytes());
        let shortfall = loop {
            // Each resolution is one unit of the run's progress; its solves check the flag.
            let done = solves.len() as u64;
            self.run.report(done, done + 1);
            let one = GridSolver {
                cells,
                tolerance: None,
                cells_given: true,
                estimate: true,
                run: self.run.silent(),
                ..self.clone()
            };
            let mut cut = 0.0;
            let e = match one.solve() {
                Ok(sol) => {
                    let e = achieved(&sol);
                    if sol.report.edges.cuts_density {
                        cut = 2.0 * sol.report.edges.beyond.iter().sum::<f64>();
                    }
                    if best.as_ref().is_none_or(|b| e <= achieved(b)) {
                        best = Some(sol);
                    }
                    e
                }
                // Too coarse to resolve the density: refine like any other miss.
                Err(err @ GridError::NegativeMass { .. }) => {
                    last_error = Some(err);
                    f64::INFINITY
                }
                Err(err) => return Err(err),
            };
            solves.push((cells, e));
            if e <= tol {
                break None;
            }
            // Mass beyond a given box stays beyond it at any cells.
            if self.domain.is_some() && cut > tol {
                break Some(Shortfall::BoxCuts { cut });
            }
            if solves.len() >= MAX_TOLERANCE_SOLVES {
                break Some(Shortfall::SolveLimit {
                    solves: solves.len(),
                });
            }
            if let [.., (_, e1), (_, e2)] = solves[..] {
                if e1.is_finite() && e2.is_finite() {
                    not_falling = if e2 >= e1 { not_falling + 1 } else { 0 };
                    if not_falling >= 2 {
                        break Some(Shortfall::Stalled);
                    }
                }
            }
            let aim = tolerance::aim_order(&solves, order);
            match next_cells(cells, e, tol, aim, limit) {
                NextCells::Free(next) | NextCells::Capped(next) => cells = next,
                NextCells::AtLimit => break Some(Shortfall::CellLimit { limit }),
            }
        };
        let Some(mut sol) = best else {
            return Err(last_error.expect("every solve failed with negative mass"));
        };
        let got = achieved(&sol);
        let done = solves.len() as u64;
        sol.report.tolerance = Some(ToleranceOutcome {
            asked: tol,
            achieved: got,
            reached: got <= tol,
            shortfall: if got <= tol {
                None
            } else {
                shortfall.or(Some(Shortfall::Stalled))
            },
            solves,
        });
        sol.report.timings.total_ms = ms(start);
        self.run.report(done, done);
        Ok(sol)
    }
}

/// The mass of negative cell values, relative to the total absolute mass, that a solution may
/// always clip and still be reported; more is allowed only within its stated error (see
/// [`negative_mass_tolerance`]). The scheme is not positive, so a coarse mesh leaves negative
/// values where the density falls steeply; clipping them changes the density by about twice
/// their mass in L1. The bundled models clip at most 5e−6 at the default cells. Measured on
/// `vibro_impact_duffing`: 8.4e−2 clipped at 8×8 cells (no estimate; velocity sd 9.5 against
/// 2.2); with a barrier at 1e6 (200×400 cells) 0.40 clipped against an estimated L1 error of
/// 0.24, mean velocity −28.
pub const NEGATIVE_MASS_TOLERANCE: f64 = 1e-3;

/// The clipped mass a solution may have: clipping changes its density by about twice that
/// mass in L1, which must stay within the error the solution states (the larger of its
/// marginals' discretisation estimates), and never needs to be below
/// [`NEGATIVE_MASS_TOLERANCE`] (the whole allowance when there is no estimate).
///
/// ```
/// use fpsolve::grid::{negative_mass_tolerance, DiscretisationEstimate, NEGATIVE_MASS_TOLERANCE};
/// assert_eq!(negative_mass_tolerance(None), NEGATIVE_MASS_TOLERANCE);
/// let e = DiscretisationEstimate {
///     x: 0.2, v: 0.24, mean: [0.0; 2], std: [0.0; 2], tail: [0.0; 2], tail_level: 1e-5,
///     coarse_cells: [100, 200], order: 1.0, curve_order: [1.0; 2], shown_order: [1.0; 2],
///     quarter_cells: None,
/// };
/// assert_eq!(negative_mass_tolerance(Some(&e)), 0.12);
/// ```
pub fn negative_mass_tolerance(estimate: Option<&DiscretisationEstimate>) -> f64 {
    estimate
        .map_or(0.0, |e| 0.5 * e.x.max(e.v))
        .max(NEGATIVE_MASS_TOLERANCE)
}

/// Cells per axis must be even (the error estimate halves them), at least 8, and neither
/// axis more than [`MAX_ASPECT`] times the other's count.
///
/// ```
/// use fpsolve::grid::{check_cells, GridError};
/// assert!(check_cells([140, 280]).is_ok());
/// assert!(matches!(check_cells([9, 8]), Err(GridError::Setting { setting: "cells", .. })));
/// assert!(matches!(check_cells([8, 65536]), Err(GridError::Setting { setting: "cells", .. })));
/// ```
///
/// # Errors
/// [`GridError::Setting`] naming the cells.
pub fn check_cells(cells: [usize; 2]) -> Result<(), GridError> {
    let [nx, nv] = cells;
    if nx < 8 || nv < 8 || nx % 2 == 1 || nv % 2 == 1 {
        return Err(GridError::Setting {
            setting: "cells",
            value: format!("{nx}x{nv}"),
            expected: "even numbers of cells, at least 8 per axis",
        });
    }
    if nx.max(nv) > MAX_ASPECT * nx.min(nv) {
        return Err(GridError::Setting {
            setting: "cells",
            value: format!("{nx}x{nv}"),
            expected: "counts within 64 times of each other (a thin mesh resolves nothing \
                       across it, and the factorisation's fill degenerates: 8x32768 took \
                       59 s and 1.8 GB to give a velocity sd 4 times the true one)",
        });
    }
    Ok(())
}

/// The cells of the quarter solve that gives the error estimate its observed order: a
/// quarter of `cells` per axis when both divide by 4 and give at least 16 cells (coarser,
/// the quarter solve is too far from the asymptotic range to say anything about the order).
fn quarter_cells(cells: [usize; 2]) -> Option<[usize; 2]> {
    cells
        .iter()
        .all(|&n| n % 4 == 0 && n / 4 >= 16)
        .then(|| cells.map(|n| n / 4))
}

/// The first cells a solve on request ([`GridSolver::tolerance`]) tries: about a third of
/// the default per axis, the default's aspect, the fewest with a quarter solve (16×32) to
/// show the order the next cells aim at.
const FIRST_CELLS: [usize; 2] = [64, 128];

/// How many times one axis's cell count may exceed the other's.
pub const MAX_ASPECT: usize = 64;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Clips negative cell values to zero and restores unit mass; returns the clipped mass
/// relative to the total absolute mass.
fn clip(p: &mut [f64], area: f64) -> f64 {
    let negative: f64 = p.iter().filter(|v| **v < 0.0).map(|v| -v).sum();
    let total: f64 = p.iter().map(|v| v.abs()).sum();
    p.iter_mut().for_each(|v| *v = v.max(0.0));
    let mass: f64 = p.iter().sum::<f64>() * area;
    p.iter_mut().for_each(|v| *v /= mass);
    negative / total
}

/// The mass and relative density of the outermost rows of cells on the free edges, and the
/// mass beyond each: the row's mass continued geometrically at the ratio of the last two
/// rows (an upper bound for any tail that decays at least as fast as it does at the edge,
/// as Gaussian and exponential tails do), the whole mass where the rows do not decay at an
/// edge that cuts the density (the row's own mass where they do not decay far below it).
fn box_edges(mesh: &Mesh, p: &[f64]) -> BoxEdges {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let area = mesh.hx * mesh.hv;
    let top = p.iter().fold(0.0f64, |a, &b| a.max(b));
    // Per side: (mass, largest value) of the outermost row and the mass of the next one in.
    let mut mass = [[0.0f64; 2]; 4];
    let mut peak = [0.0f64; 4];
    for j in 0..nv {
        for (side, i, next) in [(0, 0, 1), (1, nx - 1, nx - 2)] {
            let value = p[mesh.index(i, j)];
            mass[side][0] += value * area;
            mass[side][1] += p[mesh.index(next, j)] * area;
            peak[side] = peak[side].max(value);
        }
    }
    for i in 0..nx {
        for (side, j, next) in [(2, 0, 1), (3, nv - 1, nv - 2)] {
            let value = p[mesh.index(i, j)];
            mass[side][0] += value * area;
            mass[side][1] += p[mesh.index(i, next)] * area;
            peak[side] = peak[side].max(value);
        }
    }
    for end in 0..2 {
        // A wall, or the seam of a periodic position: no density lies beyond either.
        if mesh.ends_on_wall(end) || mesh.wrap {
            mass[end] = [0.0; 2];
            peak[end] = 0.0;
        }
    }
    let relative_density = peak.map(|v| if top > 0.0 { v / top } else { 0.0 });
    let beyond: [f64; 4] = std::array::from_fn(|k| {
        let [last, next] = mass[k];
        if last <= 0.0 {
            0.0
        } else if last < 0.99 * next {
            let r = last / next;
            (last * r / (1.0 - r)).min(1.0)
        } else if relative_density[k] > BoxEdges::LEVEL {
            1.0
        } else {
            // Rows this far below the peak that do not decay are the solve's rounding:
            // their own mass is all there is.
            last
        }
    });
    BoxEdges {
        mass: mass.map(|m| m[0]),
        beyond,
        relative_density,
        cuts_density: relative_density.iter().any(|&r| r > BoxEdges::LEVEL),
    }
}

/// A box given explicitly, checked (and, in the mechanical form, fitted to the walls).
fn checked_domain(d: &Domain, problem: &Problem, model: &BoundModel) -> Result<Domain, GridError> {
    if let Some(window) = problem.window() {
        // The window as typed: ±3.14159 for ±π.
        let near = |a: f64, b: f64| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0);
        if !(near(d.x[0], window[0]) && near(d.x[1], window[1])) {
            return Err(GridError::Unsupported {
                model: model.name().to_string(),
                reason: Unsupported::PeriodicWindow {
                    state: model.states()[0].to_string(),
                    lo: d.x[0],
                    hi: d.x[1],
                    window,
                },
            });
        }
    }
    // A periodic state's range is its window exactly (it was typed to 1e−5).
    let d = match problem.window() {
        Some(window) => Domain { x: window, ..*d },
        None => *d,
    };
    match problem {
        Problem::Mechanical(m) => check_domain(&d, m, model),
        Problem::General(_) => Problem::check_general_domain(&d),
    }
}

/// An explicit domain must be a finite, non-empty box that fits the barrier.
/// Returns the domain with an end that is a wall up to rounding (1e−9 relative) put on it.
fn check_domain(d: &Domain, problem: &Mechanical, model: &BoundModel) -> Result<Domain, GridError> {
    let ok = d.x[0] < d.x[1]
        && d.v[0] < d.v[1]
        && d.v[1] > 0.0
        && d.v[0] < 0.0
        && d.x.iter().chain(&d.v).all(|u| u.is_finite());
    if !ok {
        return Err(GridError::Setting {
            setting: "domain",
            value: format!("{d:?}"),
            expected: "a finite box with x_lo < x_hi and v_lo < 0 < v_hi (in the mechanical \
                       form the velocity's range must hold 0 inside: a face of the cells is \
                       at v = 0)",
        });
    }
    let refuse = |reason| GridError::Unsupported {
        model: model.name().to_string(),
        reason,
    };
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    let wall = |end: &'static str, given: f64, at: f64, relation: &'static str| {
        refuse(Unsupported::WallNotAnEnd {
            end,
            given,
            at,
            relation,
        })
    };
    let mut d = *d;
    for b in &problem.barriers {
        for end in &mut d.x {
            if near(*end, b.at) {
                *end = b.at;
            }
        }
    }
    if let [lo, hi] = problem.barriers.as_slice() {
        if d.x[0] < lo.at && !near(d.x[0], lo.at) {
            return Err(wall("lower", d.x[0], lo.at, "not go beyond"));
        }
        if d.x[1] > hi.at && !near(d.x[1], hi.at) {
            return Err(wall("upper", d.x[1], hi.at, "not go beyond"));
        }
        return Ok(d);
    }
    match problem.barriers.first().map(|b| (b.kind, b.at)) {
        Some((BarrierKind::Reflecting(BarrierSide::Above), at)) if !near(d.x[0], at) => {
            return Err(wall("lower", d.x[0], at, "be"));
        }
        Some((BarrierKind::Reflecting(BarrierSide::Below), at)) if !near(d.x[1], at) => {
            return Err(wall("upper", d.x[1], at, "be"));
        }
        _ => {}
    }
    if let Some(b) = problem.barriers.first() {
        let fits = match b.kind {
            BarrierKind::PassThrough => d.x[0] < b.at && b.at < d.x[1],
            BarrierKind::Reflecting(BarrierSide::Above) => b.at < d.x[1],
            BarrierKind::Reflecting(BarrierSide::Below) => d.x[0] < b.at,
        };
        if !fits {
            return Err(GridError::Unsupported {
                model: model.name().to_string(),
                reason: Unsupported::BarrierOutsideDomain {
                    at: b.at,
                    lo: d.x[0],
                    hi: d.x[1],
                },
            });
        }
    }
    Ok(d)
}

/// The larger of the two marginals' L1 estimates of a solution (infinite without one): what a
/// tolerance is held to.
fn achieved(sol: &GridSolution) -> f64 {
    sol.report
        .discretisation_estimate
        .as_ref()
        .map_or(f64::INFINITY, |e| e.x.max(e.v))
}
