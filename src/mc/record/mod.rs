//! What a statistics batch reports: its trajectories run and sampled into streaming
//! histograms and power sums, one summary per batch, batches reduced in batch order.
//! The histograms' bins and their finalisation into densities live here too.

pub(crate) mod accumulator;
pub(crate) mod batch;
pub(crate) mod crossings;
pub(crate) mod histogram;
pub(crate) mod recorder;
pub(crate) mod sample;
