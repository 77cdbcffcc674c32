//! Where the time steps report an impact: [`ImpactSink`], the per-lane impact counts every
//! scheme keeps, and, when the run records them, the impact statistics of each wall
//! ([`ImpactTally`]): the speed |v| before each impact, the kinetic energy per unit mass it
//! takes, (v² − v′²)/2, and a histogram of the speeds. Impacts are rare next to steps, so the
//! tally is a branch on the cold path of every scheme and nothing in the step loops.
//!
//! The speeds and energies are summed per lane (in each lane's time order) and the lanes
//! added up in lane order when the batch ends, so that the sums do not depend on the order
//! the vector widths visit the lanes in: the fused kernel runs all steps of a group of lanes
//! before the next group, the lane evaluator every lane before the next step.
//!
//! When the run counts level crossings of a walled state, the tally also logs which sample
//! interval (the kernel's row, [`ImpactSink::set_row`]) each impact fell in, and gives them
//! back per interval and lane as [`ImpactMark`]s: a path that meets a wall between two sample
//! points folds there, and the crossings of the levels near the wall that the fold makes
//! cannot be seen from the two samples alone (`record/crossings.rs`).

use serde::{Deserialize, Serialize};

use crate::mc::record::histogram::Grid;

/// One wall's impact statistics over the recorded lanes of a batch (or part of one).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct WallBatch {
    /// Impacts at the wall.
    pub(crate) count: u64,
    /// Σ |v| before the impacts.
    pub(crate) speed_sum: f64,
    /// Σ (v² − v′²)/2 over the impacts, v′ the velocity after.
    pub(crate) loss_sum: f64,
    /// Impacts by speed in the bins of the run's speed grid, then one count beyond it (empty
    /// when the run has no speed grid).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) speed_counts: Vec<u64>,
}

impl WallBatch {
    /// Adds `other` (the next part of the batch, in lane order).
    pub(crate) fn merge(&mut self, other: &WallBatch) {
        self.count += other.count;
        self.speed_sum += other.speed_sum;
        self.loss_sum += other.loss_sum;
        for (a, b) in self.speed_counts.iter_mut().zip(&other.speed_counts) {
            *a += b;
        }
    }
}

/// The impact statistics of a batch's lanes at each wall (see the module documentation).
pub(crate) struct ImpactTally {
    /// Lanes whose impacts count (those not left out of the batch).
    active: Vec<bool>,
    walls: Vec<WallTally>,
    speeds: Option<Grid>,
    /// The impacts since the last [`ImpactTally::take_marks`] as (row, lane, wall), when
    /// logged ([`ImpactTally::log_rows`]).
    log: Option<Vec<(u32, u32, u8)>>,
}

/// The impacts of one lane in one sample interval: none (`ImpactMark::NONE`), or the walls
/// (indices in the plan's barriers) of the first and the last and how many there were.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ImpactMark {
    /// The number of impacts (0: none).
    pub(crate) count: u32,
    /// The wall of the first impact.
    pub(crate) first: u8,
    /// The wall of the last impact.
    pub(crate) last: u8,
}

impl ImpactMark {
    /// No impact.
    pub(crate) const NONE: ImpactMark = ImpactMark {
        count: 0,
        first: 0,
        last: 0,
    };

    /// The impacts of this interval followed by those of `next`.
    pub(crate) fn then(self, next: ImpactMark) -> ImpactMark {
        match (self.count, next.count) {
            (0, _) => next,
            (_, 0) => self,
            (a, b) => ImpactMark {
                count: a + b,
                first: self.first,
                last: next.last,
            },
        }
    }
}

struct WallTally {
    count: u64,
    speed: Vec<f64>,
    loss: Vec<f64>,
    bins: Vec<u64>,
}

impl ImpactTally {
    /// An empty tally of `walls` walls for the lanes `active` (false: left out), the speeds
    /// histogrammed on `speeds` when given.
    pub(crate) fn new(walls: usize, active: Vec<bool>, speeds: Option<Grid>) -> ImpactTally {
        let lanes = active.len();
        let bins = speeds.map_or(0, |g| g.bins + 1);
        ImpactTally {
            active,
            walls: (0..walls)
                .map(|_| WallTally {
                    count: 0,
                    speed: vec![0.0; lanes],
                    loss: vec![0.0; lanes],
                    bins: vec![0; bins],
                })
                .collect(),
            speeds,
            log: None,
        }
    }

    /// Logs from now on the sample interval of every impact, for [`ImpactTally::take_marks`].
    pub(crate) fn log_rows(&mut self) {
        self.log = Some(Vec::new());
    }

    /// The impacts logged since the last call, as one mark per row and lane (`rows` rows of
    /// `lanes` lanes, row-major); `None` when the tally does not log them.
    pub(crate) fn take_marks(&mut self, rows: usize, lanes: usize) -> Option<Vec<ImpactMark>> {
        let log = self.log.as_mut()?;
        let mut marks = vec![ImpactMark::NONE; rows * lanes];
        // In time order within a lane: the kernels keep a lane's steps in order.
        for &(row, lane, wall) in log.iter() {
            let m = &mut marks[row as usize * lanes + lane as usize];
            *m = m.then(ImpactMark {
                count: 1,
                first: wall,
                last: wall,
            });
        }
        log.clear();
        Some(marks)
    }

    /// Lane `lane` met wall `wall` in sample interval `row` with velocity `before`, leaving
    /// it with `after`.
    #[cold]
    #[inline(never)]
    fn record(&mut self, row: u32, lane: usize, wall: usize, before: f64, after: f64) {
        if !self.active[lane] {
            return;
        }
        if let Some(log) = &mut self.log {
            log.push((row, lane as u32, wall as u8));
        }
        let w = &mut self.walls[wall];
        let speed = before.abs();
        w.count += 1;
        w.speed[lane] += speed;
        w.loss[lane] += 0.5 * (before * before - after * after);
        if let Some(g) = &self.speeds {
            let k = ((speed - g.lo) / g.width()).floor();
            // Beyond the grid (or not a number): the last slot.
            let k = if k >= 0.0 && k < g.bins as f64 {
                k as usize
            } else {
                g.bins
            };
            w.bins[k] += 1;
        }
    }

    /// Each wall's statistics, the lanes' sums added in lane order.
    pub(crate) fn finish(self) -> Vec<WallBatch> {
        self.walls
            .into_iter()
            .map(|w| WallBatch {
                count: w.count,
                speed_sum: w.speed.iter().sum(),
                loss_sum: w.loss.iter().sum(),
                speed_counts: w.bins,
            })
            .collect()
    }
}

/// Where a scheme reports the impacts of a range of lanes: each lane's count, and the
/// batch's [`ImpactTally`] when the run records impact statistics.
pub(crate) struct ImpactSink<'a> {
    counts: &'a mut [u64],
    tally: Option<&'a mut ImpactTally>,
    /// The batch's lane of `counts[0]`.
    first: usize,
    /// The sample interval the impacts fall in, counted from the kernel call's first.
    row: u32,
}

impl<'a> ImpactSink<'a> {
    /// The sink of a whole batch.
    pub(crate) fn new(counts: &'a mut [u64], tally: Option<&'a mut ImpactTally>) -> Self {
        ImpactSink {
            counts,
            tally,
            first: 0,
            row: 0,
        }
    }

    /// The impacts from now on fall in sample interval `row` of the kernel call.
    #[inline(always)]
    pub(crate) fn set_row(&mut self, row: u64) {
        self.row = row as u32;
    }

    /// Lane `lane` (of this sink's range) met wall `wall` (its index in the plan's barriers)
    /// with velocity `before` and left it with `after`.
    #[inline(always)]
    pub(crate) fn hit(&mut self, lane: usize, wall: usize, before: f64, after: f64) {
        self.counts[lane] += 1;
        if let Some(t) = self.tally.as_deref_mut() {
            t.record(self.row, self.first + lane, wall, before, after);
        }
    }

    /// The sink of the lanes `r` of this one.
    pub(crate) fn slice(&mut self, r: std::ops::Range<usize>) -> ImpactSink<'_> {
        ImpactSink {
            first: self.first + r.start,
            counts: &mut self.counts[r],
            tally: self.tally.as_deref_mut(),
            row: self.row,
        }
    }

    /// The counts of this sink's lanes.
    #[cfg(test)]
    pub(crate) fn counts(&self) -> &[u64] {
        self.counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Impacts count per lane always; the tally takes the active lanes' speeds, energies and
    /// bins (beyond the grid into the last slot), the lanes' sums in lane order whatever
    /// order the impacts came in.
    #[test]
    fn a_tally_keeps_the_active_lanes_impacts() {
        let grid = Grid::new(-0.5, 2.5, 3).unwrap();
        let mut tally = ImpactTally::new(2, vec![true, false, true], Some(grid));
        let mut counts = vec![0; 3];
        let mut sink = ImpactSink::new(&mut counts, Some(&mut tally));
        sink.slice(2..3).hit(0, 1, 3.0, -1.5);
        sink.hit(0, 0, -0.7, 0.35);
        sink.hit(1, 0, -1.0, 1.0);
        sink.hit(0, 0, -1.2, 0.6);
        assert_eq!(sink.counts(), [2, 1, 1]);
        let walls = tally.finish();
        assert_eq!(walls[0].count, 2);
        assert_eq!(walls[0].speed_sum, 0.7 + 1.2);
        let loss = 0.5 * (0.49 - 0.35f64 * 0.35) + 0.5 * (1.44 - 0.36);
        assert!((walls[0].loss_sum - loss).abs() < 1e-15);
        assert_eq!(walls[0].speed_counts, [0, 2, 0, 0]);
        assert_eq!(walls[1].count, 1);
        assert_eq!(walls[1].speed_counts, [0, 0, 0, 1]);
        assert_eq!(walls[1].loss_sum, 0.5 * (9.0 - 2.25));
    }

    /// A logging tally gives each lane's impacts back per sample interval, first and last
    /// wall and count, and forgets them; one that does not log gives nothing.
    #[test]
    fn logged_impacts_come_back_per_interval() {
        let mut tally = ImpactTally::new(2, vec![true, true], None);
        let mut counts = vec![0; 2];
        assert!(tally.take_marks(1, 2).is_none());
        tally.log_rows();
        let mut sink = ImpactSink::new(&mut counts, Some(&mut tally));
        sink.set_row(1);
        sink.hit(0, 1, 2.0, -2.0);
        sink.slice(1..2).hit(0, 0, -1.0, 1.0);
        sink.hit(0, 0, -1.0, 1.0);
        let marks = tally.take_marks(2, 2).unwrap();
        let none = ImpactMark::NONE;
        let m = |count, first, last| ImpactMark { count, first, last };
        assert_eq!(marks, [none, none, m(2, 1, 0), m(1, 0, 0)]);
        assert_eq!(tally.take_marks(2, 2).unwrap(), [none; 4]);
    }
}
