//! Statistics batches: the trajectories of one batch run together (structure-of-arrays),
//! streaming their samples into histograms and power sums; batches run in parallel and come
//! back in batch order.

use std::ops::Range;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::base::cancel::Cancel;
use crate::mc::compile::eval::Simd;
use crate::mc::compile::scheme::Plan;
use crate::mc::compile::tally::{ImpactTally, WallBatch};
use crate::mc::kernel::rng::Increments;
use crate::mc::record::crossings::CrossingBatch;
use crate::mc::record::histogram::QuantityBatch;
use crate::mc::record::recorder::{record_samples, Histograms, Recorder};
use crate::mc::record::sample::{record_batch, Blown, LastState, Observed};
use crate::mc::settings::{ParamValue, RunSettings};
use crate::mc::step::mech_step::fast_rows;
use crate::mc::step::state::BatchState;

/// A trajectory whose state stopped being finite: it is left out of every statistic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlowUp {
    /// The trajectory's index in the run (its random stream is `(seed, trajectory)`).
    pub trajectory: u64,
    /// The step count at which the non-finite state was found (a sample point).
    pub step: u64,
    /// The last finite state recorded, and the step it was recorded at (`None` if the
    /// trajectory never reached a sample point finite).
    pub last_finite: Option<LastState>,
    /// The model's parameter values, so the report is self-contained.
    pub params: Vec<ParamValue>,
}

/// One statistics batch's contribution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct BatchSummary {
    pub(crate) index: u64,
    /// Trajectories recorded (lanes minus blow-ups).
    pub(crate) recorded: u64,
    /// Impacts of the recorded trajectories after the burn-in.
    pub(crate) impacts: u64,
    /// Steps of the recorded trajectories after the burn-in whose impacts at a wall could not
    /// all be resolved, the overshoot reflected back into the domain.
    #[serde(default)]
    pub(crate) folded: u64,
    pub(crate) quantities: Vec<QuantityBatch>,
    pub(crate) blowups: Vec<BlowUp>,
    /// The impact statistics at each wall (none for a model without one).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) walls: Vec<WallBatch>,
    /// The up-crossings of the quantities with levels.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) crossings: Vec<CrossingBatch>,
}

/// Runs the lanes `part` of statistics batch `index` (their trajectories from their start),
/// leaving out the lanes in `excluded` (indexed from the part's first); returns the part's
/// summary and the lanes that blew up, or `None` when `cancel` was set (checked at every
/// sample point).
fn run_part_once(
    plan: &Plan,
    st: &RunSettings,
    (index, part): (u64, Range<usize>),
    excluded: &[bool],
    cancel: &Cancel,
) -> Option<(BatchSummary, Vec<usize>)> {
    run_part_with(
        plan,
        st,
        (index, part),
        excluded,
        cancel,
        Some(Simd::detect()),
    )
}

/// [`run_part_once`] with the recording fused with the fast mechanical kernel where it
/// applies, both run with the vector extension `fused` (detected on this CPU), or
/// (`None`) the general recording: the same bits either way (tested).
fn run_part_with(
    plan: &Plan,
    st: &RunSettings,
    (index, part): (u64, Range<usize>),
    excluded: &[bool],
    cancel: &Cancel,
    fused: Option<Simd>,
) -> Option<(BatchSummary, Vec<usize>)> {
    let lanes = part.len();
    let first = index * st.lanes as u64 + part.start as u64;
    let spread = plan.initial_spread();
    let mut b = BatchState::new(plan, &spread, st.seed, first, lanes, st.increments);
    if let Some(simd) = fused {
        b.set_simd(simd);
    }
    b.advance(plan, st.burn_in_steps, st.dt);
    b.impacts.fill(0);
    b.folded.fill(0);
    let mut record: Vec<bool> = excluded.iter().map(|e| !e).collect();
    let mut histograms = Histograms::new(plan, st, lanes);
    if st.has_barrier {
        let mut tally = ImpactTally::new(plan.barriers.len(), record.clone(), st.impact_speeds);
        // The crossings of a walled state's levels need each impact's sample interval.
        if histograms.crossings.has_walls() {
            tally.log_rows();
        }
        b.tally = Some(tally);
    }
    let mut blown: Vec<Blown> = Vec::new();
    // The recording fused with the fast mechanical kernel when it applies (`sample.rs`),
    // the same bits as the general recording.
    let kinds = fused.and(Observed::recognise(plan.observables.program()));
    let fused = match kinds {
        Some(kinds) => record_batch(
            plan,
            st,
            &kinds,
            &mut b,
            &mut histograms.acc,
            &mut histograms.crossings,
            &mut record,
            &mut blown,
            cancel,
        )?,
        None => false,
    };
    if !fused {
        record_samples(
            plan,
            st,
            &mut b,
            &mut histograms,
            &mut record,
            &mut blown,
            cancel,
        )?;
    }
    let impacts = (0..lanes)
        .filter(|&i| record[i])
        .map(|i| b.impacts[i])
        .sum();
    let folded = (0..lanes).filter(|&i| record[i]).map(|i| b.folded[i]).sum();
    let recorded = record.iter().filter(|&&r| r).count() as u64;
    let blowups = blown
        .iter()
        .map(|(i, step, last)| BlowUp {
            trajectory: first + *i as u64,
            step: *step,
            last_finite: last.clone(),
            params: st.params.clone(),
        })
        .collect();
    let blown = blown.into_iter().map(|b| b.0).collect();
    let (quantities, crossings) = histograms.finish();
    let summary = BatchSummary {
        index,
        recorded,
        impacts,
        folded,
        quantities,
        blowups,
        walls: b.tally.take().map_or_else(Vec::new, ImpactTally::finish),
        crossings,
    };
    Some((summary, blown))
}

/// Lanes of a part of a statistics batch on the fused fast path: the unit of work the
/// threads share. A batch's lanes are independent (each trajectory its own stream), so such a
/// batch is run as parts of at most this many lanes (one group of the AVX-512 kernel) and
/// their summaries merged in lane order: 4 parts of a batch of 128, so that 2 threads finish
/// within a part of each other (with whole batches, 7 + 7 on 2 threads, one waited up to a
/// batch, 12 % of the run) and a workstation's cores have work beyond the batch count.
const PART_LANES: usize = 32;

/// The lanes of each part of a batch of `plan` with settings `st` (see [`parts`]):
/// [`PART_LANES`] where the fast mechanical kernel runs with the fused recording (it
/// advances 32 lanes a group whatever the batch); the whole batch elsewhere, where the tape's
/// lane evaluator and the general recording pay their dispatch once per call over the lanes
/// (parts of 32 made Platen's scheme on cubic_damping_two_noises 3.5 times slower). Fixed by
/// the plan and the settings alone: the numbers do not depend on the threads, the shards or
/// the driver.
fn part_lanes(plan: &Plan, st: &RunSettings) -> usize {
    let fused = fast_rows(plan, st.increments == Increments::ThreePoint)
        && Observed::recognise(plan.observables.program()).is_some();
    if fused {
        PART_LANES.min(st.lanes).max(1)
    } else {
        st.lanes.max(1)
    }
}

/// The lane ranges of the parts of a batch of `plan` with settings `st`, in lane order.
fn parts(plan: &Plan, st: &RunSettings) -> impl Iterator<Item = Range<usize>> {
    let (lanes, size) = (st.lanes, part_lanes(plan, st));
    (0..lanes)
        .step_by(size)
        .map(move |a| a..(a + size).min(lanes))
}

/// Runs the lanes `part` of statistics batch `index`; if trajectories blow up, runs the part
/// again without them (their streams are their own, so the others repeat exactly) so that
/// none of their samples count. `None` when `cancel` was set before the part finished.
fn run_part(
    plan: &Plan,
    st: &RunSettings,
    (index, part): (u64, Range<usize>),
    cancel: &Cancel,
) -> Option<BatchSummary> {
    let mut excluded = vec![false; part.len()];
    let (summary, blown) = run_part_once(plan, st, (index, part.clone()), &excluded, cancel)?;
    if blown.is_empty() {
        return Some(summary);
    }
    let blowups = summary.blowups;
    for &i in &blown {
        excluded[i] = true;
    }
    let (mut again, _) = run_part_once(plan, st, (index, part), &excluded, cancel)?;
    again.blowups = blowups;
    Some(again)
}

/// Runs statistics batch `index`: its parts one after the other, merged in lane order (the
/// same bits as the parallel drivers). `None` when `cancel` was set before it finished.
#[cfg(test)]
pub(crate) fn run_batch(
    plan: &Plan,
    st: &RunSettings,
    index: u64,
    cancel: &Cancel,
) -> Option<BatchSummary> {
    let parts: Option<Vec<BatchSummary>> = parts(plan, st)
        .map(|p| run_part(plan, st, (index, p), cancel))
        .collect();
    Some(BatchSummary::merge(parts?))
}

impl BatchSummary {
    /// The summary of a batch from those of its parts, in lane order: counts and power sums
    /// added part by part, extremes taken, blow-ups in lane order.
    fn merge(parts: Vec<BatchSummary>) -> BatchSummary {
        let mut parts = parts.into_iter();
        let mut all = parts.next().expect("a batch has at least one part");
        for p in parts {
            debug_assert_eq!(p.index, all.index, "parts of one batch");
            all.recorded += p.recorded;
            all.impacts += p.impacts;
            all.folded += p.folded;
            for (q, pq) in all.quantities.iter_mut().zip(p.quantities) {
                q.merge(pq);
            }
            for (w, pw) in all.walls.iter_mut().zip(&p.walls) {
                w.merge(pw);
            }
            for (c, pc) in all.crossings.iter_mut().zip(&p.crossings) {
                c.merge(pc);
            }
            all.blowups.extend(p.blowups);
        }
        all
    }
}

/// The parts of the batches `jobs` (each `(run, batch)`), run in parallel and merged per
/// batch as soon as its last part ends (so that a batch's parts are not all held until the
/// whole run ends: with 4 parts a batch, they were 4 copies of every histogram of every
/// batch, 1.25 kB a bin of a default run); `done` hears about each batch then. The
/// summaries come back in the order of `jobs`. `None` when `cancel` was set before every
/// part finished (parts not yet started are not started).
fn run_jobs<'a, R: Copy + Sync>(
    plan: &Plan,
    jobs: &[(R, u64)],
    settings: &(dyn Fn(R) -> (&'a RunSettings, [&'static str; 2]) + Sync),
    done: &(dyn Fn() + Sync),
    cancel: &Cancel,
) -> Option<Vec<BatchSummary>> {
    use std::sync::Mutex;
    // (job, the part's place in its job, its lanes)
    let split: Vec<(usize, usize, Range<usize>)> = jobs
        .iter()
        .enumerate()
        .flat_map(|(j, &(run, _))| {
            parts(plan, settings(run).0)
                .enumerate()
                .map(move |(k, p)| (j, k, p))
        })
        .collect();
    // Each job's part count, from the split itself (its parts are adjacent).
    let mut counts = vec![0; jobs.len()];
    for (j, _, _) in &split {
        counts[*j] += 1;
    }
    // Per job: its finished parts until the last one ends, then the merged summary.
    type Slot = (Vec<Option<BatchSummary>>, Option<BatchSummary>);
    let slots: Vec<Mutex<Slot>> = counts
        .iter()
        .map(|&n| Mutex::new(((0..n).map(|_| None).collect(), None)))
        .collect();
    // One task per part: rayon would otherwise run runs of adjacent parts as one task that
    // no idle thread can take a part from (seen: one thread done 120 ms before the other).
    split
        .par_iter()
        .with_max_len(1)
        .map(|(j, k, part)| {
            if cancel.is_cancelled() {
                return None;
            }
            let (run, index) = jobs[*j];
            let (st, phase) = settings(run);
            crate::base::timeline::mark(phase[0]);
            let b = run_part(plan, st, (index, part.clone()), cancel)?;
            crate::base::timeline::mark(phase[1]);
            let mut slot = slots[*j].lock().unwrap_or_else(|p| p.into_inner());
            slot.0[*k] = Some(b);
            if slot.0.iter().all(Option::is_some) {
                // In lane order, whichever part ended last: the same bits as a serial run.
                let parts = std::mem::take(&mut slot.0).into_iter().flatten().collect();
                slot.1 = Some(BatchSummary::merge(parts));
                drop(slot);
                done();
            }
            Some(())
        })
        .collect::<Option<()>>()?;
    Some(
        slots
            .into_iter()
            .map(|m| {
                m.into_inner()
                    .unwrap_or_else(|p| p.into_inner())
                    .1
                    .expect("every part of every job ended")
            })
            .collect(),
    )
}

/// Runs the batches in `range` in parallel (their parts, see [`PART_LANES`]); the summaries
/// come back in batch order. `done` hears about every finished batch. `None` when `cancel`
/// was set before every batch finished (parts not yet started are not started).
pub(crate) fn run_batches(
    plan: &Plan,
    st: &RunSettings,
    range: std::ops::Range<u64>,
    done: &(dyn Fn() + Sync),
    cancel: &Cancel,
) -> Option<Vec<BatchSummary>> {
    let jobs: Vec<((), u64)> = range.map(|k| ((), k)).collect();
    let settings = |()| (st, ["mc: part start", "mc: part end"]);
    run_jobs(plan, &jobs, &settings, done, cancel)
}

/// [`run_batches`] of `range` with the settings `st` and of `coarse_range` with `coarse`
/// (the time-step bias run), as one parallel loop: the threads share the two runs' parts
/// (run one after the other, 7 + 7 batches on 2 threads left a thread idle at the end of
/// each), the batches taken alternately while both runs have some (a coarse batch costs more
/// than a fine one when the step count per sample point is odd and stays the same at 2·dt,
/// and its longer flights meet the barrier more often: with all the fine batches in one half
/// of the loop and all the coarse ones in the other, one thread waited 8 % of the run for
/// the other). The summaries come back in batch order, each run's apart.
pub(crate) fn run_batch_pair(
    plan: &Plan,
    (st, range): (&RunSettings, std::ops::Range<u64>),
    (coarse, coarse_range): (&RunSettings, std::ops::Range<u64>),
    done: &(dyn Fn() + Sync),
    cancel: &Cancel,
) -> Option<(Vec<BatchSummary>, Vec<BatchSummary>)> {
    let jobs = alternate(range, coarse_range);
    let settings = |is_coarse: bool| {
        if is_coarse {
            (coarse, ["mc: 2dt part start", "mc: 2dt part end"])
        } else {
            (st, ["mc: part start", "mc: part end"])
        }
    };
    let all = run_jobs(plan, &jobs, &settings, done, cancel)?;
    let (mut fine, mut coarse_part) = (Vec::new(), Vec::new());
    for (&(is_coarse, _), b) in jobs.iter().zip(all) {
        if is_coarse {
            coarse_part.push(b);
        } else {
            fine.push(b);
        }
    }
    Some((fine, coarse_part))
}

/// The batches of two runs as `(coarse, index)` jobs, a fine one and a coarse one in turn
/// while both runs have some, then the rest; each run's in batch order.
fn alternate(fine: std::ops::Range<u64>, coarse: std::ops::Range<u64>) -> Vec<(bool, u64)> {
    let (mut f, mut c) = (fine.peekable(), coarse.peekable());
    let mut jobs = Vec::new();
    while f.peek().is_some() || c.peek().is_some() {
        jobs.extend(f.next().map(|k| (false, k)));
        jobs.extend(c.next().map(|k| (true, k)));
    }
    jobs
}

/// [`run_batches`] for a run nobody can cancel.
pub(crate) fn run_batches_to_end(
    plan: &Plan,
    st: &RunSettings,
    range: std::ops::Range<u64>,
    done: &(dyn Fn() + Sync),
) -> Vec<BatchSummary> {
    run_batches(plan, st, range, done, &Cancel::new())
        .expect("a run whose flag nobody holds is never cancelled")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::config::Resolved;
    use crate::mc::record::histogram::Grid;
    use crate::mc::settings::QuantitySpec;
    use crate::mc::{BurnIn, McConfig};
    use crate::model::load_model;

    /// Fine and coarse batches in turn, then the longer run's rest, each run's in order and
    /// every batch once.
    #[test]
    fn alternate_takes_the_runs_in_turn() {
        assert_eq!(
            alternate(0..3, 0..2),
            [(false, 0), (true, 0), (false, 1), (true, 1), (false, 2)]
        );
        assert_eq!(
            alternate(2..3, 0..3),
            [(false, 2), (true, 0), (true, 1), (true, 2)]
        );
        assert_eq!(alternate(0..2, 0..0), [(false, 0), (false, 1)]);
        assert!(alternate(0..0, 0..0).is_empty());
    }

    /// The plan and settings of a run of the model at `path` with `lanes` lanes per batch,
    /// grids fixed (no pilot), narrow enough that some values fall outside.
    fn settings(path: &str, lanes: usize, samples: u64, dt: f64) -> (Plan, RunSettings) {
        let model = load_model(path.as_ref()).unwrap().bind(&[]).unwrap();
        let config = McConfig {
            trajectories: 2 * lanes as u64,
            lanes,
            samples,
            dt,
            spacing: 3.0 * dt,
            burn_in: BurnIn::Time(1.0),
            ..McConfig::default()
        };
        let specs = crate::mc::compile::scheme::impact_specs(&model).unwrap();
        let Resolved {
            plan,
            names,
            steps_per_sample,
            burn_in_steps,
            batches,
            ..
        } = config
            .resolve_with(
                &model,
                &crate::mc::compile::scheme::read(&model).unwrap(),
                specs,
            )
            .unwrap();
        let grid = |k: usize| Grid::new(-2.0 - k as f64, 1.5 + k as f64, 37 + k).unwrap();
        let st = RunSettings {
            model: model.name.clone(),
            params: vec![],
            scheme: plan.kind,
            increments: config.increments,
            dt,
            steps_per_sample,
            burn_in_steps,
            samples_per_trajectory: samples,
            lanes,
            batches,
            seed: 9,
            evaluator: None,
            periodic: None,
            has_barrier: !plan.barriers.is_empty(),
            barriers: vec![],
            quantities: names
                .iter()
                .enumerate()
                .map(|(k, (n, s))| QuantitySpec {
                    name: n.clone(),
                    is_state: *s,
                    grid: grid(k),
                    levels: vec![],
                })
                .collect(),
            bias_batches: 0,
            impact_speeds: None,
        };
        (plan, st)
    }

    /// The general recording hands the recorder every sample point once, in order, with the
    /// step count after it; a lane is left out from the point its state stops being finite,
    /// stays out, and is listed as blown up in the order the recorder saw it go.
    #[test]
    fn a_recorder_hears_every_sample_point_in_order() {
        use crate::mc::record::recorder::SamplePoint;
        struct Points {
            seen: Vec<SamplePoint>,
            dropped: Vec<usize>,
            last: Vec<bool>,
        }
        impl Recorder for Points {
            type Summary = Points;
            fn sample(&mut self, at: SamplePoint, x: &[f64], v: &[f64], record: &[bool]) {
                for i in 0..record.len() {
                    let finite = x[i].is_finite() && v[i].is_finite();
                    assert!(self.last[i] || !record[i], "lane {i} recorded again");
                    assert!(!record[i] || finite, "lane {i} recorded not finite");
                    if self.last[i] && !record[i] {
                        assert!(!finite, "lane {i} left out while finite");
                        self.dropped.push(i);
                    }
                }
                self.last = record.to_vec();
                self.seen.push(at);
            }
            fn finish(self) -> Points {
                self
            }
        }
        let dir = env!("CARGO_MANIFEST_DIR");
        let lanes = 50;
        let path = format!("{dir}/tests/models/runaway_damping.sde");
        let (plan, st) = settings(&path, lanes, 200, 0.05);
        let spread = plan.initial_spread();
        let mut b = BatchState::new(&plan, &spread, st.seed, 0, lanes, st.increments);
        b.advance(&plan, st.burn_in_steps, st.dt);
        let mut record = vec![true; lanes];
        let mut blown = Vec::new();
        let mut points = Points {
            seen: vec![],
            dropped: vec![],
            last: vec![true; lanes],
        };
        let cancel = Cancel::new();
        record_samples(
            &plan,
            &st,
            &mut b,
            &mut points,
            &mut record,
            &mut blown,
            &cancel,
        )
        .unwrap();
        let points = points.finish();
        assert_eq!(points.seen.len() as u64, st.samples_per_trajectory);
        for (s, p) in points.seen.iter().enumerate() {
            let step = st.burn_in_steps + (s as u64 + 1) * st.steps_per_sample;
            let want = SamplePoint {
                index: s as u64,
                of: st.samples_per_trajectory,
                step,
            };
            assert_eq!(*p, want);
        }
        assert!(!points.dropped.is_empty(), "no blow-up tested");
        let blown_lanes: Vec<usize> = blown.iter().map(|b| b.0).collect();
        assert_eq!(points.dropped, blown_lanes);
        assert_eq!(points.last, record);
    }

    /// A batch run part by part in parallel (on the fused fast path three parts of 80 lanes:
    /// 32, 32 and 16; elsewhere the whole batch), by either driver, is the batch run part
    /// after part on one thread, bit for bit, blow-ups and their reruns included; and the
    /// progress hears about each batch once.
    #[test]
    fn parallel_parts_give_the_sequential_batch() {
        let dir = env!("CARGO_MANIFEST_DIR");
        let mut blowups = 0;
        for (path, samples, count) in [
            ("models/vibro_duffing.sde", 60, 3),
            ("tests/models/runaway_damping.sde", 200, 3),
            // Platen's scheme (not of the mechanical form): one part.
            ("models/cubic_damping_two_noises.sde", 20, 1),
        ] {
            let (plan, st) = settings(&format!("{dir}/{path}"), 80, samples, 0.05);
            assert_eq!(parts(&plan, &st).count(), count, "{path}");
            let cancel = Cancel::new();
            let text = |b: &BatchSummary| format!("{b:?}");
            let one: Vec<String> = (0..3)
                .map(|k| {
                    let b = run_batch(&plan, &st, k, &cancel).unwrap();
                    blowups += b.blowups.len();
                    text(&b)
                })
                .collect();
            let ticks = std::sync::atomic::AtomicU64::new(0);
            let tick = || {
                ticks.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            };
            let all = run_batches(&plan, &st, 0..3, &tick, &cancel).unwrap();
            assert_eq!(all.iter().map(text).collect::<Vec<_>>(), one, "{path}");
            let (fine, coarse) =
                run_batch_pair(&plan, (&st, 1..3), (&st, 0..2), &tick, &cancel).unwrap();
            assert_eq!(
                fine.iter().map(text).collect::<Vec<_>>(),
                one[1..],
                "{path}"
            );
            assert_eq!(
                coarse.iter().map(text).collect::<Vec<_>>(),
                one[..2],
                "{path}"
            );
            assert_eq!(ticks.into_inner(), 3 + 4, "{path}");
        }
        assert!(blowups > 0, "no blow-up tested");
    }

    /// The recording fused with the fast kernel gives the batch's summary bit for bit as the
    /// general recording does, at every vector width: lanes in whole groups and blocks and
    /// not (50 = one group of 32, two blocks of 8, two lanes alone), sample counts across
    /// chunks and quarters, values beyond the grids, blow-ups and the batch's rerun without
    /// them.
    #[test]
    fn the_fused_recording_is_the_general_one_bit_for_bit() {
        let dir = env!("CARGO_MANIFEST_DIR");
        let cases = [
            (format!("{dir}/models/vibro_duffing.sde"), 50, 37, 0.01),
            (format!("{dir}/models/vibro_duffing.sde"), 64, 3, 0.01),
            (format!("{dir}/models/linear.sde"), 40, 70, 0.02),
            (
                format!("{dir}/models/vibro_impact_duffing.sde"),
                32,
                21,
                0.01,
            ),
            // Runs away where the damping turns negative: blow-ups.
            (
                format!("{dir}/tests/models/runaway_damping.sde"),
                50,
                200,
                0.05,
            ),
        ];
        let mut blowups = 0;
        for (path, lanes, samples, dt) in cases {
            let (plan, st) = settings(&path, lanes, samples, dt);
            let kinds = Observed::recognise(plan.observables.program());
            assert!(kinds.is_some(), "{path}: observables not recognised");
            let cancel = Cancel::new();
            let none = vec![false; lanes];
            for index in 0..2 {
                let (general, blown) =
                    run_part_with(&plan, &st, (index, 0..lanes), &none, &cancel, None).unwrap();
                blowups += blown.len();
                let mut excluded = vec![false; lanes];
                for &i in &blown {
                    excluded[i] = true;
                }
                let (again, _) =
                    run_part_with(&plan, &st, (index, 0..lanes), &excluded, &cancel, None).unwrap();
                // Debug's shortest round-trip text: equal strings are equal bits (NaN
                // included, which `==` would not call equal).
                let text = |b: &BatchSummary| format!("{b:?}");
                for simd in Simd::available() {
                    let run = |ex: &[bool]| {
                        run_part_with(&plan, &st, (index, 0..lanes), ex, &cancel, Some(simd))
                            .unwrap()
                    };
                    let (fused, fused_blown) = run(&none);
                    assert_eq!(fused_blown, blown, "{path} {simd:?}");
                    assert_eq!(text(&fused), text(&general), "{path} {simd:?}");
                    assert_eq!(text(&run(&excluded).0), text(&again), "{path} {simd:?}");
                }
            }
        }
        assert!(blowups > 0, "no blow-up tested");
    }
}
