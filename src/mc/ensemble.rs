//! Ensembles: statistics batches of trajectories run in parallel, each streaming its samples
//! into histograms and power sums, reduced in batch order.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::histogram::{finalize, Accumulator, Estimate, Grid, QuantityBatch, QuantityStats};
use super::rng::Increments;
use super::scheme::{BatchState, Plan, SchemeKind};
use super::shard::exact;
use super::verdict::{
    bias_warnings, stationarity, time_step_bias, BlowUps, McWarning, Stationarity,
};
use super::McError;

/// A parameter value, as a run records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamValue {
    /// The parameter's name.
    pub name: String,
    /// Its value.
    #[serde(with = "exact")]
    pub value: f64,
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
    #[serde(with = "exact")]
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
    /// The histogrammed quantities: the two states, then the observables.
    pub quantities: Vec<QuantitySpec>,
    /// Statistics batches `0..bias_batches` are run a second time at 2·dt for the
    /// time-step bias estimate (0: no estimate).
    pub bias_batches: u64,
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

/// A trajectory whose state stopped being finite: it is left out of every statistic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlowUp {
    /// The trajectory's index in the run (its random stream is `(seed, trajectory)`).
    pub trajectory: u64,
    /// The step count at which the non-finite state was found (a sample point).
    pub step: u64,
    /// The last finite state recorded, and the step it was recorded at (`None` if the
    /// trajectory never reached a sample point finite).
    pub last_finite: Option<LastState>,
    /// The model's parameter values, so the report is self-contained.
    pub params: Vec<ParamValue>,
}

/// A recorded state of a trajectory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LastState {
    /// The step it was recorded at.
    pub step: u64,
    /// The two states.
    #[serde(with = "exact::array2")]
    pub state: [f64; 2],
}

/// One statistics batch's contribution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct BatchSummary {
    pub(crate) index: u64,
    /// Trajectories recorded (lanes minus blow-ups).
    pub(crate) recorded: u64,
    /// Impacts of the recorded trajectories after the burn-in.
    pub(crate) impacts: u64,
    pub(crate) quantities: Vec<QuantityBatch>,
    pub(crate) blowups: Vec<BlowUp>,
}

/// Impact statistics of a run with a barrier.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpactStats {
    /// Impacts counted over the recording time of all recorded trajectories.
    pub count: u64,
    /// Impacts per unit time per trajectory.
    pub rate: Estimate,
}

/// The result of a Monte Carlo run: the statistics, and whether they can be trusted
/// ([`McResult::verdict`]). A run whose verdict fails still returns its histograms, so that
/// the caller can write them, flagged.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct McResult {
    /// The settings it was run with (the scheme is `settings.scheme`).
    pub settings: RunSettings,
    /// The first-vs-last-quarter stationarity test of the recording.
    pub stationarity: Stationarity,
    /// Whether the blown-up trajectories leave a usable result.
    pub blowup_verdict: BlowUps,
    /// Warnings that do not invalidate the result (time-step bias above the statistical
    /// error, a few blow-ups).
    pub warnings: Vec<McWarning>,
    /// Trajectories that contributed (all but the blow-ups).
    pub trajectories: u64,
    /// Histograms and moments, states first, then observables.
    pub quantities: Vec<QuantityStats>,
    /// Impact statistics, for models with a barrier.
    pub impacts: Option<ImpactStats>,
    /// Trajectories left out because their state stopped being finite.
    pub blowups: Vec<BlowUp>,
}

impl McResult {
    /// The statistics of a quantity by name.
    pub fn quantity(&self, name: &str) -> Option<&QuantityStats> {
        self.quantities.iter().find(|q| q.name == name)
    }

    /// `Ok` when the result represents the stationary law; else the failed verdict as an
    /// error (too many blow-ups first, then a failed stationarity test). Warnings do not
    /// fail it.
    pub fn verdict(&self) -> Result<(), McError> {
        if let BlowUps::TooMany {
            count,
            trajectories,
        } = self.blowup_verdict
        {
            return Err(McError::TooManyBlowUps {
                count,
                trajectories,
                tolerance: super::verdict::BLOWUP_TOLERANCE,
            });
        }
        if let Stationarity::NotStationary { largest } = &self.stationarity {
            return Err(McError::NotStationary {
                drift: largest.clone(),
            });
        }
        Ok(())
    }
}

/// Runs statistics batch `index` (all its trajectories from their start), leaving out the
/// lanes in `excluded`; returns its summary and the lanes that blew up.
fn run_batch_once(
    plan: &Plan,
    st: &RunSettings,
    index: u64,
    excluded: &[bool],
) -> (BatchSummary, Vec<usize>) {
    let lanes = st.lanes;
    let first = index * lanes as u64;
    let spread = plan.initial_spread();
    let mut b = BatchState::new(plan, &spread, st.seed, first, lanes, st.increments);
    b.advance(plan, st.burn_in_steps, st.dt);
    b.impacts.fill(0);
    let mut record: Vec<bool> = excluded.iter().map(|e| !e).collect();
    let mut acc: Vec<Accumulator> = st
        .quantities
        .iter()
        .map(|q| Accumulator::new(q.grid, lanes))
        .collect();
    let n_obs = st.quantities.len() - 2;
    let mut obs = vec![0.0; n_obs * lanes];
    let mut scratch = super::eval::Scratch::new();
    let mut blown: Vec<(usize, u64, Option<LastState>)> = Vec::new();
    let (mut prev_x, mut prev_v) = (vec![0.0; lanes], vec![0.0; lanes]);
    let mut step = st.burn_in_steps;
    for s in 0..st.samples_per_trajectory {
        let window = ((s as u128 * 4) / st.samples_per_trajectory as u128) as usize;
        for a in &mut acc {
            a.set_window(window);
        }
        prev_x.copy_from_slice(&b.x);
        prev_v.copy_from_slice(&b.v);
        b.advance(plan, st.steps_per_sample, st.dt);
        let prev_step = step;
        step += st.steps_per_sample;
        for i in 0..lanes {
            if record[i] && !(b.x[i].is_finite() && b.v[i].is_finite()) {
                record[i] = false;
                let last = (s > 0).then(|| LastState {
                    step: prev_step,
                    state: [prev_x[i], prev_v[i]],
                });
                blown.push((i, step, last));
            }
        }
        plan.observables
            .eval_batch(&b.x, &b.v, &mut obs, &mut scratch);
        acc[0].add(&b.x, &record);
        acc[1].add(&b.v, &record);
        for j in 0..n_obs {
            acc[2 + j].add(&obs[j * lanes..(j + 1) * lanes], &record);
        }
    }
    let impacts = (0..lanes)
        .filter(|&i| record[i])
        .map(|i| b.impacts[i])
        .sum();
    let recorded = record.iter().filter(|&&r| r).count() as u64;
    let blowups = blown
        .iter()
        .map(|(i, step, last)| BlowUp {
            trajectory: first + *i as u64,
            step: *step,
            last_finite: last.clone(),
            params: st.params.clone(),
        })
        .collect();
    let blown = blown.into_iter().map(|b| b.0).collect();
    let summary = BatchSummary {
        index,
        recorded,
        impacts,
        quantities: acc.into_iter().map(Accumulator::finish).collect(),
        blowups,
    };
    (summary, blown)
}

/// Runs statistics batch `index`; if trajectories blow up, runs it again without them (their
/// streams are their own, so the others repeat exactly) so that none of their samples count.
pub(crate) fn run_batch(plan: &Plan, st: &RunSettings, index: u64) -> BatchSummary {
    let mut excluded = vec![false; st.lanes];
    let (summary, blown) = run_batch_once(plan, st, index, &excluded);
    if blown.is_empty() {
        return summary;
    }
    let blowups = summary.blowups;
    for &i in &blown {
        excluded[i] = true;
    }
    let (mut again, _) = run_batch_once(plan, st, index, &excluded);
    again.blowups = blowups;
    again
}

/// Runs the batches in `range` in parallel; the summaries come back in batch order.
/// `done` hears about every finished batch.
pub(crate) fn run_batches(
    plan: &Plan,
    st: &RunSettings,
    range: std::ops::Range<u64>,
    done: &(dyn Fn() + Sync),
) -> Vec<BatchSummary> {
    range
        .into_par_iter()
        .map(|k| {
            let b = run_batch(plan, st, k);
            done();
            b
        })
        .collect()
}

/// Reduces batch summaries (all of a run's, in batch order) to the run's result; an error
/// if no trajectory survived.
pub(crate) fn finalize_run(
    st: &RunSettings,
    batches: &[&BatchSummary],
    coarse: &[&BatchSummary],
) -> Result<McResult, McError> {
    if batches.iter().all(|b| b.recorded == 0) {
        return Err(McError::AllBlewUp {
            blowups: batches.iter().map(|b| b.blowups.len()).sum(),
        });
    }
    let coarse_dt = 2.0 * st.dt; // as `RunSettings::coarse` sets it
    let quantities: Vec<QuantityStats> = st
        .quantities
        .iter()
        .enumerate()
        .map(|(q, spec)| {
            let per: Vec<&QuantityBatch> = batches.iter().map(|b| &b.quantities[q]).collect();
            let mut stats = finalize(&spec.name, spec.is_state, spec.grid, &per);
            stats.time_step_bias = time_step_bias(st, q, batches, coarse, coarse_dt);
            stats
        })
        .collect();
    let trajectories: u64 = batches.iter().map(|b| b.recorded).sum();
    let blown: u64 = batches.iter().map(|b| b.blowups.len() as u64).sum();
    let blowup_verdict = BlowUps::judge(blown, trajectories + blown);
    let mut warnings = Vec::new();
    if let BlowUps::Tolerable {
        count,
        trajectories,
    } = blowup_verdict
    {
        warnings.push(McWarning::SomeBlewUp {
            count,
            trajectories,
        });
    }
    for q in &quantities {
        bias_warnings(q, &mut warnings);
    }
    let impacts = st.has_barrier.then(|| {
        let t = st.samples_per_trajectory as f64 * st.spacing();
        // Saturating: a merged file may claim absurd counts (validation bounds each batch).
        let count: u64 = batches
            .iter()
            .fold(0u64, |a, b| a.saturating_add(b.impacts));
        let rate = count as f64 / (trajectories as f64 * t);
        let nb = batches.len() as f64;
        let ss: f64 = batches
            .iter()
            .map(|b| (b.impacts as f64 - rate * b.recorded as f64 * t).powi(2))
            .sum();
        ImpactStats {
            count,
            rate: Estimate {
                value: rate,
                stderr: (nb / (nb - 1.0) * ss).sqrt() / (trajectories as f64 * t),
            },
        }
    });
    Ok(McResult {
        settings: st.clone(),
        stationarity: stationarity(st, batches),
        blowup_verdict,
        warnings,
        trajectories,
        quantities,
        impacts,
        blowups: batches
            .iter()
            .flat_map(|b| b.blowups.iter().cloned())
            .collect(),
    })
}
