//! The Monte Carlo transient: an ensemble drawn from the initial law (rest, a point, a
//! Gaussian), advanced by the stationary run's kernel (its scheme, flights and exact
//! impacts: [`BatchState::advance`], no second integrator) and recorded at the output times:
//! mean, variance and kurtosis of each state with standard errors, histograms on given bins
//! with standard errors, and the time-step bias from the first quarter of the batches (at
//! least two) run again at 2·dt, as the stationary runs estimate it.
//!
//! Between two output times the step is the largest that divides the interval into whole
//! steps no longer than `dt`. Batches of [`TRANSIENT_LANES`] trajectories run in parallel
//! (rayon; a task steps up to 16 side by side), each trajectory with its own random stream
//! (the stationary run's, by index); the per-batch sums are combined in batch order and the
//! histograms are integer counts, so a seed gives the same numbers whatever the number of
//! threads.
//!
//! A model whose drift or diffusion depends on the time `t` (a modulated white noise, a
//! periodic force) is simulated with its coefficients at the times each scheme takes within
//! a step (see `BatchState::advance`): the mechanical splitting's velocity update at the
//! step's midpoint and Platen's scheme at the step's ends keep weak order 2, so the bias
//! estimate's p is the scheme's order as for a model without the time. For coefficients of
//! period P, [`McTransient::periodic`] samples the periodic steady state at phases instead
//! ([`McPeriodic`]).
//!
//! ```
//! use fpsolve::mc::McTransient;
//! // White noise modulated by the Shinozuka–Sato envelope 4(e^{−t/2} − e^{−t}).
//! let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\nnoise xi: intensity 1\n\
//!             diffusion v: 4*(exp(-0.5*t) - exp(-t))*xi\n";
//! let model = fpsolve::model::parse_model(text, None)?.bind(&[])?;
//! let h = McTransient::new(&model).times(vec![0.0, 3.0, 20.0]).trajectories(1024).run()?;
//! let var = |k: usize| h.snapshots[k].moments[0].variance.value;
//! // The response grows while the excitation does, then decays with it.
//! assert!(var(1) > 0.4 && var(2) < 0.1 * var(1));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ```
//! use fpsolve::mc::{Grid, McTransient};
//! use fpsolve::model::{load_model, InitialState};
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
//! let model = load_model(path.as_ref())?.bind(&[])?;
//! let bins = [Grid::new(-10.0, 10.0, 40)?, Grid::new(-10.0, 10.0, 40)?];
//! let h = McTransient::new(&model)
//!     .initial(InitialState::Rest)
//!     .times(vec![0.0, 2.0])
//!     .trajectories(256)
//!     .dt(0.02)
//!     .bins(bins)
//!     .run()?;
//! let s = &h.snapshots[1];
//! // From rest the variance grows; it has an error bar.
//! assert!(s.moments[0].variance.value > 0.0 && s.moments[0].variance.stderr > 0.0);
//! assert_eq!(h.snapshots[0].moments[0].variance.value, 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod periodic;
mod sums;

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::compile::impact::Crossing;
use super::compile::scheme::{walls, Plan, SchemeChoice, SchemeKind};
use super::kernel::rng::Increments;
use super::record::histogram::Grid;
use super::step::state::BatchState;
use super::step::timed::SpanTable;
use crate::model::{BoundModel, InitialState};
use crate::stats::Estimate;
use sums::PowerSums;

pub use error::McTransientError;
pub use periodic::{
    McPeriodic, McPeriodicPilot, McPeriodicReport, McPeriodicState, RECORDED_PERIODS,
};

/// Trajectories per batch: the unit of the error bars and of the bias run's pairing.
pub const TRANSIENT_LANES: usize = 64;

/// At most this many batches are stepped side by side in one state (a task of the thread
/// pool): a model whose coefficients depend on the time has them computed once per step
/// for all their lanes. Each lane's arithmetic and random stream are its own whatever lanes
/// share its state, so the grouping changes no number.
const BLOCK_BATCHES: u64 = 16;

/// At most this many coefficient values (8 bytes each) of a time-dependent form are
/// computed once for all the batches of a pass; beyond, each block computes its own (the
/// same numbers, more slowly).
const MAX_SHARED_VALUES: usize = 1 << 22;

/// At most this many trajectories in one run.
pub const MAX_TRANSIENT_TRAJECTORIES: u64 = 100_000_000;

/// At most this many time steps per trajectory.
pub const MAX_TRANSIENT_STEPS: f64 = 1e9;

/// A Gaussian start must keep this many of its standard deviations from a reflecting wall
/// (less than 1e−9 of it beyond).
pub const WALL_SDS: f64 = 6.0;

/// A Monte Carlo transient of one bound model: a builder, then [`McTransient::run`].
#[derive(Clone, Debug)]
pub struct McTransient<'a> {
    model: &'a BoundModel,
    initial: InitialState,
    times: Vec<f64>,
    dt: f64,
    trajectories: u64,
    seed: u64,
    bins: Option<[Grid; 2]>,
    bias: bool,
}

/// Mean, variance and kurtosis of one state at one time, each with its standard error, and
/// their time-step bias.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct McStateMoments {
    /// E\[q\].
    pub mean: Estimate,
    /// Var\[q\] (unbiased).
    pub variance: Estimate,
    /// E[(q − mean)⁴]/Var² (NaN where the variance is zero, as at a point start).
    pub kurtosis: Estimate,
    /// Estimated S_dt − S_exact of (mean, variance, kurtosis); `None` without the bias run.
    pub bias: Option<[Estimate; 3]>,
}

/// A state's histogram at one time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McDensity {
    /// The bins.
    pub grid: Grid,
    /// Density in each bin: the fraction of the trajectories in it over its width.
    pub density: Vec<f64>,
    /// Standard error of each bin's density (binomial: the trajectories are independent).
    pub stderr: Vec<f64>,
    /// The fraction of the (finite) trajectories outside the bins.
    pub outside: f64,
    /// Estimated time-step bias of each bin's density, (S_2dt − S_dt)/(2ᵖ − 1) on the paired
    /// batches; `None` without the bias run.
    pub bias: Option<Vec<f64>>,
}

/// The ensemble at one output time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McSnapshot {
    /// The time.
    pub t: f64,
    /// Moments of each state.
    pub moments: [McStateMoments; 2],
    /// Histograms of each state (when bins were given).
    pub densities: Option<[McDensity; 2]>,
    /// Trajectories whose state is no longer finite (left out of every statistic).
    pub blown_up: u64,
}

/// The settings of a run and what it did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McTransientSettings {
    /// Trajectories.
    pub trajectories: u64,
    /// The largest time step.
    pub dt: f64,
    /// The seed of the random streams.
    pub seed: u64,
    /// The scheme the stationary run would use for this model.
    pub scheme: SchemeKind,
    /// Its weak order (the bias extrapolation's p).
    pub weak_order: u32,
    /// Batches run again at 2·dt for the bias (0 without).
    pub bias_pairs: u64,
    /// Wall-clock time, in milliseconds.
    pub total_ms: f64,
}

/// The ensemble statistics at the requested times, from [`McTransient::run`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McTransientHistory {
    /// One per requested time, in order.
    pub snapshots: Vec<McSnapshot>,
    /// How it was obtained.
    pub settings: McTransientSettings,
}

impl McTransientHistory {
    /// The six series (value, standard error) over the outputs of each state's mean,
    /// variance and kurtosis, state by state: what a pilot judges settled
    /// (`mc::relax::relaxation`).
    pub(crate) fn moment_series(&self) -> Vec<Vec<(f64, f64)>> {
        (0..6)
            .map(|s| {
                self.snapshots
                    .iter()
                    .map(|snap| {
                        let m = &snap.moments[s / 3];
                        let e = [m.mean, m.variance, m.kurtosis][s % 3];
                        (e.value, e.stderr)
                    })
                    .collect()
            })
            .collect()
    }

    /// The first output time after 0 at which every trajectory is still exactly at its
    /// start (both states' variances 0): the sampled drift and noise vanish at a point start,
    /// as sgn(0) = 0 does to a Zhuravlev form's noise sgn(z)·ξ at rest, and the ensemble's
    /// numbers are not the law's. `None` for an ensemble that moved.
    ///
    /// ```
    /// use fpsolve::mc::McTransient;
    /// use fpsolve::model::{load_model, InitialState};
    /// // Refused before any work where the model says so (vibro_duffing.sde at rest, see
    /// // McError::StartHeldStill); a noise that vanishes there at every time is found only
    /// // by running.
    /// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -z - 0.1*v\n\
    ///             noise xi: intensity 1\ndiffusion v: sgn(z)*exp(-0.01*t)*xi\n";
    /// let model = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// let run = |start| McTransient::new(&model).initial(start).times(vec![0.0, 1.0])
    ///     .trajectories(256).run();
    /// assert_eq!(run(InitialState::Rest)?.stuck_at_start(), Some(1.0));
    /// assert_eq!(run(InitialState::Point([1e-6, 0.0]))?.stuck_at_start(), None);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn stuck_at_start(&self) -> Option<f64> {
        self.snapshots
            .iter()
            .find(|s| s.t > 0.0 && s.moments.iter().all(|m| m.variance.value == 0.0))
            .map(|s| s.t)
    }
}

/// What one pass over a set of batches collects.
struct Pass {
    /// Per batch (in batch order), per time, per state: its power sums.
    sums: Vec<Vec<[PowerSums; 2]>>,
    /// Per time, per state: bin counts, then the count outside (all batches).
    counts: Vec<[Vec<u64>; 2]>,
    /// The same over the batches that are paired with the 2·dt run.
    paired_counts: Vec<[Vec<u64>; 2]>,
    /// Per time: trajectories no longer finite.
    blown_up: Vec<u64>,
}

impl<'a> McTransient<'a> {
    /// A run from rest, 10 000 trajectories, dt = 0.01, seed 1, no bins, with the bias run;
    /// no output time yet.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// # let model = fpsolve::model::load_model(path.as_ref()).unwrap().bind(&[]).unwrap();
    /// let _run = fpsolve::mc::McTransient::new(&model);
    /// ```
    pub fn new(model: &'a BoundModel) -> McTransient<'a> {
        McTransient {
            model,
            initial: InitialState::Rest,
            times: Vec::new(),
            dt: 0.01,
            trajectories: 10_000,
            seed: 1,
            bins: None,
            bias: true,
        }
    }

    /// Where the trajectories start (rest: exactly the origin).
    pub fn initial(mut self, initial: InitialState) -> Self {
        self.initial = initial;
        self
    }

    /// The output times: finite, non-decreasing, none negative.
    pub fn times(mut self, times: Vec<f64>) -> Self {
        self.times = times;
        self
    }

    /// The largest time step.
    pub fn dt(mut self, dt: f64) -> Self {
        self.dt = dt;
        self
    }

    /// The number of trajectories (rounded up to whole batches of [`TRANSIENT_LANES`]).
    pub fn trajectories(mut self, n: u64) -> Self {
        self.trajectories = n;
        self
    }

    /// The seed of the random streams.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// The bins of the position's and the velocity's histograms.
    pub fn bins(mut self, bins: [Grid; 2]) -> Self {
        self.bins = Some(bins);
        self
    }

    /// Whether to estimate the time-step bias (default on).
    pub fn bias(mut self, on: bool) -> Self {
        self.bias = on;
        self
    }

    fn batches(&self) -> u64 {
        self.trajectories.div_ceil(TRANSIENT_LANES as u64)
    }

    /// Checks every setting, the model and the start without stepping anything; returns the
    /// compiled plan.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// # let model = fpsolve::model::load_model(path.as_ref()).unwrap().bind(&[]).unwrap();
    /// use fpsolve::mc::{McTransient, McTransientError};
    /// let err = McTransient::new(&model).times(vec![1.0]).dt(0.0).check().unwrap_err();
    /// assert!(matches!(err, McTransientError::Setting { setting: "dt", .. }));
    /// ```
    ///
    /// # Errors
    /// [`McTransientError::Setting`], [`McTransientError::StartBeyondWall`],
    /// [`McTransientError::Mc`] (a model that cannot be simulated; a dt its drift makes
    /// unstable, at t = 0 or, for a drift that depends on the time, at an output time).
    pub fn check(&self) -> Result<(), McTransientError> {
        self.plan().map(|_| ())
    }

    fn plan(&self) -> Result<Plan, McTransientError> {
        crate::mc::refuse::refuse_periodic(self.model)?;
        let setting = |setting, value: String, expected| McTransientError::Setting {
            setting,
            value,
            expected,
        };
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
        let dt = self.dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(setting("dt", format!("{dt}"), "a positive step"));
        }
        let last = t[t.len() - 1];
        if last / dt > MAX_TRANSIENT_STEPS {
            return Err(setting(
                "dt",
                format!("{dt} (to t = {last})"),
                "at most 1e9 steps per trajectory",
            ));
        }
        let min = 2 * TRANSIENT_LANES as u64;
        if !(min..=MAX_TRANSIENT_TRAJECTORIES).contains(&self.trajectories) {
            return Err(setting(
                "trajectories",
                format!("{}", self.trajectories),
                "between 128 (two batches, for error bars) and 1e8",
            ));
        }
        if let Some(bins) = &self.bins {
            if !bins.iter().all(Grid::well_formed) {
                return Err(setting(
                    "bins",
                    format!("{bins:?}"),
                    "finite lo < hi, at least one bin",
                ));
            }
        }
        match self.initial {
            InitialState::Point(p) if !p.iter().all(|u| u.is_finite()) => {
                return Err(setting("initial", format!("{p:?}"), "a finite point"));
            }
            InitialState::Gaussian { mean, covariance } if cholesky(mean, covariance).is_none() => {
                return Err(setting(
                    "initial",
                    format!("mean {mean:?}, covariance {covariance:?}"),
                    "a finite mean and a symmetric positive definite covariance",
                ));
            }
            _ => {}
        }
        let dynamics = crate::dynamics::Dynamics::read(self.model);
        match self.initial {
            InitialState::Rest => crate::mc::refuse::refuse_held_still(&dynamics, [0.0, 0.0])?,
            InitialState::Point(p) => crate::mc::refuse::refuse_held_still(&dynamics, p)?,
            InitialState::Gaussian { .. } => {}
        }
        let observables: Vec<_> = self
            .model
            .observables
            .iter()
            .map(|o| o.expr.clone())
            .collect();
        let plan = Plan::with_impacts(
            &dynamics,
            &observables,
            SchemeChoice::Auto,
            walls(&dynamics)?,
        )?;
        let states = dynamics.states();
        // A drift that depends on the time is checked at the output times too.
        let at: &[f64] = if plan.drift.program().is_timed() {
            t
        } else {
            &[]
        };
        for &time in std::iter::once(&0.0).chain(at) {
            if let Some(limit) = plan.step_limit([&states[0], &states[1]], time) {
                if dt > limit.largest_dt {
                    return Err(super::McError::UnstableStep { dt, limit }.into());
                }
            }
        }
        self.check_walls(&plan)?;
        Ok(plan)
    }

    /// A start must lie on the trajectories' side of every reflecting wall.
    fn check_walls(&self, plan: &Plan) -> Result<(), McTransientError> {
        let (mean, sd) = match self.initial {
            InitialState::Rest => ([0.0, 0.0], [0.0, 0.0]),
            InitialState::Point(p) => (p, [0.0, 0.0]),
            InitialState::Gaussian { mean, covariance } => {
                (mean, [covariance[0][0].sqrt(), covariance[1][1].sqrt()])
            }
        };
        for b in &plan.barriers {
            if b.crossing != Crossing::Reflects {
                continue;
            }
            let distance = (mean[b.state] - b.at) * b.side;
            let sds = if sd[b.state] > 0.0 {
                distance / sd[b.state]
            } else if distance >= 0.0 {
                f64::INFINITY
            } else {
                f64::NEG_INFINITY
            };
            if sds < WALL_SDS && !(sd[b.state] == 0.0 && distance >= 0.0) {
                return Err(McTransientError::StartBeyondWall {
                    sds,
                    state: self.model.states()[b.state].to_string(),
                    at: b.at,
                });
            }
        }
        Ok(())
    }

    /// Runs the ensemble (and the bias run at 2·dt); the statistics at every output time.
    ///
    /// # Errors
    /// As [`McTransient::check`]; nothing fails once the trajectories run (a trajectory that
    /// blows up is counted in [`McSnapshot::blown_up`] and left out).
    pub fn run(&self) -> Result<McTransientHistory, McTransientError> {
        let start = Instant::now();
        let plan = self.plan()?;
        let batches = self.batches();
        let pairs = if self.bias {
            (batches / 4).max(2).min(batches)
        } else {
            0
        };
        let fine = self.pass(&plan, batches, pairs, self.dt);
        let coarse = (pairs > 0).then(|| self.pass(&plan, pairs, 0, 2.0 * self.dt));
        let order = plan.kind.weak_order();
        let total = (batches * TRANSIENT_LANES as u64).min(self.trajectories);
        let snapshots = self
            .times
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                let moments = std::array::from_fn(|a| {
                    let coarse = coarse.as_ref().map(|c| &c.sums[..]);
                    let ([mean, variance, kurtosis], bias) =
                        sums::moments(&fine.sums, coarse, k, a, order);
                    McStateMoments {
                        mean,
                        variance,
                        kurtosis,
                        bias,
                    }
                });
                let densities = self.bins.as_ref().map(|bins| {
                    std::array::from_fn(|a| {
                        density(
                            bins[a],
                            &fine.counts[k][a],
                            coarse
                                .as_ref()
                                .map(|c| (&fine.paired_counts[k][a], &c.counts[k][a], order)),
                        )
                    })
                });
                McSnapshot {
                    t,
                    moments,
                    densities,
                    blown_up: fine.blown_up[k],
                }
            })
            .collect();
        Ok(McTransientHistory {
            snapshots,
            settings: McTransientSettings {
                trajectories: total,
                dt: self.dt,
                seed: self.seed,
                scheme: plan.kind,
                weak_order: order,
                bias_pairs: pairs,
                total_ms: start.elapsed().as_secs_f64() * 1e3,
            },
        })
    }

    /// Batches `0..batches` at step at most `dt`; the first `pairs` also counted apart.
    fn pass(&self, plan: &Plan, batches: u64, pairs: u64, dt: f64) -> Pass {
        let empty = || Pass {
            sums: Vec::new(),
            counts: self.empty_counts(),
            paired_counts: self.empty_counts(),
            blown_up: vec![0; self.times.len()],
        };
        let spans = self.span_tables(plan, dt);
        // Enough blocks for every thread to take several.
        let threads = rayon::current_num_threads().max(1) as u64;
        let per = (batches / (4 * threads)).clamp(1, BLOCK_BATCHES);
        // `collect` keeps the blocks' order, whichever thread ran each.
        let parts: Vec<Pass> = (0..batches.div_ceil(per))
            .into_par_iter()
            .map(|j| {
                let mut p = empty();
                let first = j * per;
                let range = first..(first + per).min(batches);
                self.block(plan, &spans, range, pairs, dt, &mut p);
                p
            })
            .collect();
        let mut out = empty();
        for p in parts {
            out.sums.extend(p.sums);
            add_counts(&mut out.counts, &p.counts);
            add_counts(&mut out.paired_counts, &p.paired_counts);
            out.blown_up
                .iter_mut()
                .zip(&p.blown_up)
                .for_each(|(a, b)| *a += b);
        }
        out
    }

    /// For each output time, the coefficients of a time-dependent form over the steps from
    /// the previous one at step at most `dt` ([`SpanTable`]), while they fit
    /// [`MAX_SHARED_VALUES`]; `None` where there are none to share.
    fn span_tables(&self, plan: &Plan, dt: f64) -> Vec<Option<SpanTable>> {
        let mut left = MAX_SHARED_VALUES;
        let mut now = 0.0;
        self.times
            .iter()
            .map(|&t| {
                let (from, span) = (now, t - now);
                now = t;
                if span <= 0.0 {
                    return None;
                }
                let (steps, h) = steps_of(span, dt);
                let table = SpanTable::of(plan, from, steps, h, left)?;
                left -= table.len();
                Some(table)
            })
            .collect()
    }

    fn empty_counts(&self) -> Vec<[Vec<u64>; 2]> {
        let n = |a: usize| self.bins.map_or(0, |b| b[a].bins + 1);
        vec![[vec![0; n(0)], vec![0; n(1)]]; self.times.len()]
    }

    /// The state of the batches `batches` side by side at their start (drawn from the
    /// initial law, each lane from its own stream), and each batch's lanes in it.
    fn start(
        &self,
        plan: &Plan,
        batches: std::ops::Range<u64>,
    ) -> (BatchState, Vec<(u64, std::ops::Range<usize>)>) {
        let width = TRANSIENT_LANES as u64;
        let first = batches.start * width;
        let lanes = self
            .trajectories
            .saturating_sub(first)
            .min((batches.end - batches.start) * width) as usize;
        let mut b = BatchState::new(
            plan,
            &[[0.0; 2]; 2],
            self.seed,
            first,
            lanes,
            Increments::default(),
        );
        let factor = match self.initial {
            InitialState::Gaussian { mean, covariance } => cholesky(mean, covariance),
            _ => None,
        };
        for i in 0..lanes {
            let p = match self.initial {
                InitialState::Rest => [0.0, 0.0],
                InitialState::Point(p) => p,
                InitialState::Gaussian { mean, .. } => {
                    let l = factor.expect("checked in plan");
                    let (z0, z1) = (b.lane_normal(i), b.lane_normal(i));
                    [mean[0] + l[0] * z0, mean[1] + l[1] * z0 + l[2] * z1]
                }
            };
            b.x[i] = p[0];
            b.v[i] = p[1];
        }
        // A pass-through barrier's side is where each trajectory starts (a start on it
        // keeps the plan's side).
        if let [bar] = plan.barriers.as_slice() {
            if bar.crossing == Crossing::PassesThrough {
                for i in 0..lanes {
                    let q = if bar.state == 0 { b.x[i] } else { b.v[i] };
                    if q != bar.at {
                        b.side[i] = (q - bar.at).signum();
                    }
                }
            }
        }
        // Each batch's lanes of the block.
        let members: Vec<(u64, std::ops::Range<usize>)> = batches
            .clone()
            .map(|k| {
                let lo = ((k - batches.start) * width) as usize;
                (k, lo.min(lanes)..(lo + TRANSIENT_LANES).min(lanes))
            })
            .collect();
        (b, members)
    }

    /// The batches `batches` stepped side by side in one state, from the start through
    /// every output time: each batch's power sums per time and state pushed to `pass` (in
    /// batch order), its counts added there (those of a batch below `pairs` also to the
    /// paired counts).
    fn block(
        &self,
        plan: &Plan,
        spans: &[Option<SpanTable>],
        batches: std::ops::Range<u64>,
        pairs: u64,
        dt: f64,
        pass: &mut Pass,
    ) {
        let (mut b, members) = self.start(plan, batches);
        let mut sums = vec![Vec::with_capacity(self.times.len()); members.len()];
        let mut now = 0.0;
        for (k, &t) in self.times.iter().enumerate() {
            let span = t - now;
            if span > 0.0 {
                let (steps, h) = steps_of(span, dt);
                b.advance_with(plan, steps, h, spans[k].as_ref());
                // The output time itself, not the sum of the steps, starts the next span.
                b.t = t;
                now = t;
            }
            for ((batch, r), out) in members.iter().zip(&mut sums) {
                let finite: Vec<bool> = r
                    .clone()
                    .map(|i| b.x[i].is_finite() && b.v[i].is_finite())
                    .collect();
                pass.blown_up[k] += finite.iter().filter(|f| !**f).count() as u64;
                let states = [&b.x[r.clone()], &b.v[r.clone()]];
                out.push(std::array::from_fn(|a| {
                    let q: Vec<f64> = states[a]
                        .iter()
                        .zip(&finite)
                        .map(|(&q, &f)| if f { q } else { f64::NAN })
                        .collect();
                    if let Some(bins) = &self.bins {
                        count(&bins[a], &q, &mut pass.counts[k][a]);
                        if *batch < pairs {
                            count(&bins[a], &q, &mut pass.paired_counts[k][a]);
                        }
                    }
                    PowerSums::of(&q)
                }));
            }
        }
        pass.sums.extend(sums);
    }
}

/// The steps over `span` at step at most `dt`: the fewest whole steps, and their size.
fn steps_of(span: f64, dt: f64) -> (u64, f64) {
    let steps = (span / dt * (1.0 - 1e-12)).ceil().max(1.0);
    (steps as u64, span / steps)
}

/// Adds the finite values `q` to the bin counts `c` (the last entry: outside the bins).
fn count(g: &Grid, q: &[f64], c: &mut [u64]) {
    let w = g.width();
    for &q in q.iter().filter(|q| q.is_finite()) {
        let i = ((q - g.lo) / w).floor();
        if i >= 0.0 && (i as usize) < g.bins {
            c[i as usize] += 1;
        } else {
            c[g.bins] += 1;
        }
    }
}

fn add_counts(to: &mut [[Vec<u64>; 2]], from: &[[Vec<u64>; 2]]) {
    for (a, b) in to.iter_mut().zip(from) {
        for (x, y) in a.iter_mut().zip(b) {
            x.iter_mut().zip(y).for_each(|(x, y)| *x += y);
        }
    }
}

/// The histogram of counts `c` on `g`, with the bias from (paired fine counts, coarse
/// counts, order).
fn density(g: Grid, c: &[u64], bias: Option<(&Vec<u64>, &Vec<u64>, u32)>) -> McDensity {
    let w = g.width();
    let n = c.iter().sum::<u64>() as f64;
    let rate = |c: &[u64]| -> Vec<f64> {
        let n = c.iter().sum::<u64>() as f64;
        c[..g.bins].iter().map(|&k| k as f64 / n / w).collect()
    };
    let density = rate(c);
    let stderr = c[..g.bins]
        .iter()
        .map(|&k| {
            let p = k as f64 / n;
            (p * (1.0 - p) / n).sqrt() / w
        })
        .collect();
    let bias = bias.map(|(fine, coarse, order)| {
        let scale = 1.0 / (2f64.powi(order as i32) - 1.0);
        rate(coarse)
            .iter()
            .zip(rate(fine))
            .map(|(c, f)| (c - f) * scale)
            .collect()
    });
    McDensity {
        grid: g,
        density,
        stderr,
        outside: c[g.bins] as f64 / n,
        bias,
    }
}

/// The lower Cholesky factor [l00, l10, l11] of a symmetric positive definite covariance,
/// `None` if it is not one or anything is not finite.
fn cholesky(mean: [f64; 2], c: [[f64; 2]; 2]) -> Option<[f64; 3]> {
    let finite = mean.iter().chain(c.iter().flatten()).all(|u| u.is_finite());
    if !finite || c[0][1] != c[1][0] || c[0][0] <= 0.0 {
        return None;
    }
    let l00 = c[0][0].sqrt();
    let l10 = c[1][0] / l00;
    let r = c[1][1] - l10 * l10;
    (r > 0.0).then(|| [l00, l10, r.sqrt()])
}
