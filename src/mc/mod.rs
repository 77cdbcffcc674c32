//! Monte Carlo simulation of a bound model: the reference the EPC solution is checked against.
//!
//! Trajectories start from the stationary Gaussian of the drift linearised at the origin
//! (folded onto the barrier's side, or into the strip between two walls) and are integrated with a scheme matching the model (see
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
//! use fpsolve::mc::{McConfig, Simulation};
//! use fpsolve::model::{load_model, Override};
//! // The bundled linear oscillator z'' + c z' + k z = ξ with c = 0.5: Var z = πK/(ck) = 1.
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
//! let file = load_model(path.as_ref()).unwrap();
//! let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
//! let config = McConfig { trajectories: 256, samples: 200, seed: 1, ..McConfig::default() };
//! let result = Simulation::new(&model, &config).unwrap().run().unwrap();
//! let var = result.quantity("z").unwrap().moments.variance;
//! assert!((var.value - 1.0).abs() < 5.0 * var.stderr + 0.02);
//! ```

// Lane loops index several structure-of-arrays columns in lockstep; iterator zips of four
// or five slices would hide that.
#![allow(clippy::needless_range_loop)]

mod compile;
mod config;
mod error;
mod exact;
mod kernel;
mod passage;
mod record;
#[cfg(any(test, feature = "test-support"))]
#[doc(hidden)]
pub mod reference;
mod refuse;
mod relax;
mod settings;
mod shard;
mod simulation;
mod stats;
mod step;
mod transient;

#[cfg(test)]
pub(crate) mod strip_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod trust_tests;

pub use compile::scheme::{Evaluator, SchemeChoice, SchemeKind};
pub use compile::step_limit::{StepLimit, STABLE_RATE_TIMES_DT};
pub(crate) use config::MAX_LANES;
pub use config::{
    BurnIn, McConfig, RunEstimate, MAX_TRAJECTORIES, MIN_BIAS_PAIRS, TIME_LIMIT_SECONDS,
};
pub use error::{BarrierLayout, DigestPart, McError, ShardDefect};
pub use kernel::rng::Increments;
pub use passage::{
    McPassage, McPassageResult, PassageBias, PassageEstimate, MAX_PASSAGE_PATHS, MAX_PASSAGE_STEPS,
    PASSAGE_LANES,
};
pub use record::batch::BlowUp;
pub use record::histogram::{
    Grid, NamedGrid, NamedGridError, QuantityHistogram, TimeStepBias, MAX_BINS,
};
pub use record::sample::LastState;
pub use settings::{BarrierSetting, ParamValue, PeriodicSetting, QuantitySpec, RunSettings};
pub use shard::digest::ShardDigest;
pub use shard::index::Shard;
pub use shard::part::{merge_named, merge_shards, ShardOutput};
pub use simulation::Simulation;
pub use stats::impacts::ImpactStats;
pub use stats::reliability::{CrossingRates, SpeedDensity, WallStats};
pub use stats::result::McResult;
pub use stats::verdict::{
    BlowUps, Drift, McWarning, Moment, Stationarity, Statistic, Undetermined, BLOWUP_TOLERANCE,
    MIN_STATIONARITY_BATCHES, OUTSIDE_GRID_TOLERANCE,
};
pub use transient::{
    McDensity, McPeriodic, McPeriodicPilot, McPeriodicReport, McPeriodicState, McSnapshot,
    McStateMoments, McTransient, McTransientError, McTransientHistory, McTransientSettings,
    MAX_TRANSIENT_STEPS, MAX_TRANSIENT_TRAJECTORIES, RECORDED_PERIODS, TRANSIENT_LANES, WALL_SDS,
};
