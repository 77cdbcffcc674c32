//! Streaming histograms and moments on fixed grids: no sample is kept, only bin counts and
//! power sums per statistics batch.

use serde::{Deserialize, Serialize};

use crate::mc::error::McError;
use crate::mc::exact;
use crate::stats::Estimate;
use crate::stats::Moments;

/// Largest number of bins of one histogram grid.
pub const MAX_BINS: usize = 10_000_000;

/// A fixed histogram grid: `bins` equal bins covering `[lo, hi)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Left edge of the first bin.
    #[serde(with = "exact::number")]
    pub lo: f64,
    /// Right edge of the last bin.
    #[serde(with = "exact::number")]
    pub hi: f64,
    /// Number of bins (≥ 1).
    pub bins: usize,
}

impl Grid {
    /// A grid of `bins` bins on `[lo, hi)`.
    ///
    /// ```
    /// let g = fpsolve::mc::Grid::new(0.0, 2.0, 4).unwrap();
    /// assert_eq!(g.width(), 0.5);
    /// assert!(fpsolve::mc::Grid::new(1.0, 1.0, 4).is_err());
    /// ```
    pub fn new(lo: f64, hi: f64, bins: usize) -> Result<Grid, McError> {
        if !(Grid { lo, hi, bins }).well_formed() {
            return Err(McError::BadSetting {
                name: "grid",
                reason: format!(
                    "need finite lo < hi and bins ≥ 1, got [{lo:?}, {hi:?}) with {bins}"
                ),
            });
        }
        Ok(Grid { lo, hi, bins })
    }

    /// Finite `lo < hi` and at least one bin: what every grid must be (a `Grid` built field
    /// by field, or read from a shard file, is checked with this).
    pub(crate) fn well_formed(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite() && self.lo < self.hi && self.bins > 0
    }

    /// The width of one bin.
    pub fn width(&self) -> f64 {
        (self.hi - self.lo) / self.bins as f64
    }

    /// The centres of the bins.
    ///
    /// ```
    /// let g = fpsolve::mc::Grid::new(0.0, 1.0, 2).unwrap();
    /// assert_eq!(g.centers(), vec![0.25, 0.75]);
    /// ```
    pub fn centers(&self) -> Vec<f64> {
        let w = self.width();
        (0..self.bins)
            .map(|j| self.lo + (j as f64 + 0.5) * w)
            .collect()
    }
}

/// A histogram grid for a named quantity, as the command line gives it: `NAME=LO:HI:BINS`.
///
/// ```
/// use fpsolve::mc::NamedGrid;
/// let g: NamedGrid = "y=0:8:300".parse().unwrap();
/// assert_eq!((g.name.as_str(), g.grid.bins), ("y", 300));
/// let err = "y=0:8".parse::<NamedGrid>().unwrap_err();
/// assert!(err.to_string().contains("expected NAME=LO:HI:BINS"));
/// assert!("y=8:0:10".parse::<NamedGrid>().is_err());
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NamedGrid {
    /// The state's or observable's name.
    pub name: String,
    /// The grid.
    pub grid: Grid,
}

/// Why a `NAME=LO:HI:BINS` text is not a grid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NamedGridError {
    /// Not of the form `NAME=LO:HI:BINS` with numbers and a whole number of bins.
    #[error("`{text}`: expected NAME=LO:HI:BINS (e.g. y=0:8:300)")]
    Shape {
        /// The text given.
        text: String,
    },
    /// Nothing before `=`.
    #[error("`{text}`: the quantity's name is missing")]
    NoName {
        /// The text given.
        text: String,
    },
    /// The numbers do not make a grid (lo ≥ hi, non-finite, no bins).
    #[error("`{text}`: {reason}")]
    Grid {
        /// The text given.
        text: String,
        /// What is wrong.
        reason: String,
    },
}

impl std::str::FromStr for NamedGrid {
    type Err = NamedGridError;

    fn from_str(text: &str) -> Result<NamedGrid, NamedGridError> {
        let shown = || text.chars().take(60).collect::<String>();
        let parsed = text.split_once('=').and_then(|(name, spec)| {
            let parts: Vec<&str> = spec.split(':').collect();
            let [lo, hi, bins] = parts.as_slice() else {
                return None;
            };
            Some((
                name.trim().to_string(),
                lo.trim().parse::<f64>().ok()?,
                hi.trim().parse::<f64>().ok()?,
                bins.trim().parse::<usize>().ok()?,
            ))
        });
        let Some((name, lo, hi, bins)) = parsed else {
            return Err(NamedGridError::Shape { text: shown() });
        };
        if name.is_empty() {
            return Err(NamedGridError::NoName { text: shown() });
        }
        let grid = Grid::new(lo, hi, bins).map_err(|e| NamedGridError::Grid {
            text: shown(),
            reason: e.to_string(),
        })?;
        Ok(NamedGrid { name, grid })
    }
}

/// One quantity's statistics over one batch: bin counts, out-of-range and invalid counts,
/// power sums of `q − shift` (`shift` is the grid's centre, to keep the sums well
/// conditioned), and the extremes of the finite values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct QuantityBatch {
    pub(crate) counts: Vec<u64>,
    pub(crate) under: u64,
    pub(crate) over: u64,
    /// Non-finite values of an observable at a finite state.
    pub(crate) invalid: u64,
    #[serde(with = "exact::array4")]
    pub(crate) sums: [f64; 4],
    #[serde(with = "exact")]
    pub(crate) min: f64,
    #[serde(with = "exact")]
    pub(crate) max: f64,
    /// Finite values recorded in each quarter of the recording (for the stationarity test).
    pub(crate) window_counts: [u64; 4],
    /// Σ (q − shift) per quarter of the recording.
    #[serde(with = "exact::array4")]
    pub(crate) window_sums: [f64; 4],
    /// Σ (q − shift)² per quarter of the recording.
    #[serde(with = "exact::array4")]
    pub(crate) window_squares: [f64; 4],
}

impl QuantityBatch {
    /// Adds the statistics of `other`, taken over other lanes of the same batch and grid:
    /// counts and sums added, extremes taken.
    pub(crate) fn merge(&mut self, other: QuantityBatch) {
        for (c, o) in self.counts.iter_mut().zip(&other.counts) {
            *c += o;
        }
        self.under += other.under;
        self.over += other.over;
        self.invalid += other.invalid;
        for k in 0..4 {
            self.sums[k] += other.sums[k];
            self.window_counts[k] += other.window_counts[k];
            self.window_sums[k] += other.window_sums[k];
            self.window_squares[k] += other.window_squares[k];
        }
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }
}

/// One quantity's histogram over a run, with its moments: what Monte Carlo knows about a
/// state or an observable.
///
/// ```
/// # use fpsolve::mc::{McConfig, Simulation};
/// # use fpsolve::model::{load_model, Override};
/// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
/// # let file = load_model(path.as_ref()).unwrap();
/// # let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
/// # let config = McConfig { trajectories: 256, lanes: 32, samples: 100, ..McConfig::default() };
/// let result = Simulation::new(&model, &config)?.run()?;
/// let z = result.quantity("z").unwrap();
/// // Raw moments and the statistics built on them, each with its standard error.
/// let [m1, m2, _, m4] = z.moments.raw;
/// assert!((m1.value - z.moments.mean.value).abs() < 1e-12);
/// assert!(m2.value > 0.0 && m4.value > 0.0 && m4.stderr.is_finite());
/// # Ok::<(), fpsolve::mc::McError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantityHistogram {
    /// The state's or observable's name.
    pub name: String,
    /// Whether it is a state (`true`) or an observable.
    pub is_state: bool,
    /// The histogram grid.
    pub grid: Grid,
    /// Density estimate per bin: count / (finite samples · bin width), so it integrates to the
    /// fraction of samples inside the grid.
    pub density: Vec<f64>,
    /// Standard error of each bin's density, from the spread over statistics batches.
    pub stderr: Vec<f64>,
    /// Finite samples recorded.
    pub samples: u64,
    /// Samples below the grid.
    pub underflow: u64,
    /// Samples at or above the grid's right edge.
    pub overflow: u64,
    /// Non-finite values of the quantity at a finite state (excluded from all statistics).
    pub invalid: u64,
    /// Sample raw moments E\[q\], …, E\[q⁴\], mean, variance and kurtosis m₄/m₂² (3 for a
    /// Gaussian), each with its standard error from the spread over statistics batches.
    pub moments: Moments<Estimate>,
    /// Smallest finite value seen.
    pub min: f64,
    /// Largest finite value seen.
    pub max: f64,
    /// The time-step bias of the moments and the density, estimated by
    /// Richardson extrapolation from a paired run at 2·dt (`None` when not estimated, as in
    /// the pilot run or with [`McConfig::bias_fraction`](crate::mc::McConfig::bias_fraction) 0).
    pub time_step_bias: Option<TimeStepBias>,
}

/// The estimated discretisation bias S_dt − S_exact ≈ (S_2dt − S_dt)/(2ᵖ − 1) of a
/// quantity's statistics (p the scheme's weak order), from statistics batches run twice,
/// at dt and at 2·dt with the same random streams; each value's standard error comes from
/// the spread of the per-batch differences. A bias smaller than about twice its standard
/// error is not resolved: only `|value| + 2·stderr` bounds it (see [`Estimate::resolved`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeStepBias {
    /// The weak order p used in the extrapolation.
    pub order: u32,
    /// The coarse time step (2·dt).
    pub coarse_dt: f64,
    /// The paired statistics batches it was estimated from.
    pub pairs: u64,
    /// Bias of each moment (raw moments, mean, variance, kurtosis).
    pub moments: Moments<Estimate>,
    /// Bias of each bin's density.
    pub density: Vec<f64>,
    /// Standard error of each bin's density bias.
    pub density_stderr: Vec<f64>,
}

/// Moments of one batch (or of the whole run) from the power sums of q − `shift` over `n`
/// samples: the mean about `shift` (kept apart, so that standard errors and bias pairs are
/// computed exactly as from the shifted sums), variance, kurtosis, and the raw moments about
/// zero.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BatchMoments {
    /// E\[q\] − shift.
    pub(crate) shifted_mean: f64,
    pub(crate) variance: f64,
    pub(crate) kurtosis: f64,
    /// E\[q\], …, E\[q⁴\].
    pub(crate) raw: [f64; 4],
}

fn central(sums: &[f64; 4], n: f64, shift: f64) -> BatchMoments {
    let m1 = sums[0] / n;
    let r2 = sums[1] / n;
    let r3 = sums[2] / n;
    let r4 = sums[3] / n;
    let var = r2 - m1 * m1;
    let c4 = r4 - 4.0 * m1 * r3 + 6.0 * m1 * m1 * r2 - 3.0 * m1.powi(4);
    // E[q^k] = Σ_j C(k, j) shift^(k−j) E[(q − shift)^j].
    let c = shift;
    let raw = [
        c + m1,
        c * c + 2.0 * c * m1 + r2,
        c.powi(3) + 3.0 * c * c * m1 + 3.0 * c * r2 + r3,
        c.powi(4) + 4.0 * c.powi(3) * m1 + 6.0 * c * c * r2 + 4.0 * c * r3 + r4,
    ];
    BatchMoments {
        shifted_mean: m1,
        variance: var,
        kurtosis: c4 / (var * var),
        raw,
    }
}

/// Combines one quantity's batch statistics, in batch order, into a [`QuantityHistogram`].
///
/// Standard errors treat the batches as independent replicas; the density's uses the ratio
/// estimator Var(p̂_j) ≈ B/(B−1) Σ_b (c_bj − p̂_j n_b)² / (N w)², which allows batches of
/// unequal size (batches that lost trajectories to blow-ups).
pub(crate) fn finalize(
    name: &str,
    is_state: bool,
    grid: Grid,
    batches: &[&QuantityBatch],
) -> QuantityHistogram {
    let nb = batches.len() as f64;
    let w = grid.width();
    let shift = 0.5 * (grid.lo + grid.hi);
    let finite = |b: &QuantityBatch| b.counts.iter().sum::<u64>() + b.under + b.over;
    let n_b: Vec<f64> = batches.iter().map(|b| finite(b) as f64).collect();
    let n: f64 = n_b.iter().sum();
    let mut counts = vec![0u64; grid.bins];
    let (mut under, mut over, mut invalid) = (0, 0, 0);
    let mut sums = [0.0; 4];
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for b in batches {
        for (c, bc) in counts.iter_mut().zip(&b.counts) {
            *c += bc;
        }
        under += b.under;
        over += b.over;
        invalid += b.invalid;
        for k in 0..4 {
            sums[k] += b.sums[k];
        }
        min = min.min(b.min);
        max = max.max(b.max);
    }
    let density: Vec<f64> = counts.iter().map(|&c| c as f64 / (n * w)).collect();
    let stderr: Vec<f64> = (0..grid.bins)
        .map(|j| {
            let f = counts[j] as f64 / n;
            let ss: f64 = batches
                .iter()
                .zip(&n_b)
                .map(|(b, &nb_)| {
                    let d = b.counts[j] as f64 - f * nb_;
                    d * d
                })
                .sum();
            (nb / (nb - 1.0) * ss).sqrt() / (n * w)
        })
        .collect();
    let all = central(&sums, n, shift);
    // Per-batch values for the moments' standard errors.
    // Batches that lost every trajectory to blow-ups carry no moments.
    let per_batch: Vec<BatchMoments> = batches
        .iter()
        .zip(&n_b)
        .filter(|(_, &k)| k > 0.0)
        .map(|(b, &k)| central(&b.sums, k, shift))
        .collect();
    let spread = |pick: &dyn Fn(&BatchMoments) -> f64| -> f64 {
        let m = per_batch.len() as f64;
        if m < 2.0 {
            return f64::INFINITY;
        }
        let mean = per_batch.iter().map(pick).sum::<f64>() / m;
        let ss: f64 = per_batch.iter().map(|t| (pick(t) - mean).powi(2)).sum();
        (ss / (m - 1.0) / m).sqrt()
    };
    let raw = std::array::from_fn(|k| Estimate {
        value: all.raw[k],
        stderr: spread(&|t| t.raw[k]),
    });
    QuantityHistogram {
        name: name.to_string(),
        is_state,
        grid,
        density,
        stderr,
        samples: n as u64,
        underflow: under,
        overflow: over,
        invalid,
        moments: Moments {
            raw,
            mean: Estimate {
                value: shift + all.shifted_mean,
                stderr: spread(&|t| t.shifted_mean),
            },
            variance: Estimate {
                value: all.variance,
                stderr: spread(&|t| t.variance),
            },
            kurtosis: Estimate {
                value: all.kurtosis,
                stderr: spread(&|t| t.kurtosis),
            },
        },
        min,
        max,
        time_step_bias: None,
    }
}

/// Per-batch moments of a quantity on `grid` (its mean about the grid's centre), `None` for
/// a batch without finite samples.
pub(crate) fn batch_moments(b: &QuantityBatch, grid: Grid) -> Option<BatchMoments> {
    let n = (b.counts.iter().sum::<u64>() + b.under + b.over) as f64;
    (n > 0.0).then(|| central(&b.sums, n, 0.5 * (grid.lo + grid.hi)))
}

/// The per-bin densities of one batch.
pub(crate) fn batch_density(b: &QuantityBatch, grid: Grid) -> Option<Vec<f64>> {
    let n = (b.counts.iter().sum::<u64>() + b.under + b.over) as f64;
    let w = grid.width();
    (n > 0.0).then(|| b.counts.iter().map(|&c| c as f64 / (n * w)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::record::accumulator::Accumulator;

    #[test]
    fn bins_edges_and_out_of_range_values() {
        let g = Grid::new(0.0, 1.0, 4).unwrap();
        let vals = [
            0.0,
            0.2499,
            0.25,
            0.99,
            1.0,
            -0.1,
            f64::NAN,
            0.5,
            -7.0,
            f64::INFINITY,
            -1e-18,
        ];
        let rec = [
            true, true, true, true, true, true, true, false, true, true, true,
        ];
        let mut a = Accumulator::new(g, vals.len());
        a.add(&vals, &rec);
        let out = a.finish();
        assert_eq!(out.counts, vec![2, 1, 0, 1]);
        assert_eq!((out.under, out.over, out.invalid), (3, 1, 2));
        assert_eq!((out.min, out.max), (-7.0, 1.0));
    }

    #[test]
    fn moments_and_errors_of_known_batches() {
        // Two batches of the values {0, 1, 2, 3} and {1, 2, 3, 4}.
        let g = Grid::new(0.0, 5.0, 5).unwrap();
        let mut a = Accumulator::new(g, 4);
        a.add(&[0.0, 1.0, 2.0, 3.0], &[true; 4]);
        let mut b = Accumulator::new(g, 2);
        b.add(&[1.0, 2.0], &[true; 2]);
        b.add(&[3.0, 4.0], &[true; 2]);
        let s = finalize("q", true, g, &[&a.finish(), &b.finish()]);
        assert_eq!(s.samples, 8);
        approx::assert_relative_eq!(s.moments.mean.value, 2.0, epsilon = 1e-14);
        // Batch means 1.5 and 2.5: standard error 0.5.
        approx::assert_relative_eq!(s.moments.mean.stderr, 0.5, epsilon = 1e-14);
        approx::assert_relative_eq!(s.moments.variance.value, 1.5, epsilon = 1e-14);
        // Values 0,1,1,2,2,3,3,4 about 2: m4 = (16+1+1+0+0+1+1+16)/8 = 4.5, m2 = 1.5.
        approx::assert_relative_eq!(s.moments.kurtosis.value, 2.0, epsilon = 1e-14);
        // Raw moments about zero: E x² = 44/8, E x³ = 136/8, E x⁴ = 452/8; the batches'
        // E x⁴ are 98/4 and 354/4, so its standard error is half their difference, 32.
        let raw: Vec<f64> = s.moments.raw.iter().map(|e| e.value).collect();
        for (r, e) in raw.iter().zip([2.0, 5.5, 17.0, 56.5]) {
            approx::assert_relative_eq!(*r, e, epsilon = 1e-12);
        }
        approx::assert_relative_eq!(s.moments.raw[3].stderr, 32.0, epsilon = 1e-12);
        assert_eq!(s.density, vec![1.0 / 8.0, 0.25, 0.25, 0.25, 1.0 / 8.0]);
        // Bin 0: counts 1 and 0 against 0.5 expected each: B/(B−1)·(0.25+0.25) = 1 → 1/8.
        approx::assert_relative_eq!(s.stderr[0], 1.0 / 8.0, epsilon = 1e-14);
        approx::assert_relative_eq!(s.stderr[2], 0.0, epsilon = 1e-14);
    }
}
