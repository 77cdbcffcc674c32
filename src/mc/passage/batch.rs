//! One batch of first-passage paths, stepped a block of [`BLOCK_STEPS`] steps at a time: on
//! the fast mechanical path one kernel call per block that keeps the state after each step
//! ([`BatchState::advance_rows`]), otherwise [`BatchState::advance`] step by step. The
//! states are the same either way, so are the exit times. Each block is screened
//! (`screen.rs`) lane by lane, then part by part of [`PART_STEPS`] steps; only the steps of
//! a part the screen does not clear are tested one by one (`locate.rs`), in order, as if
//! every step were.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

use super::locate::left_within;
use super::screen::Spans;
use crate::mc::compile::scheme::Plan;
use crate::mc::kernel::rng::Increments;
use crate::mc::step::state::BatchState;
use crate::model::BoundSafe;
use crate::symbolic::Interval;

/// Lanes per batch of paths (each path with its own random stream).
pub const PASSAGE_LANES: usize = 64;

/// Steps per block: one kernel call, the state after each kept (126 steps of 64 lanes:
/// 126 KiB of states, within the second-level cache). A multiple of three, so that every
/// block starts at a new three-point draw (where a lane may start a new path).
pub(super) const BLOCK_STEPS: usize = 126;

/// Steps per part of a block: the screen's finer unit where a block's box is not cleared.
pub(super) const PART_STEPS: usize = 16;

/// What a batch needs of the run.
pub(super) struct Exits<'a> {
    pub(super) safe: &'a BoundSafe,
    pub(super) start: [f64; 2],
    pub(super) horizon: f64,
    pub(super) seed: u64,
    pub(super) increments: Increments,
}

/// Paths waiting to run, handed out in index order to whichever batch asks first (a path's
/// exit time depends on its own random stream alone, not on the batch or lane that runs it).
pub(super) struct Queue {
    next: AtomicU64,
    end: u64,
}

impl Queue {
    /// Paths `paths`.
    pub(super) fn new(paths: Range<u64>) -> Queue {
        Queue {
            next: AtomicU64::new(paths.start),
            end: paths.end,
        }
    }

    /// The next `n` paths, or fewer when fewer are left; `None` when none is.
    fn take(&self, n: u64) -> Option<Range<u64>> {
        let start = self.next.fetch_add(n, Ordering::Relaxed);
        (start < self.end).then(|| start..(start + n).min(self.end))
    }
}

/// How a path's test within a block ended.
enum Outcome {
    /// It left within step `step` of the block, at the fraction `at` of it.
    Left { step: usize, at: f64 },
    /// Its state after step `step` stopped being finite, or its quantity a number.
    BlewUp,
}

/// The states of a block: before it and after each of its steps (lane i after step j at
/// `x[j * lanes + i]`), and the working memory of its tests.
struct Block {
    before_x: Vec<f64>,
    before_v: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    spans: Spans,
    quantity: Vec<f64>,
    enclosure: Vec<Interval>,
}

impl Exits<'_> {
    /// Runs paths taken from `queue` at step `h` until it is empty: their indices and exit
    /// times (`f64::INFINITY`: censored at the horizon; NaN: blew up), in no set order.
    ///
    /// On the fast mechanical path a batch's [`PASSAGE_LANES`] lanes take the paths in
    /// turn: a lane whose path has ended starts the next one from the queue at the end of
    /// the block ([`BatchState::restart_lane`]), as that path would start in a batch of its
    /// own, so no lane idles while paths wait. Elsewhere the paths run in batches of
    /// [`PASSAGE_LANES`], each until its last path ends.
    pub(super) fn drain(&self, plan: &Plan, queue: &Queue, h: f64) -> Vec<(u64, f64)> {
        let mut exits = Vec::new();
        let spread = plan.initial_spread();
        while let Some(first) = queue.take(PASSAGE_LANES as u64) {
            let lanes = first.end - first.start;
            let mut b = BatchState::new(
                plan,
                &spread,
                self.seed,
                first.start,
                lanes as usize,
                self.increments,
            );
            let refill = b.has_fast_rows(plan);
            self.batch(&mut b, plan, first, refill.then_some(queue), h, &mut exits);
        }
        exits
    }

    /// Runs batch `b`, lanes started at paths `first`, until its paths end, starting paths
    /// taken from `queue` (when given) in the lanes of those that ended; their indices and
    /// exit times to `exits`.
    fn batch(
        &self,
        b: &mut BatchState,
        plan: &Plan,
        first: Range<u64>,
        queue: Option<&Queue>,
        h: f64,
        exits: &mut Vec<(u64, f64)>,
    ) {
        let spread = plan.initial_spread();
        let lanes = b.x.len();
        b.x.fill(self.start[0]);
        b.v.fill(self.start[1]);
        let mut blk = Block {
            before_x: Vec::with_capacity(lanes),
            before_v: Vec::with_capacity(lanes),
            x: vec![0.0; BLOCK_STEPS * lanes],
            v: vec![0.0; BLOCK_STEPS * lanes],
            spans: Spans::default(),
            quantity: Vec::new(),
            enclosure: Vec::new(),
        };
        // Each lane's path and the batch's step it started at (`None`: no path left).
        let mut path: Vec<Option<(u64, u64)>> = first.map(|p| Some((p, 0))).collect();
        // Whether paths may wait in the queue.
        let mut waiting = queue.is_some();
        let steps = (self.horizon / h).ceil() as u64;
        let mut done = 0;
        loop {
            // Whole blocks while paths may wait (a multiple of three steps, so the lanes
            // restart at a new three-point draw), then up to the last path's horizon.
            let left = path
                .iter()
                .flatten()
                .map(|&(_, s)| steps - (done - s))
                .max();
            let Some(left) = left else { break };
            let n = if waiting {
                BLOCK_STEPS
            } else {
                left.min(BLOCK_STEPS as u64) as usize
            };
            blk.step(b, plan, n, h);
            for (i, lane) in path.iter_mut().enumerate() {
                let Some((p, s)) = *lane else { continue };
                // This path's steps before the block, and its steps within it.
                let own = done - s;
                let m = (steps - own).min(n as u64) as usize;
                let t = match self.lane(&mut blk, i, m, h) {
                    Some(Outcome::BlewUp) => f64::NAN,
                    Some(Outcome::Left { step, at }) => {
                        let t = ((own + step as u64) as f64 + at) * h;
                        // A path that leaves after the horizon within the last step is
                        // censored.
                        if t <= self.horizon {
                            t
                        } else {
                            f64::INFINITY
                        }
                    }
                    None if own + m as u64 == steps => f64::INFINITY,
                    None => continue,
                };
                exits.push((p, t));
                *lane = None;
                let Some(next) = queue.filter(|_| waiting).and_then(|q| q.take(1)) else {
                    waiting = false;
                    continue;
                };
                // Only the fast path has paths waiting, and blocks of whole draws.
                let restarted = b.restart_lane(plan, &spread, self.seed, next.start, i);
                assert!(restarted, "a lane restarts at the start of a block");
                b.x[i] = self.start[0];
                b.v[i] = self.start[1];
                *lane = Some((next.start, done + n as u64));
            }
            done += n as u64;
        }
    }

    /// Lane `i`'s test over the `n` steps of the block: whether and where it left.
    fn lane(&self, blk: &mut Block, i: usize, n: usize, h: f64) -> Option<Outcome> {
        let parts = blk.spans.parts();
        let whole = (1..parts).fold(blk.spans.get(0, i), |s, p| s.union(blk.spans.get(p, i)));
        if whole.inside(self.safe, h, &mut blk.enclosure) {
            return None;
        }
        // The quantity after the last step tested, carried to the next.
        let mut carried: Option<(usize, f64)> = None;
        for p in 0..parts {
            if blk.spans.get(p, i).inside(self.safe, h, &mut blk.enclosure) {
                continue;
            }
            for j in p * PART_STEPS..((p + 1) * PART_STEPS).min(n) {
                let end = blk.state(j, i);
                let q1 = self.safe.quantity_with(end, &mut blk.quantity);
                if q1.is_nan() || !end[0].is_finite() || !end[1].is_finite() {
                    return Some(Outcome::BlewUp);
                }
                let a = blk.before_step(j, i);
                let q0 = match carried {
                    Some((k, q)) if k + 1 == j => q,
                    _ => self.safe.quantity_with(a, &mut blk.quantity),
                };
                if let Some(at) = left_within(self.safe, (a, q0), (end, q1), h, &mut blk.quantity) {
                    return Some(Outcome::Left { step: j, at });
                }
                carried = Some((j, q1));
            }
        }
        None
    }
}

impl Block {
    /// Advances the batch by `n` steps of `h`, keeping the states.
    fn step(&mut self, b: &mut BatchState, plan: &Plan, n: usize, h: f64) {
        let lanes = b.x.len();
        self.before_x.clone_from(&b.x);
        self.before_v.clone_from(&b.v);
        let (x, v) = (&mut self.x[..n * lanes], &mut self.v[..n * lanes]);
        if !b.advance_rows(plan, n as u64, 1, h, x, v) {
            for j in 0..n {
                b.advance(plan, 1, h);
                x[j * lanes..(j + 1) * lanes].copy_from_slice(&b.x);
                v[j * lanes..(j + 1) * lanes].copy_from_slice(&b.v);
            }
        }
        let simd = b.simd();
        self.spans
            .fill(simd, &self.before_x, &self.before_v, x, v, PART_STEPS);
    }

    /// Lane `i`'s state after step `j`.
    fn state(&self, j: usize, i: usize) -> [f64; 2] {
        let at = j * self.before_x.len() + i;
        [self.x[at], self.v[at]]
    }

    /// Lane `i`'s state before step `j`.
    fn before_step(&self, j: usize, i: usize) -> [f64; 2] {
        if j == 0 {
            [self.before_x[i], self.before_v[i]]
        } else {
            self.state(j - 1, i)
        }
    }
}
