//! The one moments vocabulary of every method: raw moments up to the fourth and the statistics
//! built on them.
//!
//! EPC and the other density methods fill a [`Moments<f64>`]; Monte Carlo fills a
//! `Moments<Estimate>` (each value with its standard error), so a table or a comparison reads
//! the same field names whatever produced the numbers.

use serde::{Deserialize, Serialize};

/// Moments of one scalar quantity g: the raw moments E\[g\], …, E\[g⁴\] and the mean, variance
/// and kurtosis built from them. `T` is `f64` for a density method and an estimate with its
/// standard error for Monte Carlo.
///
/// A moment that does not exist (its integral diverges) is NaN, and so is every statistic
/// built on it; the producer says how many exist.
///
/// ```
/// use fpsolve::stats::Moments;
/// // A standard normal: E g = 0, E g² = 1, E g³ = 0, E g⁴ = 3.
/// let m = Moments::from_raw([0.0, 1.0, 0.0, 3.0]);
/// assert_eq!((m.mean, m.variance, m.kurtosis), (0.0, 1.0, 3.0));
/// assert_eq!(m.std_dev(), 1.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Moments<T = f64> {
    /// E\[g\], E\[g²\], E\[g³\], E\[g⁴\].
    pub raw: [T; 4],
    /// E\[g\].
    pub mean: T,
    /// Var\[g\] = E\[(g − mean)²\].
    pub variance: T,
    /// E\[(g − mean)⁴\] / Var\[g\]² (3 for a Gaussian).
    pub kurtosis: T,
}

impl Moments<f64> {
    /// The moments whose raw moments are `raw` = \[E g, E g², E g³, E g⁴\].
    ///
    /// ```
    /// use fpsolve::stats::Moments;
    /// // g uniform on {1, 3}: E g = 2, E g² = 5, E g³ = 14, E g⁴ = 41.
    /// let m = Moments::from_raw([2.0, 5.0, 14.0, 41.0]);
    /// assert_eq!((m.mean, m.variance, m.kurtosis), (2.0, 1.0, 1.0));
    /// ```
    pub fn from_raw(raw: [f64; 4]) -> Self {
        let [m1, m2, m3, m4] = raw;
        let variance = m2 - m1 * m1;
        let c4 = m4 - 4.0 * m1 * m3 + 6.0 * m1 * m1 * m2 - 3.0 * m1.powi(4);
        Moments {
            raw,
            mean: m1,
            variance,
            kurtosis: c4 / (variance * variance),
        }
    }

    /// √Var\[g\].
    ///
    /// ```
    /// use fpsolve::stats::Moments;
    /// assert_eq!(Moments::from_raw([1.0, 5.0, 13.0, 73.0]).std_dev(), 2.0);
    /// ```
    pub fn std_dev(&self) -> f64 {
        self.variance.sqrt()
    }

    /// The moments with every statistic that needs a raw moment beyond the first `existing`
    /// set to NaN: a moment that does not exist is never reported as a number.
    ///
    /// ```
    /// use fpsolve::stats::Moments;
    /// let m = Moments::from_raw([0.0, 1.0, 0.0, 3.0]).keep_existing(2);
    /// assert_eq!(m.variance, 1.0);
    /// assert!(m.raw[2].is_nan() && m.kurtosis.is_nan());
    /// ```
    pub fn keep_existing(mut self, existing: usize) -> Self {
        for (k, r) in self.raw.iter_mut().enumerate() {
            if k >= existing {
                *r = f64::NAN;
            }
        }
        if existing < 1 {
            self.mean = f64::NAN;
        }
        if existing < 2 {
            self.variance = f64::NAN;
        }
        if existing < 4 {
            self.kurtosis = f64::NAN;
        }
        self
    }
}
