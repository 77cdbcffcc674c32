//! The transient density on the grid: dp/dt = G(t) p with G the stationary solver's
//! finite-volume operator (transport, outflow through a barrier and its re-injection; every
//! column sums to zero), from an initial density to the requested times, by the ESDIRK
//! stepper of [`crate::numerics::timestep`], ESDIRK4 (fourth order, L-stable).
//!
//! * **Time in the model.** A model whose drift or diffusion mentions the time `t`
//!   (modulated noise, a periodic force) has its operator assembled anew at every stage
//!   time the stepper needs (five per step), and each stage solved with that time's matrix:
//!   directly where its own factorisation is at hand, else iterated to the same backward
//!   error with a nearby time's factor as the preconditioner; a stage matrix is factorised
//!   when that iteration stalls or has cost about a factorisation (see `operator.rs` for
//!   why no split A₀ + Σ f_k(t) A_k is used). Such a model
//!   needs an explicit [`GridTransient::domain`] (the automatic box is sized from a
//!   stationary law), and the checks that only a stationary density needs are skipped.
//!
//! * **Box.** The one the stationary solver would size (or [`GridTransient::domain`]); the
//!   start must have at least 1 − [`INITIAL_MASS_LOSS`] of its mass inside it, else the run
//!   is refused ([`TransientError::InitialOutsideDomain`]): the box is not enlarged. Each
//!   output reports the mass in the box's edge cells, where the zero-flux edges would pile up
//!   what should leave.
//! * **Error control.** Each step's L1 error per unit time, ‖e‖₁/h, is held below the
//!   tolerance, so the time-stepping error at any output is about the tolerance times the
//!   time elapsed (less once the density relaxes), and falls in proportion to the tolerance;
//!   the spatial error is the stationary solver's.
//! * **Reuse.** For a time-invariant model the stage matrix I − d h G is factorised once per
//!   step size (nested dissection order, as the stationary solve), the step sizes being
//!   powers of two of the first, so a run factorises a few times.
//! * **Mass and sign.** Mass is conserved to the rounding of the solves and reported per
//!   output, as is the negative mass (nothing is clipped).
//!
//! ```
//! use fpsolve::grid::{GridTransient, Initial};
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
//! let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
//! let history = GridTransient::new(&bound)
//!     .cells(40, 40)
//!     .initial(Initial::Rest)
//!     .times(vec![0.0, 1.0, 2.0])
//!     .run()?;
//! let s = &history.snapshots[2];
//! assert!((s.mass - 1.0).abs() < 1e-12);
//! // From rest the position's variance grows.
//! assert!(s.moments[0].variance > history.snapshots[1].moments[0].variance);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod history;
mod initial;
mod operator;
mod periodic;

use std::time::Instant;

pub use error::TransientError;
pub use history::{
    Moments, Snapshot, SnapshotErrors, TransientHistory, TransientReport, UNRESOLVED_L1,
};
pub use initial::{Initial, EDGE_SDS, POINT_CELLS};
pub use periodic::{
    GridPeriodic, PeriodicOutcome, PeriodicReport, PeriodicState, MAX_PERIOD_MAPS,
    PERIODIC_RESIDUAL, PERIOD_STEPS,
};

use super::assemble::{assemble, generator};
use super::mesh::Mesh;
use super::nested::{cell_coords, nested_dissection};
use super::problem::Mechanical;
use super::{check_cells, check_domain, domain, Domain, GridError, DEFAULT_CELLS};
use crate::model::BoundModel;
use crate::numerics::timestep::{Esdirk, Generator, History, Scheme, StepError, Tolerance};
use operator::TimeOperator;

/// The largest mass of the initial density that may lie outside the box.
pub const INITIAL_MASS_LOSS: f64 = 1e-9;

/// The tolerance used unless [`GridTransient::tolerance`] says otherwise.
pub const TRANSIENT_TOLERANCE: f64 = 1e-4;

/// The grid transient of one bound model: a builder, then
/// [`GridTransient::run`].
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
/// use fpsolve::grid::{GridTransient, TransientError};
/// let err = GridTransient::new(&bound).times(vec![2.0, 1.0]).run().unwrap_err();
/// assert!(matches!(err, TransientError::Setting { setting: "times", .. }));
/// ```
#[derive(Clone, Debug)]
pub struct GridTransient<'a> {
    model: &'a BoundModel,
    cells: [usize; 2],
    domain: Option<Domain>,
    initial: Initial,
    times: Vec<f64>,
    tolerance: f64,
    joint: bool,
    estimate: bool,
}

/// The box of a time-marching problem on the grid (the transient, first passage): `given`
/// (checked as the stationary solver checks it) or the one the stationary solver starts from.
pub(in crate::grid) fn starting_box(
    given: Option<Domain>,
    problem: &Mechanical,
    model: &BoundModel,
) -> Result<Domain, GridError> {
    match given {
        Some(d) => {
            check_domain(&d, problem, model)?;
            Ok(d)
        }
        None => match domain::energy_box(problem) {
            Some(d) => Ok(domain::fit_barrier(d, problem)),
            None => domain::size(problem).map(|(d, _, _)| d),
        },
    }
}

impl<'a> GridTransient<'a> {
    /// A transient from rest on the default cells and the automatic box, tolerance
    /// [`TRANSIENT_TOLERANCE`], no output time yet.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let _t = fpsolve::grid::GridTransient::new(&bound);
    /// ```
    pub fn new(model: &'a BoundModel) -> GridTransient<'a> {
        GridTransient {
            model,
            cells: DEFAULT_CELLS,
            domain: None,
            initial: Initial::Rest,
            times: Vec::new(),
            tolerance: TRANSIENT_TOLERANCE,
            joint: false,
            estimate: true,
        }
    }

    /// Cells along the position and the velocity (as [`crate::grid::GridSolver::cells`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridError, GridTransient, TransientError};
    /// let err = GridTransient::new(&bound).cells(41, 40).times(vec![1.0]).run().unwrap_err();
    /// assert!(matches!(err, TransientError::Grid(GridError::Setting { setting: "cells", .. })));
    /// ```
    pub fn cells(mut self, nx: usize, nv: usize) -> Self {
        self.cells = [nx, nv];
        self
    }

    /// Runs on `domain` instead of the stationary solver's box (as
    /// [`crate::grid::GridSolver::domain`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{Domain, GridTransient};
    /// let d = Domain { x: [-8.0, 8.0], v: [-8.0, 8.0] };
    /// let h = GridTransient::new(&bound).cells(32, 32).domain(d).times(vec![0.5]).run().unwrap();
    /// assert_eq!(h.report.domain, d);
    /// ```
    pub fn domain(mut self, domain: Domain) -> Self {
        self.domain = Some(domain);
        self
    }

    /// Where the run starts (default [`Initial::Rest`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridTransient, Initial};
    /// let start = Initial::Gaussian { mean: [1.0, 0.0], covariance: [[0.1, 0.0], [0.0, 0.1]] };
    /// let h = GridTransient::new(&bound).cells(40, 40).initial(start).times(vec![0.0]).run().unwrap();
    /// let s = &h.snapshots[0];
    /// // The start's mass on the cells is whole; its mean is that of the cell averages, within
    /// // a small part of a cell (about 0.8 wide here) of the Gaussian's.
    /// assert!((s.mass - 1.0).abs() < 1e-9);
    /// assert!((s.moments[0].mean - 1.0).abs() < 0.05, "{}", s.moments[0].mean);
    /// ```
    pub fn initial(mut self, initial: Initial) -> Self {
        self.initial = initial;
        self
    }

    /// The output times: finite, non-decreasing, none negative (the run starts at t = 0).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let h = fpsolve::grid::GridTransient::new(&bound).cells(32, 32).times(vec![0.0, 0.5]).run().unwrap();
    /// assert_eq!(h.snapshots.len(), 2);
    /// ```
    pub fn times(mut self, times: Vec<f64>) -> Self {
        self.times = times;
        self
    }

    /// The L1 error each step may make per unit time (default [`TRANSIENT_TOLERANCE`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let h = fpsolve::grid::GridTransient::new(&bound).cells(32, 32).tolerance(1e-3)
    ///     .times(vec![1.0]).run().unwrap();
    /// assert_eq!(h.report.tolerance, 1e-3);
    /// ```
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Whether each snapshot keeps the joint density's cell averages (default off).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let h = fpsolve::grid::GridTransient::new(&bound).cells(32, 32).joint(true)
    ///     .times(vec![1.0]).run().unwrap();
    /// assert_eq!(h.snapshots[0].joint.as_ref().unwrap().len(), 32 * 32);
    /// ```
    pub fn joint(mut self, on: bool) -> Self {
        self.joint = on;
        self
    }

    /// Whether every output gets its discretisation-error estimate ([`SnapshotErrors`]) from
    /// a second run on half the cells, alongside the main one (default on; about a fifth
    /// of the main run's work; off, or below 16 cells on an axis, the outputs' `estimate`
    /// is `None`).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let h = fpsolve::grid::GridTransient::new(&bound).cells(32, 32).estimate(false)
    ///     .times(vec![1.0]).run().unwrap();
    /// assert!(h.snapshots[0].estimate.is_none() && h.report.estimate_cells.is_none());
    /// ```
    pub fn estimate(mut self, on: bool) -> Self {
        self.estimate = on;
        self
    }

    fn check_settings(&self) -> Result<(), TransientError> {
        let setting = |setting, value: String, expected| TransientError::Setting {
            setting,
            value,
            expected,
        };
        check_cells(self.cells)?;
        let t = &self.times;
        let ordered = !t.is_empty()
            && t.iter().all(|t| t.is_finite() && *t >= 0.0)
            && t.windows(2).all(|w| w[0] <= w[1]);
        if !ordered {
            return Err(setting(
                "times",
                format!("{t:?}"),
                "at least one time; finite, non-decreasing, none negative",
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(setting(
                "tolerance",
                format!("{}", self.tolerance),
                "finite, positive",
            ));
        }
        match &self.initial {
            Initial::Gaussian { mean, covariance }
                if !initial::valid_gaussian(*mean, *covariance) =>
            {
                Err(setting(
                    "initial",
                    format!("mean {mean:?}, covariance {covariance:?}"),
                    "a finite mean and a symmetric positive definite covariance",
                ))
            }
            Initial::Point(at) if !at.iter().all(|u| u.is_finite()) => {
                Err(setting("initial", format!("{at:?}"), "a finite point"))
            }
            Initial::Cells(p) if self.domain.is_none() => Err(setting(
                "initial",
                format!("{} cell values", p.len()),
                "an explicit domain with cell values (so that the cells are known)",
            )),
            Initial::Cells(p) if p.len() != self.cells[0] * self.cells[1] => Err(setting(
                "initial",
                format!("{} cell values", p.len()),
                "one value per cell",
            )),
            Initial::Cells(p) if !p.iter().all(|u| u.is_finite() && *u >= 0.0) => Err(setting(
                "initial",
                "cell values".to_string(),
                "finite, non-negative cell values",
            )),
            _ => Ok(()),
        }
    }

    /// Steps `p0` (of unit mass) on `mesh` to the output times; with the operator's
    /// assembly count.
    fn march(
        &self,
        problem: &Mechanical,
        mesh: &Mesh,
        p0: &[f64],
    ) -> Result<(History, usize), TransientError> {
        if problem.time_dependent() {
            let op = TimeOperator::new(mesh, problem);
            // The pattern at mid-span (at t = 0 a modulated noise may vanish, and with it
            // the diffusion's entries); the order is geometric, so any time's pattern serves.
            let t_mid = 0.5 * self.times.last().copied().unwrap_or(0.0);
            let g = op.assemble(t_mid)?;
            let run = self.step(&op, &g, mesh, p0)?;
            Ok((run, op.assemblies()))
        } else {
            let op = assemble(mesh, problem)?;
            let g = generator(mesh.cells(), &op).ok_or(GridError::Singular {
                nx: mesh.nx,
                nv: mesh.nv,
                detail: "the generator's entries could not be allocated".to_string(),
            })?;
            Ok((self.step(&g, &g, mesh, p0)?, 1))
        }
    }

    /// The outputs of a run on `mesh`, with the observables' values `observed` at its cell
    /// centres; the joint cell averages kept when `joint`.
    fn snapshots(
        &self,
        mesh: &Mesh,
        run: History,
        observed: &[Vec<f64>],
        joint: bool,
    ) -> Vec<Snapshot> {
        run.outputs
            .into_iter()
            .map(|o| self.snapshot(mesh, o.t, o.y, observed, joint))
            .collect()
    }

    /// The output at time `t` of the cell averages `y` on `mesh` (see
    /// [`GridTransient::snapshots`]).
    fn snapshot(
        &self,
        mesh: &Mesh,
        t: f64,
        y: Vec<f64>,
        observed: &[Vec<f64>],
        joint: bool,
    ) -> Snapshot {
        let area = mesh.hx * mesh.hv;
        let observables = observed.iter().map(|q| Moments::weighted(q, &y)).collect();
        let marginals = [mesh.marginal(&y, 0), mesh.marginal(&y, 1)];
        let moments = [Moments::of(&marginals[0]), Moments::of(&marginals[1])];
        Snapshot {
            t,
            edge_mass: history::edge_mass(mesh, &y),
            marginals,
            moments,
            observables,
            mass: area * y.iter().sum::<f64>(),
            negative_mass: area * y.iter().filter(|v| **v < 0.0).map(|v| -v).sum::<f64>(),
            joint: joint.then_some(y),
            estimate: None,
        }
    }

    /// Runs the stepper on `generator` from `p0` on `mesh`, the stage matrices ordered by
    /// nested dissection of `pattern`'s cells.
    fn step<G: Generator>(
        &self,
        generator: &G,
        pattern: &faer::sparse::SparseColMat<usize, f64>,
        mesh: &Mesh,
        p0: &[f64],
    ) -> Result<History, StepError> {
        let area = mesh.hx * mesh.hv;
        let order = nested_dissection(pattern.symbolic(), &cell_coords(mesh.nx, mesh.nv, false), 1);
        // ESDIRK4 (five stage solves a step) for every generator. One that depends on t has a
        // stage matrix per stage time; each is solved with a nearby time's factor as the
        // preconditioner of an iteration on that time's matrix, and factorised only when the
        // iteration stalls or the factor's corrections have cost about a factorisation. On
        // tests/models/linear_modulated.sde from rest, 96x96, 161 times to 80, tolerance 1e-4:
        // TR-BDF2 with a factorisation per stage time took 486 steps, 976 factorisations, 11 s
        // user; this takes 175 steps, 56 factorisations, 5 s, and its time-stepping error is
        // smaller (7e-5 against 1.7e-4 at most over the outputs).
        let stepper = Esdirk::new(generator)
            .scheme(Scheme::Esdirk4)
            .tolerance(Tolerance {
                relative: self.tolerance,
                absolute: 0.0,
            })
            .weight(area)
            .conserve_mass()
            .order(order);
        let stepper = if generator.time_invariant() {
            stepper
        } else {
            stepper.reuse_across_times()
        };
        stepper.run(p0, 0.0, &self.times)
    }

    /// Each observable of the model at the mesh's cell centres.
    fn observable_values(&self, mesh: &Mesh) -> Result<Vec<Vec<f64>>, GridError> {
        let observables = self.model.observables();
        if observables.is_empty() {
            return Ok(Vec::new());
        }
        let states = self.model.states();
        let exprs: Vec<_> = observables.iter().map(|o| o.expr.clone()).collect();
        let tape = crate::symbolic::Tape::compile(
            &exprs,
            &[&*states[0], &*states[1]],
            crate::symbolic::DeltaPolicy::Zero,
        )
        .map_err(|source| GridError::Symbolic {
            what: "the observables".to_string(),
            source,
        })?;
        Ok(history::observable_values(mesh, &tape, exprs.len()))
    }

    /// The box: see [`starting_box`].
    fn domain_for(&self, problem: &Mechanical) -> Result<Domain, GridError> {
        starting_box(self.domain, problem, self.model)
    }

    /// Checks every setting, the model, the box and the initial density's fit in it, as
    /// [`GridTransient::run`] does before its first step, and returns the box (sized as the
    /// run would size it): a front end calls it before it touches any output.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{Domain, GridTransient, Initial, TransientError};
    /// let d = Domain { x: [-8.0, 8.0], v: [-8.0, 8.0] };
    /// let run = GridTransient::new(&bound).cells(32, 32).domain(d).times(vec![1.0]);
    /// assert_eq!(run.check().unwrap(), d);
    /// let far = run.initial(Initial::Point([30.0, 0.0])).check().unwrap_err();
    /// assert!(matches!(far, TransientError::InitialOutsideDomain { .. }));
    /// ```
    ///
    /// # Errors
    /// As [`GridTransient::run`] before its first step.
    pub fn check(&self) -> Result<Domain, TransientError> {
        self.prepare().map(|(_, mesh, _, _)| mesh.domain())
    }

    /// The problem, the mesh, the initial cell averages (not yet normalised) and their mass.
    fn prepare(&self) -> Result<(Mechanical, Mesh, Vec<f64>, f64), TransientError> {
        self.check_settings()?;
        let problem = Mechanical::transient(&crate::dynamics::Dynamics::read(self.model))?
            .not_periodic(self.model, "a transient")?;
        if problem.time_dependent() && self.domain.is_none() {
            return Err(TransientError::Setting {
                setting: "domain",
                value: "none".to_string(),
                expected: "an explicit domain for a model whose coefficients depend on the \
                           time (the automatic box is sized from a stationary law)",
            });
        }
        let domain = self.domain_for(&problem)?;
        let [nx, nv] = self.cells;
        let mesh = Mesh::new(domain, nx, nv, &problem.barriers, 4);
        let area = mesh.hx * mesh.hv;
        let p0 = match self.initial.gaussian(&mesh) {
            Some((mean, covariance)) => initial::gaussian_cells(&mesh, mean, covariance),
            None => match &self.initial {
                Initial::Cells(p) => p.clone(),
                _ => unreachable!("every other start is a Gaussian"),
            },
        };
        let inside = p0.iter().sum::<f64>() * area;
        let cells_given = matches!(self.initial, Initial::Cells(_));
        if !cells_given && (inside.is_nan() || inside < 1.0 - INITIAL_MASS_LOSS) {
            return Err(TransientError::InitialOutsideDomain {
                inside,
                allowed: INITIAL_MASS_LOSS,
                domain: mesh.domain(),
            });
        }
        if !(inside.is_finite() && inside > 0.0) {
            return Err(TransientError::Setting {
                setting: "initial",
                value: format!("mass {inside}"),
                expected: "a positive mass",
            });
        }
        Ok((problem, mesh, p0, inside))
    }

    /// Runs: every setting and the initial density's fit in the box are checked before the
    /// first step.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{Domain, GridTransient, Initial, TransientError};
    /// let far = Initial::Point([30.0, 0.0]);
    /// let d = Domain { x: [-8.0, 8.0], v: [-8.0, 8.0] };
    /// let err = GridTransient::new(&bound).cells(32, 32).domain(d).initial(far)
    ///     .times(vec![1.0]).run().unwrap_err();
    /// assert!(matches!(err, TransientError::InitialOutsideDomain { .. }));
    /// ```
    ///
    /// # Errors
    /// [`TransientError::Setting`], [`TransientError::Grid`] (the cells, a model outside the
    /// mechanical form, a domain that does not fit the barrier),
    /// [`TransientError::InitialOutsideDomain`], [`TransientError::Step`].
    pub fn run(&self) -> Result<TransientHistory, TransientError> {
        let start = Instant::now();
        let (problem, mesh, mut p0, inside) = self.prepare()?;
        let [nx, nv] = self.cells;
        p0.iter_mut().for_each(|p| *p /= inside);
        // The error estimate's run on half the cells, alongside the main one; its start is
        // this run's start on its own cells (a point twice as wide), so that the difference
        // holds the start's smear too.
        let half = (self.estimate && nx >= 16 && nv >= 16).then(|| {
            let half = Mesh::new(mesh.domain(), nx / 2, nv / 2, &problem.barriers, 2);
            let q0 = match self.initial.gaussian(&half) {
                Some((mean, covariance)) => initial::gaussian_cells(&half, mean, covariance),
                None => coarsened(&mesh, &p0),
            };
            (half, q0)
        });
        let (main, coarse) = rayon::join(
            || self.march(&problem, &mesh, &p0),
            || {
                half.as_ref().map(|(half, q0)| {
                    let mass = q0.iter().sum::<f64>() * half.hx * half.hv;
                    let q0: Vec<f64> = q0.iter().map(|q| q / mass).collect();
                    self.march(&problem, half, &q0)
                })
            },
        );
        let (run, assemblies) = main?;
        let stats = run.stats;
        let observed = self.observable_values(&mesh)?;
        let mut snapshots = self.snapshots(&mesh, run, &observed, self.joint);
        let estimate_cells = match (coarse.transpose()?, &half) {
            (Some((coarse, _)), Some((half, _))) => {
                let observed = self.observable_values(half)?;
                let coarse = self.snapshots(half, coarse, &observed, false);
                let factor = super::solution::richardson_factor(super::ASSUMED_ORDER);
                for (s, c) in snapshots.iter_mut().zip(&coarse) {
                    let stepping = self.tolerance * s.t;
                    s.estimate = Some(SnapshotErrors::between(s, c, factor, stepping));
                }
                Some([half.nx, half.nv])
            }
            _ => None,
        };
        let worst = |f: fn(&Snapshot) -> f64| snapshots.iter().map(f).fold(0.0, f64::max);
        let report = TransientReport {
            cells: [nx, nv],
            domain: mesh.domain(),
            tolerance: self.tolerance,
            accepted: stats.accepted,
            rejected: stats.rejected,
            factorizations: stats.factorizations,
            time_dependent: problem.time_dependent(),
            assemblies,
            initial_mass_inside: inside,
            estimate_cells,
            mass_drift: worst(|s| (s.mass - 1.0).abs()),
            negative_mass: worst(|s| s.negative_mass),
            total_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        Ok(TransientHistory { snapshots, report })
    }
}

/// Cell averages `p` on `mesh` averaged over 2×2 blocks: the same density on half the cells
/// per axis (the half mesh of the error estimate nests in `mesh`).
fn coarsened(mesh: &Mesh, p: &[f64]) -> Vec<f64> {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let (hx, hv) = (nx / 2, nv / 2);
    let mut q = vec![0.0; hx * hv];
    for i in 0..2 * hx {
        for j in 0..2 * hv {
            q[(i / 2) * hv + j / 2] += 0.25 * p[i * nv + j];
        }
    }
    q
}
