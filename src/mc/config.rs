//! The settings of a Monte Carlo run and their pre-flight: every setting checked and the
//! run's cost estimated before any simulation.

use serde::{Deserialize, Serialize};

use super::compile::scheme::{Plan, SchemeChoice, SchemeKind};
use super::error::McError;
use super::kernel::rng::Increments;
use super::record::accumulator::COUNT_COPIES;
use super::record::histogram::{Grid, MAX_BINS};
use crate::base::limits::MEMORY_LIMIT_BYTES;
use crate::model::BoundModel;
use crate::symbolic::Expr;
/// How long to run each trajectory before recording.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BurnIn {
    /// A multiple of the slowest decay time 1/λ of the drift linearised at the origin; where
    /// that does not decay (an unstable origin), of the decay time a pilot ensemble's
    /// moments show (`mc/relax.rs`).
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
    /// Levels whose up-crossing rates the run counts, by quantity name, each ascending
    /// (default none: no crossings counted).
    #[serde(default)]
    pub levels: Vec<(String, Vec<f64>)>,
    /// The grid of the impact-speed histograms at the walls (default none: no histogram;
    /// the impact count, mean speed and dissipated power are recorded whenever the model has
    /// a wall).
    #[serde(default)]
    pub impact_speeds: Option<Grid>,
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
            levels: Vec::new(),
            impact_speeds: None,
        }
    }
}

/// Fewest statistics batches the time-step bias is estimated from (its standard error
/// needs a spread).
pub const MIN_BIAS_PAIRS: u64 = 8;
/// Largest number of trajectories of one run (the blow-up list and the batch summaries
/// grow with it).
pub const MAX_TRAJECTORIES: u64 = 1 << 40;
/// Longest run [`McConfig::preflight`] accepts, in estimated seconds (24 h).
pub const TIME_LIMIT_SECONDS: f64 = 86_400.0;

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
    /// Estimated peak memory of the histograms, in bytes: every statistics batch's counts
    /// (kept until the reduction), each thread's accumulators, the result and its files.
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
pub(super) struct Resolved {
    pub(super) plan: Plan,
    /// The histogrammed quantities: the states (`true`), then the observables.
    pub(super) names: Vec<(String, bool)>,
    pub(super) steps_per_sample: u64,
    pub(super) burn_in_steps: u64,
    pub(super) batches: u64,
    pub(super) bias_batches: u64,
    pub(super) estimate: RunEstimate,
}

impl McConfig {
    /// Checks the configuration against `model` and estimates the run's cost, before any
    /// simulation (milliseconds: it compiles the model, nothing more). Refuses settings out
    /// of range (dt, a spacing that is not a whole number of steps, burn-in, trajectories,
    /// lanes, samples, grids) and runs estimated to take more than [`TIME_LIMIT_SECONDS`]
    /// or more memory than [`MEMORY_LIMIT_BYTES`], with the estimate in the error.
    /// [`Simulation::new`](super::Simulation::new) makes the same checks, with the limits applied to the smallest
    /// shard (one statistics batch), since it also sets up shards.
    ///
    /// ```
    /// use fpsolve::mc::{McConfig, McError};
    /// use fpsolve::model::{load_model, Override};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let file = load_model(path.as_ref()).unwrap();
    /// let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
    /// let estimate = McConfig::default().preflight(&model).unwrap();
    /// assert_eq!(estimate.batches, 32);
    /// let forever = McConfig { dt: 1e-300, spacing: 1e-299, ..McConfig::default() };
    /// assert!(matches!(forever.preflight(&model), Err(McError::TooLong { .. })));
    /// ```
    pub fn preflight(&self, model: &BoundModel) -> Result<RunEstimate, McError> {
        self.preflight_of(&crate::dynamics::Dynamics::read(model))
    }

    /// [`McConfig::preflight`] of a model already read.
    ///
    /// ```
    /// use fpsolve::mc::McConfig;
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let model = fpsolve::model::load_model(path.as_ref())?.bind(&[])?;
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&model);
    /// let config = McConfig::default();
    /// assert_eq!(config.preflight_of(&dynamics)?, config.preflight(&model)?);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// As [`McConfig::preflight`].
    pub fn preflight_of(
        &self,
        dynamics: &crate::dynamics::Dynamics,
    ) -> Result<RunEstimate, McError> {
        let estimate = self.estimate_of(dynamics)?;
        estimate.within_limits(1)?;
        Ok(estimate)
    }

    /// [`McConfig::preflight`] without the time and memory limits: every setting checked,
    /// the cost estimated, for a caller that splits the run ([`RunEstimate::within_limits`]).
    ///
    /// ```
    /// use fpsolve::mc::{McConfig};
    /// use fpsolve::model::{load_model, Override};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let file = load_model(path.as_ref()).unwrap();
    /// let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
    /// let big = McConfig { trajectories: 1 << 30, ..McConfig::default() };
    /// let estimate = big.estimate(&model).unwrap();
    /// assert!(estimate.within_limits(1).is_err());
    /// assert!(estimate.within_limits(estimate.batches).is_ok());
    /// ```
    pub fn estimate(&self, model: &BoundModel) -> Result<RunEstimate, McError> {
        self.estimate_of(&crate::dynamics::Dynamics::read(model))
    }

    /// [`McConfig::estimate`] of a model already read.
    ///
    /// # Errors
    /// As [`McConfig::estimate`].
    pub fn estimate_of(
        &self,
        dynamics: &crate::dynamics::Dynamics,
    ) -> Result<RunEstimate, McError> {
        let walls = super::compile::scheme::walls(dynamics)?;
        Ok(self
            .resolve_with(dynamics.model(), dynamics, walls)?
            .estimate)
    }

    /// [`McConfig::resolve`] of `model` read as `dynamics`, with the impact laws `specs` (its
    /// own, or others in their place).
    pub(super) fn resolve_with(
        &self,
        model: &BoundModel,
        dynamics: &crate::dynamics::Dynamics,
        specs: Vec<crate::dynamics::Barrier>,
    ) -> Result<Resolved, McError> {
        // No stationary law to sample: refused before anything else (issue 9, item 13), by
        // the pre-flight as by `Simulation::new`.
        crate::dynamics::check_with_drift(model, dynamics.ito_drift().ok())?;
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
        let periodic = model
            .periodic()
            .map(|p| model.states()[p.state].to_string());
        for (q, levels) in &self.levels {
            if periodic.as_ref() == Some(q) {
                return Err(bad(
                    "levels",
                    format!("`{q}` is periodic; its crossings are not counted"),
                ));
            }
            if !names.iter().any(|(n, _)| n == q) {
                return Err(bad(
                    "levels",
                    format!("`{q}` is neither a state nor an observable"),
                ));
            }
            let ascending = levels.windows(2).all(|w| w[0] < w[1]);
            if levels.is_empty() || !ascending || levels.iter().any(|u| !u.is_finite()) {
                return Err(bad(
                    "levels",
                    format!("`{q}`: need finite levels in ascending order, at least one"),
                ));
            }
        }
        if let Some(g) = &self.impact_speeds {
            if !g.well_formed() || g.bins > MAX_BINS {
                return Err(bad(
                    "impact_speeds",
                    format!("need finite lo < hi and 1..={MAX_BINS} bins"),
                ));
            }
        }
        let given = |n: &str| self.grids.iter().any(|(g, _)| g == n);
        if !(self.bias_fraction.is_finite() && (0.0..=1.0).contains(&self.bias_fraction)) {
            return Err(bad(
                "bias_fraction",
                format!("must lie in [0, 1], got {:?}", self.bias_fraction),
            ));
        }
        let observables: Vec<Expr> = model.observables.iter().map(|o| o.expr.clone()).collect();
        let plan = Plan::with_impacts(dynamics, &observables, self.scheme, specs)?;
        // A step the drift makes unstable blows every trajectory up, in a run that looks
        // like a hang (c = 1e6 at dt = 0.01): refused with the largest stable step.
        let states = dynamics.states();
        if let Some(limit) = plan.step_limit([&states[0], &states[1]], 0.0) {
            if dt > limit.largest_dt {
                return Err(McError::UnstableStep { dt, limit });
            }
        }
        let burn_in = match self.burn_in {
            BurnIn::Time(t) if t.is_finite() && t >= 0.0 => t,
            BurnIn::DecayTimes(k) if k.is_finite() && k >= 0.0 => {
                let rate = plan.slowest_decay_rate();
                if rate.is_finite() && rate > 0.0 {
                    k / rate
                } else {
                    // No decay at the origin: a pilot ensemble's relaxation.
                    super::relax::pilot_burn_in(
                        model,
                        plan.initial_spread(),
                        dt,
                        self.seed,
                        k,
                        rate,
                    )?
                }
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
        // Memory, per bin: every batch's counts are kept until the reduction (8 bytes a
        // batch); each thread holds a part's accumulator (COUNT_COPIES interleaved copies of
        // the counts), its finished counts and those of a sibling part waiting for the rest
        // of its batch; the result and its files take 24 words more (density, stderr, their
        // time-step biases, centres, the JSON and CSV text). Peak RSS measured on 2 threads
        // (`simulate vibro_duffing.sde --grid y=0:8:N`): 391 bytes a bin with 40 batches
        // (N = 10⁵ to 10⁶; 600 estimated), 216 with 4 batches (N = 10⁷, 2.19 GB; 312).
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
            + threads as f64
                * ((COUNT_COPIES + 2) as f64 * per_batch
                    + 8.0 * lanes * (20.0 + 6.0 * quantities as f64))
            + 24.0 * 8.0 * bins;
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
pub(super) const PILOT_SAMPLES: u64 = 500;
/// Statistics batches of the pilot run.
pub(super) const PILOT_BATCHES: u64 = 2;
/// Mixed into the seed so the pilot's trajectories are not the run's first ones.
pub(super) const PILOT_SALT: u64 = 0x5049_4C4F_545F_5255;

pub(super) fn bad(name: &'static str, reason: String) -> McError {
    McError::BadSetting { name, reason }
}
