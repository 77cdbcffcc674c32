//! A Monte Carlo estimate with its standard error: the number type of every statistic a run
//! reports.

use serde::{Deserialize, Serialize};

/// A Monte Carlo estimate with its standard error (infinite when fewer than two statistics
/// batches have samples).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The estimate.
    pub value: f64,
    /// Its standard error (from the spread over statistics batches).
    pub stderr: f64,
}

impl Estimate {
    /// Whether the value is resolved from zero: |value| > 2·stderr.
    ///
    /// ```
    /// use fpsolve::stats::Estimate;
    /// assert!(Estimate { value: 0.3, stderr: 0.1 }.resolved());
    /// assert!(!Estimate { value: 0.1, stderr: 0.1 }.resolved());
    /// ```
    pub fn resolved(&self) -> bool {
        self.stderr.is_finite() && self.value.abs() > 2.0 * self.stderr
    }

    /// The bound |value| + 2·stderr below which an unresolved value lies.
    ///
    /// ```
    /// use fpsolve::stats::Estimate;
    /// assert_eq!(Estimate { value: -0.1, stderr: 0.1 }.bound(), 0.30000000000000004);
    /// ```
    pub fn bound(&self) -> f64 {
        self.value.abs() + 2.0 * self.stderr
    }
}
