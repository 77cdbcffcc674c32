//! Batch-means statistics the judges and the reliability statistics share: the mean and
//! standard error of per-batch (or per-pair) values, and the pairing of a 2·dt batch with its
//! dt batch.

use crate::mc::record::batch::BatchSummary;
use crate::stats::Estimate;

/// The mean and standard error of per-pair values.
pub(crate) fn mean_se(values: &[f64]) -> Estimate {
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

/// The fine batch with the index of the coarse batch `c`. Fine batches are normally in index
/// order from 0 (a run, or shards merged in order): direct lookup, the search only if that
/// ever does not hold.
pub(crate) fn paired<'a>(fine: &[&'a BatchSummary], c: &BatchSummary) -> Option<&'a BatchSummary> {
    fine.get(c.index as usize)
        .filter(|f| f.index == c.index)
        .or_else(|| fine.iter().find(|f| f.index == c.index))
        .copied()
}
