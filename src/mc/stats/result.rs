//! The result of a run: the batches reduced in batch order into histograms and moments,
//! with the verdicts that say whether it can be trusted; `Display` renders the summary table.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::base::number_text::fixed_or_scientific;
use crate::mc::error::McError;
use crate::mc::record::batch::{BatchSummary, BlowUp};
use crate::mc::record::histogram::{finalize, QuantityBatch, QuantityHistogram};
use crate::mc::settings::RunSettings;
use crate::mc::stats::impacts::ImpactStats;
use crate::mc::stats::judge::{
    bias_warnings, impact_rate_bias, impact_warnings, render_bias, stationarity, time_step_bias,
};
use crate::mc::stats::reliability::{crossing_rates, wall_stats, CrossingRates};
use crate::mc::stats::verdict::{BlowUps, McWarning, Stationarity, Undetermined};
use crate::stats::Estimate;

/// The share of the recorded steps whose impacts may run past a step's events before the run
/// says so ([`McWarning::UnresolvedImpacts`]).
const FOLDED_STEPS_TOLERATED: f64 = 1e-4;

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
    pub quantities: Vec<QuantityHistogram>,
    /// Impact statistics, for models with a barrier.
    pub impacts: Option<ImpactStats>,
    /// Trajectories left out because their state stopped being finite.
    pub blowups: Vec<BlowUp>,
    /// The mean up-crossing rates of the quantities whose levels the run was given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub crossings: Vec<CrossingRates>,
}

impl McResult {
    /// The statistics of a quantity by name.
    pub fn quantity(&self, name: &str) -> Option<&QuantityHistogram> {
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
                tolerance: crate::mc::stats::verdict::BLOWUP_TOLERANCE,
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
    let quantities: Vec<QuantityHistogram> = st
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
    // Mass outside a histogram's grid is never silent.
    for q in quantities.iter().filter(|q| q.underflow + q.overflow > 0) {
        warnings.push(McWarning::OutsideGrid {
            quantity: q.name.clone(),
            range: [q.grid.lo, q.grid.hi],
            below: q.underflow,
            above: q.overflow,
            samples: q.samples,
        });
    }
    let bias = st
        .has_barrier
        .then(|| impact_rate_bias(st, batches, coarse))
        .flatten();
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
            time_step_bias: bias.map(|(b, _)| b),
            folded: batches.iter().fold(0u64, |a, b| a.saturating_add(b.folded)),
            walls: wall_stats(st, batches, coarse),
        }
    });
    // A folded step misplaces at most one step's share of its trajectory's time, so the
    // folded steps move at most 2·folded/steps of the recorded mass (L1): below 1e-4 of the
    // steps that is under any histogram's statistical resolution, and chattering against a
    // wall folds a few steps in a million at every dt.
    let steps = trajectories as f64 * st.samples_per_trajectory as f64 * st.steps_per_sample as f64;
    if let Some(impacts) = impacts
        .as_ref()
        .filter(|i| i.folded as f64 > FOLDED_STEPS_TOLERATED * steps)
    {
        warnings.push(McWarning::UnresolvedImpacts {
            folded: impacts.folded,
            steps: steps as u64,
        });
    }
    if let (Some(impacts), Some((_, pairs))) = (&impacts, bias) {
        impact_warnings(impacts, pairs, &mut warnings);
    }
    Ok(McResult {
        settings: st.clone(),
        // Survivors of a run that lost trajectories to infinity can look stationary; the
        // run is not, whatever their quarters say.
        stationarity: match blowup_verdict {
            BlowUps::TooMany {
                count,
                trajectories,
            } => Stationarity::Undetermined {
                why: Undetermined::BlewUp {
                    count,
                    trajectories,
                },
            },
            _ => stationarity(st, batches),
        },
        blowup_verdict,
        warnings,
        trajectories,
        quantities,
        impacts,
        blowups: batches
            .iter()
            .flat_map(|b| b.blowups.iter().cloned())
            .collect(),
        crossings: crossing_rates(st, batches, coarse),
    })
}

impl fmt::Display for McResult {
    /// The summary table of a run: scheme, sizes, moments with standard errors and
    /// time-step biases, impacts, blow-ups, the stationarity verdict and the warnings.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let st = &self.settings;
        writeln!(
            f,
            "Monte Carlo of {}: {}, dt = {}, {} trajectories recorded of {}, {} samples each \
             every {} after a burn-in of {}",
            st.model,
            st.scheme,
            st.dt,
            self.trajectories,
            st.trajectories(),
            st.samples_per_trajectory,
            st.spacing(),
            st.burn_in()
        )?;
        if let Some(evaluator) = st.evaluator {
            writeln!(f, "evaluator: {evaluator}")?;
        }
        writeln!(
            f,
            "{:>8} {:>9} {:>13} {:>8} {:>24} {:>13} {:>8} {:>24} {:>10} {:>8} {:>24}",
            "quantity",
            "statistic",
            "mean",
            "± se",
            "time-step bias",
            "variance",
            "± se",
            "time-step bias",
            "kurtosis",
            "± se",
            "time-step bias"
        )?;
        for q in &self.quantities {
            let b = q.time_step_bias.as_ref();
            writeln!(
                f,
                "{:>8} {:>9} {} {:>8.1e} {:>24} {} {:>8.1e} {:>24} {} {:>8.1e} {:>24}",
                q.name,
                "mc",
                fixed_or_scientific(q.moments.mean.value, 6, 13),
                q.moments.mean.stderr,
                render_bias(b.map(|b| b.moments.mean)),
                fixed_or_scientific(q.moments.variance.value, 6, 13),
                q.moments.variance.stderr,
                render_bias(b.map(|b| b.moments.variance)),
                fixed_or_scientific(q.moments.kurtosis.value, 4, 10),
                q.moments.kurtosis.stderr,
                render_bias(b.map(|b| b.moments.kurtosis))
            )?;
        }
        if let Some(b) = self
            .quantities
            .first()
            .and_then(|q| q.time_step_bias.as_ref())
        {
            writeln!(
                f,
                "time-step bias: Richardson estimate S_dt - S from {} statistics batches paired \
                 with a run at dt = {} (weak order {})",
                b.pairs, b.coarse_dt, b.order
            )?;
        } else {
            writeln!(f, "time-step bias: not estimated")?;
        }
        if let Some(impacts) = &self.impacts {
            writeln!(
                f,
                "impacts: {} in all, rate {:.5} ± {:.1e} per unit time, time-step bias {}",
                impacts.count,
                impacts.rate.value,
                impacts.rate.stderr,
                render_bias(impacts.time_step_bias)
            )?;
            if impacts.folded > 0 {
                writeln!(
                    f,
                    "impacts unresolved: {} steps ran out of events beyond a wall, their \
                     overshoot reflected back",
                    impacts.folded
                )?;
            }
        }
        writeln!(f, "blow-ups: {}", self.blowup_verdict)?;
        writeln!(f, "stationarity: {}", self.stationarity)?;
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}
