//! First passage by Monte Carlo (issue 35, item 4): paths from a start point until they
//! leave a safe set, integrated by the stationary run's kernel and impacts (a block of steps
//! per call, the state after each kept: `batch.rs`), the exit time located within its step,
//! censoring at a horizon.
//!
//! The safe set is tested within every step on the cubic Hermite interpolant of the position
//! (C¹ between impacts) and the linear one of the velocity, at four points; the exit time is
//! interpolated linearly between the last point inside and the first outside (`locate.rs`).
//! A step is tested only where a cheap enclosure of the quantity over the states a part of
//! a block passes through does not clear it (`screen.rs`): the same exit times as testing
//! every step. Each path has its own random stream, so its exit time does not depend on the
//! batch or lane that runs it: one task per thread (rayon) runs batches of [`PASSAGE_LANES`]
//! lanes that take paths from a shared queue, a lane starting the next path when its own
//! ends (on the fast mechanical path), and a seed gives the same exit times whatever the
//! number of threads. The time-step bias is estimated as for stationary runs:
//! the first quarter of the batches (at least two) again at 2·dt.

mod batch;
mod density;
mod locate;
mod screen;
mod summary;

use rayon::prelude::*;

pub use batch::PASSAGE_LANES;
use batch::{Exits, Queue};

use super::compile::scheme::{walls, Plan, SchemeChoice};
use super::config::bad;
use super::error::McError;
use super::kernel::rng::Increments;
use crate::model::{BoundModel, BoundSafe};

pub use summary::{McPassageResult, PassageBias, PassageEstimate};

/// At most this many paths in one run.
pub const MAX_PASSAGE_PATHS: u64 = 100_000_000;

/// At most this many time steps per path (the horizon over dt).
pub const MAX_PASSAGE_STEPS: f64 = 1e9;

/// A Monte Carlo first-passage run: the model, its safe set and the settings.
///
/// ```
/// use fpsolve::mc::McPassage;
/// use fpsolve::model::{load_model, Override};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
/// let model = load_model(path.as_ref()).unwrap().with_safe("abs(z) < 1").unwrap();
/// let bound = model.bind(&[Override::number("c", 1.0)]).unwrap();
/// let safe = model.safe().unwrap().bind(&bound).unwrap();
/// let run = McPassage::new(&bound, &safe).paths(256).dt(0.01).horizon(200.0).seed(3);
/// let r = run.run().unwrap();
/// assert_eq!(r.censored, 0);
/// let mean = r.mean.unwrap();
/// assert!(mean.value > 0.0 && mean.stderr > 0.0);
/// ```
pub struct McPassage<'a> {
    model: &'a BoundModel,
    safe: &'a BoundSafe,
    start: [f64; 2],
    dt: f64,
    horizon: f64,
    paths: u64,
    seed: u64,
    times: Vec<f64>,
    reliability: bool,
    increments: Increments,
}

impl<'a> McPassage<'a> {
    /// A run of `model` out of `safe` from rest, 10 000 paths, dt = 0.01, horizon 1000,
    /// seed 1.
    pub fn new(model: &'a BoundModel, safe: &'a BoundSafe) -> McPassage<'a> {
        McPassage {
            model,
            safe,
            start: [0.0, 0.0],
            dt: 0.01,
            horizon: 1000.0,
            paths: 10_000,
            seed: 1,
            times: Vec::new(),
            reliability: true,
            increments: Increments::default(),
        }
    }

    /// The start (position, velocity).
    pub fn start(mut self, start: [f64; 2]) -> Self {
        self.start = start;
        self
    }

    /// The time step.
    pub fn dt(mut self, dt: f64) -> Self {
        self.dt = dt;
        self
    }

    /// The horizon: paths still inside then are censored.
    pub fn horizon(mut self, horizon: f64) -> Self {
        self.horizon = horizon;
        self
    }

    /// The number of paths.
    pub fn paths(mut self, paths: u64) -> Self {
        self.paths = paths;
        self
    }

    /// The seed of the random streams.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// The times of R(t) (default: 101 from 0 to the horizon).
    pub fn times(mut self, times: Vec<f64>) -> Self {
        self.times = times;
        self
    }

    /// Whether R(t) and the first-passage-time histogram are reported at the output times
    /// (default on). Off, the result's `times`, `reliability` (with its band) and
    /// `pdf_binned` are empty: the mean and variance of T alone, from the same paths (the
    /// output times are read off the exit times after the run, so the paths and the mean do
    /// not depend on them).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = fpsolve::model::load_model(&path)?.with_safe("abs(z) < 1")?;
    /// # let bound = model.bind(&[fpsolve::model::Override::number("c", 1.0)])?;
    /// # let safe = model.safe().unwrap().bind(&bound)?;
    /// use fpsolve::mc::McPassage;
    /// let run = || McPassage::new(&bound, &safe).paths(256).horizon(100.0);
    /// let (with, without) = (run().run()?, run().reliability(false).run()?);
    /// assert_eq!(with.times.len(), 101);
    /// assert!(without.times.is_empty() && without.reliability.is_empty());
    /// assert_eq!(with.mean, without.mean);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn reliability(mut self, on: bool) -> Self {
        self.reliability = on;
        self
    }

    /// The random increments (three-point by default, as stationary runs).
    pub fn increments(mut self, increments: Increments) -> Self {
        self.increments = increments;
        self
    }

    /// Checks the settings and the start without running anything.
    ///
    /// ```
    /// # use fpsolve::mc::McPassage;
    /// # use fpsolve::model::{load_model, Override};
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// # let model = load_model(path.as_ref()).unwrap().with_safe("abs(z) < 1").unwrap();
    /// # let bound = model.bind(&[Override::number("c", 1.0)]).unwrap();
    /// # let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// assert!(McPassage::new(&bound, &safe).paths(1).check().is_err());
    /// assert!(McPassage::new(&bound, &safe).dt(-1.0).check().is_err());
    /// ```
    pub fn check(&self) -> Result<(), McError> {
        self.check_read(&crate::dynamics::Dynamics::read(self.model))
    }

    /// [`McPassage::check`] of the model already read.
    fn check_read(&self, dynamics: &crate::dynamics::Dynamics) -> Result<(), McError> {
        crate::mc::refuse::refuse_periodic(self.model)?;
        let (dt, h) = (self.dt, self.horizon);
        if !(dt.is_finite() && dt > 0.0) {
            return Err(bad("dt", format!("must be a positive number, got {dt:?}")));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(bad(
                "horizon",
                format!("must be a positive number, got {h:?}"),
            ));
        }
        if h / dt > MAX_PASSAGE_STEPS {
            return Err(bad(
                "horizon",
                format!("{h} over dt = {dt} is more than {MAX_PASSAGE_STEPS:e} steps per path"),
            ));
        }
        let min = 2 * PASSAGE_LANES as u64;
        if !(min..=MAX_PASSAGE_PATHS).contains(&self.paths) {
            return Err(bad(
                "paths",
                format!(
                    "must lie in {min}..={MAX_PASSAGE_PATHS} (two batches of {PASSAGE_LANES} \
                     at least, for error bars), got {}",
                    self.paths
                ),
            ));
        }
        if self.times.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(bad("times", "must be finite and non-negative".into()));
        }
        if !self.safe.contains(self.start) {
            return Err(bad(
                "start",
                format!(
                    "({}, {}) is not inside the safe set `{}`",
                    self.start[0], self.start[1], self.safe.text
                ),
            ));
        }
        crate::mc::refuse::refuse_held_still(dynamics, self.start)
    }

    /// Runs the paths at dt and the bias estimate's at 2·dt; the statistics of the exit
    /// times.
    pub fn run(&self) -> Result<McPassageResult, McError> {
        // One reading of the model for the checks and the plan.
        let dynamics = crate::dynamics::Dynamics::read(self.model);
        self.check_read(&dynamics)?;
        let plan = self.plan(&dynamics)?;
        let batches = self.paths.div_ceil(PASSAGE_LANES as u64);
        let coarse_batches = (batches / 4).max(2).min(batches);
        let coarse_paths = (coarse_batches * PASSAGE_LANES as u64).min(self.paths);
        let mut runs = self
            .exit_times(
                &plan,
                &[(self.paths, self.dt), (coarse_paths, 2.0 * self.dt)],
            )
            .into_iter();
        let (fine, coarse) = (
            runs.next().unwrap_or_default(),
            runs.next().unwrap_or_default(),
        );
        let times = if !self.reliability {
            Vec::new()
        } else if self.times.is_empty() {
            (0..=100).map(|k| self.horizon * k as f64 / 100.0).collect()
        } else {
            self.times.clone()
        };
        let n_coarse = coarse.len();
        Ok(McPassageResult::new(
            summary::Run {
                exits: &fine,
                coarse: &coarse,
                coarse_fine: &fine[..n_coarse.min(fine.len())],
                horizon: self.horizon,
                dt: self.dt,
                seed: self.seed,
            },
            times,
        ))
    }

    /// The stationary run's scheme and impacts for the model.
    fn plan(&self, dynamics: &crate::dynamics::Dynamics) -> Result<Plan, McError> {
        let observables: Vec<_> = self
            .model
            .observables
            .iter()
            .map(|o| o.expr.clone())
            .collect();
        Plan::with_impacts(dynamics, &observables, SchemeChoice::Auto, walls(dynamics)?)
    }

    /// What each batch needs of the run.
    fn exits(&self) -> Exits<'_> {
        Exits {
            safe: self.safe,
            start: self.start,
            horizon: self.horizon,
            seed: self.seed,
            increments: self.increments,
        }
    }

    /// The exit times of the first `paths` paths at step `h` (`f64::INFINITY`: censored
    /// at the horizon; NaN: blew up), in path order, for each `(paths, h)` of `runs`: one
    /// task per thread, each running paths from a queue of each run in turn, so that all
    /// stay busy to the end of each (a path's exit time depends on its own stream alone,
    /// not on the task that runs it).
    fn exit_times(&self, plan: &Plan, runs: &[(u64, f64)]) -> Vec<Vec<f64>> {
        let queues: Vec<Queue> = runs
            .iter()
            .map(|&(paths, _)| Queue::new(0..paths))
            .collect();
        let done: Vec<Vec<Vec<(u64, f64)>>> = (0..rayon::current_num_threads())
            .into_par_iter()
            .map(|_| {
                let exits = self.exits();
                runs.iter()
                    .zip(&queues)
                    .map(|(&(_, h), q)| exits.drain(plan, q, h))
                    .collect()
            })
            .collect();
        let mut out: Vec<Vec<f64>> = runs
            .iter()
            .map(|&(paths, _)| vec![f64::NAN; paths as usize])
            .collect();
        for task in done {
            for (run, exits) in out.iter_mut().zip(task) {
                for (p, t) in exits {
                    run[p as usize] = t;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
