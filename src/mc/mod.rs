//! Monte Carlo simulation of a bound model: the reference the EPC solution is checked against.
//!
//! Trajectories start from the stationary Gaussian of the drift linearised at the origin
//! (folded onto the barrier's side) and are integrated with a scheme matching the model (see
//! [`SchemeKind`]), impacts handled as events, and after a burn-in each trajectory's states
//! and observables are sampled at a fixed spacing into streaming histograms on fixed grids.
//! Trajectories run in statistics batches of [`McConfig::lanes`] (structure-of-arrays, one
//! random stream per trajectory); batches run in parallel and are reduced in batch order, so
//! a seed gives bit-identical results whatever the number of threads, and a run split into
//! [`Shard`]s merges ([`merge_shards`]) to exactly the unsplit result.
//!
//! Trust is part of the result: [`McConfig::preflight`] checks settings and refuses runs that
//! cannot finish before any work; every statistic carries its standard error and a
//! [`TimeStepBias`] (Richardson, from a quarter of the batches run again at 2·dt); a finished
//! [`McResult`] carries a [`Stationarity`] verdict (first vs last quarter of the recording)
//! and a [`BlowUps`] verdict, and [`McResult::verdict`] turns a failed one into an error while
//! the histograms stay available to be written, flagged.
//!
//! ```
//! use fpsolve::mc::{reference, McConfig, Simulation};
//! // A linear oscillator z'' + c z' + k z = ξ: Var z = S/(2ck).
//! let model = reference::linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
//! let config = McConfig { trajectories: 256, samples: 200, seed: 1, ..McConfig::default() };
//! let result = Simulation::new(&model, &config).unwrap().run().unwrap();
//! let var = result.quantity("z").unwrap().variance;
//! assert!((var.value - 1.0).abs() < 5.0 * var.stderr + 0.02);
//! ```

// Lane loops index several structure-of-arrays columns in lockstep; iterator zips of four
// or five slices would hide that.
#![allow(clippy::needless_range_loop)]

mod ensemble;
mod error;
mod eval;
mod histogram;
mod impact;
pub mod reference;
mod rng;
mod scheme;
mod shard;
mod verdict;

pub use ensemble::{
    BlowUp, ImpactStats, LastState, McResult, ParamValue, QuantitySpec, RunSettings,
};
pub use error::{McError, ShardDefect};
pub use histogram::{Estimate, Grid, NamedGrid, NamedGridError, QuantityStats, TimeStepBias};
pub use rng::Increments;
pub use scheme::{SchemeChoice, SchemeKind};
pub use shard::{merge_named, merge_shards, Shard, ShardOutput};
pub use verdict::{
    t_critical, BlowUps, Drift, McWarning, Moment, Stationarity, Statistic, Undetermined,
    BLOWUP_TOLERANCE, MIN_STATIONARITY_BATCHES,
};

use serde::{Deserialize, Serialize};

use crate::model::BoundModel;
use ensemble::{finalize_run, run_batches};
use scheme::Plan;

/// How long to run each trajectory before recording.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BurnIn {
    /// A multiple of the slowest decay time 1/λ of the drift linearised at the origin.
    DecayTimes(f64),
    /// A fixed time.
    Time(f64),
}

/// Settings of a Monte Carlo run. Start from [`McConfig::default`] and change fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct McConfig {
    /// Time step (default 0.01).
    pub dt: f64,
    /// Time between recorded samples, a whole number of steps (default 0.1).
    pub spacing: f64,
    /// Number of trajectories, rounded up to whole statistics batches (default 4096). Error
    /// bars come from the spread over batches: at least two are required, ~30 or more give
    /// trustworthy ones.
    pub trajectories: u64,
    /// Samples recorded per trajectory (default 1000).
    pub samples: u64,
    /// Burn-in before the first sample (default: 10 decay times).
    pub burn_in: BurnIn,
    /// Seed of all random streams (default 0).
    pub seed: u64,
    /// Trajectories per statistics batch, run together structure-of-arrays (default 128, the
    /// compiled tape's block length).
    pub lanes: usize,
    /// Bins of the grids chosen automatically (default 100).
    pub bins: usize,
    /// Histogram grids by quantity name; the others are chosen from a short pilot run
    /// (mean ± 6 standard deviations, cut at 0 for quantities the pilot never saw negative).
    pub grids: Vec<(String, Grid)>,
    /// Distribution of the noise increments (default three-point, see [`Increments`]).
    pub increments: Increments,
    /// Scheme selection (default automatic).
    pub scheme: SchemeChoice,
    /// Fraction of the statistics batches run a second time at 2·dt for the time-step bias
    /// estimate (default 0.25, at least [`MIN_BIAS_PAIRS`] batches or all when there are
    /// fewer; 0 turns the estimate off). At the default spacing (an even number of steps)
    /// a coarse batch costs half a fine one: 12.5 % extra for the default 32 batches.
    pub bias_fraction: f64,
}

impl Default for McConfig {
    fn default() -> McConfig {
        McConfig {
            dt: 0.01,
            spacing: 0.1,
            trajectories: 4096,
            samples: 1000,
            burn_in: BurnIn::DecayTimes(10.0),
            seed: 0,
            lanes: 128,
            bins: 100,
            grids: Vec::new(),
            increments: Increments::default(),
            scheme: SchemeChoice::default(),
            bias_fraction: 0.25,
        }
    }
}

/// Fewest statistics batches the time-step bias is estimated from (its standard error
/// needs a spread).
pub const MIN_BIAS_PAIRS: u64 = 8;
/// Largest number of bins of one histogram grid.
pub const MAX_BINS: usize = 10_000_000;
/// Largest number of trajectories of one run (the blow-up list and the batch summaries
/// grow with it).
pub const MAX_TRAJECTORIES: u64 = 1 << 40;
/// Longest run [`McConfig::preflight`] accepts, in estimated seconds (24 h).
pub const TIME_LIMIT_SECONDS: f64 = 86_400.0;
/// Most memory [`McConfig::preflight`] accepts for the histograms, in bytes (4 GiB).
pub const MEMORY_LIMIT_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;

/// What a run will cost, estimated before it starts by [`McConfig::preflight`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunEstimate {
    /// The scheme that will run.
    pub scheme: SchemeKind,
    /// Statistics batches (trajectories rounded up to whole batches of `lanes`).
    pub batches: u64,
    /// Batches run again at 2·dt for the bias estimate.
    pub bias_batches: u64,
    /// Steps of the burn-in.
    pub burn_in_steps: f64,
    /// Trajectory steps in all: pilot, main run and the 2·dt run.
    pub steps: f64,
    /// Estimated wall time in seconds, from a conservative throughput
    /// ([`SchemeKind::conservative_steps_per_second`]) on `threads` threads.
    pub seconds: f64,
    /// Threads assumed.
    pub threads: usize,
    /// Estimated memory of the histograms (kept per statistics batch until the merge), in
    /// bytes.
    pub memory_bytes: f64,
    /// Trajectory steps of the pilot run (paid by every shard).
    pub pilot_steps: f64,
    /// The throughput assumed, steps per second per thread.
    pub rate: f64,
    /// Bytes of one statistics batch's histograms.
    pub batch_bytes: f64,
    /// Histogram bins over all quantities.
    pub bins: f64,
}

impl RunEstimate {
    /// Checks that one of `shards` equal shards of the run (1: the whole run) fits
    /// [`TIME_LIMIT_SECONDS`] and [`MEMORY_LIMIT_BYTES`]; the error carries the estimate.
    pub fn within_limits(&self, shards: u64) -> Result<(), McError> {
        let shards = shards.clamp(1, self.batches.max(1));
        let share = 1.0 / shards as f64;
        let steps = (self.steps - self.pilot_steps) * share + self.pilot_steps;
        let seconds = steps / (self.rate * self.threads as f64);
        let kept = ((self.batches + self.bias_batches) as f64 * share).ceil();
        let memory = self.memory_bytes
            - self.batch_bytes * ((self.batches + self.bias_batches) as f64 - kept);
        if memory.is_nan() || memory > MEMORY_LIMIT_BYTES {
            return Err(McError::TooMuchMemory {
                bytes: memory,
                limit_bytes: MEMORY_LIMIT_BYTES,
                bins: self.bins,
                shards,
            });
        }
        if seconds.is_nan() || seconds > TIME_LIMIT_SECONDS {
            return Err(McError::TooLong {
                seconds,
                limit_seconds: TIME_LIMIT_SECONDS,
                steps,
                rate: self.rate,
                threads: self.threads,
                shards,
            });
        }
        Ok(())
    }
}

/// The checked numbers a run derives from its configuration.
struct Resolved {
    plan: Plan,
    /// The histogrammed quantities: the states (`true`), then the observables.
    names: Vec<(String, bool)>,
    steps_per_sample: u64,
    burn_in_steps: u64,
    batches: u64,
    bias_batches: u64,
    estimate: RunEstimate,
}

impl McConfig {
    /// Checks the configuration against `model` and estimates the run's cost, before any
    /// simulation (milliseconds: it compiles the model, nothing more). Refuses settings out
    /// of range (dt, a spacing that is not a whole number of steps, burn-in, trajectories,
    /// lanes, samples, grids) and runs estimated to take more than [`TIME_LIMIT_SECONDS`]
    /// or more memory than [`MEMORY_LIMIT_BYTES`], with the estimate in the error.
    /// [`Simulation::new`] makes the same checks, with the limits applied to the smallest
    /// shard (one statistics batch), since it also sets up shards.
    ///
    /// ```
    /// use fpsolve::mc::{reference, McConfig, McError};
    /// let model = reference::linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
    /// let estimate = McConfig::default().preflight(&model).unwrap();
    /// assert_eq!(estimate.batches, 32);
    /// let forever = McConfig { dt: 1e-300, spacing: 1e-299, ..McConfig::default() };
    /// assert!(matches!(forever.preflight(&model), Err(McError::TooLong { .. })));
    /// ```
    pub fn preflight(&self, model: &BoundModel) -> Result<RunEstimate, McError> {
        let estimate = self.estimate(model)?;
        estimate.within_limits(1)?;
        Ok(estimate)
    }

    /// [`McConfig::preflight`] without the time and memory limits: every setting checked,
    /// the cost estimated, for a caller that splits the run ([`RunEstimate::within_limits`]).
    ///
    /// ```
    /// use fpsolve::mc::{reference, McConfig};
    /// let model = reference::linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
    /// let big = McConfig { trajectories: 1 << 30, ..McConfig::default() };
    /// let estimate = big.estimate(&model).unwrap();
    /// assert!(estimate.within_limits(1).is_err());
    /// assert!(estimate.within_limits(estimate.batches).is_ok());
    /// ```
    pub fn estimate(&self, model: &BoundModel) -> Result<RunEstimate, McError> {
        Ok(self.resolve(model)?.estimate)
    }

    fn resolve(&self, model: &BoundModel) -> Result<Resolved, McError> {
        // No stationary law to sample: refused before anything else (issue 9, item 13), by
        // the pre-flight as by `Simulation::new`.
        crate::physics::check(model)?;
        let dt = self.dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(bad("dt", format!("must be a positive number, got {dt:?}")));
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return Err(bad(
                "spacing",
                format!("must be a positive number, got {:?}", self.spacing),
            ));
        }
        let ratio = self.spacing / dt;
        let steps_per_sample = ratio.round();
        if !(steps_per_sample >= 1.0 && (ratio - steps_per_sample).abs() <= 1e-6 * ratio) {
            return Err(bad(
                "spacing",
                format!(
                    "must be a positive whole number of steps dt = {dt:?}, got {:?}",
                    self.spacing
                ),
            ));
        }
        if self.lanes == 0 || self.lanes > MAX_LANES {
            return Err(bad(
                "lanes",
                format!("must lie in 1..={MAX_LANES}, got {}", self.lanes),
            ));
        }
        if self.trajectories > MAX_TRAJECTORIES {
            return Err(bad(
                "trajectories",
                format!(
                    "at most {MAX_TRAJECTORIES} in one run (split larger runs into shards), got {}",
                    self.trajectories
                ),
            ));
        }
        let batches = self.trajectories.div_ceil(self.lanes as u64);
        if batches < 2 {
            return Err(bad(
                "trajectories",
                format!(
                    "need at least two statistics batches of {} for error bars, got {}",
                    self.lanes, self.trajectories
                ),
            ));
        }
        if self.samples == 0 {
            return Err(bad("samples", "must be at least 1".into()));
        }
        if self.bins == 0 || self.bins > MAX_BINS {
            return Err(bad(
                "bins",
                format!("must lie in 1..={MAX_BINS}, got {}", self.bins),
            ));
        }
        for (name, g) in &self.grids {
            if !g.well_formed() {
                return Err(bad(
                    "grid",
                    format!("`{name}`: need finite lo < hi and bins ≥ 1"),
                ));
            }
            if g.bins > MAX_BINS {
                return Err(bad(
                    "grid",
                    format!("`{name}`: {} bins, at most {MAX_BINS}", g.bins),
                ));
            }
        }
        let names: Vec<(String, bool)> = model
            .states
            .iter()
            .map(|s| (s.to_string(), true))
            .chain(
                model
                    .observables
                    .iter()
                    .map(|o| (o.name.to_string(), false)),
            )
            .collect();
        for (g, _) in &self.grids {
            if !names.iter().any(|(n, _)| n == g) {
                return Err(McError::UnknownQuantity { name: g.clone() });
            }
        }
        let given = |n: &str| self.grids.iter().any(|(g, _)| g == n);
        if !(self.bias_fraction.is_finite() && (0.0..=1.0).contains(&self.bias_fraction)) {
            return Err(bad(
                "bias_fraction",
                format!("must lie in [0, 1], got {:?}", self.bias_fraction),
            ));
        }
        let plan = Plan::new(model, self.scheme)?;
        let burn_in = match self.burn_in {
            BurnIn::Time(t) if t.is_finite() && t >= 0.0 => t,
            BurnIn::DecayTimes(k) if k.is_finite() && k >= 0.0 => {
                let rate = plan.slowest_decay_rate();
                if !(rate.is_finite() && rate > 0.0) {
                    return Err(McError::NoDecay { rate });
                }
                k / rate
            }
            other => {
                return Err(bad(
                    "burn_in",
                    format!("must be finite and ≥ 0, got {other:?}"),
                ))
            }
        };
        let burn_in_steps = (burn_in / dt).ceil();
        let bias_batches = if self.bias_fraction > 0.0 {
            ((self.bias_fraction * batches as f64).ceil() as u64)
                .max(MIN_BIAS_PAIRS)
                .min(batches)
        } else {
            0
        };
        // Cost: trajectory steps of the main run, the coarse run (half the steps when the
        // spacing is even) and the pilot.
        let lanes = self.lanes as f64;
        let per_trajectory = burn_in_steps + self.samples as f64 * steps_per_sample;
        let coarse_share = if (steps_per_sample as u64).is_multiple_of(2) {
            0.5
        } else {
            1.0
        };
        // The pilot runs when some quantity has no grid given (as `Simulation::new` decides).
        let pilot = if names.iter().any(|(n, _)| !given(n)) {
            PILOT_BATCHES as f64
                * lanes
                * (burn_in_steps + self.samples.min(PILOT_SAMPLES) as f64 * steps_per_sample)
        } else {
            0.0
        };
        let steps =
            lanes * per_trajectory * (batches as f64 + coarse_share * bias_batches as f64) + pilot;
        let threads = rayon::current_num_threads().max(1);
        let rate = plan.kind.conservative_steps_per_second();
        let seconds = steps / (rate * threads as f64);
        // Memory: every batch's histograms are kept until the reduction; each thread holds
        // one batch's accumulators.
        let quantities = names.len();
        let bins: f64 = names
            .iter()
            .map(|(name, _)| {
                self.grids
                    .iter()
                    .find(|(n, _)| n == name)
                    .map_or(self.bins, |(_, g)| g.bins) as f64
            })
            .sum();
        let per_batch = 8.0 * (bins + 24.0 * quantities as f64);
        let memory_bytes = per_batch * (batches + bias_batches) as f64
            + threads as f64 * (per_batch + 8.0 * lanes * (20.0 + 6.0 * quantities as f64))
            + 3.0 * 8.0 * bins;
        let estimate = RunEstimate {
            scheme: plan.kind,
            batches,
            bias_batches,
            burn_in_steps,
            steps,
            pilot_steps: pilot,
            rate,
            seconds,
            threads,
            memory_bytes,
            batch_bytes: per_batch,
            bins,
        };
        Ok(Resolved {
            plan,
            names,
            steps_per_sample: steps_per_sample as u64,
            burn_in_steps: burn_in_steps as u64,
            batches,
            bias_batches,
            estimate,
        })
    }
}

/// Largest number of trajectories per statistics batch ([`McConfig::lanes`]).
pub(crate) const MAX_LANES: usize = 1 << 16;

/// Samples per trajectory of the pilot run that chooses the automatic grids.
const PILOT_SAMPLES: u64 = 500;
/// Statistics batches of the pilot run.
const PILOT_BATCHES: u64 = 2;
/// Mixed into the seed so the pilot's trajectories are not the run's first ones.
const PILOT_SALT: u64 = 0x5049_4C4F_545F_5255;
/// Half-width of an automatic grid, in pilot standard deviations.
const GRID_HALF_WIDTH_SDS: f64 = 6.0;

/// A model compiled for simulation with its run settings resolved: ready to run whole or
/// in shards.
pub struct Simulation {
    plan: Plan,
    settings: RunSettings,
}

fn bad(name: &'static str, reason: String) -> McError {
    McError::BadSetting { name, reason }
}

impl Simulation {
    /// Compiles `model`, checks `config`, fixes the burn-in and the histogram grids (running
    /// the pilot if some grid is not given).
    pub fn new(model: &BoundModel, config: &McConfig) -> Result<Simulation, McError> {
        let Resolved {
            plan,
            names,
            steps_per_sample,
            burn_in_steps,
            batches,
            bias_batches,
            estimate,
        } = config.resolve(model)?;
        // The run may be split into as many shards as batches: the smallest shard must fit.
        estimate.within_limits(batches)?;
        let dt = config.dt;
        let placeholder = Grid::new(-1.0, 1.0, 1)?;
        let mut settings = RunSettings {
            model: model.name.clone(),
            params: model
                .params
                .iter()
                .map(|(n, v)| ParamValue {
                    name: n.to_string(),
                    value: *v,
                })
                .collect(),
            scheme: plan.kind,
            increments: config.increments,
            dt,
            steps_per_sample,
            burn_in_steps,
            samples_per_trajectory: config.samples,
            lanes: config.lanes,
            batches,
            seed: config.seed,
            has_barrier: model.impact.is_some(),
            quantities: names
                .iter()
                .map(|(n, s)| QuantitySpec {
                    name: n.clone(),
                    is_state: *s,
                    grid: config
                        .grids
                        .iter()
                        .find(|(g, _)| g == n)
                        .map_or(placeholder, |(_, g)| *g),
                })
                .collect(),
            bias_batches,
        };
        let given = |n: &str| config.grids.iter().any(|(g, _)| g == n);
        if settings.quantities.iter().any(|q| !given(&q.name)) {
            let pilot = RunSettings {
                seed: config.seed ^ PILOT_SALT,
                batches: PILOT_BATCHES,
                samples_per_trajectory: config.samples.min(PILOT_SAMPLES),
                bias_batches: 0,
                ..settings.clone()
            };
            let summaries = run_batches(&plan, &pilot, 0..PILOT_BATCHES, &|| {});
            let refs: Vec<_> = summaries.iter().collect();
            let res = finalize_run(&pilot, &refs, &[]).map_err(|_| McError::NoPilotRange {
                name: settings.quantities[0].name.clone(),
            })?;
            for (spec, stats) in settings.quantities.iter_mut().zip(&res.quantities) {
                if !given(&spec.name) {
                    spec.grid = auto_grid(stats, config.bins)?;
                }
            }
        }
        Ok(Simulation { plan, settings })
    }

    /// The resolved settings (scheme, burn-in, grids, …).
    pub fn settings(&self) -> &RunSettings {
        &self.settings
    }

    /// Runs the whole simulation: the statistics batches at dt, then the first
    /// `bias_batches` again at 2·dt for the time-step bias. Trajectories that blow up are
    /// listed in the result and left out; if all do, that is an error. A finished run is
    /// returned even when its verdict fails ([`McResult::verdict`]).
    pub fn run(&self) -> Result<McResult, McError> {
        self.run_with_progress(&|_, _| {})
    }

    /// [`Simulation::run`], calling `progress(done, total)` (in statistics batches, the
    /// coarse ones included) from the worker threads as batches finish.
    ///
    /// ```
    /// use std::sync::atomic::{AtomicU64, Ordering};
    /// use fpsolve::mc::{reference, McConfig, Simulation};
    /// let model = reference::linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
    /// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
    /// let sim = Simulation::new(&model, &config).unwrap();
    /// let seen = AtomicU64::new(0);
    /// sim.run_with_progress(&|_, _| { seen.fetch_add(1, Ordering::Relaxed); }).unwrap();
    /// // 4 batches, run again at 2·dt for the bias estimate (at least 8, here all 4).
    /// assert_eq!(seen.into_inner(), 4 + 4);
    /// ```
    pub fn run_with_progress(
        &self,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<McResult, McError> {
        let st = &self.settings;
        let total = st.batches + st.bias_batches;
        let done = std::sync::atomic::AtomicU64::new(0);
        let tick = || {
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(k, total);
        };
        let summaries = run_batches(&self.plan, st, 0..st.batches, &tick);
        let coarse = run_batches(&self.plan, &st.coarse(), 0..st.bias_batches, &tick);
        let refs: Vec<_> = summaries.iter().collect();
        let coarse_refs: Vec<_> = coarse.iter().collect();
        finalize_run(st, &refs, &coarse_refs)
    }

    /// Runs one shard of the simulation (its statistics batches, and those of them in the
    /// bias estimate's range again at 2·dt); see [`merge_shards`].
    pub fn run_shard(&self, shard: Shard) -> Result<ShardOutput, McError> {
        let st = &self.settings;
        if shard.count == 0 || shard.index >= shard.count || shard.count > st.batches {
            return Err(bad(
                "shard",
                format!(
                    "shard {} of {} does not fit a run of {} statistics batches",
                    shard.index.saturating_add(1),
                    shard.count,
                    st.batches
                ),
            ));
        }
        let range = shard.batch_range(st.batches);
        let coarse = range.start.min(st.bias_batches)..range.end.min(st.bias_batches);
        Ok(ShardOutput {
            settings: st.clone(),
            shard,
            batches: run_batches(&self.plan, st, range, &|| {}),
            coarse: run_batches(&self.plan, &st.coarse(), coarse, &|| {}),
        })
    }
}

/// A grid covering mean ± 6 sd of the pilot samples, one-sided where the pilot saw only
/// values of one sign (|z|, energies).
fn auto_grid(stats: &QuantityStats, bins: usize) -> Result<Grid, McError> {
    let (m, var) = (stats.mean.value, stats.variance.value);
    if stats.samples == 0 || !m.is_finite() || !var.is_finite() {
        return Err(McError::NoPilotRange {
            name: stats.name.clone(),
        });
    }
    let sd = var.max(0.0).sqrt();
    let half = if sd > 0.0 {
        GRID_HALF_WIDTH_SDS * sd
    } else {
        0.5 * m.abs().max(1.0)
    };
    let (mut lo, mut hi) = (m - half, m + half);
    if stats.min >= 0.0 && lo < 0.0 && hi > 0.0 {
        lo = 0.0;
    }
    if stats.max <= 0.0 && hi > 0.0 && lo < 0.0 {
        hi = 0.0;
    }
    Grid::new(lo, hi, bins)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::reference::{duffing, linear_oscillator, vibro_impact, VibroImpact};

    fn small(trajectories: u64) -> McConfig {
        McConfig {
            trajectories,
            lanes: 16,
            samples: 100,
            ..McConfig::default()
        }
    }

    #[test]
    fn blown_up_trajectories_are_reported_and_left_out() {
        // A softening spring, k z − z³: trajectories that cross |z| = 1 run off to infinity.
        let model = duffing(0.5, 1.0, -1.0, 0.12).bind(&[]).unwrap();
        let config = McConfig {
            grids: vec![
                ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
                ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ],
            ..small(64)
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let res = sim.run().unwrap();
        let total = sim.settings().trajectories();
        let lost = res.blowups.len() as u64;
        assert!(lost > 0 && lost < total, "{lost} of {total} blew up");
        assert_eq!(res.trajectories, total - lost);
        let mut seen = std::collections::HashSet::new();
        for b in &res.blowups {
            assert!(b.trajectory < total && seen.insert(b.trajectory));
            assert_eq!(b.params.len(), 4);
            if let Some(last) = &b.last_finite {
                assert!(last.step < b.step && last.state.iter().all(|s| s.is_finite()));
            }
        }
        let z = res.quantity("z").unwrap();
        assert!(z.mean.value.is_finite() && z.variance.value.is_finite());
        assert_eq!(z.samples, res.trajectories * 100);
        assert_eq!(z.invalid, 0);
    }

    #[test]
    fn a_run_where_every_trajectory_blows_up_is_an_error() {
        // Strong noise over a low barrier: every trajectory escapes to infinity.
        let model = duffing(0.5, 1.0, -1.0, 5.0).bind(&[]).unwrap();
        let config = McConfig {
            grids: vec![
                ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
                ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ],
            ..small(32)
        };
        let sim = Simulation::new(&model, &config).unwrap();
        assert_eq!(sim.run(), Err(McError::AllBlewUp { blowups: 32 }));
    }

    #[test]
    fn schemes_are_chosen_from_the_model_form() {
        let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&lin, &small(32)).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::MechanicalStrang);
        let general = McConfig {
            scheme: SchemeChoice::General,
            ..small(32)
        };
        let sim = Simulation::new(&lin, &general).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
        // Noise in the x-equation: not mechanical.
        let mut m = linear_oscillator(0.5, 1.0, 1.0);
        m.noise_matrix[0] = vec![crate::symbolic::Expr::num(0.1)];
        let sim = Simulation::new(&m.bind(&[]).unwrap(), &small(32)).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
        let order1 = McConfig {
            scheme: SchemeChoice::GeneralOrder1,
            ..small(32)
        };
        let sim = Simulation::new(&m.bind(&[]).unwrap(), &order1).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::Heun);
        m.interpretation = crate::model::Interpretation::Ito;
        let sim = Simulation::new(&m.bind(&[]).unwrap(), &order1).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::EulerMaruyama);
    }

    #[test]
    fn burn_in_is_ten_decay_times_of_the_linearisation() {
        // z'' + 0.4 z' + z: eigenvalues −0.2 ± i·0.98, decay time 5.
        let lin = linear_oscillator(0.4, 1.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&lin, &small(32)).unwrap();
        assert_eq!(sim.settings().burn_in_steps, 5000);
        // Overdamped z'' + 5 z' + 4 z: eigenvalues −1 and −4, the slow one decides.
        let od = linear_oscillator(5.0, 4.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&od, &small(32)).unwrap();
        assert_eq!(sim.settings().burn_in_steps, 1000);
        // No damping: no stationary law at all, refused before the burn-in is estimated.
        let free = linear_oscillator(0.0, 1.0, 1.0).bind(&[]).unwrap();
        assert!(matches!(
            Simulation::new(&free, &small(32)),
            Err(McError::Inadmissible(
                crate::physics::Inadmissible::NoDamping { .. }
            ))
        ));
    }

    #[test]
    fn automatic_grids_cover_the_pilot_and_fold_at_zero() {
        let p = VibroImpact {
            c: 0.5,
            k: 1.0,
            mu: 1.0,
            eps: 0.0,
            r: 0.9,
            big_k: 0.1,
        };
        let m = vibro_impact(p).bind(&[]).unwrap();
        let sim = Simulation::new(&m, &small(32)).unwrap();
        let q = &sim.settings().quantities;
        let names: Vec<&str> = q.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["z", "v", "y", "ydot"]);
        assert_eq!(q[2].grid.lo, 0.0, "y = |z| is never negative");
        assert!(q[0].grid.lo < -0.5 && q[0].grid.hi > 0.5);
        assert_eq!(q[0].grid.bins, 100);
    }

    #[test]
    fn bad_settings_are_errors() {
        let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
        let bad = |c: McConfig| Simulation::new(&lin, &c).err().unwrap();
        assert!(matches!(
            bad(McConfig {
                dt: 0.0,
                ..small(32)
            }),
            McError::BadSetting { name: "dt", .. }
        ));
        assert!(matches!(
            bad(McConfig {
                spacing: 0.015,
                ..small(32)
            }),
            McError::BadSetting {
                name: "spacing",
                ..
            }
        ));
        assert!(matches!(
            bad(small(16)),
            McError::BadSetting {
                name: "trajectories",
                ..
            }
        ));
        let unknown = McConfig {
            grids: vec![("w".into(), Grid::new(0.0, 1.0, 2).unwrap())],
            ..small(32)
        };
        assert!(matches!(bad(unknown), McError::UnknownQuantity { .. }));
    }

    #[test]
    fn a_delta_term_without_an_impact_law_is_an_error() {
        let p = VibroImpact {
            c: 0.5,
            k: 1.0,
            mu: 1.0,
            eps: 0.0,
            r: 0.9,
            big_k: 0.1,
        };
        let mut m = vibro_impact(p);
        m.impact = None;
        assert!(matches!(
            Simulation::new(&m.bind(&[]).unwrap(), &small(32)),
            Err(McError::DeltaWithoutImpact { .. })
        ));
    }

    /// `v' = −c v − k z + ξ₀ + σ v ξ₁` (independent sources of intensities s₀, s₁): the
    /// stationary E[v²] is s₀/(2c − s₁σ²) read as Itô and s₀/(2c − 2s₁σ²) read as
    /// Stratonovich (Wong–Zakai adds ½s₁σ²·v to the drift).
    fn velocity_noise(
        interpretation: crate::model::Interpretation,
        scheme: SchemeChoice,
        seed: u64,
    ) -> McResult {
        use crate::model::NoiseSource;
        use crate::symbolic::Expr;
        let mut m = linear_oscillator(0.5, 1.0, 1.0);
        m.noises.push(NoiseSource {
            name: "xi1".into(),
            intensity: Expr::num(1.0),
        });
        m.noise_matrix = [
            vec![Expr::num(0.0), Expr::num(0.0)],
            vec![Expr::num(1.0), Expr::num(0.5) * Expr::sym("v")],
        ];
        m.interpretation = interpretation;
        let config = McConfig {
            dt: 0.005,
            spacing: 0.5,
            trajectories: 512,
            lanes: 16,
            samples: 200,
            seed,
            scheme,
            grids: vec![
                ("z".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
                ("v".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
            ],
            ..McConfig::default()
        };
        Simulation::new(&m.bind(&[]).unwrap(), &config)
            .unwrap()
            .run()
            .unwrap()
    }

    #[test]
    fn ito_and_stratonovich_readings_reach_their_own_exact_variances() {
        use crate::model::Interpretation;
        for (interp, exact, scheme, kind) in [
            (
                Interpretation::Ito,
                1.0 / (1.0 - 0.25),
                SchemeChoice::GeneralOrder1,
                SchemeKind::EulerMaruyama,
            ),
            (
                Interpretation::Stratonovich,
                1.0 / (1.0 - 0.5),
                SchemeChoice::GeneralOrder1,
                SchemeKind::Heun,
            ),
            (
                Interpretation::Ito,
                1.0 / (1.0 - 0.25),
                SchemeChoice::Auto,
                SchemeKind::PlatenWeak2,
            ),
            (
                Interpretation::Stratonovich,
                1.0 / (1.0 - 0.5),
                SchemeChoice::Auto,
                SchemeKind::PlatenWeak2,
            ),
        ] {
            let res = velocity_noise(interp, scheme, 4);
            assert_eq!(res.settings.scheme, kind);
            let var = res.quantity("v").unwrap().variance;
            eprintln!("{interp:?}: {} ± {} (exact {exact})", var.value, var.stderr);
            assert!(
                (var.value - exact).abs() < 4.5 * var.stderr,
                "{interp:?}: {} ± {} vs {exact}",
                var.value,
                var.stderr
            );
        }
    }

    #[test]
    fn fully_correlated_sources_have_a_singular_square_root() {
        let l = scheme::psd_sqrt(&[vec![4.0, 2.0], vec![2.0, 1.0]]).unwrap();
        assert_eq!(l, vec![2.0, 0.0, 1.0, 0.0]);
        assert!(matches!(
            scheme::psd_sqrt(&[vec![1.0, 2.0], vec![2.0, 1.0]]),
            Err(McError::IntensityNotPsd { .. })
        ));
    }
}

#[cfg(test)]
mod trust_tests {
    use super::*;
    use crate::model::load_model;

    fn bundled(name: &str, set: &[(&str, f64)]) -> BoundModel {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(name);
        let overrides: Vec<crate::model::Override> = set
            .iter()
            .map(|(n, v)| crate::model::Override {
                name: n.to_string(),
                value: crate::symbolic::Expr::num(*v),
            })
            .collect();
        load_model(&path).unwrap().bind(&overrides).unwrap()
    }

    fn grids(names: &[&str], half: f64) -> Vec<(String, Grid)> {
        names
            .iter()
            .map(|n| (n.to_string(), Grid::new(-half, half, 20).unwrap()))
            .collect()
    }

    /// E[v²] of `cubic_damping_two_noises.sde` (exactly 1: Var v = 1, mean 0).
    fn cubic_second_moment(
        choice: SchemeChoice,
        dt: f64,
        bias_fraction: f64,
    ) -> (Estimate, McResult) {
        let model = bundled("cubic_damping_two_noises.sde", &[]);
        let config = McConfig {
            dt,
            spacing: 1.0,
            trajectories: 4096,
            lanes: 64,
            samples: 200,
            burn_in: BurnIn::Time(30.0),
            seed: 3,
            scheme: choice,
            grids: grids(&["z", "v", "y", "ydot"], 6.0),
            bias_fraction,
            ..McConfig::default()
        };
        let r = Simulation::new(&model, &config).unwrap().run().unwrap();
        let v = r.quantity("v").unwrap();
        let m2 = Estimate {
            value: v.variance.value + v.mean.value * v.mean.value,
            stderr: v.variance.stderr,
        };
        (m2, r)
    }

    /// `v' = −v − z + ξ₀ + ½ v ξ₁` read as Itô: E[v²] = 1/(2 − ¼) exactly.
    fn multiplicative_ito() -> BoundModel {
        use crate::model::{Interpretation, NoiseSource};
        use crate::symbolic::Expr;
        let mut m = reference::linear_oscillator(1.0, 1.0, 1.0);
        m.noises.push(NoiseSource {
            name: "xi1".into(),
            intensity: Expr::num(1.0),
        });
        m.noise_matrix = [
            vec![Expr::num(0.0), Expr::num(0.0)],
            vec![Expr::num(1.0), Expr::num(0.5) * Expr::sym("v")],
        ];
        m.interpretation = Interpretation::Ito;
        m.bind(&[]).unwrap()
    }

    fn linear_variance(choice: SchemeChoice, dt: f64, bias_fraction: f64) -> McResult {
        let config = McConfig {
            dt,
            spacing: 0.8,
            trajectories: 4096,
            lanes: 64,
            samples: 200,
            burn_in: BurnIn::Time(20.0),
            seed: 3,
            scheme: choice,
            grids: grids(&["z", "v"], 8.0),
            bias_fraction,
            ..McConfig::default()
        };
        Simulation::new(&multiplicative_ito(), &config)
            .unwrap()
            .run()
            .unwrap()
    }

    /// The measured weak order log2(bias(2h)/bias(h)) and its standard error.
    fn order(coarse: Estimate, fine: Estimate, exact: f64) -> (f64, f64) {
        let (b2, b1) = (coarse.value - exact, fine.value - exact);
        let p = (b2 / b1).log2();
        let se = ((coarse.stderr / b2).powi(2) + (fine.stderr / b1).powi(2)).sqrt()
            / std::f64::consts::LN_2;
        (p, se)
    }

    #[test]
    fn the_general_path_has_weak_order_two() {
        // Bundled model with an exact stationary law, two sources, one multiplicative in v,
        // read as Stratonovich (so the Wong–Zakai drift is exercised): E[v²] = 1.
        let (coarse, _) = cubic_second_moment(SchemeChoice::General, 0.25, 0.0);
        let (fine, res) = cubic_second_moment(SchemeChoice::General, 0.125, 0.0);
        assert_eq!(res.settings.scheme, SchemeKind::PlatenWeak2);
        let (p, se) = order(coarse, fine, 1.0);
        eprintln!(
            "Platen: E v² = {:.5} ± {:.5} (dt 0.25), {:.5} ± {:.5} (dt 0.125): order {p:.2} ± {se:.2}",
            coarse.value, coarse.stderr, fine.value, fine.stderr
        );
        assert!((1.4..2.6).contains(&p), "order {p} ± {se}");
        // The old scheme (Euler–Maruyama) on an Itô model with multiplicative noise: order 1.
        let exact = 1.0 / 1.75;
        let em = |dt| {
            let r = linear_variance(SchemeChoice::GeneralOrder1, dt, 0.0);
            assert_eq!(r.settings.scheme, SchemeKind::EulerMaruyama);
            r.quantity("v").unwrap().variance
        };
        let (p1, se1) = order(em(0.1), em(0.05), exact);
        eprintln!("Euler-Maruyama: order {p1:.2} ± {se1:.2}");
        assert!((0.8..1.45).contains(&p1), "order {p1} ± {se1}");
        // Platen's scheme on the same model at dt = 0.1, where Euler–Maruyama is 19 % off:
        // exact within the error bars.
        let pl = linear_variance(SchemeChoice::General, 0.1, 0.0);
        let var = pl.quantity("v").unwrap().variance;
        eprintln!(
            "Platen (Itô model) dt 0.1: {} ± {} vs {exact}",
            var.value, var.stderr
        );
        assert!((var.value - exact).abs() < 4.5 * var.stderr);
    }

    #[test]
    fn the_bias_estimate_covers_the_true_bias_of_euler_maruyama() {
        let exact = 1.0 / 1.75;
        let r = linear_variance(SchemeChoice::GeneralOrder1, 0.05, 0.25);
        let v = r.quantity("v").unwrap();
        let b = v.time_step_bias.as_ref().unwrap();
        let truth = v.variance.value - exact;
        eprintln!(
            "EM dt 0.05: Var v = {:.5} ± {:.5}, true bias {truth:.5}, estimate {:.5} ± {:.5} from {} pairs",
            v.variance.value, v.variance.stderr, b.variance.value, b.variance.stderr, b.pairs
        );
        assert_eq!((b.order, b.pairs, b.coarse_dt), (1, 16, 0.1));
        assert!(b.variance.resolved());
        // Richardson's own error is O(dt²) here (about a fifth of the bias at dt = 0.05).
        assert!(
            (b.variance.value - truth).abs() < 3.0 * b.variance.stderr + 0.3 * truth.abs(),
            "estimate {} ± {} vs true {truth}",
            b.variance.value,
            b.variance.stderr
        );
        assert!(r.warnings.iter().any(|w| matches!(
            w,
            McWarning::BiasExceedsError { quantity, statistic: Statistic::Variance, .. } if quantity == "v"
        )));
        // The weak order-2 scheme at dt = 0.01 on the bundled exact model: no resolved bias
        // of E[v²], and a bound below 1 %.
        let (m2, res) = cubic_second_moment(SchemeChoice::Auto, 0.01, 0.25);
        let b = res.quantity("v").unwrap().time_step_bias.clone().unwrap();
        eprintln!(
            "Platen dt 0.01: E v² = {:.5} ± {:.5}; bias of Var v {:.2e} ± {:.1e}; warnings {:?}",
            m2.value, m2.stderr, b.variance.value, b.variance.stderr, res.warnings
        );
        assert!((m2.value - 1.0).abs() < 4.5 * m2.stderr);
        assert!(b.variance.bound() < 0.01, "{:?}", b.variance);
        assert!(res.warnings.is_empty(), "{:?}", res.warnings);
    }

    fn vibro(set: &[(&str, f64)], burn_in: BurnIn, trajectories: u64, samples: u64) -> McResult {
        let model = bundled("vibro_duffing.sde", set);
        let config = McConfig {
            trajectories,
            lanes: 32,
            samples,
            burn_in,
            seed: 1,
            ..McConfig::default()
        };
        Simulation::new(&model, &config).unwrap().run().unwrap()
    }

    #[test]
    fn platen_runs_are_bit_identical_across_threads_and_shards() {
        // Two correlated sources, both multiplicative, and an impact law: every branch of
        // the general path (pair signs, supporting values, events) in one run.
        use crate::symbolic::Expr;
        let mut m = reference::vibro_impact(reference::VibroImpact {
            c: 0.3,
            k: 1.0,
            mu: 0.5,
            eps: 0.4,
            r: 0.7,
            big_k: 0.08,
        });
        m.noises.push(crate::model::NoiseSource {
            name: "eta".into(),
            intensity: Expr::num(0.05),
        });
        m.correlations.push(crate::model::Correlation {
            a: 0,
            b: 1,
            coefficient: Expr::num(0.4),
        });
        m.noise_matrix[0].push(Expr::num(0.0));
        m.noise_matrix[1].push(Expr::sym("v"));
        let model = m.bind(&[]).unwrap();
        let config = McConfig {
            trajectories: 8 * 16,
            lanes: 16,
            samples: 50,
            seed: 9,
            ..McConfig::default()
        };
        let sim = Simulation::new(&model, &config).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
        let run_with = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| sim.run().unwrap())
        };
        let one = run_with(1);
        assert_eq!(one, run_with(2));
        assert!(one.impacts.as_ref().unwrap().count > 0);
        let shards: Vec<ShardOutput> = (0..3)
            .map(|k| {
                let out = sim.run_shard(Shard::new(k, 3).unwrap()).unwrap();
                serde_json::from_str(&serde_json::to_string(&out).unwrap()).unwrap()
            })
            .collect();
        let merged = merge_shards(&shards).unwrap();
        assert_eq!(
            serde_json::to_string(&merged).unwrap(),
            serde_json::to_string(&one).unwrap()
        );
    }

    #[test]
    fn healthy_bundled_models_pass_the_stationarity_test() {
        let r = vibro(&[], BurnIn::DecayTimes(10.0), 1024, 400);
        eprintln!("vibro_duffing: {}", r.stationarity);
        assert!(matches!(r.stationarity, Stationarity::Stationary { .. }));
        assert_eq!(r.verdict(), Ok(()));
        let model = bundled("linear.sde", &[]);
        let config = McConfig {
            trajectories: 1024,
            lanes: 32,
            samples: 400,
            ..McConfig::default()
        };
        let r = Simulation::new(&model, &config).unwrap().run().unwrap();
        eprintln!("linear: {}", r.stationarity);
        assert!(matches!(r.stationarity, Stationarity::Stationary { .. }));
        assert_eq!(r.verdict(), Ok(()));
    }

    /// A test fixture from `tests/models/` (models the admissibility check accepts but whose
    /// Monte Carlo verdict must fail).
    fn fixture(name: &str, trajectories: u64, samples: u64, config: McConfig) -> McResult {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/models")
            .join(name);
        let model = load_model(&path).unwrap().bind(&[]).unwrap();
        let config = McConfig {
            trajectories,
            lanes: 32,
            samples,
            seed: 1,
            ..config
        };
        Simulation::new(&model, &config).unwrap().run().unwrap()
    }

    #[test]
    fn a_run_that_keeps_growing_is_not_stationary_and_keeps_its_histograms() {
        let r = fixture(
            "fading_damping.sde",
            1024,
            400,
            McConfig {
                burn_in: BurnIn::Time(50.0),
                ..McConfig::default()
            },
        );
        eprintln!("fading damping: {}", r.stationarity);
        let Stationarity::NotStationary { largest } = &r.stationarity else {
            panic!("{}", r.stationarity)
        };
        assert!(largest.t.abs() > largest.threshold);
        assert!(largest.last_quarter > largest.first_quarter);
        assert!(matches!(r.verdict(), Err(McError::NotStationary { .. })));
        // The histograms are there to be written, flagged.
        assert!(r.quantity("v").unwrap().samples > 0);
    }

    #[test]
    fn mass_blow_ups_fail_the_verdict() {
        // Escapes over the softening potential's barrier.
        let grid = Grid::new(-10.0, 10.0, 50).unwrap();
        let r = fixture(
            "softening_duffing.sde",
            256,
            200,
            McConfig {
                grids: vec![("z".into(), grid), ("v".into(), grid)],
                ..McConfig::default()
            },
        );
        eprintln!("softening Duffing: {}", r.blowup_verdict);
        let BlowUps::TooMany {
            count,
            trajectories,
        } = r.blowup_verdict
        else {
            panic!("{}", r.blowup_verdict)
        };
        assert_eq!(trajectories, 256);
        assert!(count > 100, "{count}");
        assert!(matches!(r.verdict(), Err(McError::TooManyBlowUps { .. })));
    }

    #[test]
    fn preflight_refuses_what_cannot_finish() {
        let model = bundled("vibro_duffing.sde", &[]);
        let ok = McConfig::default().preflight(&model).unwrap();
        eprintln!("default: {ok:?}");
        assert!(ok.seconds < 600.0 && ok.memory_bytes < 1e8);
        let long = |c: McConfig| match c.preflight(&model) {
            Err(McError::TooLong { seconds, .. }) => seconds,
            other => panic!("{other:?}"),
        };
        assert!(
            long(McConfig {
                dt: 1e-300,
                ..McConfig::default()
            }) > 1e290
        );
        assert!(
            long(McConfig {
                spacing: 1e6,
                ..McConfig::default()
            }) > 1e6
        );
        assert!(
            long(McConfig {
                burn_in: BurnIn::Time(1e300),
                ..McConfig::default()
            }) > 1e290
        );
        let setting = |c: McConfig| match c.preflight(&model) {
            Err(McError::BadSetting { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            setting(McConfig {
                trajectories: u64::MAX,
                ..McConfig::default()
            }),
            "trajectories"
        );
        let grid = |bins| McConfig {
            grids: vec![(
                "y".into(),
                Grid {
                    lo: 0.0,
                    hi: 8.0,
                    bins,
                },
            )],
            ..McConfig::default()
        };
        assert_eq!(setting(grid(4_294_967_297)), "grid");
        assert_eq!(setting(grid(100_000_000)), "grid");
        let big = McConfig {
            trajectories: 16384,
            ..grid(5_000_000)
        };
        assert!(matches!(
            big.preflight(&model),
            Err(McError::TooMuchMemory { .. })
        ));
        // Simulation::new makes the same checks before any work.
        assert!(matches!(
            Simulation::new(
                &model,
                &McConfig {
                    dt: 1e-300,
                    ..McConfig::default()
                }
            ),
            Err(McError::TooLong { .. })
        ));
        let message = long_message(&model);
        assert!(
            message.len() < 400 && message.contains("years"),
            "{message}"
        );
    }

    fn long_message(model: &BoundModel) -> String {
        McConfig {
            burn_in: BurnIn::Time(1e300),
            ..McConfig::default()
        }
        .preflight(model)
        .unwrap_err()
        .to_string()
    }
}
