//! The impact statistics of a run with a barrier: the rate with its error and time-step
//! bias, and the steps whose impacts ran past what one step resolves.

use serde::{Deserialize, Serialize};

use crate::mc::stats::reliability::WallStats;
use crate::stats::Estimate;

/// Impact statistics of a run with a barrier.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpactStats {
    /// Impacts counted over the recording time of all recorded trajectories.
    pub count: u64,
    /// Impacts per unit time per trajectory.
    pub rate: Estimate,
    /// The rate's time-step bias r_dt − r, by the moments' Richardson estimate from the
    /// batches paired with the 2·dt run ([`TimeStepBias`](crate::mc::TimeStepBias)); `None`
    /// when the run estimated no bias.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_step_bias: Option<Estimate>,
    /// Steps whose impacts at a wall ran past the events one step may resolve, the overshoot
    /// reflected back into the domain (the general schemes' bound on chattering; 0 on the
    /// splitting scheme, whose flights resolve their impacts exactly).
    #[serde(default)]
    pub folded: u64,
    /// The statistics of each wall (the plan's barriers in order, a strip's lower first):
    /// rate, mean impact speed, mean dissipated power and the impact-speed density.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub walls: Vec<WallStats>,
}
