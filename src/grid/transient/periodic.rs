//! The periodic steady state of a model whose coefficients have period P (a periodic force,
//! a periodically modulated noise): the density p* = Φ p* of unit mass, Φ the grid's
//! propagator over one period from phase 0, found by GMRES on (I − Φ) δ = Φ p₀ − p₀
//! (p* = p₀ + δ) instead of stepping through the many periods a lightly damped oscillator
//! needs to forget its start (a multiplier e^{−cP/2} per period for damping c).
//!
//! * **The map.** Φ is one period of ESDIRK4 (fourth order, L-stable: the transient's
//!   stepper's tableau) on a fixed lattice of [`GridPeriodic::steps`] equal steps, so that
//!   Φ is one linear map — GMRES needs that; the error-controlled steps of the transient
//!   would change with the vector the map is applied to — and so that every period visits
//!   the same stage times. Only 12 of the 5 × steps stage matrices, at times spread evenly
//!   over the period, are factorised and kept; every other stage solve iterates with the
//!   factor of the kept stage nearest in time as the preconditioner of its own exact matrix
//!   (x ← x + M⁻¹(b − S x), to the backward error of a direct solve, as the stepper's
//!   `Esdirk::reuse_across_times`), or is factorised for that solve when the iteration
//!   stalls. On the forced linear oscillator (tests/transient_periodic.rs) at 128x128,
//!   keeping 12 of 160 instead of as many as 3/4 of the memory limit held took the peak
//!   memory from 4.0 GB to 0.86 GB (16 kept: 1.01 GB and 7 % less CPU time), about 5
//!   corrections per stage solve. The stages themselves are the stepper's
//!   (`timestep::implicit_stages`); only their solves differ.
//! * **Mass.** Φ conserves mass (the operator's columns sum to zero), so the residual
//!   Φ p₀ − p₀ and the Krylov space have zero mass and p* keeps p₀'s: 1.
//! * **Stop.** GMRES restarts from the true fixed-point residual r = Φ p − p, whose L1 norm
//!   ‖r‖₁ is the number reported ([`PeriodicOutcome`]); the run ends when it is at most
//!   [`GridPeriodic::residual`], or unconverged (with that residual) when
//!   [`GridPeriodic::max_maps`] period maps have been applied.
//! * **Outputs** at the requested phases in [0, P] (phase = t mod P) come from the last
//!   residual's period: a phase between lattice times is reached by one step of its own
//!   length from the lattice time before it.
//! * **Checks before any work.** A finite period > 0; a model whose coefficients mention t
//!   (otherwise [`PeriodError::NotTimeDependent`]: the stationary solver applies); the
//!   drift and diffusion equal at t and t + P at probe points of the box
//!   ([`PeriodError::NotPeriodic`] names the coefficient: the check every method shares,
//!   [`crate::model::BoundModel::check_period`]); the transient's own checks.
//!
//! [`PeriodError::NotTimeDependent`]: crate::model::PeriodError::NotTimeDependent
//! [`PeriodError::NotPeriodic`]: crate::model::PeriodError::NotPeriodic

use std::cell::{Cell, RefCell};
use std::fmt;
use std::time::Instant;

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMatRef};
use serde::Serialize;

use super::operator::TimeOperator;
use super::TransientError;
use super::{GridTransient, Initial, Snapshot, SnapshotErrors, TransientHistory, TransientReport};
use crate::base::limits::memory_limit_bytes;
use crate::grid::mesh::{Domain, Mesh};
use crate::grid::nested::{cell_coords, nested_dissection};
use crate::grid::problem::Mechanical;
use crate::model::PeriodError;
use crate::numerics::krylov::gmres;
use crate::numerics::sparse::faer_lu::{FaerLu, Ordering};
use crate::numerics::sparse::pattern_lu::PatternLu;
use crate::numerics::sparse::{Check, FactorError, Factorization};
use crate::numerics::timestep::{
    apply, apply_ref, implicit_stages, shifted, shifted_ref, Scheme, StepError,
};

/// The fixed-point residual ‖Φ p − p‖₁ the run stops at unless
/// [`GridPeriodic::residual`] says otherwise.
pub const PERIODIC_RESIDUAL: f64 = 1e-8;

/// Equal steps per period unless [`GridPeriodic::steps`] says otherwise.
pub const PERIOD_STEPS: usize = 32;

/// The most period maps a run applies unless [`GridPeriodic::max_maps`] says otherwise.
pub const MAX_PERIOD_MAPS: usize = 300;

/// The period map's method: ESDIRK4, fourth order. On the forced linear oscillator at 64x64
/// (tests/transient_periodic.rs) TR-BDF2 needed 256 steps (512 stage matrices) to bring the
/// marginals' L1 error down to the cells' 2.3e-2; ESDIRK4 reaches 2.4e-2 with 32 steps (160).
const SCHEME: Scheme = Scheme::Esdirk4;

/// Krylov vectors kept before GMRES restarts from the true residual.
const RESTART: usize = 40;

/// Stage factorisations kept per period; the other stages iterate with the nearest one's
/// (at 128x128 on the forced linear oscillator, one run each at a load of about 7: 12 kept,
/// 0.86 GB and 48.6 s of CPU; 16 kept, 1.01 GB and 45.0 s).
const KEPT_STAGES: usize = 12;

/// The most corrections of a stage solve iterating with another stage's factor before that
/// stage is factorised itself.
const MAX_SWEEPS: usize = 8;

/// For each of `times` (stage times, period `period`), the index of the kept one whose
/// factor solves it: `kept` times nearest to evenly spaced anchors are kept, and every
/// other time goes to the nearest kept one (distances modulo the period).
fn anchors(times: &[f64], period: f64, kept: usize) -> Vec<usize> {
    let distance = |a: f64, b: f64| {
        let d = (a - b).rem_euclid(period);
        d.min(period - d)
    };
    let mut chosen: Vec<usize> = Vec::with_capacity(kept);
    for m in 0..kept {
        let target = (m as f64 + 0.5) * period / kept as f64;
        let best = (0..times.len())
            .filter(|k| !chosen.contains(k))
            .min_by(|&a, &b| distance(times[a], target).total_cmp(&distance(times[b], target)));
        chosen.extend(best);
    }
    times
        .iter()
        .map(|&t| {
            *chosen
                .iter()
                .min_by(|&&a, &&b| distance(times[a], t).total_cmp(&distance(times[b], t)))
                .expect("at least one kept stage")
        })
        .collect()
}

/// When a stage solve is accepted (as the transient's stepper).
const CHECK: Check = Check {
    refine_above: 1e-14,
    limit: 1e-12,
};

/// The periodic steady state of a grid transient's model: [`GridTransient::periodic`], then
/// [`GridPeriodic::run`]. The transient's times are the output phases, in [0, P]; its
/// start is the first guess (rest, the transient's default, is replaced by a broad Gaussian
/// at the box's centre, its standard deviation a fourteenth of the box on each axis).
///
/// ```
/// use fpsolve::grid::{Domain, GridTransient};
/// let text = "model forced\nstate x, v\ndrift x: v\ndrift v: -0.5*v - x + cos(t)\n\
///     noise xi: intensity 0.5\ndiffusion v: xi\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let p = 2.0 * std::f64::consts::PI;
/// let state = GridTransient::new(&bound)
///     .cells(32, 32)
///     .domain(Domain { x: [-5.0, 5.0], v: [-5.0, 5.0] })
///     .times(vec![0.0, p / 2.0])
///     .periodic(p)
///     .steps(32)
///     .run()?;
/// assert!(state.report.outcome.converged());
/// // Half a period apart the mean response has the opposite sign.
/// let m = |k: usize| state.history.snapshots[k].moments[0].mean;
/// assert!(m(0) * m(1) < 0.0, "{} {}", m(0), m(1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct GridPeriodic<'a> {
    transient: GridTransient<'a>,
    period: f64,
    residual: f64,
    max_maps: usize,
    steps: usize,
}

/// Why a periodic run stopped.
///
/// ```
/// use fpsolve::grid::PeriodicOutcome;
/// let o = PeriodicOutcome::MapsExhausted { residual: 1e-3, target: 1e-8, maps: 300 };
/// assert!(!o.converged() && o.residual() == 1e-3);
/// assert!(o.to_string().contains("300"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "stop", rename_all = "snake_case")]
pub enum PeriodicOutcome {
    /// ‖Φ p − p‖₁ reached the target.
    Converged {
        /// ‖Φ p − p‖₁ of the state returned.
        residual: f64,
        /// Period maps applied.
        maps: usize,
    },
    /// The most period maps allowed were applied first; the state returned is the last
    /// iterate, its residual above the target.
    MapsExhausted {
        /// ‖Φ p − p‖₁ of the state returned.
        residual: f64,
        /// The target.
        target: f64,
        /// Period maps applied.
        maps: usize,
    },
}

impl PeriodicOutcome {
    /// Whether the residual reached the target.
    ///
    /// ```
    /// use fpsolve::grid::PeriodicOutcome;
    /// assert!(PeriodicOutcome::Converged { residual: 1e-9, maps: 12 }.converged());
    /// ```
    pub fn converged(&self) -> bool {
        matches!(self, PeriodicOutcome::Converged { .. })
    }

    /// ‖Φ p − p‖₁ of the state returned.
    ///
    /// ```
    /// use fpsolve::grid::PeriodicOutcome;
    /// assert_eq!(PeriodicOutcome::Converged { residual: 1e-9, maps: 12 }.residual(), 1e-9);
    /// ```
    pub fn residual(&self) -> f64 {
        match *self {
            PeriodicOutcome::Converged { residual, .. }
            | PeriodicOutcome::MapsExhausted { residual, .. } => residual,
        }
    }

    /// Period maps applied.
    ///
    /// ```
    /// use fpsolve::grid::PeriodicOutcome;
    /// assert_eq!(PeriodicOutcome::Converged { residual: 1e-9, maps: 12 }.maps(), 12);
    /// ```
    pub fn maps(&self) -> usize {
        match *self {
            PeriodicOutcome::Converged { maps, .. }
            | PeriodicOutcome::MapsExhausted { maps, .. } => maps,
        }
    }
}

impl fmt::Display for PeriodicOutcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PeriodicOutcome::Converged { residual, maps } => write!(
                f,
                "periodic state found: |Phi p - p|_1 = {residual:.2e} after {maps} period maps"
            ),
            PeriodicOutcome::MapsExhausted {
                residual,
                target,
                maps,
            } => write!(
                f,
                "no periodic state within {maps} period maps: |Phi p - p|_1 = {residual:.2e} \
                 (target {target:.1e}); the outputs are the last iterate's"
            ),
        }
    }
}

/// How the periodic state was found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PeriodicReport {
    /// The period P.
    pub period: f64,
    /// Equal ESDIRK4 steps per period.
    pub steps_per_period: usize,
    /// Why the run stopped, with the residual and the period maps applied.
    pub outcome: PeriodicOutcome,
    /// ‖Φ p − p‖₁ at the start of each GMRES cycle and at the end, in order.
    pub residuals: Vec<f64>,
    /// Stage matrices whose factorisations were kept across period maps (of 5 per step);
    /// every other stage is solved by iterating with the factor of the kept one nearest
    /// in time.
    pub cached_stages: usize,
    /// Corrections those iterations took, over all period maps (each one solve with a kept
    /// factor and one product with the stage's matrix).
    pub corrections: usize,
}

/// The periodic steady state: the outputs at the requested phases (each snapshot's `t` is
/// its phase) and the run's report as the transient's, with how the fixed point was found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PeriodicState {
    /// The density at each phase; `report.accepted` counts every step taken.
    pub history: TransientHistory,
    /// The period map's residual and counts.
    pub report: PeriodicReport,
}

impl<'a> GridTransient<'a> {
    /// The periodic steady state for coefficients of period `period` instead of a history
    /// from the start: see [`GridPeriodic`].
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridTransient, TransientError};
    /// use fpsolve::model::PeriodError;
    /// // models/linear.sde has no t: its long-time density is the stationary one.
    /// let err = GridTransient::new(&bound).times(vec![0.0]).periodic(1.0).run().unwrap_err();
    /// assert!(matches!(err, TransientError::Period(PeriodError::NotTimeDependent { .. })));
    /// ```
    pub fn periodic(self, period: f64) -> GridPeriodic<'a> {
        GridPeriodic {
            transient: self,
            period,
            residual: PERIODIC_RESIDUAL,
            max_maps: MAX_PERIOD_MAPS,
            steps: PERIOD_STEPS,
        }
    }
}

impl GridPeriodic<'_> {
    /// The fixed-point residual ‖Φ p − p‖₁ to reach (default [`PERIODIC_RESIDUAL`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridTransient, TransientError};
    /// let err = GridTransient::new(&bound).times(vec![0.0]).periodic(1.0).residual(0.0)
    ///     .check().unwrap_err();
    /// assert!(matches!(err, TransientError::Setting { setting: "residual", .. }));
    /// ```
    pub fn residual(mut self, target: f64) -> Self {
        self.residual = target;
        self
    }

    /// The most period maps to apply (default [`MAX_PERIOD_MAPS`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let _p = fpsolve::grid::GridTransient::new(&bound).periodic(1.0).max_maps(50);
    /// ```
    pub fn max_maps(mut self, maps: usize) -> Self {
        self.max_maps = maps;
        self
    }

    /// Equal steps per period (default [`PERIOD_STEPS`]): the time-stepping error is
    /// fourth order in P / steps (ESDIRK4's stage order two may lower that where the
    /// coefficients change fast).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::grid::{GridTransient, TransientError};
    /// let err = GridTransient::new(&bound).times(vec![0.0]).periodic(1.0).steps(1)
    ///     .check().unwrap_err();
    /// assert!(matches!(err, TransientError::Setting { setting: "steps", .. }));
    /// ```
    pub fn steps(mut self, steps: usize) -> Self {
        self.steps = steps;
        self
    }

    /// The checks of [`GridPeriodic::run`] before any work; returns the box.
    ///
    /// ```
    /// use fpsolve::grid::{Domain, GridTransient, TransientError};
    /// use fpsolve::model::PeriodError;
    /// let text = "model f\nstate x, v\ndrift x: v\ndrift v: -v - x + cos(2*t)\n\
    ///     noise xi: intensity 1\ndiffusion v: xi\n";
    /// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// let run = GridTransient::new(&bound).cells(32, 32)
    ///     .domain(Domain { x: [-5.0, 5.0], v: [-5.0, 5.0] }).times(vec![0.0, 1.0]);
    /// // cos(2t) has period pi, not 3.
    /// let err = run.clone().periodic(3.0).check().unwrap_err();
    /// assert!(matches!(err, TransientError::Period(PeriodError::NotPeriodic { .. })), "{err}");
    /// assert!(run.periodic(std::f64::consts::PI).check().is_ok());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// As [`GridPeriodic::run`] before its first step.
    pub fn check(&self) -> Result<Domain, TransientError> {
        self.prepare().map(|(_, mesh, _, _, _)| mesh.domain())
    }

    /// The settings, the model and its period, then the transient's checks: the problem,
    /// the mesh, the first guess's cell averages (not normalised), their mass and the
    /// transient builder that made them.
    #[allow(clippy::type_complexity)]
    fn prepare(
        &self,
    ) -> Result<(Mechanical, Mesh, Vec<f64>, f64, GridTransient<'_>), TransientError> {
        let setting = |setting, value: String, expected| TransientError::Setting {
            setting,
            value,
            expected,
        };
        let p = self.period;
        let model = self.transient.model;
        // The period's own value first, then this run's settings, then the model's time.
        if let Err(e @ PeriodError::NotPositive { .. }) = model.check_period(p, None) {
            return Err(e.into());
        }
        if !(self.residual.is_finite() && self.residual > 0.0) {
            return Err(setting(
                "residual",
                format!("{}", self.residual),
                "finite, positive",
            ));
        }
        if self.steps < 2 {
            return Err(setting("steps", format!("{}", self.steps), "at least 2"));
        }
        if self.max_maps < 1 {
            return Err(setting(
                "max_maps",
                format!("{}", self.max_maps),
                "at least 1",
            ));
        }
        model.check_period(p, None)?;
        if self.transient.times.iter().any(|t| *t > p) {
            return Err(setting(
                "times",
                format!("{:?}", self.transient.times),
                "phases within [0, period]",
            ));
        }
        let mut transient = self.transient.clone();
        if let (Initial::Rest, Some(d)) = (&transient.initial, transient.domain) {
            let (wx, wv) = ((d.x[1] - d.x[0]) / 14.0, (d.v[1] - d.v[0]) / 14.0);
            transient.initial = Initial::Gaussian {
                mean: [0.5 * (d.x[0] + d.x[1]), 0.5 * (d.v[0] + d.v[1])],
                covariance: [[wx * wx, 0.0], [0.0, wv * wv]],
            };
        }
        let (problem, mesh, p0, inside) = transient.prepare()?;
        let d = mesh.domain();
        model.check_period(p, Some([d.x, d.v]))?;
        Ok((problem, mesh, p0, inside, transient))
    }

    /// Finds the periodic state and returns it at the requested phases, with a second
    /// solve on half the cells and half the steps per period for the outputs' error
    /// estimates when the transient's [`GridTransient::estimate`] is on (so that they cover
    /// both the cells and the steps).
    ///
    /// # Errors
    /// [`TransientError::Setting`] (`period`, `residual`, `steps`, `max_maps`, phases
    /// beyond the period, and the transient's), [`TransientError::Period`] (not time
    /// dependent, not periodic), the transient's refusals of the model and the box,
    /// [`TransientError::Step`] when a stage matrix cannot be built or solved. A run that
    /// does not reach its residual is not an error: its [`PeriodicOutcome`] says so.
    pub fn run(&self) -> Result<PeriodicState, TransientError> {
        let start = Instant::now();
        let (problem, mesh, mut p0, inside, transient) = self.prepare()?;
        let [nx, nv] = transient.cells;
        p0.iter_mut().for_each(|p| *p /= inside);
        let half = (transient.estimate && nx >= 16 && nv >= 16).then(|| {
            let half = Mesh::new(mesh.domain(), nx / 2, nv / 2, &problem.barriers, 2);
            let q0 = match transient.initial.gaussian(&half) {
                Some((mean, covariance)) => super::initial::gaussian_cells(&half, mean, covariance),
                None => super::coarsened(&mesh, &p0),
            };
            let mass = q0.iter().sum::<f64>() * half.hx * half.hv;
            let q0: Vec<f64> = q0.iter().map(|q| q / mass).collect();
            (half, q0)
        });
        // The estimate's solve halves the steps per period with the cells, so that its
        // difference from this one carries the steps' error too (the same steps on both would
        // cancel it: a period of too few steps would go unseen).
        let (main, coarse) = rayon::join(
            || self.solve_on(&problem, &mesh, &p0, self.steps),
            || {
                half.as_ref()
                    .map(|(half, q0)| self.solve_on(&problem, half, q0, (self.steps / 2).max(2)))
            },
        );
        let main = main?;
        let observed = transient.observable_values(&mesh)?;
        let mut snapshots: Vec<Snapshot> = main
            .outputs
            .iter()
            .map(|(t, y)| transient.snapshot(&mesh, *t, y.clone(), &observed, transient.joint))
            .collect();
        let estimate_cells = match (coarse.transpose()?, &half) {
            (Some(coarse), Some((half, _))) => {
                let observed = transient.observable_values(half)?;
                let factor = crate::grid::solution::richardson_factor(crate::grid::ASSUMED_ORDER);
                for (s, (t, y)) in snapshots.iter_mut().zip(coarse.outputs) {
                    let c = transient.snapshot(half, t, y, &observed, false);
                    s.estimate = Some(SnapshotErrors::between(s, &c, factor, 0.0));
                }
                Some([half.nx, half.nv])
            }
            _ => None,
        };
        let worst = |f: fn(&Snapshot) -> f64| snapshots.iter().map(f).fold(0.0, f64::max);
        let history = TransientHistory {
            report: TransientReport {
                cells: [nx, nv],
                domain: mesh.domain(),
                tolerance: self.residual,
                accepted: main.steps,
                rejected: 0,
                factorizations: main.factorizations,
                time_dependent: true,
                assemblies: main.assemblies,
                initial_mass_inside: inside,
                estimate_cells,
                mass_drift: worst(|s| (s.mass - 1.0).abs()),
                negative_mass: worst(|s| s.negative_mass),
                total_ms: start.elapsed().as_secs_f64() * 1e3,
            },
            snapshots,
        };
        Ok(PeriodicState {
            history,
            report: PeriodicReport {
                period: self.period,
                steps_per_period: self.steps,
                outcome: main.outcome,
                residuals: main.residuals,
                cached_stages: main.cached_stages,
                corrections: main.corrections,
            },
        })
    }

    /// The fixed point on `mesh` from the first guess `p0` (unit mass).
    fn solve_on(
        &self,
        problem: &Mechanical,
        mesh: &Mesh,
        p0: &[f64],
        steps: usize,
    ) -> Result<Solved, TransientError> {
        let map = PeriodMap::new(mesh, problem, self.period, steps)?;
        let area = mesh.hx * mesh.hv;
        let target = self.residual;
        let phases = &self.transient.times;
        let mut p = p0.to_vec();
        let mut maps = 0;
        let mut residuals = Vec::new();
        let (outcome, outputs) = loop {
            let (q, outputs) = map.period(&p, phases)?;
            maps += 1;
            let r: Vec<f64> = q.iter().zip(&p).map(|(q, p)| q - p).collect();
            let residual = area * r.iter().map(|v| v.abs()).sum::<f64>();
            residuals.push(residual);
            if residual <= target {
                break (PeriodicOutcome::Converged { residual, maps }, outputs);
            }
            if maps >= self.max_maps {
                let outcome = PeriodicOutcome::MapsExhausted {
                    residual,
                    target,
                    maps,
                };
                break (outcome, outputs);
            }
            // One map is kept for the next cycle's true residual.
            let most = RESTART.min(self.max_maps - maps - 1).max(1);
            // The L1 residual must fall by target/residual; GMRES watches the 2-norm, so
            // a tenth more, and the true residual judges.
            let beta = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            let stop = beta * (0.1 * target / residual).min(0.5);
            let (delta, cycle) = gmres(
                |v| {
                    let (phi, _) = map.period(v, &[])?;
                    Ok::<_, TransientError>(v.iter().zip(&phi).map(|(v, f)| v - f).collect())
                },
                &r,
                most,
                stop,
            )?;
            maps += cycle.products;
            p.iter_mut().zip(&delta).for_each(|(p, d)| *p += d);
        };
        Ok(Solved {
            outputs,
            outcome,
            residuals,
            steps: map.steps_taken.get(),
            factorizations: map.factorizations.get(),
            assemblies: map.op.assemblies(),
            cached_stages: map.cached(),
            corrections: map.corrections.get(),
        })
    }
}

/// A fixed point on one mesh.
struct Solved {
    /// (phase, cell averages) per requested phase.
    outputs: Vec<(f64, Vec<f64>)>,
    outcome: PeriodicOutcome,
    residuals: Vec<f64>,
    steps: usize,
    factorizations: usize,
    assemblies: usize,
    cached_stages: usize,
    corrections: usize,
}

/// A factorised stage matrix.
enum Lu {
    Pattern(PatternLu),
    Faer(Box<FaerLu>),
}

/// A generator kept across period maps: its values alone when it has A(0)'s pattern (an
/// assembly drops the entries that are zero at its time, so a few may not), which halves
/// what the 5 × steps generators take (128x128 cells: 0.15 GB instead of 0.3).
enum Generator {
    Values(Vec<f64>),
    Whole(SparseColMat<usize, f64>),
}

/// A kept stage matrix I − γ h A and its factors.
struct Stage {
    s: SparseColMat<usize, f64>,
    lu: Lu,
}

/// Φ on one mesh: the lattice of steps, A(0), the generators at the stage times and the
/// few stage factorisations kept.
struct PeriodMap<'m> {
    op: TimeOperator<'m>,
    steps: usize,
    h: f64,
    order: Vec<usize>,
    a0: SparseColMat<usize, f64>,
    /// The generator at stage (step j, implicit stage i), at j·(implicit stages) + i,
    /// assembled on the first period.
    generators: RefCell<Vec<Option<Generator>>>,
    /// The factors of the kept stages, at their keys.
    kept: RefCell<Vec<Option<Stage>>>,
    /// The time of each stage.
    times: Vec<f64>,
    /// The kept stage whose factor solves each stage: itself, or the nearest in time.
    anchor: Vec<usize>,
    factorizations: Cell<usize>,
    corrections: Cell<usize>,
    steps_taken: Cell<usize>,
}

impl<'m> PeriodMap<'m> {
    fn new(
        mesh: &'m Mesh,
        problem: &'m Mechanical,
        period: f64,
        steps: usize,
    ) -> Result<Self, TransientError> {
        let op = TimeOperator::new(mesh, problem);
        let a0 = op.assemble(0.0)?;
        let order = nested_dissection(a0.symbolic(), &cell_coords(mesh.nx, mesh.nv, false), 1);
        let tableau = SCHEME.tableau();
        let implicit = tableau.a.len();
        let h = period / steps as f64;
        let times: Vec<f64> = (0..steps * implicit)
            .map(|k| (k / implicit) as f64 * h + tableau.c[k % implicit + 1] * h)
            .collect();
        let anchor = anchors(&times, period, KEPT_STAGES.min(times.len()));
        Ok(PeriodMap {
            op,
            steps,
            h,
            order,
            a0,
            generators: RefCell::new(times.iter().map(|_| None).collect()),
            kept: RefCell::new(times.iter().map(|_| None).collect()),
            times,
            anchor,
            factorizations: Cell::new(0),
            corrections: Cell::new(0),
            steps_taken: Cell::new(0),
        })
    }

    /// Stage matrices kept.
    fn cached(&self) -> usize {
        self.kept.borrow().iter().filter(|s| s.is_some()).count()
    }

    /// Φ y, and y's image at each of `phases` (sorted, within [0, P]) along the way.
    #[allow(clippy::type_complexity)]
    fn period(
        &self,
        y: &[f64],
        phases: &[f64],
    ) -> Result<(Vec<f64>, Vec<(f64, Vec<f64>)>), StepError> {
        let mut y = y.to_vec();
        let mut f = vec![0.0; y.len()];
        apply(&self.a0, &y, &mut f);
        let mut outputs = Vec::with_capacity(phases.len());
        let mut next = 0;
        for j in 0..=self.steps {
            let t = j as f64 * self.h;
            // Phases at this lattice time; those inside the next step below.
            while next < phases.len() && phases[next] <= t + 1e-9 * self.h {
                outputs.push((phases[next], y.clone()));
                next += 1;
            }
            if j == self.steps {
                break;
            }
            // A phase inside this step: one step of its own length from the step's start.
            while next < phases.len() && phases[next] < t + self.h - 1e-9 * self.h {
                let phase = phases[next];
                let (mut z, mut g) = (y.clone(), f.clone());
                self.step(None, t, phase - t, &mut z, &mut g)?;
                outputs.push((phase, z));
                next += 1;
            }
            self.step(Some(j), t, self.h, &mut y, &mut f)?;
        }
        Ok((y, outputs))
    }

    /// One ESDIRK4 step of length `h` from (t, y, f = A(t) y), in place: lattice step `j`
    /// (its stages solved with the kept factors), or a step of its own (each stage's matrix
    /// assembled and factorised for it).
    fn step(
        &self,
        j: Option<usize>,
        t: f64,
        h: f64,
        y: &mut Vec<f64>,
        f: &mut Vec<f64>,
    ) -> Result<(), StepError> {
        let implicit = SCHEME.tableau().a.len();
        let n = y.len();
        let mut y1 = vec![0.0; n];
        let mut stages = vec![vec![0.0; n]; implicit];
        match j {
            Some(j) => implicit_stages(
                SCHEME,
                (t, h),
                (y, f),
                &mut y1,
                &mut stages,
                |i, at, b| self.lattice_solve(j * implicit + i, at, b),
                |i, _, y, out| {
                    self.with_generator(j * implicit + i, |a| apply_ref(a, y, out));
                    Ok(())
                },
            )?,
            None => {
                // The stage's generator, from its solve to its derivative.
                let generator = RefCell::new(None);
                implicit_stages(
                    SCHEME,
                    (t, h),
                    (y, f),
                    &mut y1,
                    &mut stages,
                    |_, at, b| {
                        let a = self.op.assemble(at)?;
                        let s = shifted(&a, SCHEME.tableau().gamma * h);
                        let lu = self.factor(&s, at, h)?;
                        checked_solve(&s, &lu, at, h, b)?;
                        *generator.borrow_mut() = Some(a);
                        Ok(())
                    },
                    |_, _, y, out| {
                        apply(generator.borrow().as_ref().expect("solved first"), y, out);
                        Ok(())
                    },
                )?
            }
        }
        *y = y1;
        *f = stages.pop().expect("an implicit stage");
        self.steps_taken.set(self.steps_taken.get() + 1);
        Ok(())
    }

    /// Assembles the generator of lattice stage `k` unless it is kept.
    fn assemble(&self, k: usize) -> Result<(), StepError> {
        if self.generators.borrow()[k].is_some() {
            return Ok(());
        }
        let a = self.op.assemble(self.times[k])?;
        let (p, q) = (self.a0.symbolic(), a.symbolic());
        let kept = if p.col_ptr() == q.col_ptr() && p.row_idx() == q.row_idx() {
            Generator::Values(a.val().to_vec())
        } else {
            Generator::Whole(a)
        };
        self.generators.borrow_mut()[k] = Some(kept);
        Ok(())
    }

    /// The generator of lattice stage `k` (assembled), lent to `with`.
    fn with_generator<T>(
        &self,
        k: usize,
        with: impl FnOnce(SparseColMatRef<'_, usize, f64>) -> T,
    ) -> T {
        let generators = self.generators.borrow();
        match generators[k].as_ref().expect("assembled") {
            Generator::Values(values) => with(SparseColMatRef::new(self.a0.symbolic(), values)),
            Generator::Whole(a) => with(a.as_ref()),
        }
    }

    /// Solves lattice stage `k` (at time `at`) against `b` in place: with its own kept
    /// factor, or iterating with its anchor's (x ← x + M⁻¹(b − S x) to the same backward
    /// error), or, when that iteration stalls, with a factorisation of its own not kept.
    fn lattice_solve(&self, k: usize, at: f64, b: &mut [f64]) -> Result<(), StepError> {
        let gamma_h = SCHEME.tableau().gamma * self.h;
        self.assemble(k)?;
        let anchor = self.anchor[k];
        if self.kept.borrow()[anchor].is_none() {
            self.assemble(anchor)?;
            let s = self.with_generator(anchor, |a| shifted_ref(a, gamma_h));
            let lu = self.factor(&s, self.times[anchor], self.h)?;
            self.kept.borrow_mut()[anchor] = Some(Stage { s, lu });
        }
        let kept = self.kept.borrow();
        let stage = kept[anchor].as_ref().expect("factorised");
        if anchor == k {
            return checked_solve(&stage.s, &stage.lu, at, self.h, b);
        }
        let s = self.with_generator(k, |a| shifted_ref(a, gamma_h));
        let iterated = match &stage.lu {
            Lu::Pattern(lu) => lu.preconditioned_solve(s.as_ref(), b, CHECK.limit, MAX_SWEEPS),
            Lu::Faer(lu) => lu.preconditioned_solve(s.as_ref(), b, CHECK.limit, MAX_SWEEPS),
        };
        match iterated {
            Some((x, sweeps)) => {
                self.corrections.set(self.corrections.get() + sweeps);
                b.copy_from_slice(&x);
                Ok(())
            }
            None => {
                let lu = self.factor(&s, at, self.h)?;
                checked_solve(&s, &lu, at, self.h, b)
            }
        }
    }

    /// Factorises `s` (a stage matrix at `at` for step `h`, named in errors).
    fn factor(&self, s: &SparseColMat<usize, f64>, at: f64, h: f64) -> Result<Lu, StepError> {
        let failed = |e: FactorError| StepError::Factorization {
            time: at,
            step: h,
            detail: e.to_string(),
        };
        let limit = memory_limit_bytes();
        let same = |p: SymbolicSparseColMatRef<'_, usize>| {
            let q = s.symbolic();
            p.col_ptr() == q.col_ptr() && p.row_idx() == q.row_idx()
        };
        // A kept factor of the same pattern lends its symbolic analysis.
        let reused = self
            .kept
            .borrow()
            .iter()
            .flatten()
            .find_map(|k| match &k.lu {
                Lu::Pattern(lu) if same(k.s.symbolic()) => Some(lu.refactor(s.as_ref(), limit)),
                _ => None,
            });
        let pattern =
            reused.unwrap_or_else(|| PatternLu::factor(s.as_ref(), self.order.clone(), limit));
        self.factorizations.set(self.factorizations.get() + 1);
        let lu = match pattern {
            Ok(lu) => Lu::Pattern(lu),
            Err(e @ FactorError::TooLarge { .. }) => return Err(failed(e)),
            Err(_) => Lu::Faer(Box::new(
                FaerLu::factor(s.as_ref(), Ordering::Colamd, limit).map_err(failed)?,
            )),
        };
        Ok(lu)
    }
}

/// Solves the stage matrix `s` against `b` in place with its factors `lu`, checked by its
/// backward error; a pattern LU that fails the check is replaced by faer's for this solve.
fn checked_solve(
    s: &SparseColMat<usize, f64>,
    lu: &Lu,
    at: f64,
    h: f64,
    b: &mut [f64],
) -> Result<(), StepError> {
    let failed = |e: FactorError| StepError::Factorization {
        time: at,
        step: h,
        detail: e.to_string(),
    };
    let s = s.as_ref();
    let x = match lu {
        Lu::Pattern(lu) => lu.checked_solve(s, b, CHECK).or_else(|e| {
            let faer = FaerLu::factor(s, Ordering::Colamd, memory_limit_bytes())?;
            faer.checked_solve(s, b, CHECK)
                .map_err(|f| FactorError::Faer(format!("{e}; faer's LU: {f}")))
        }),
        Lu::Faer(lu) => lu.checked_solve(s, b, CHECK),
    }
    .map_err(failed)?;
    b.copy_from_slice(&x);
    Ok(())
}
