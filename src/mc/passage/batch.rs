//! One batch of first-passage paths, stepped a block of [`BLOCK_STEPS`] steps at a time: on
//! the fast mechanical path one kernel call per block that keeps the state after each step
//! ([`BatchState::advance_rows`]), otherwise [`BatchState::advance`] step by step. The
//! states are the same either way, so are the exit times. Each block is screened
//! (`screen.rs`) lane by lane, then part by part of [`PART_STEPS`] steps; only the steps of
//! a part the screen does not clear are tested one by one (`locate.rs`), in order, as if
//! every step were.

use super::locate::left_within;
use super::screen::Spans;
use crate::mc::compile::scheme::Plan;
use crate::mc::kernel::rng::Increments;
use crate::mc::step::state::BatchState;
use crate::model::BoundSafe;
use crate::symbolic::Interval;

/// Steps per block: one kernel call, the state after each kept (128 steps of 64 lanes:
/// 128 KiB of states, within the second-level cache).
pub(super) const BLOCK_STEPS: usize = 128;

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
    /// The exit times of paths `first..first + lanes` at step `h` (`f64::INFINITY`:
    /// censored at the horizon; NaN: blew up), in path order.
    pub(super) fn batch(&self, plan: &Plan, first: u64, lanes: usize, h: f64) -> Vec<f64> {
        let spread = plan.initial_spread();
        let mut b = BatchState::new(plan, &spread, self.seed, first, lanes, self.increments);
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
        let mut exit = vec![f64::INFINITY; lanes];
        let mut open = lanes;
        let steps = (self.horizon / h).ceil() as u64;
        let mut done = 0;
        while done < steps && open > 0 {
            let n = (steps - done).min(BLOCK_STEPS as u64) as usize;
            blk.step(&mut b, plan, n, h);
            for (i, e) in exit.iter_mut().enumerate() {
                if *e != f64::INFINITY {
                    continue;
                }
                let Some(outcome) = self.lane(&mut blk, i, n, h) else {
                    continue;
                };
                open -= 1;
                *e = match outcome {
                    Outcome::BlewUp => f64::NAN,
                    Outcome::Left { step, at } => {
                        let t = ((done + step as u64) as f64 + at) * h;
                        // A path that leaves after the horizon within the last step is
                        // censored (marked apart until the end: it is no longer open).
                        if t <= self.horizon {
                            t
                        } else {
                            f64::NEG_INFINITY
                        }
                    }
                };
            }
            done += n as u64;
        }
        exit.iter_mut()
            .filter(|t| **t == f64::NEG_INFINITY)
            .for_each(|t| *t = f64::INFINITY);
        exit
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
