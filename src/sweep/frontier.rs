//! What a solved point knows of its tail-threshold reference values, and the one point of a
//! range whose EPC reference values are worth computing while the points run in parallel
//! (the frontier); the walk in `thresholds.rs` reads both.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What a solved point knows of its own reference values.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum ReferenceRms {
    /// Not computed (an EPC point behind the frontier when it finished).
    Unknown,
    /// Computed: √E\[g²\] per quantity, or `None` when the point cannot be the reference
    /// (no reference solution, or a value not finite and positive).
    Known(Option<Vec<f64>>),
}

/// The first point of a range not yet known to have no reference: the one point whose EPC
/// reference values are worth computing while the points run in parallel.
pub(super) struct Frontier(AtomicUsize);

impl Frontier {
    /// A frontier at the first point of `range`.
    pub(super) fn at(range: &Range<usize>) -> Self {
        Frontier(AtomicUsize::new(range.start))
    }

    /// Whether point `index` is the frontier (its reference values are wanted).
    pub(super) fn wants(&self, index: usize) -> bool {
        self.0.load(Ordering::Acquire) == index
    }

    /// Point `index`, the frontier, has no reference: the frontier moves to the next point
    /// (which computes its values if it has not finished yet, and is solved by the walk
    /// otherwise).
    pub(super) fn passed(&self, index: usize) {
        // Only the frontier itself moves it, so the exchange cannot fail for another reason.
        let _ = self
            .0
            .compare_exchange(index, index + 1, Ordering::AcqRel, Ordering::Acquire);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frontier_moves_only_from_itself() {
        let frontier = Frontier::at(&(3..9));
        assert!(frontier.wants(3) && !frontier.wants(4));
        frontier.passed(5); // not the frontier: no move
        assert!(frontier.wants(3));
        frontier.passed(3);
        assert!(frontier.wants(4) && !frontier.wants(3));
    }
}
