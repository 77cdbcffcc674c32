//! Level up-crossings counted from the trajectories at the sample points: a lane up-crosses
//! level u between two consecutive samples g₀, g₁ of a quantity when g₀ < u ≤ g₁ (the sign
//! of g − u changes from below). Each sample is reduced to its level index, the number of
//! levels at or below it, so a change of index between samples up-crosses the levels in
//! between, one range added to a difference array; no pass over the levels per sample.
//!
//! Counting at the sample points misses a down- and up-crossing pair within one spacing (and
//! sees a crossing where the path only touched the level and came back), an error of order
//! the spacing: the same crossings are also counted on every other sample point (twice the
//! spacing), from which the run states the spacing's bias by first-order Richardson
//! extrapolation (`stats/crossings.rs`). An impact changes the velocity, not the position,
//! so a position crossing across an impact is counted once, as any other.

use serde::{Deserialize, Serialize};

use crate::mc::settings::QuantitySpec;

/// The up-crossings of one quantity's levels in a batch (or part of one).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct CrossingBatch {
    /// The quantity's place in the run's quantities.
    pub(crate) quantity: usize,
    /// Up-crossings of each level between consecutive sample points.
    pub(crate) up: Vec<u64>,
    /// Up-crossings of each level between the sample points 0, 2, 4, … (twice the spacing).
    pub(crate) up_wide: Vec<u64>,
}

impl CrossingBatch {
    /// Adds `other` (the next part of the batch).
    pub(crate) fn merge(&mut self, other: &CrossingBatch) {
        for (a, b) in self.up.iter_mut().zip(&other.up) {
            *a += b;
        }
        for (a, b) in self.up_wide.iter_mut().zip(&other.up_wide) {
            *a += b;
        }
    }
}

/// A lane without a previous sample (the first, or one not recorded).
const NONE: u32 = u32::MAX;

/// One quantity's counter.
struct Counter {
    quantity: usize,
    levels: Vec<f64>,
    /// Each lane's level index at the previous sample point, and at the previous even one.
    prev: Vec<u32>,
    prev_wide: Vec<u32>,
    /// Difference arrays of the counts (one longer than the levels).
    diff: Vec<i64>,
    diff_wide: Vec<i64>,
}

impl Counter {
    #[inline(always)]
    fn index(&self, g: f64) -> u32 {
        if g.is_nan() {
            NONE
        } else {
            self.levels.partition_point(|&u| u <= g) as u32
        }
    }
}

/// Adds the up-crossings from `prev` to `now` to `diff` and moves `prev` on.
#[inline(always)]
fn step(diff: &mut [i64], prev: &mut u32, now: u32) {
    if *prev != NONE && now != NONE && now > *prev {
        diff[*prev as usize] += 1;
        diff[now as usize] -= 1;
    }
    *prev = now;
}

/// The up-crossing counters of a batch's quantities that have levels.
pub(crate) struct LevelCrossings {
    counters: Vec<Counter>,
}

impl LevelCrossings {
    /// Counters for the quantities of `specs` with levels, over `lanes` lanes.
    pub(crate) fn new(specs: &[QuantitySpec], lanes: usize) -> LevelCrossings {
        LevelCrossings {
            counters: specs
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.levels.is_empty())
                .map(|(q, s)| Counter {
                    quantity: q,
                    levels: s.levels.clone(),
                    prev: vec![NONE; lanes],
                    prev_wide: vec![NONE; lanes],
                    diff: vec![0; s.levels.len() + 1],
                    diff_wide: vec![0; s.levels.len() + 1],
                })
                .collect(),
        }
    }

    /// Whether any quantity has levels.
    pub(crate) fn any(&self) -> bool {
        !self.counters.is_empty()
    }

    /// The places (in the run's quantities) of the quantities counted.
    pub(crate) fn quantities(&self) -> impl Iterator<Item = usize> + '_ {
        self.counters.iter().map(|c| c.quantity)
    }

    /// Hears the values `g` of the `k`-th counted quantity at sample point `sample` (counted
    /// from 0 after the burn-in); `record[i]` false for a lane left out.
    pub(crate) fn add(&mut self, k: usize, sample: u64, g: &[f64], record: &[bool]) {
        let c = &mut self.counters[k];
        let even = sample.is_multiple_of(2);
        for (i, (&g, &r)) in g.iter().zip(record).enumerate() {
            let now = if r { c.index(g) } else { NONE };
            step(&mut c.diff, &mut c.prev[i], now);
            if even {
                step(&mut c.diff_wide, &mut c.prev_wide[i], now);
            }
        }
    }

    /// The counts of each quantity.
    pub(crate) fn finish(self) -> Vec<CrossingBatch> {
        let counts = |diff: &[i64]| {
            let mut run = 0i64;
            diff[..diff.len() - 1]
                .iter()
                .map(|d| {
                    run += d;
                    run as u64
                })
                .collect()
        };
        self.counters
            .into_iter()
            .map(|c| CrossingBatch {
                quantity: c.quantity,
                up: counts(&c.diff),
                up_wide: counts(&c.diff_wide),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::record::histogram::Grid;

    fn spec(levels: Vec<f64>) -> QuantitySpec {
        QuantitySpec {
            name: "z".into(),
            is_state: true,
            grid: Grid::new(-1.0, 1.0, 2).unwrap(),
            levels,
        }
    }

    /// From below to at or above a level is an up-crossing; down-crossings, touching from
    /// above, lanes left out and the first sample are not; every other sample point sees
    /// only the crossings between even points.
    #[test]
    fn up_crossings_are_counted_between_samples() {
        let specs = [spec(vec![]), spec(vec![-1.0, 0.0, 1.0])];
        let mut c = LevelCrossings::new(&specs, 2);
        assert_eq!(c.quantities().collect::<Vec<_>>(), [1]);
        // Lane 0: −2 → 0.5 → −0.5 → 0 → 3; lane 1 left out at sample 2.
        let path = [
            [-2.0, 0.2],
            [0.5, 1.5],
            [-0.5, 2.0],
            [0.0, -5.0],
            [3.0, 5.0],
        ];
        let rec = [
            [true, true],
            [true, true],
            [true, false],
            [true, true],
            [true, true],
        ];
        for (s, (g, r)) in path.iter().zip(&rec).enumerate() {
            c.add(0, s as u64, g, r);
        }
        let b = c.finish();
        // Lane 0: levels −1, 0 at s=1; 0 at s=3; 1 at s=4. Lane 1: 1 at s=1; −1, 0, 1 at s=4.
        assert_eq!(b[0].up, [2, 3, 3]);
        // Even points: lane 0 −2 → −0.5 → 3: −1, then 0, 1; lane 1: 0.2 → (out) → 5: none.
        assert_eq!(b[0].up_wide, [1, 1, 1]);
    }
}
