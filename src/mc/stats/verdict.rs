//! Whether a finished run can be trusted, as data: the stationarity verdict, the blow-up
//! verdict and the warnings; `Display` renders them as sentences. `judge.rs` beside it computes them.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::stats::Estimate;

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
    /// More trajectories blew up than [`BLOWUP_TOLERANCE`] allows: the run is not
    /// stationary whatever its survivors' quarters show, so they are not compared.
    BlewUp {
        /// Trajectories that blew up.
        count: u64,
        /// Trajectories run.
        trajectories: u64,
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
            Stationarity::Undetermined {
                why:
                    Undetermined::BlewUp {
                        count,
                        trajectories,
                    },
            } => write!(
                f,
                "not stationary: {count} of {trajectories} trajectories blew up (the survivors' \
                 quarters were not compared)"
            ),
        }
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
    /// A rate (of impacts).
    Rate,
}

impl fmt::Display for Statistic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Statistic::Mean => "mean",
            Statistic::Variance => "variance",
            Statistic::Kurtosis => "kurtosis",
            Statistic::Rate => "rate",
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
    /// More than 1e-4 of the recorded steps met a wall more often than one step may resolve
    /// (a trajectory chattering against it), their overshoot reflected back into the domain:
    /// the motion near the wall is not resolved there.
    UnresolvedImpacts {
        /// Steps folded back.
        folded: u64,
        /// Steps recorded.
        steps: u64,
    },
    /// Samples of a quantity fell outside its histogram grid: the histogram's density
    /// integrates to less than 1 by their share, and so do the distances computed from it.
    OutsideGrid {
        /// The quantity.
        quantity: String,
        /// The grid's range [lo, hi).
        range: [f64; 2],
        /// Samples below the grid.
        below: u64,
        /// Samples at or above its right edge.
        above: u64,
        /// Finite samples recorded.
        samples: u64,
    },
}

/// The fraction of a quantity's samples outside its histogram grid above which a job that
/// compares methods with the histogram is flagged: a report grid reaches 1e−8 of the
/// density's peak, which leaves out far less than this for any density with a tail lighter
/// than a power law, and a mass below it cannot change a distance printed to 1e−4.
pub const OUTSIDE_GRID_TOLERANCE: f64 = 1e-6;

impl McWarning {
    /// Whether a job that compares with the histogram must be flagged for it: samples
    /// outside the grid beyond [`OUTSIDE_GRID_TOLERANCE`] of them (the histogram, and every
    /// distance computed from it, leave their mass out).
    pub fn flags_a_comparison(&self) -> bool {
        match self {
            McWarning::OutsideGrid {
                below,
                above,
                samples,
                ..
            } => (below + above) as f64 > OUTSIDE_GRID_TOLERANCE * *samples as f64,
            _ => false,
        }
    }
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
            McWarning::UnresolvedImpacts { folded, steps } => write!(
                f,
                "{folded} of {steps} steps met a wall more often than a step resolves, their \
                 overshoot reflected back (more than 1e-4 of them): the motion at the wall is \
                 not resolved; reduce dt"
            ),
            McWarning::OutsideGrid {
                quantity,
                range,
                below,
                above,
                samples,
            } => write!(
                f,
                "{below} samples of {quantity} fell below its histogram grid [{:.4e}, {:.4e}) \
                 and {above} above it, a fraction {:.2e} of the {samples}: the histogram and \
                 the distances computed from it leave that mass out",
                range[0],
                range[1],
                (below + above) as f64 / (*samples).max(1) as f64
            ),
        }
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
