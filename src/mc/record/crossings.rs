//! Level up-crossings counted from the trajectories at the sample points: a lane up-crosses
//! level u between two consecutive samples g₀, g₁ of a quantity when g₀ < u ≤ g₁ (the sign
//! of g − u changes from below). Each sample is reduced to its level index, the number of
//! levels at or below it, so a change of index between samples up-crosses the levels in
//! between, one range added to a difference array; no pass over the levels per sample.
//!
//! A path that meets a wall between two sample points folds there: from g₀ down to a lower
//! wall a and back up to g₁ it up-crosses every level in [a, g₁], not only those in
//! (g₀, g₁]; from g₀ up to an upper wall b and back down it up-crosses those in (g₀, b]. So
//! for the state a wall stands on, the interval's impacts ([`ImpactMark`]: the first wall,
//! the last, how many) decide what is counted: the first leg's crossings up to an upper wall,
//! the last leg's from a lower wall, a leg from the lower wall to the upper one in between,
//! and each further departure from (arrival at) the same wall as an up-crossing of the wall's
//! own level. The wall's level is thereby up-crossed once per impact, which is what Rice's
//! formula gives there (∫ v⁺ p dv at the wall: the flux leaving a lower wall, the flux
//! arriving at an upper one). A pass-through barrier does not fold the path and is not
//! counted so; neither is an observable of a walled state.
//!
//! What counting at the sample points still misses is a down- and up-crossing pair within
//! one spacing away from impacts (a velocity turning near a level), an error of order the
//! spacing: the same crossings are also counted on every other sample point (twice the
//! spacing), from which the run states the spacing's bias by first-order Richardson
//! extrapolation (`stats/reliability.rs`).

use serde::{Deserialize, Serialize};

use crate::mc::compile::tally::ImpactMark;
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

/// A wall the counted state stands on, as its levels see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WallLevel {
    /// The wall's index in the plan's barriers.
    pub(crate) wall: u8,
    /// The state the wall stands on.
    pub(crate) state: usize,
    /// Where it is.
    pub(crate) at: f64,
    /// Whether the state lives above it.
    pub(crate) lower: bool,
}

/// A wall of one counter: `lower`, and the level index `edge` where its levels start (a
/// lower wall: the first level at or above it) or end (an upper wall: one past the last at
/// or below it).
#[derive(Clone, Copy, Debug)]
struct Edge {
    wall: u8,
    lower: bool,
    edge: u32,
    /// Whether a level sits on the wall (its index `edge` below, `edge − 1` above).
    on_wall: bool,
}

/// One quantity's counter.
struct Counter {
    quantity: usize,
    levels: Vec<f64>,
    /// The walls the quantity (a state) stands on.
    walls: Vec<Edge>,
    /// Each lane's level index at the previous sample point, and at the previous even one.
    prev: Vec<u32>,
    prev_wide: Vec<u32>,
    /// Each lane's impacts since the previous even sample point.
    marks_wide: Vec<ImpactMark>,
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

/// One up-crossing of the levels `lo..hi` (nothing when empty), `times` times.
#[inline(always)]
fn range(diff: &mut [i64], lo: u32, hi: u32, times: i64) {
    if hi > lo {
        diff[lo as usize] += times;
        diff[hi as usize] -= times;
    }
}

/// Adds the up-crossings from `prev` to `now` to `diff` and moves `prev` on; `mark` holds
/// the interval's impacts, `walls` the counter's walls (see the module documentation).
#[inline(always)]
fn step(diff: &mut [i64], prev: &mut u32, now: u32, mark: ImpactMark, walls: &[Edge]) {
    if *prev != NONE && now != NONE {
        match fold(mark, walls) {
            Some((first, last)) => {
                if !first.lower {
                    range(diff, *prev, first.edge, 1);
                }
                if last.lower {
                    range(diff, last.edge, now, 1);
                }
                if first.lower && !last.lower {
                    range(diff, first.edge, last.edge, 1);
                }
                if first.wall == last.wall && mark.count > 1 && first.on_wall {
                    let k = if first.lower {
                        first.edge
                    } else {
                        first.edge - 1
                    };
                    range(diff, k, k + 1, i64::from(mark.count - 1));
                }
            }
            None => range(diff, *prev, now, 1),
        }
    }
    *prev = now;
}

/// The walls of the interval's first and last impacts when both are the counter's (the
/// path folded there); `None` without impacts (the walls are then not searched).
#[inline(always)]
fn fold(mark: ImpactMark, walls: &[Edge]) -> Option<(&Edge, &Edge)> {
    if mark.count == 0 {
        return None;
    }
    let find = |w: u8| walls.iter().find(|e| e.wall == w);
    Some((find(mark.first)?, find(mark.last)?))
}

/// The up-crossing counters of a batch's quantities that have levels.
pub(crate) struct LevelCrossings {
    counters: Vec<Counter>,
}

impl LevelCrossings {
    /// Counters for the quantities of `specs` with levels, over `lanes` lanes; `walls` the
    /// walls of the states (a pass-through barrier is not one).
    pub(crate) fn new(specs: &[QuantitySpec], lanes: usize, walls: &[WallLevel]) -> Self {
        LevelCrossings {
            counters: specs
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.levels.is_empty())
                .map(|(q, s)| {
                    let levels = s.levels.clone();
                    let walls = walls
                        .iter()
                        .filter(|w| w.state == q && s.is_state)
                        .map(|w| {
                            let edge = if w.lower {
                                levels.partition_point(|&u| u < w.at)
                            } else {
                                levels.partition_point(|&u| u <= w.at)
                            };
                            let on = if w.lower { edge } else { edge.wrapping_sub(1) };
                            Edge {
                                wall: w.wall,
                                lower: w.lower,
                                edge: edge as u32,
                                on_wall: levels.get(on) == Some(&w.at),
                            }
                        })
                        .collect();
                    Counter {
                        quantity: q,
                        walls,
                        prev: vec![NONE; lanes],
                        prev_wide: vec![NONE; lanes],
                        marks_wide: vec![ImpactMark::NONE; lanes],
                        diff: vec![0; levels.len() + 1],
                        diff_wide: vec![0; levels.len() + 1],
                        levels,
                    }
                })
                .collect(),
        }
    }

    /// Whether a counted state stands on a wall (the impacts' intervals are then needed).
    pub(crate) fn has_walls(&self) -> bool {
        self.counters.iter().any(|c| !c.walls.is_empty())
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
    /// from 0 after the burn-in); `record[i]` false for a lane left out; `marks[i]` lane i's
    /// impacts since the previous sample point (`None`: no wall's, or not logged).
    pub(crate) fn add(
        &mut self,
        k: usize,
        sample: u64,
        g: &[f64],
        record: &[bool],
        marks: Option<&[ImpactMark]>,
    ) {
        let c = &mut self.counters[k];
        let even = sample.is_multiple_of(2);
        for (i, (&g, &r)) in g.iter().zip(record).enumerate() {
            let now = if r { c.index(g) } else { NONE };
            let mark = marks.map_or(ImpactMark::NONE, |m| m[i]);
            step(&mut c.diff, &mut c.prev[i], now, mark, &c.walls);
            let wide = c.marks_wide[i].then(mark);
            if even {
                step(&mut c.diff_wide, &mut c.prev_wide[i], now, wide, &c.walls);
                c.marks_wide[i] = ImpactMark::NONE;
            } else {
                c.marks_wide[i] = wide;
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
        let mut c = LevelCrossings::new(&specs, 2, &[]);
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
            c.add(0, s as u64, g, r, None);
        }
        let b = c.finish();
        // Lane 0: levels −1, 0 at s=1; 0 at s=3; 1 at s=4. Lane 1: 1 at s=1; −1, 0, 1 at s=4.
        assert_eq!(b[0].up, [2, 3, 3]);
        // Even points: lane 0 −2 → −0.5 → 3: −1, then 0, 1; lane 1: 0.2 → (out) → 5: none.
        assert_eq!(b[0].up_wide, [1, 1, 1]);
    }

    fn mark(count: u32, first: u8, last: u8) -> ImpactMark {
        ImpactMark { count, first, last }
    }

    /// A path folded by a wall between two samples up-crosses the levels the fold passes:
    /// from a lower wall (wall 0 at 0) up to the sample, up to an upper wall (wall 1 at 1)
    /// from the sample, the whole strip on a leg from the lower wall to the upper one, and the
    /// wall's own level once more per further impact at the same wall; the wide count sees
    /// the two intervals' impacts together.
    #[test]
    fn a_fold_at_a_wall_up_crosses_the_levels_it_passes() {
        let specs = [spec(vec![0.0, 0.5, 1.0])];
        let walls = [
            WallLevel {
                wall: 0,
                state: 0,
                at: 0.0,
                lower: true,
            },
            WallLevel {
                wall: 1,
                state: 0,
                at: 1.0,
                lower: false,
            },
        ];
        let count = |path: &[f64], marks: &[ImpactMark]| {
            let mut c = LevelCrossings::new(&specs, 1, &walls);
            assert!(c.has_walls());
            for (s, (g, m)) in path.iter().zip(marks).enumerate() {
                c.add(0, s as u64, &[*g], &[true], Some(&[*m]));
            }
            let b = c.finish();
            (b[0].up.clone(), b[0].up_wide.clone())
        };
        let none = ImpactMark::NONE;
        // 0.8 → lower wall → 0.7: levels 0 and 0.5 (none without the mark).
        assert_eq!(count(&[0.8, 0.7], &[none, mark(1, 0, 0)]).0, [1, 1, 0]);
        assert_eq!(count(&[0.8, 0.7], &[none, none]).0, [0, 0, 0]);
        // 0.2 → upper wall → 0.3: levels 0.5 and 1.
        assert_eq!(count(&[0.2, 0.3], &[none, mark(1, 1, 1)]).0, [0, 1, 1]);
        // Three impacts at the lower wall: the wall's level twice more.
        assert_eq!(count(&[0.8, 0.7], &[none, mark(3, 0, 0)]).0, [3, 1, 0]);
        // Lower wall, then the upper one: the strip once.
        assert_eq!(count(&[0.8, 0.7], &[none, mark(2, 0, 1)]).0, [1, 1, 1]);
        // Upper wall, then the lower one: up to the upper wall from 0.2, up from the lower.
        assert_eq!(count(&[0.2, 0.7], &[none, mark(2, 1, 0)]).0, [1, 2, 1]);
        // Wide: 0.8 (s=0) → lower wall → 0.9 (s=1) → 0.6 (s=2): [0, 0.6] once.
        let (up, wide) = count(&[0.8, 0.9, 0.6], &[none, mark(1, 0, 0), none]);
        assert_eq!((up, wide), (vec![1, 1, 0], vec![1, 1, 0]));
    }
}
