//! The fully resolved settings of a run: everything its numbers depend on, as shard files
//! and `mc_summary.json` record them.

use serde::{Deserialize, Serialize};

use super::compile::scheme::Evaluator;

use super::compile::scheme::SchemeKind;
use super::exact;
use super::kernel::rng::Increments;
use super::record::histogram::Grid;

/// A parameter and the value a model was bound with, as runs and reports record it (in
/// `summary.json`, `mc_summary.json`, shard files and blow-up reports). The value is a JSON
/// number, which reads back to the same bits.
///
/// ```
/// use fpsolve::mc::ParamValue;
/// let p = ParamValue { name: "mu".into(), value: 0.1 };
/// let json = serde_json::to_string(&p).unwrap();
/// assert_eq!(json, r#"{"name":"mu","value":0.1}"#);
/// assert_eq!(serde_json::from_str::<ParamValue>(&json).unwrap(), p);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamValue {
    /// The parameter's name.
    pub name: String,
    /// Its value.
    #[serde(with = "exact::number")]
    pub value: f64,
}

/// An impact law as a run records it.
///
/// ```
/// use fpsolve::mc::BarrierSetting;
/// let b = BarrierSetting { state: "y".into(), at: -0.5, map: "-v".into(), above: true };
/// let json = serde_json::to_string(&b).unwrap();
/// assert_eq!(serde_json::from_str::<BarrierSetting>(&json).unwrap(), b);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BarrierSetting {
    /// The state that meets the barrier.
    pub state: String,
    /// Where the barrier is.
    #[serde(with = "exact::number")]
    pub at: f64,
    /// The post-impact value of the other state, printed.
    pub map: String,
    /// Whether trajectories start above the barrier (else below).
    pub above: bool,
}

/// A quantity a run histograms: a state or an observable, with its grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantitySpec {
    /// Its name.
    pub name: String,
    /// Whether it is a state (else an observable).
    pub is_state: bool,
    /// Its histogram grid.
    pub grid: Grid,
    /// Levels whose up-crossings the run counts, ascending (none: not counted).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<f64>,
}

/// The fully resolved settings of a run: everything its numbers depend on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSettings {
    /// The model's name.
    pub model: String,
    /// The parameter values the model was bound with.
    pub params: Vec<ParamValue>,
    /// The time-stepping scheme.
    pub scheme: SchemeKind,
    /// The noise increments' distribution.
    pub increments: Increments,
    /// Time step.
    #[serde(with = "exact::number")]
    pub dt: f64,
    /// Steps between recorded samples.
    pub steps_per_sample: u64,
    /// Steps before the first sample.
    pub burn_in_steps: u64,
    /// Samples recorded per trajectory.
    pub samples_per_trajectory: u64,
    /// Trajectories per statistics batch.
    pub lanes: usize,
    /// Number of statistics batches (trajectories = lanes · batches).
    pub batches: u64,
    /// The seed.
    pub seed: u64,
    /// Whether the model has an impact law (so impacts are counted).
    pub has_barrier: bool,
    /// The impact laws simulated (none, one, or two bounding a strip, lower first): shards
    /// of runs with different barriers do not merge.
    #[serde(default)]
    pub barriers: Vec<BarrierSetting>,
    /// The histogrammed quantities: the two states, then the observables.
    pub quantities: Vec<QuantitySpec>,
    /// Statistics batches `0..bias_batches` are run a second time at 2·dt for the
    /// time-step bias estimate (0: no estimate).
    pub bias_batches: u64,
    /// What evaluates the model's coefficients in the time-stepping loop (absent in files
    /// written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evaluator: Option<Evaluator>,
    /// The grid of the impact-speed histogram at each wall (none: the impact statistics are
    /// the count, the mean speed and the dissipated power without a histogram).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impact_speeds: Option<Grid>,
    /// A periodic state, recorded modulo its period in its window [−L/2, L/2) (the
    /// trajectories themselves run on the line: the coefficients repeat with the period).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periodic: Option<PeriodicSetting>,
}

/// The periodic state of a run ([`RunSettings::periodic`]).
///
/// ```
/// let p = fpsolve::mc::PeriodicSetting { state: 0, period: 2.0 };
/// let mut x = [2.5, -1.0, 0.25];
/// p.wrap(&mut x);
/// assert_eq!(x, [0.5, -1.0, 0.25]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeriodicSetting {
    /// The state's index.
    pub state: usize,
    /// Its period L.
    #[serde(with = "exact::number")]
    pub period: f64,
}

impl PeriodicSetting {
    /// Takes the values `x` of the state into its window [−L/2, L/2) (not-a-number stays).
    pub fn wrap(&self, x: &mut [f64]) {
        let p = crate::model::BoundPeriodic {
            state: self.state,
            period: self.period,
        };
        for x in x {
            *x = p.wrap(*x);
        }
    }
}

impl RunSettings {
    /// Total trajectories of the run.
    pub fn trajectories(&self) -> u64 {
        self.lanes as u64 * self.batches
    }

    /// Time between samples.
    pub fn spacing(&self) -> f64 {
        self.steps_per_sample as f64 * self.dt
    }

    /// Burn-in time.
    pub fn burn_in(&self) -> f64 {
        self.burn_in_steps as f64 * self.dt
    }

    /// The settings of the paired coarse run: step 2·dt, the same burn-in time (rounded up),
    /// the same spacing when it is an even number of steps (else twice the spacing: the
    /// stationary statistics do not depend on it), the same samples and random streams.
    pub fn coarse(&self) -> RunSettings {
        let steps_per_sample = if self.steps_per_sample.is_multiple_of(2) {
            self.steps_per_sample / 2
        } else {
            self.steps_per_sample
        };
        RunSettings {
            dt: 2.0 * self.dt,
            steps_per_sample,
            burn_in_steps: self.burn_in_steps.div_ceil(2),
            bias_batches: 0,
            ..self.clone()
        }
    }
}
