//! Whether a finished run can be trusted: the stationarity test on the recording, the
//! blow-up verdict, the time-step bias estimate and the warnings they raise. Outcomes are
//! data; `Display` renders them as sentences.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::batch::BatchSummary;
use super::histogram::{batch_density, batch_moments, Estimate, QuantityHistogram, TimeStepBias};
use super::settings::RunSettings;
use crate::moments::Moments;

/// Statistics batches needed for the stationarity test (its t statistic then has at least
/// 7 degrees of freedom).
pub const MIN_STATIONARITY_BATCHES: u64 = 8;

/// The largest fraction of trajectories that may blow up while the survivors are still taken
/// to represent the stationary law (reported as a warning); more is an error.
pub const BLOWUP_TOLERANCE: f64 = 1e-3;

/// The two-sided critical value of Student's t with `df` degrees of freedom at p = 1e-6:
/// a table for 7–14 degrees of freedom (numerical integration of the t density), the
/// Cornish–Fisher expansion (five terms, accurate to 0.1 % from 15 on) beyond.
pub(crate) fn t_critical(df: u64) -> f64 {
    const TABLE: [f64; 8] = [15.77, 13.26, 11.64, 10.52, 9.70, 9.08, 8.60, 8.22];
    if (7..15).contains(&df) {
        return TABLE[(df - 7) as usize];
    }
    let n = df.max(15) as f64;
    let z: f64 = 4.891_638;
    z + (z.powi(3) + z) / (4.0 * n)
        + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * n * n)
        + (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / (384.0 * n.powi(3))
        + (79.0 * z.powi(9) + 776.0 * z.powi(7) + 1482.0 * z.powi(5)
            - 1920.0 * z.powi(3)
            - 945.0 * z)
            / (92160.0 * n.powi(4))
}

/// A moment the stationarity test compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Moment {
    /// The mean.
    Mean,
    /// The variance.
    Variance,
}

impl fmt::Display for Moment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Moment::Mean => "mean",
            Moment::Variance => "variance",
        })
    }
}

/// The change of one state's moment between the first and the last quarter of the
/// recording, tested against its spread over statistics batches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Drift {
    /// The state.
    pub quantity: String,
    /// The moment.
    pub moment: Moment,
    /// The moment over the first quarter of the recording (averaged over batches).
    pub first_quarter: f64,
    /// The moment over the last quarter.
    pub last_quarter: f64,
    /// t = mean change / its standard error over batches.
    pub t: f64,
    /// The critical |t| (two-sided p = 1e-6 for Student's t with `batches − 1` degrees of freedom).
    pub threshold: f64,
    /// Statistics batches compared.
    pub batches: u64,
}

impl fmt::Display for Drift {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} of {} went from {:.4e} (first quarter of the recording) to {:.4e} (last \
             quarter), t = {:.1} against a threshold of {:.1} over {} batches",
            self.moment,
            self.quantity,
            self.first_quarter,
            self.last_quarter,
            self.t,
            self.threshold,
            self.batches
        )
    }
}

/// Why the stationarity test could not decide.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "kebab-case")]
pub enum Undetermined {
    /// Too few statistics batches for a trustworthy spread.
    TooFewBatches {
        /// Batches with samples in both quarters.
        batches: u64,
        /// Batches needed.
        needed: u64,
    },
    /// Fewer than four samples per trajectory: no quarters to compare.
    TooFewSamples {
        /// Samples per trajectory.
        samples: u64,
    },
}

/// The stationarity verdict: the first and last quarter of every trajectory's recording must
/// have the same mean and variance of each state, within the spread over statistics batches
/// (a t test on the per-batch changes at two-sided p = 1e-6 per moment, so a stationary run
/// fails it about once in 10⁵ runs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "verdict", rename_all = "kebab-case")]
pub enum Stationarity {
    /// No significant drift; the largest one found.
    Stationary {
        /// The largest |t| relative to its threshold.
        largest: Drift,
    },
    /// A significant drift: the recording is not from the stationary law.
    NotStationary {
        /// The largest |t| relative to its threshold.
        largest: Drift,
    },
    /// The test could not be run.
    Undetermined {
        /// Why.
        why: Undetermined,
    },
}

impl fmt::Display for Stationarity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Stationarity::Stationary { largest } => {
                write!(f, "stationary (largest drift: {largest})")
            }
            Stationarity::NotStationary { largest } => write!(f, "NOT stationary: {largest}"),
            Stationarity::Undetermined {
                why: Undetermined::TooFewBatches { batches, needed },
            } => write!(
                f,
                "not tested ({batches} statistics batches, the test needs {needed})"
            ),
            Stationarity::Undetermined {
                why: Undetermined::TooFewSamples { samples },
            } => write!(
                f,
                "not tested ({samples} samples per trajectory, the test needs 4)"
            ),
        }
    }
}

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

/// Whether the trajectories that blew up leave a usable result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "verdict", rename_all = "kebab-case")]
pub enum BlowUps {
    /// No trajectory blew up.
    None,
    /// A few blew up (at most [`BLOWUP_TOLERANCE`] of them): left out and reported.
    Tolerable {
        /// Trajectories that blew up.
        count: u64,
        /// Trajectories run.
        trajectories: u64,
    },
    /// Too many blew up for the survivors to represent the stationary law (which may not
    /// exist: trajectories that escape to infinity carry probability away).
    TooMany {
        /// Trajectories that blew up.
        count: u64,
        /// Trajectories run.
        trajectories: u64,
    },
}

impl BlowUps {
    pub(crate) fn judge(count: u64, trajectories: u64) -> BlowUps {
        if count == 0 {
            BlowUps::None
        } else if count as f64 <= BLOWUP_TOLERANCE * trajectories as f64 {
            BlowUps::Tolerable {
                count,
                trajectories,
            }
        } else {
            BlowUps::TooMany {
                count,
                trajectories,
            }
        }
    }
}

impl fmt::Display for BlowUps {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BlowUps::None => f.write_str("none"),
            BlowUps::Tolerable {
                count,
                trajectories,
            } => write!(
                f,
                "{count} of {trajectories} trajectories blew up (non-finite state) and were \
                 left out (tolerated up to a fraction {BLOWUP_TOLERANCE})"
            ),
            BlowUps::TooMany {
                count,
                trajectories,
            } => write!(
                f,
                "{count} of {trajectories} trajectories blew up (non-finite state), more than \
                 the tolerated fraction {BLOWUP_TOLERANCE}: the survivors do not represent a \
                 stationary law (which may not exist)"
            ),
        }
    }
}

/// A statistic the time-step bias is estimated for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Statistic {
    /// The mean.
    Mean,
    /// The variance.
    Variance,
    /// The kurtosis.
    Kurtosis,
}

impl fmt::Display for Statistic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Statistic::Mean => "mean",
            Statistic::Variance => "variance",
            Statistic::Kurtosis => "kurtosis",
        })
    }
}

/// Something a caller should know about a finished run that does not invalidate it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "warning", rename_all = "kebab-case")]
pub enum McWarning {
    /// A few trajectories blew up and were left out.
    SomeBlewUp {
        /// Trajectories that blew up.
        count: u64,
        /// Trajectories run.
        trajectories: u64,
    },
    /// A statistic's time-step bias, resolved beyond max(4, t/2) of its own standard errors
    /// (t the p = 1e-6 critical value for the pairs' degrees of freedom), exceeds its
    /// statistical error: the error bar understates the error; reduce dt.
    BiasExceedsError {
        /// The quantity.
        quantity: String,
        /// The statistic.
        statistic: Statistic,
        /// The estimated bias.
        bias: Estimate,
        /// The statistic's standard error.
        stderr: f64,
    },
    /// Some histogram bins have a resolved time-step bias (by the same rule as
    /// [`McWarning::BiasExceedsError`]) larger than their statistical error.
    DensityBiasExceedsError {
        /// The quantity.
        quantity: String,
        /// How many bins.
        bins: usize,
        /// The centre of the worst bin.
        at: f64,
        /// Its density.
        density: f64,
        /// Its estimated bias.
        bias: Estimate,
        /// Its statistical error.
        stderr: f64,
    },
}

impl fmt::Display for McWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            McWarning::SomeBlewUp {
                count,
                trajectories,
            } => write!(
                f,
                "{count} of {trajectories} trajectories blew up and were left out"
            ),
            McWarning::BiasExceedsError {
                quantity,
                statistic,
                bias,
                stderr,
            } => write!(
                f,
                "the time-step bias of the {statistic} of {quantity}, {:.2e} ± {:.1e}, \
                 exceeds its statistical error {stderr:.1e}: reduce dt",
                bias.value, bias.stderr
            ),
            McWarning::DensityBiasExceedsError {
                quantity,
                bins,
                at,
                density,
                bias,
                stderr,
            } => write!(
                f,
                "{bins} bins of the density of {quantity} have a time-step bias above their \
                 statistical error (worst at {at:.4e}: density {density:.4e}, bias {:.2e} ± \
                 {:.1e}, error {stderr:.1e}): reduce dt",
                bias.value, bias.stderr
            ),
        }
    }
}

/// The mean and standard error of per-pair values.
fn mean_se(values: &[f64]) -> Estimate {
    let k = values.len() as f64;
    if values.is_empty() {
        return Estimate {
            value: f64::NAN,
            stderr: f64::INFINITY,
        };
    }
    let m = values.iter().sum::<f64>() / k;
    let stderr = if k < 2.0 {
        f64::INFINITY
    } else {
        (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt()
    };
    Estimate { value: m, stderr }
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
        // Fine batches are normally in index order from 0 (a run, or shards merged in order):
        // direct lookup, the search only if that ever does not hold.
        let Some(f) = fine
            .get(c.index as usize)
            .filter(|f| f.index == c.index)
            .or_else(|| fine.iter().find(|f| f.index == c.index))
        else {
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

/// The warnings a quantity's bias estimate raises.
pub(crate) fn bias_warnings(q: &QuantityHistogram, out: &mut Vec<McWarning>) {
    let Some(b) = &q.time_step_bias else {
        return;
    };
    // A bias counts as resolved beyond `k` of its own standard errors, k from Student's t
    // with the pairs' degrees of freedom (about p = 1e-4 per statistic or bin, so that the
    // dozen statistics and hundreds of bins of a healthy run raise no spurious warning).
    if b.pairs < 3 {
        return;
    }
    let k = (0.5 * t_critical(b.pairs - 1)).max(4.0);
    for (statistic, bias, stat) in [
        (Statistic::Mean, b.moments.mean, q.moments.mean),
        (Statistic::Variance, b.moments.variance, q.moments.variance),
        (Statistic::Kurtosis, b.moments.kurtosis, q.moments.kurtosis),
    ] {
        if bias.stderr.is_finite()
            && bias.value.abs() > k * bias.stderr
            && bias.value.abs() > stat.stderr
        {
            out.push(McWarning::BiasExceedsError {
                quantity: q.name.clone(),
                statistic,
                bias,
                stderr: stat.stderr,
            });
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_critical_matches_the_t_distribution() {
        // Two-sided p = 1e-6 (numerical integration of the t density).
        assert_eq!(t_critical(7), 15.77);
        assert!((t_critical(20) - 6.927).abs() < 0.01);
        assert!((t_critical(31) - 6.072).abs() < 0.005);
        assert!((t_critical(1000) - 4.922).abs() < 0.005);
    }

    #[test]
    fn blow_up_verdicts_follow_the_tolerance() {
        assert_eq!(BlowUps::judge(0, 4096), BlowUps::None);
        assert!(matches!(
            BlowUps::judge(4, 4096),
            BlowUps::Tolerable { count: 4, .. }
        ));
        assert!(matches!(
            BlowUps::judge(5, 4096),
            BlowUps::TooMany { count: 5, .. }
        ));
    }
}
