//! Judging a finished run: the stationarity test on the recording (first against last
//! quarter), the time-step bias estimate (Richardson, from the paired 2·dt batches) and the
//! warnings the bias raises.

use crate::mc::record::batch::BatchSummary;
use crate::mc::record::histogram::{batch_density, batch_moments, QuantityHistogram, TimeStepBias};
use crate::mc::settings::RunSettings;
use crate::mc::stats::impacts::ImpactStats;
use crate::mc::stats::pairs::{mean_se, paired};
use crate::mc::stats::verdict::{
    t_critical, Drift, McWarning, Moment, Stationarity, Statistic, Undetermined,
    MIN_STATIONARITY_BATCHES,
};
use crate::stats::Estimate;
use crate::stats::Moments;

/// Compares the first and last quarter of the recording of each state.
pub(crate) fn stationarity(st: &RunSettings, batches: &[&BatchSummary]) -> Stationarity {
    if st.samples_per_trajectory < 4 {
        return Stationarity::Undetermined {
            why: Undetermined::TooFewSamples {
                samples: st.samples_per_trajectory,
            },
        };
    }
    let mut largest: Option<(f64, Drift)> = None;
    let mut compared = 0;
    for (q, spec) in st.quantities.iter().enumerate() {
        if !spec.is_state {
            continue;
        }
        let shift = 0.5 * (spec.grid.lo + spec.grid.hi);
        let quarter = |b: &BatchSummary, k: usize| -> Option<(f64, f64)> {
            let qb = &b.quantities[q];
            let n = qb.window_counts[k] as f64;
            let m = qb.window_sums[k] / n;
            let var = qb.window_squares[k] / n - m * m;
            (n > 0.0 && m.is_finite() && var.is_finite()).then_some((m, var))
        };
        for moment in [Moment::Mean, Moment::Variance] {
            let pick = |t: (f64, f64)| match moment {
                Moment::Mean => t.0,
                Moment::Variance => t.1,
            };
            let pairs: Vec<(f64, f64)> = batches
                .iter()
                .filter_map(|b| Some((pick(quarter(b, 0)?), pick(quarter(b, 3)?))))
                .collect();
            let k = pairs.len() as u64;
            compared = compared.max(k);
            if k < MIN_STATIONARITY_BATCHES {
                continue;
            }
            let kf = k as f64;
            let first = pairs.iter().map(|p| p.0).sum::<f64>() / kf;
            let last = pairs.iter().map(|p| p.1).sum::<f64>() / kf;
            let d_mean = last - first;
            let ss: f64 = pairs.iter().map(|p| (p.1 - p.0 - d_mean).powi(2)).sum();
            let se = (ss / (kf - 1.0) / kf).sqrt();
            let t = if se > 0.0 {
                d_mean / se
            } else if d_mean == 0.0 {
                0.0
            } else {
                f64::MAX.copysign(d_mean)
            };
            let threshold = t_critical(k - 1);
            let offset = if moment == Moment::Mean { shift } else { 0.0 };
            let drift = Drift {
                quantity: spec.name.clone(),
                moment,
                first_quarter: first + offset,
                last_quarter: last + offset,
                t,
                threshold,
                batches: k,
            };
            let score = t.abs() / threshold;
            if largest.as_ref().is_none_or(|(s, _)| score > *s) {
                largest = Some((score, drift));
            }
        }
    }
    match largest {
        None => Stationarity::Undetermined {
            why: Undetermined::TooFewBatches {
                batches: compared,
                needed: MIN_STATIONARITY_BATCHES,
            },
        },
        Some((score, largest)) if score > 1.0 => Stationarity::NotStationary { largest },
        Some((_, largest)) => Stationarity::Stationary { largest },
    }
}

/// The Richardson estimate of a quantity's time-step bias from fine batches (dt) and the
/// coarse batches (2·dt) with the same indices.
pub(crate) fn time_step_bias(
    st: &RunSettings,
    q: usize,
    fine: &[&BatchSummary],
    coarse: &[&BatchSummary],
    coarse_dt: f64,
) -> Option<TimeStepBias> {
    if coarse.is_empty() {
        return None;
    }
    let order = st.scheme.weak_order();
    let factor = 1.0 / (2f64.powi(order as i32) - 1.0);
    let grid = st.quantities[q].grid;
    let (mut dm, mut dv, mut dk) = (Vec::new(), Vec::new(), Vec::new());
    let mut draw: [Vec<f64>; 4] = Default::default();
    let mut dd: Vec<Vec<f64>> = Vec::new();
    for c in coarse {
        let Some(f) = paired(fine, c) else {
            continue;
        };
        let (fq, cq) = (&f.quantities[q], &c.quantities[q]);
        let (Some(fm), Some(cm), Some(fd), Some(cd)) = (
            batch_moments(fq, grid),
            batch_moments(cq, grid),
            batch_density(fq, grid),
            batch_density(cq, grid),
        ) else {
            continue;
        };
        // bias(dt) = S_dt − S ≈ (S_2dt − S_dt)/(2ᵖ − 1).
        dm.push((cm.shifted_mean - fm.shifted_mean) * factor);
        dv.push((cm.variance - fm.variance) * factor);
        dk.push((cm.kurtosis - fm.kurtosis) * factor);
        for (d, (c, f)) in draw.iter_mut().zip(cm.raw.iter().zip(&fm.raw)) {
            d.push((c - f) * factor);
        }
        dd.push(cd.iter().zip(&fd).map(|(c, f)| (c - f) * factor).collect());
    }
    let per_bin: Vec<Estimate> = (0..grid.bins)
        .map(|j| mean_se(&dd.iter().map(|d| d[j]).collect::<Vec<_>>()))
        .collect();
    Some(TimeStepBias {
        order,
        coarse_dt,
        pairs: dm.len() as u64,
        moments: Moments {
            raw: std::array::from_fn(|k| mean_se(&draw[k])),
            mean: mean_se(&dm),
            variance: mean_se(&dv),
            kurtosis: mean_se(&dk),
        },
        density: per_bin.iter().map(|e| e.value).collect(),
        density_stderr: per_bin.iter().map(|e| e.stderr).collect(),
    })
}

/// The Richardson estimate of the impact rate's time-step bias, as [`time_step_bias`] for a
/// moment: per pair of batches, (r_2dt − r_dt)/(2ᵖ − 1), each batch's rate its impacts over
/// its recorded trajectories' recording time (twice as long at 2·dt when the step count per
/// sample point stays the same, [`RunSettings::coarse`]), with the number of pairs; `None`
/// without a 2·dt run.
pub(crate) fn impact_rate_bias(
    st: &RunSettings,
    fine: &[&BatchSummary],
    coarse: &[&BatchSummary],
) -> Option<(Estimate, u64)> {
    if coarse.is_empty() {
        return None;
    }
    let factor = 1.0 / (2f64.powi(st.scheme.weak_order() as i32) - 1.0);
    let c_st = st.coarse();
    let time = |s: &RunSettings| s.samples_per_trajectory as f64 * s.spacing();
    let (tf, tc) = (time(st), time(&c_st));
    let rate = |b: &BatchSummary, t: f64| b.impacts as f64 / (b.recorded as f64 * t);
    let d: Vec<f64> = coarse
        .iter()
        .filter_map(|c| {
            let f = paired(fine, c)?;
            (f.recorded > 0 && c.recorded > 0).then(|| (rate(c, tc) - rate(f, tf)) * factor)
        })
        .collect();
    Some((mean_se(&d), d.len() as u64))
}

/// The warning the impact rate's bias estimate (from `pairs` pairs of batches) raises: by
/// the rule of [`bias_warnings`].
pub(crate) fn impact_warnings(impacts: &ImpactStats, pairs: u64, out: &mut Vec<McWarning>) {
    let (Some(bias), Some(k)) = (impacts.time_step_bias, resolved_beyond(pairs)) else {
        return;
    };
    out.extend(bias_exceeds(
        "impacts",
        Statistic::Rate,
        bias,
        impacts.rate,
        k,
    ));
}

/// How many of its own standard errors a bias estimated from `pairs` pairs of batches must
/// exceed to count as resolved: from Student's t with the pairs' degrees of freedom (about
/// p = 1e-4 per statistic or bin, so that the dozen statistics and hundreds of bins of a
/// healthy run raise no spurious warning), at least 4; `None` below 3 pairs.
fn resolved_beyond(pairs: u64) -> Option<f64> {
    (pairs >= 3).then(|| (0.5 * t_critical(pairs - 1)).max(4.0))
}

/// A [`McWarning::BiasExceedsError`] when the bias of `statistic` is resolved (beyond `k`
/// of its own standard errors) and larger than the statistic's own error.
fn bias_exceeds(
    quantity: &str,
    statistic: Statistic,
    bias: Estimate,
    stat: Estimate,
    k: f64,
) -> Option<McWarning> {
    (bias.stderr.is_finite()
        && bias.value.abs() > k * bias.stderr
        && bias.value.abs() > stat.stderr)
        .then(|| McWarning::BiasExceedsError {
            quantity: quantity.to_string(),
            statistic,
            bias,
            stderr: stat.stderr,
        })
}

/// The warnings a quantity's bias estimate raises.
pub(crate) fn bias_warnings(q: &QuantityHistogram, out: &mut Vec<McWarning>) {
    let Some(b) = &q.time_step_bias else {
        return;
    };
    let Some(k) = resolved_beyond(b.pairs) else {
        return;
    };
    for (statistic, bias, stat) in [
        (Statistic::Mean, b.moments.mean, q.moments.mean),
        (Statistic::Variance, b.moments.variance, q.moments.variance),
        (Statistic::Kurtosis, b.moments.kurtosis, q.moments.kurtosis),
    ] {
        out.extend(bias_exceeds(&q.name, statistic, bias, stat, k));
    }
    let flagged: Vec<usize> = (0..q.grid.bins)
        .filter(|&j| {
            let (v, se) = (b.density[j], b.density_stderr[j]);
            se.is_finite() && v.abs() > k * se && v.abs() > q.stderr[j]
        })
        .collect();
    if let Some(&worst) = flagged.iter().max_by(|&&i, &&j| {
        let r = |k: usize| b.density[k].abs() / q.stderr[k].max(f64::MIN_POSITIVE);
        r(i).total_cmp(&r(j))
    }) {
        out.push(McWarning::DensityBiasExceedsError {
            quantity: q.name.clone(),
            bins: flagged.len(),
            at: q.grid.lo + (worst as f64 + 0.5) * q.grid.width(),
            density: q.density[worst],
            bias: Estimate {
                value: b.density[worst],
                stderr: b.density_stderr[worst],
            },
            stderr: q.stderr[worst],
        });
    }
}

/// `bias ± se` when resolved, `< bound (unresolved)` when not, `n/a` without an estimate.
pub(crate) fn render_bias(b: Option<Estimate>) -> String {
    match b {
        None => "n/a".into(),
        Some(e) if !e.value.is_finite() || !e.stderr.is_finite() => "unknown".into(),
        Some(e) if e.resolved() => format!("{:+.1e} ± {:.0e}", e.value, e.stderr),
        Some(e) => format!("< {:.1e} (unresolved)", e.bound()),
    }
}
