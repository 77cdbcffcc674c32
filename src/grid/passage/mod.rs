//! First passage out of a safe set on the grid (issue 35): the mean first-passage time and
//! its second moment from the backward (Pontryagin) equations L*T = −1, L*T₂ = −2T on the
//! transpose of the killed finite-volume generator, and the reliability R(t) = P(T > t) with
//! the first-passage-time density −R′(t) from the forward equation with killing, time-stepped
//! by the crate's ESDIRK4 (fourth order, L-stable; mass not conserved: the lost mass is the failure
//! probability).
//!
//! * **Cells.** Those whose centre is inside the safe set; the rest are removed (absorbing).
//!   Where the boundary is crossed along x the absorption is at outflow faces only (no
//!   diffusion in x; see `killed`). When the safe set bounds the position alone, the box is
//!   moved and stretched (by less than a cell) so that its bounds fall on cell faces.
//! * **Impacts** act as in the stationary operator (outflow through the barrier and its
//!   re-injection), on the safe cells.
//! * **Consistency.** The forward and backward problems use one matrix and its transpose,
//!   so ∫₀^∞ R dt from a start density equals the start's average of T to the solves'
//!   rounding; over a finite horizon the difference is the tail R(t_end)/λ.
//! * **Stationary average.** T averaged over the grid's stationary density (same cells,
//!   impacts, box) restricted to the safe set and renormalised.
//! * **Models without a stationary density** whose response grows without bound (no
//!   damping, as the randomly accelerated particle x' = v, v' = σξ; negative damping; a
//!   softening spring that lets the paths escape) still have a first passage out of a set
//!   bounded in the position: the box must then be given ([`GridPassage::domain`]), the set
//!   must end inside it along x on both sides, and the stationary averages are `None`.
//!   Models whose paths may come to rest inside the set (no noise, noise vanishing at a
//!   stable rest point) or that depend on the time stay refused.
//!
//! ```
//! use fpsolve::grid::GridPassage;
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
//! let model = fpsolve::model::load_model(&path)?.with_safe("abs(z) < 2")?;
//! let bound = model.bind(&[])?;
//! let safe = model.safe().unwrap().bind(&bound)?;
//! let p = GridPassage::new(&bound, &safe).cells(40, 40).times(vec![0.0, 5.0, 10.0]).run()?;
//! assert!(p.mean_at_start > 0.0 && p.second_at_start > p.mean_at_start.powi(2));
//! assert_eq!(p.reliability[0], 1.0);
//! assert!(p.reliability[2] < p.reliability[1]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod align;
mod decay;
mod error;
mod killed;
mod on_mesh;

use std::time::Instant;

use serde::Serialize;

pub use decay::{Decay, DecayFailure, DECAY_RESIDUAL, MAX_DECAY_ITERATIONS};
pub use error::PassageError;

use super::mesh::Mesh;
use super::problem::Mechanical;
use super::{check_cells, Domain, GridError, Marginal, DEFAULT_CELLS, TRANSIENT_TOLERANCE};
use crate::dynamics::{Dynamics, Inadmissible};
use crate::model::{BoundModel, BoundSafe};
use crate::numerics::sparse::Check;

/// The least stationary probability a safe set must hold on the grid.
pub const MIN_SAFE_MASS: f64 = 1e-9;

/// When a backward solve is accepted (as the stationary solve's check).
const CHECK: Check = Check {
    refine_above: 1e-14,
    limit: 1e-12,
};

/// A first-passage problem on the grid: a builder, then [`GridPassage::run`].
#[derive(Clone, Debug)]
pub struct GridPassage<'a> {
    model: &'a BoundModel,
    safe: &'a BoundSafe,
    cells: [usize; 2],
    domain: Option<Domain>,
    start: [f64; 2],
    times: Times,
    tolerance: f64,
    estimate: bool,
    decay: bool,
}

/// Where R(t) is computed.
#[derive(Clone, Debug, PartialEq)]
enum Times {
    /// At these times (none: the mean times only).
    At(Vec<f64>),
    /// At `count` times evenly spaced to `means` mean times from the start.
    InMeans { means: f64, count: usize },
}

/// `count` times evenly spaced from 0 to `end`, the k-th `end·k/(count − 1)`; `None` unless
/// `end` is positive and finite and `count` at least 2.
pub(crate) fn evenly_spaced(end: f64, count: usize) -> Option<Vec<f64>> {
    if !(end.is_finite() && end > 0.0 && count >= 2) {
        return None;
    }
    let n = count - 1;
    Some((0..=n).map(|k| end * k as f64 / n as f64).collect())
}

/// What [`GridPassage::run`] found.
#[derive(Clone, Debug, Serialize)]
pub struct PassageSolution {
    /// E\[T\] from the start (T interpolated bilinearly between cell centres).
    pub mean_at_start: f64,
    /// E\[T²\] from the start.
    pub second_at_start: f64,
    /// E\[T\] from the start cell's point mass: the forward run's start, so that
    /// ∫R dt = `mean_from_start_cell` (up to the horizon's tail).
    pub mean_from_start_cell: f64,
    /// E\[T\] with the start drawn from the stationary density restricted to the safe set;
    /// `None` for a model without a stationary density.
    pub mean_stationary: Option<f64>,
    /// E\[T²\] likewise.
    pub second_stationary: Option<f64>,
    /// The stationary probability of the safe set (on the grid); `None` without a stationary
    /// density.
    pub safe_mass: Option<f64>,
    /// The output times.
    pub times: Vec<f64>,
    /// R(t) = P(T > t) at each time (from the start cell).
    pub reliability: Vec<f64>,
    /// The first-passage-time density −R′(t) at each time.
    pub pdf: Vec<f64>,
    /// ∫ R dt from 0 to the last time (trapezoid on the outputs' R and R′, i.e. the cubic
    /// Hermite rule), for the consistency check against `mean_from_start_cell`; `None`
    /// without output times.
    pub integral_of_reliability: Option<f64>,
    /// The slowest decay of the survival probability, R(t) ≈ A e^{−λt} beyond the horizon,
    /// or why it was not found, or that it was not asked ([`GridPassage::decay`]).
    pub decay: DecayOutcome,
    /// The quasi-stationary density's marginals (position, velocity), when the decay was
    /// found: the law of the paths not yet absorbed, long after the start.
    #[serde(skip)]
    pub quasi_stationary: Option<[Marginal; 2]>,
    /// The estimated discretisation errors of the numbers above, from the solve on half the
    /// cells ([`GridPassage::estimate`]); `None` without it.
    pub errors: Option<PassageErrors>,
    /// Settings and costs.
    pub report: PassageReport,
}

/// The estimated errors of a [`PassageSolution`]'s numbers: each number from the solve on
/// half the cells differs from this one's by both errors, scaled by 1.25 (order 1 and
/// Roache's safety factor, as the stationary solver's moments,
/// [`crate::grid::DiscretisationEstimate`]). It covers the discretisation of the killed
/// operator and of its boundary; not a limit the scheme converges to that is not the law's
/// (see the caution in the README: on two cases the converged mean time sits about 1 % below
/// Monte Carlo).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassageErrors {
    /// Of `mean_at_start`.
    pub mean_at_start: f64,
    /// Of `second_at_start`.
    pub second_at_start: f64,
    /// Of `mean_stationary` (`None` when it is).
    pub mean_stationary: Option<f64>,
    /// Of `second_stationary` (`None` when it is).
    pub second_stationary: Option<f64>,
    /// Of R(t) at each output time.
    pub reliability: Vec<f64>,
    /// Of the decay rate λ, when both solves found it.
    pub rate: Option<f64>,
}

impl PassageErrors {
    fn between(fine: &PassageSolution, half: &PassageSolution) -> PassageErrors {
        let factor = super::solution::richardson_factor(super::ASSUMED_ORDER);
        let e = |a: f64, b: f64| factor * (a - b).abs();
        let both = |a: Option<f64>, b: Option<f64>| Some(e(a?, b?));
        PassageErrors {
            mean_at_start: e(fine.mean_at_start, half.mean_at_start),
            second_at_start: e(fine.second_at_start, half.second_at_start),
            mean_stationary: both(fine.mean_stationary, half.mean_stationary),
            second_stationary: both(fine.second_stationary, half.second_stationary),
            reliability: fine
                .reliability
                .iter()
                .zip(&half.reliability)
                .map(|(a, b)| e(*a, *b))
                .collect(),
            rate: match (&fine.decay, &half.decay) {
                (DecayOutcome::Found(a), DecayOutcome::Found(b)) => Some(e(a.rate, b.rate)),
                _ => None,
            },
        }
    }
}

/// The slowest decay, or why it is not reported.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum DecayOutcome {
    /// Found.
    Found(Decay),
    /// Not found (the mean times and R(t) stand without it).
    NotFound {
        /// Why.
        reason: DecayFailure,
    },
    /// Not computed: the run did not ask for it ([`GridPassage::decay`] off).
    NotComputed,
}

/// How a [`PassageSolution`] was computed.
#[derive(Clone, Debug, Serialize)]
pub struct PassageReport {
    /// Cells (x, v).
    pub cells: [usize; 2],
    /// The box.
    pub domain: Domain,
    /// Cells inside the safe set.
    pub safe_cells: usize,
    /// The start.
    pub start: [f64; 2],
    /// The safe set as written.
    pub safe: String,
    /// The stepper's tolerance.
    pub tolerance: f64,
    /// Accepted and rejected steps, factorisations of the forward run.
    pub steps: [usize; 3],
    /// The cells of the solve on half the cells the errors come from, when it was made and
    /// succeeded.
    pub estimate_cells: Option<[usize; 2]>,
    /// Wall time, ms.
    pub total_ms: f64,
}

impl<'a> GridPassage<'a> {
    /// A problem on the default cells and the stationary solver's first box, from rest,
    /// tolerance [`TRANSIENT_TOLERANCE`], no output time (the mean times only).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path).unwrap().with_safe("z < 3").unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// let _p = fpsolve::grid::GridPassage::new(&bound, &safe);
    /// ```
    pub fn new(model: &'a BoundModel, safe: &'a BoundSafe) -> GridPassage<'a> {
        GridPassage {
            model,
            safe,
            cells: DEFAULT_CELLS,
            domain: None,
            start: [0.0, 0.0],
            times: Times::At(Vec::new()),
            tolerance: TRANSIENT_TOLERANCE,
            estimate: true,
            decay: true,
        }
    }

    /// Whether the numbers get their estimated errors ([`PassageErrors`]) from a second solve
    /// on half the cells, alongside (default on; below 16 cells on an axis there is none).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path).unwrap().with_safe("abs(z) < 2").unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// # let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// use fpsolve::grid::GridPassage;
    /// let with = GridPassage::new(&bound, &safe).cells(40, 40).run().unwrap();
    /// assert!(with.errors.unwrap().mean_at_start > 0.0);
    /// let without = GridPassage::new(&bound, &safe).cells(40, 40).estimate(false).run().unwrap();
    /// assert!(without.errors.is_none() && without.report.estimate_cells.is_none());
    /// ```
    pub fn estimate(mut self, on: bool) -> Self {
        self.estimate = on;
        self
    }

    /// Whether the slowest decay (λ, the amplitude A and the quasi-stationary density) is
    /// found, by inverse iteration on the mean times' factorisation (default on). Off, the
    /// solution's [`PassageSolution::decay`] is [`DecayOutcome::NotComputed`] and
    /// [`PassageSolution::quasi_stationary`] `None`: with no output times the run is then
    /// the mean times alone.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path).unwrap().with_safe("abs(z) < 2").unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// # let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// use fpsolve::grid::{DecayOutcome, GridPassage};
    /// let p = GridPassage::new(&bound, &safe).cells(40, 40).decay(false).run()?;
    /// assert_eq!(p.decay, DecayOutcome::NotComputed);
    /// assert!(p.quasi_stationary.is_none() && p.integral_of_reliability.is_none());
    /// assert!(p.mean_at_start > 0.0 && p.errors.unwrap().rate.is_none());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn decay(mut self, on: bool) -> Self {
        self.decay = on;
        self
    }

    /// Cells along x and v (as [`crate::grid::GridSolver::cells`]).
    pub fn cells(mut self, nx: usize, nv: usize) -> Self {
        self.cells = [nx, nv];
        self
    }

    /// The box (as [`crate::grid::GridSolver::domain`]) instead of the automatic one; a
    /// model without a stationary density needs it (the automatic box is sized from that
    /// density), with the safe set ending inside it along x.
    ///
    /// ```
    /// use fpsolve::grid::{Domain, GridPassage, PassageError};
    /// // The randomly accelerated particle between walls at |x| = 1.
    /// let text = "model free\nstate x, v\ndrift x: v\ndrift v: 0\nnoise xi: intensity 1\n\
    ///             diffusion v: xi\nsafe abs(x) < 1\n";
    /// let model = fpsolve::model::parse_model(text, None)?;
    /// let bound = model.bind(&[])?;
    /// let safe = model.safe().unwrap().bind(&bound)?;
    /// let refused = GridPassage::new(&bound, &safe).cells(40, 80).run();
    /// assert!(matches!(refused, Err(PassageError::NoBox { .. })));
    /// let box_ = Domain { x: [-1.1, 1.1], v: [-8.0, 8.0] };
    /// let p = GridPassage::new(&bound, &safe).cells(40, 80).domain(box_).run()?;
    /// assert!(p.mean_stationary.is_none() && p.safe_mass.is_none());
    /// assert!((p.mean_at_start - 2.31).abs() < 0.05, "{}", p.mean_at_start);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn domain(mut self, domain: Domain) -> Self {
        self.domain = Some(domain);
        self
    }

    /// The start (x, v); default rest (0, 0).
    pub fn start(mut self, start: [f64; 2]) -> Self {
        self.start = start;
        self
    }

    /// Output times of R(t): finite, non-decreasing, none negative.
    pub fn times(mut self, times: Vec<f64>) -> Self {
        self.times = Times::At(times);
        self
    }

    /// Output times of R(t) set by the mean first-passage time T̄ from the start on the run's
    /// cells: `count` (at least 2) evenly spaced from 0 to `means`·T̄ (finite, positive),
    /// none when that end is not a positive finite time. The mean times are solved once,
    /// the forward run starting from that solve (the half cells' estimate at the same times).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path).unwrap().with_safe("abs(z) < 2").unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// # let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// use fpsolve::grid::GridPassage;
    /// let p = GridPassage::new(&bound, &safe).cells(40, 40).times_in_means(5.0, 11).run()?;
    /// assert_eq!(p.times.len(), 11);
    /// assert!((p.times[10] - 5.0 * p.mean_at_start).abs() < 1e-12 * p.times[10]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn times_in_means(mut self, means: f64, count: usize) -> Self {
        self.times = Times::InMeans { means, count };
        self
    }

    /// The forward run's L1 error per unit time.
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    fn check_settings(&self) -> Result<(), PassageError> {
        let setting = |setting, value: String, expected| PassageError::Setting {
            setting,
            value,
            expected,
        };
        check_cells(self.cells)?;
        match &self.times {
            Times::At(t) => {
                if !(t.iter().all(|t| t.is_finite() && *t >= 0.0)
                    && t.windows(2).all(|w| w[0] <= w[1]))
                {
                    return Err(setting(
                        "times",
                        format!("{t:?}"),
                        "finite, non-decreasing, none negative",
                    ));
                }
            }
            Times::InMeans { means, count } => {
                if !(means.is_finite() && *means > 0.0) {
                    return Err(setting("means", format!("{means}"), "finite, positive"));
                }
                if *count < 2 {
                    return Err(setting("count", format!("{count}"), "at least 2"));
                }
            }
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(setting(
                "tolerance",
                format!("{}", self.tolerance),
                "finite, positive",
            ));
        }
        let [x, v] = self.start;
        if !(x.is_finite() && v.is_finite()) {
            return Err(setting("start", format!("{x},{v}"), "a finite point"));
        }
        if !self.safe.contains(self.start) {
            return Err(PassageError::StartOutside {
                x,
                v,
                safe: self.safe.text.clone(),
            });
        }
        Ok(())
    }

    /// Every check that needs no solve, as [`GridPassage::run`] makes them first: the
    /// settings, the start inside the set, the model (one without a stationary density needs
    /// the box), the box given against the model's walls and the start inside it, and for a
    /// model without a stationary density the set ending inside the box along x on the
    /// cells. Not checked here: the safe set's probability, which needs the stationary solve.
    ///
    /// ```
    /// use fpsolve::grid::{Domain, GridPassage, PassageError};
    /// let text = "model free\nstate x, v\ndrift x: v\ndrift v: 0\nnoise xi: intensity 1\n\
    ///             diffusion v: xi\nsafe abs(x) < 1\n";
    /// let model = fpsolve::model::parse_model(text, None)?;
    /// let bound = model.bind(&[])?;
    /// let safe = model.safe().unwrap().bind(&bound)?;
    /// let p = GridPassage::new(&bound, &safe);
    /// assert!(matches!(p.check(), Err(PassageError::NoBox { .. })));
    /// let p = p.domain(Domain { x: [0.5, 1.1], v: [-8.0, 8.0] });
    /// assert!(matches!(p.check(), Err(PassageError::StartOutsideBox { .. })));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`PassageError::Setting`], [`PassageError::StartOutside`], [`PassageError::NoBox`],
    /// [`PassageError::StartOutsideBox`], [`PassageError::NotBounded`], [`PassageError::Grid`].
    pub fn check(&self) -> Result<(), PassageError> {
        self.prepare().map(|_| ())
    }

    /// The checks of [`GridPassage::check`]; the model's mechanical form, the box and
    /// whether the model has a stationary density.
    fn prepare(&self) -> Result<(Mechanical, Domain, bool), PassageError> {
        self.check_settings()?;
        let dynamics = crate::dynamics::Dynamics::read(self.model);
        let without = without_stationary_density(&dynamics)?;
        let problem = match without {
            None => Mechanical::new(&dynamics)?,
            Some(_) => Mechanical::first_passage(&dynamics)?,
        }
        .not_periodic(self.model, "a first passage")?
        .with_midpoint_fluxes();
        let box_ = match (&without, self.domain) {
            (Some(reason), None) => {
                return Err(PassageError::NoBox {
                    reason: reason.clone(),
                })
            }
            _ => super::transient::starting_box(self.domain, &problem, self.model)?,
        };
        let [x, v] = self.start;
        if self.domain.is_some()
            && !(box_.x[0] <= x && x <= box_.x[1] && box_.v[0] <= v && v <= box_.v[1])
        {
            return Err(PassageError::StartOutsideBox { x, v, domain: box_ });
        }
        if without.is_some() {
            // On the run's cells, as the solve will find it.
            let [nx, nv] = self.cells;
            let aligned = align::aligned(box_, nx, &problem, self.safe, self.model);
            let mesh = Mesh::new(aligned, nx, nv, &problem.barriers, align::MESH_ALIGN);
            let safe: Vec<bool> = (0..mesh.cells())
                .map(|c| self.safe.contains([mesh.xc(c / nv), mesh.vc(c % nv)]))
                .collect();
            self.bounded(&mesh, &safe)?;
        }
        Ok((problem, box_, without.is_none()))
    }

    /// Solves: every setting, the start and the safe set's probability are checked before
    /// the backward and forward solves.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path).unwrap().with_safe("z < 1").unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// # let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// use fpsolve::grid::{GridPassage, PassageError};
    /// let err = GridPassage::new(&bound, &safe).start([2.0, 0.0]).run().unwrap_err();
    /// assert!(matches!(err, PassageError::StartOutside { .. }));
    /// ```
    ///
    /// # Errors
    /// [`PassageError::Setting`], [`PassageError::StartOutside`],
    /// [`PassageError::StartOutsideBox`], [`PassageError::NoProbability`],
    /// [`PassageError::Grid`], [`PassageError::Singular`], [`PassageError::Step`].
    pub fn run(&self) -> Result<PassageSolution, PassageError> {
        let started = Instant::now();
        crate::base::timeline::mark("passage: run start");
        let (problem, box_, stationary) = self.prepare()?;
        crate::base::timeline::mark("passage: prepared");
        let [nx, nv] = self.cells;
        // The error estimate's solve on half the cells, alongside (the same problem and box,
        // aligned to its own cells, R(t) at the same times); its failure leaves the numbers
        // without an estimate.
        let backward = |cells| self.backward_at(&problem, box_, cells, stationary);
        let half_cells = (self.estimate && nx >= 16 && nv >= 16).then_some([nx / 2, nv / 2]);
        let (fine, half) = match &self.times {
            Times::At(times) => rayon::join(
                || backward(self.cells)?.finish(self, times),
                || half_cells.map(|c| backward(c)?.finish(self, times)),
            ),
            Times::InMeans { means, count } => {
                // The times wait for the fine cells' mean time only.
                let (fine, half) =
                    rayon::join(|| backward(self.cells), || half_cells.map(backward));
                let fine = fine?;
                let times =
                    evenly_spaced(means * fine.mean_at(self.start), *count).unwrap_or_default();
                rayon::join(
                    || fine.finish(self, &times),
                    || half.map(|h| h?.finish(self, &times)),
                )
            }
        };
        let mut fine = fine?;
        if let Some(Ok(half)) = half {
            fine.errors = Some(PassageErrors::between(&fine, &half));
            fine.report.estimate_cells = Some(half.report.cells);
        }
        fine.report.total_ms = started.elapsed().as_secs_f64() * 1e3;
        crate::base::timeline::mark("passage: run end");
        Ok(fine)
    }
}

impl GridPassage<'_> {
    /// For a model without a stationary density: nothing holds the paths near the start but
    /// the set itself, so where it is open at the box's ends in x (`safe`: whether each of
    /// `mesh`'s cells is inside) the box would decide the mean time.
    fn bounded(&self, mesh: &Mesh, safe: &[bool]) -> Result<(), PassageError> {
        let d = mesh.domain();
        let column = |i: usize| (0..mesh.nv).any(|j| safe[mesh.index(i, j)]);
        match [(0, d.x[0]), (mesh.nx - 1, d.x[1])]
            .into_iter()
            .find_map(|(i, x)| column(i).then_some(x))
        {
            Some(edge) => Err(PassageError::NotBounded {
                safe: self.safe.text.clone(),
                edge,
            }),
            None => Ok(()),
        }
    }
}

/// `None` for a model with a stationary density; else why it has none, when that still
/// leaves a first passage out of a set bounded in the position well posed: the response
/// grows without bound, so the paths leave any such set. The reasons that may keep a path
/// inside for ever (no noise; noise vanishing at a stable rest point) or change the killed
/// operator in time are refused with the grid's error.
fn without_stationary_density(dynamics: &Dynamics) -> Result<Option<Inadmissible>, GridError> {
    use Inadmissible as I;
    match dynamics.admissible() {
        Ok(()) => Ok(None),
        Err(
            why @ (I::NoDamping { .. }
            | I::NegativeDamping { .. }
            | I::EnergyAddingImpact { .. }
            | I::EnergyAddingImpactTerm { .. }
            | I::UnstableLinearDrift { .. }
            | I::Escapes { .. }
            | I::NoRestoringForce { .. }),
        ) => Ok(Some(why)),
        Err(why @ (I::TimeDependent { .. } | I::NoNoise | I::VanishingDiffusionAtRest { .. })) => {
            Err(GridError::Inadmissible(why))
        }
    }
}

/// The cell holding `at` (clamped to the mesh).
fn cell_of(mesh: &Mesh, at: [f64; 2]) -> usize {
    let cell =
        |u: f64, lo: f64, h: f64, n: usize| ((((u - lo) / h).floor()).max(0.0) as usize).min(n - 1);
    mesh.index(
        cell(at[0], mesh.x0, mesh.hx, mesh.nx),
        cell(at[1], mesh.v0, mesh.hv, mesh.nv),
    )
}

/// Bilinear interpolation of cell-centre values at `at` (the nearest centres at the edges).
fn bilinear(mesh: &Mesh, f: &[f64], at: [f64; 2]) -> f64 {
    let coord = |u: f64, lo: f64, h: f64, n: usize| {
        let s = ((u - lo) / h - 0.5).clamp(0.0, (n - 1) as f64);
        let i = (s.floor() as usize).min(n.saturating_sub(2));
        (i, s - i as f64)
    };
    let (i, a) = coord(at[0], mesh.x0, mesh.hx, mesh.nx);
    let (j, b) = coord(at[1], mesh.v0, mesh.hv, mesh.nv);
    let g = |i: usize, j: usize| f[mesh.index(i, j)];
    (1.0 - a) * ((1.0 - b) * g(i, j) + b * g(i, j + 1))
        + a * ((1.0 - b) * g(i + 1, j) + b * g(i + 1, j + 1))
}

/// out = A y.
fn apply(a: &faer::sparse::SparseColMat<usize, f64>, y: &[f64], out: &mut [f64]) {
    out.iter_mut().for_each(|o| *o = 0.0);
    for (c, &yc) in y.iter().enumerate() {
        let rows = a.symbolic().row_idx_of_col_raw(c);
        for (&r, &v) in rows.iter().zip(a.val_of_col(c)) {
            out[r] += v * yc;
        }
    }
}

/// ∫ R dt over the outputs by the cubic Hermite rule (values and derivatives −pdf at both
/// ends of each interval), fourth order in the outputs' spacing.
fn hermite_integral(t: &[f64], r: &[f64], pdf: &[f64]) -> f64 {
    (1..t.len())
        .map(|k| {
            let h = t[k] - t[k - 1];
            0.5 * h * (r[k - 1] + r[k]) + h * h / 12.0 * (-pdf[k - 1] + pdf[k])
        })
        .sum()
}
