//! From batch summaries to a result that says whether it can be trusted: the judges
//! (stationarity, time-step bias, impact rates), the verdicts as data and the [`McResult`].
//! Verdicts keep the statistics writable; only [`McResult::verdict`] turns one into an error.

pub(crate) mod impacts;
pub(crate) mod judge;
pub(crate) mod pairs;
pub(crate) mod reliability;
pub(crate) mod result;
pub(crate) mod verdict;

#[cfg(doc)]
use result::McResult;
