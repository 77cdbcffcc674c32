//! The one memory limit of a run: the ceiling every method checks its estimated peak memory
//! against before any work (Monte Carlo's histograms, the grid solver's factorisation), so that
//! a run that cannot fit is refused at once instead of killed by the kernel halfway.

/// Most memory a run may plan for, in bytes (4 GiB): Monte Carlo's preflight holds its
/// histograms to it, and [`memory_limit_bytes`] never exceeds it.
///
/// ```
/// assert_eq!(fpsolve::base::limits::MEMORY_LIMIT_BYTES, 4.0 * 1024.0 * 1024.0 * 1024.0);
/// ```
pub const MEMORY_LIMIT_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;

/// The memory a solve may use on this machine: the memory available (`MemAvailable` of
/// `/proc/meminfo`), at most [`MEMORY_LIMIT_BYTES`]; that limit where the machine does not
/// say.
///
/// ```
/// use fpsolve::base::limits::{memory_limit_bytes, MEMORY_LIMIT_BYTES};
/// let limit = memory_limit_bytes();
/// assert!(limit > 0.0 && limit <= MEMORY_LIMIT_BYTES);
/// ```
pub fn memory_limit_bytes() -> f64 {
    let cap = MEMORY_LIMIT_BYTES;
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(cap, |kb| (kb * 1024.0).min(cap))
}
