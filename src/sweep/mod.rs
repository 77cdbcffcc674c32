//! Parameter sweeps: one model solved at every point of a grid of parameter values by one or
//! several methods, with the moments and tail probabilities of every state and observable at
//! each point (how a response statistic changes with, say, the parametric-noise strength ε,
//! and where the closure departs from the grid solution). It is an application of the
//! pipeline beside the job: it solves through the front door ([`crate::solve::Problem`]) and
//! hands its tables and figures to the report stage.
//!
//! A sweep is described by `--set` arguments ([`SweepSpec::parse`], each read by [`SetArg`]): a range
//! `name=lo:hi:count`, a list `name=v1,v2,...`, or a plain `name=expr` that stays fixed. The
//! points are the Cartesian product of the ranged and listed parameters (one or two of them).
//! [`Sweep::check`] refuses, before any work, a method that does not apply to the model;
//! [`Sweep::run`] first checks every point for a stationary density (as a single run checks
//! its parameters) and records a point without one as [`PointOutcome::Refused`], solved by no
//! method, then solves every other point by every method in parallel (EPC by its ladder of degrees, the
//! others through [`crate::solve::Problem`]) and keeps what fails next to the rest, each
//! method's failure at a point a typed [`PointFailure`] in that method's [`MethodOutcome`];
//! [`SweepResult::write`] writes `sweep.csv`, `sweep.json` and figures of the statistics
//! against the first swept parameter.
//!
//! Each point is solved from scratch (EPC: Gaussian closure, degree 2, then the target
//! degree), and is not continued from its neighbour: measured (`perf record`) on the
//! 100-point ε sweep of the paper's case 1, the ladder's solves are 18 % of a sweep's CPU
//! time, of which the normalisation of the density (which a warm start does not shorten) is
//! 14.5 %, the rest of the time being the moments and PDF curves; a warm start could save at
//! most the remaining 4 % (closure, assembly, Newton), while it would make a point depend
//! on its neighbours. Solved from scratch, a
//! point's result is the same as `fpsolve solve` at those values, whatever the sweep's order,
//! spacing, thread count or sharding, and the points run in parallel. A point computes only
//! what the sweep reports: the target degree's moments and PDF curves (on the grid common to
//! both degrees, as the main job tabulates them), not the degree-2 curves and moments.
//!
//! A sweep runs in parts on several machines with [`Sweep::run_shard`] (consecutive blocks
//! of points, `fpsolve sweep --shard K/N`), merged by [`merge_sweep_shards`] (`fpsolve
//! merge`) into the `sweep.csv` and `sweep.json` of one run.
//!
//! ```
//! use fpsolve::model::parse_model;
//! use fpsolve::solve::MethodName;
//! use fpsolve::sweep::{PointOutcome, Sweep, SweepSpec};
//!
//! let model = parse_model(
//!     "model linear
//! param c = 0.1, k = 1, K = 1/(2*pi)
//! state z, v
//! drift z: v
//! drift v: -c*v - k*z
//! noise xi: intensity 2*pi*K
//! diffusion v: xi
//! ",
//!     None,
//! )?;
//! let spec = SweepSpec::parse(&["c=0.1:0.2:2".to_string(), "k=2".to_string()])?;
//! let result = Sweep::new(&model, &spec).degree(2).run();
//! assert_eq!(result.points.len(), 2);
//! // The exact stationary variance of z is πK/(ck) = 1/(2ck).
//! for point in &result.points {
//!     let Some(PointOutcome::Converged(solution)) = point.outcome(MethodName::Epc) else {
//!         panic!("failed")
//!     };
//!     let z = &solution.stats[0];
//!     let exact = 1.0 / (2.0 * point.values[0] * 2.0);
//!     assert!((z.moments.variance - exact).abs() < 1e-4 * exact);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod admission;
mod frontier;
mod method;
mod outcome;
mod point;
mod report;
mod run;
mod shard;
mod spec;
mod thresholds;

pub use crate::solve::{EpcFigures, EpcNormalisation, SolverFigures};
pub use method::MethodRefusal;
pub use outcome::{
    MethodOutcome, PointFailure, PointOutcome, PointRefusal, PointSolution, PointStats, SweepPoint,
    SweepResult, TailThresholds,
};
pub use run::Sweep;
pub use shard::{
    merge_sweep_shards, MergedSweep, ShardDifference, SweepIdentity, SweepShard, SweepShardError,
};
pub use spec::{SetArg, SweepError, SweepSpec, SweptParameter};

/// Most parameters a sweep may vary at once (a table and line figures stay readable).
pub const MAX_SWEPT: usize = 2;
/// Most points a sweep may have: a typo like `eps=0:1:10000000` is refused instead of
/// allocating and solving for hours.
pub const MAX_POINTS: usize = 10_000;
/// Tail thresholds are these multiples of a quantity's root mean square at the first point.
pub const TAIL_MULTIPLES: [f64; 3] = [2.0, 3.0, 4.0];

#[cfg(test)]
mod tests;
