//! What a statistics batch reports about its trajectories: the [`Recorder`] trait, the
//! general recording loop that drives one ([`record_samples`]) and the stationary run's
//! recorder, streaming histograms and power sums per quantity ([`Histograms`]).

use crate::base::cancel::Cancel;
use crate::mc::compile::eval::{BatchKernel, Scratch, NO_TIME};
use crate::mc::compile::impact::Crossing;
use crate::mc::compile::scheme::Plan;
use crate::mc::compile::tally::ImpactMark;
use crate::mc::record::accumulator::Accumulator;
use crate::mc::record::crossings::{CrossingBatch, LevelCrossings, WallLevel};
use crate::mc::record::histogram::QuantityBatch;
use crate::mc::record::sample::{Blown, LastState};
use crate::mc::settings::RunSettings;
use crate::mc::step::state::BatchState;

/// Where a batch's trajectories are when a [`Recorder`] hears from them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SamplePoint {
    /// The sample point, counted from 0 after the burn-in.
    pub(crate) index: u64,
    /// Sample points per trajectory in the run.
    pub(crate) of: u64,
    /// Time steps taken since the start, burn-in included.
    pub(crate) step: u64,
}

impl SamplePoint {
    /// The quarter of the recording this point falls in (0–3): the stationarity verdict
    /// compares the first quarter with the last.
    pub(crate) fn quarter(&self) -> usize {
        ((self.index as u128 * 4) / self.of as u128) as usize
    }
}

/// What a statistics batch reports about its lanes at each sample point: the states
/// (structure-of-arrays) and which lanes are still recorded (finite so far, not excluded).
///
/// The batch owns the time stepping, the blow-up detection and the cancellation; a recorder
/// only looks. The stationary run records histograms and power sums ([`Histograms`]). The
/// planned recorders plug in the same way: a first-passage recorder keeps, per lane, the
/// first sample point at which the state left the safe domain (run with one step per sample
/// point when the passage time must be resolved to a step), and a time-slice recorder of a
/// transient run (no burn-in) keeps one histogram per sample point instead of one per
/// quarter. Each returns its own [`Recorder::Summary`], reduced over batches in batch order
/// as the histograms are, so that its results stay independent of the threads.
pub(crate) trait Recorder {
    /// What the recorder hands back for the batch.
    type Summary;

    /// Hears the lanes' states `x`, `v` at sample point `at`; `record[i]` is false for a lane
    /// that is left out (excluded from the start, or blown up at or before this point).
    fn sample(&mut self, at: SamplePoint, x: &[f64], v: &[f64], record: &[bool]);

    /// The batch's summary, after the last sample point.
    fn finish(self) -> Self::Summary;

    /// Hears, before [`Recorder::sample`], each lane's impacts since the previous sample
    /// point when the batch logs them; ignored unless the recorder needs them.
    fn impacts(&mut self, _marks: Option<Vec<ImpactMark>>) {}
}

/// The stationary run's recorder: each quantity's histogram and power sums, by quarter of
/// the recording (the states, then the observables in the plan's order).
pub(crate) struct Histograms<'a> {
    observables: &'a dyn BatchKernel,
    /// One accumulator per quantity; the fused recording (`sample.rs`) writes them directly.
    pub(crate) acc: Vec<Accumulator>,
    obs: Vec<f64>,
    scratch: Scratch,
    lanes: usize,
    /// The up-crossings of the quantities with levels; the fused recording counts them too.
    pub(crate) crossings: LevelCrossings,
    /// The lanes' impacts since the previous sample point, when logged.
    marks: Option<Vec<ImpactMark>>,
}

/// The walls of the plan's states as the crossing counters see them (a pass-through
/// barrier does not fold a path and is left out).
pub(crate) fn wall_levels(plan: &Plan) -> Vec<WallLevel> {
    plan.barriers
        .iter()
        .enumerate()
        .filter(|(_, b)| b.crossing == Crossing::Reflects)
        .map(|(k, b)| WallLevel {
            wall: k as u8,
            state: b.state,
            at: b.at,
            lower: b.side > 0.0,
        })
        .collect()
}

impl<'a> Histograms<'a> {
    /// Empty histograms on the run's grids for a batch of `lanes` lanes.
    pub(crate) fn new(plan: &'a Plan, st: &RunSettings, lanes: usize) -> Histograms<'a> {
        let acc: Vec<Accumulator> = st
            .quantities
            .iter()
            .map(|q| Accumulator::new(q.grid, lanes))
            .collect();
        let n_obs = st.quantities.len() - 2;
        Histograms {
            observables: plan.observables.as_ref(),
            acc,
            obs: vec![0.0; n_obs * lanes],
            scratch: Scratch::new(),
            lanes,
            crossings: LevelCrossings::new(&st.quantities, lanes, &wall_levels(plan)),
            marks: None,
        }
    }
}

impl Recorder for Histograms<'_> {
    type Summary = (Vec<QuantityBatch>, Vec<CrossingBatch>);

    fn sample(&mut self, at: SamplePoint, x: &[f64], v: &[f64], record: &[bool]) {
        let window = at.quarter();
        for a in &mut self.acc {
            a.set_window(window);
        }
        self.observables
            .eval_batch(NO_TIME, x, v, &mut self.obs, &mut self.scratch);
        self.acc[0].add(x, record);
        self.acc[1].add(v, record);
        let lanes = self.lanes;
        for (j, a) in self.acc[2..].iter_mut().enumerate() {
            a.add(&self.obs[j * lanes..(j + 1) * lanes], record);
        }
        if self.crossings.any() {
            let counted: Vec<usize> = self.crossings.quantities().collect();
            for (k, q) in counted.into_iter().enumerate() {
                let g = match q {
                    0 => x,
                    1 => v,
                    j => &self.obs[(j - 2) * lanes..(j - 1) * lanes],
                };
                self.crossings
                    .add(k, at.index, g, record, self.marks.as_deref());
            }
        }
    }

    fn impacts(&mut self, marks: Option<Vec<ImpactMark>>) {
        self.marks = marks;
    }

    fn finish(self) -> (Vec<QuantityBatch>, Vec<CrossingBatch>) {
        let hist = self.acc.into_iter().map(Accumulator::finish).collect();
        (hist, self.crossings.finish())
    }
}

/// Runs the batch `b` (past its burn-in) through the run's sample points, handing the
/// states at each to `recorder`. A lane whose state stops being finite is left out from that
/// point on (`record[i] = false`) and listed in `blown` with its last finite sampled state.
/// `None` when `cancel` was set.
pub(crate) fn record_samples<R: Recorder>(
    plan: &Plan,
    st: &RunSettings,
    b: &mut BatchState,
    recorder: &mut R,
    record: &mut [bool],
    blown: &mut Vec<Blown>,
    cancel: &Cancel,
) -> Option<()> {
    let lanes = record.len();
    let (mut prev_x, mut prev_v) = (vec![0.0; lanes], vec![0.0; lanes]);
    let mut wrapped = vec![0.0; if st.periodic.is_some() { lanes } else { 0 }];
    let mut step = st.burn_in_steps;
    for s in 0..st.samples_per_trajectory {
        if cancel.is_cancelled() {
            return None;
        }
        prev_x.copy_from_slice(&b.x);
        prev_v.copy_from_slice(&b.v);
        b.advance(plan, st.steps_per_sample, st.dt);
        let prev_step = step;
        step += st.steps_per_sample;
        for i in 0..lanes {
            if record[i] && !(b.x[i].is_finite() && b.v[i].is_finite()) {
                record[i] = false;
                let last = (s > 0).then(|| LastState {
                    step: prev_step,
                    state: [prev_x[i], prev_v[i]],
                });
                blown.push((i, step, last));
            }
        }
        let at = SamplePoint {
            index: s,
            of: st.samples_per_trajectory,
            step,
        };
        let marks = b.tally.as_mut().and_then(|t| t.take_marks(1, lanes));
        recorder.impacts(marks);
        match st.periodic {
            // The periodic state recorded in its window; the trajectory runs on.
            Some(p) => {
                wrapped.copy_from_slice(if p.state == 0 { &b.x } else { &b.v });
                p.wrap(&mut wrapped);
                let (x, v) = if p.state == 0 {
                    (&wrapped[..], &b.v[..])
                } else {
                    (&b.x[..], &wrapped[..])
                };
                recorder.sample(at, x, v, record);
            }
            None => recorder.sample(at, &b.x, &b.v, record),
        }
    }
    Some(())
}
