//! The accumulator of one quantity of one statistics batch ([`Accumulator`]), and the one
//! lane update ([`SlotGrid::update`]) that both recordings run: the general one (`add`, a
//! sample point of every lane) and the fused one (`add_lanes`, a block of lanes through a
//! chunk of sample points, its sums in registers), with the fused recording's fast form for
//! blocks every lane of which is recorded with finite values ([`SlotGrid::update_finite`],
//! `add_lanes` with `FINE`).

use crate::mc::compile::eval::Simd;
use crate::mc::record::histogram::{Grid, QuantityBatch};

/// Accumulates one quantity of one batch, lane-parallel: power sums, extremes and the
/// current quarter's sums per lane (vectorised), bin indices computed for all lanes and then
/// counted into [`COUNT_COPIES`] interleaved copies of the bins (so that lanes landing in
/// the same bin do not wait on each other's increments). [`Accumulator::finish`] adds the
/// lanes up in lane order; a quarter's per-lane sums are added up in lane order when the
/// quarter ends.
pub(crate) struct Accumulator {
    grid: Grid,
    inv_width: f64,
    shift: f64,
    /// Slots of each copy: 0 below the grid, 1..=bins the bins, bins+1 above, bins+2 lanes
    /// not recorded, bins+3 non-finite values; copy c at `c * (bins + 4)`.
    slots: Vec<u64>,
    index: Vec<u32>,
    /// Per lane, Σ d, Σ d², Σ d³, Σ d⁴ of d = q − shift: the first two the quarters' sums
    /// added up as each quarter ends, the others sample by sample.
    sums: [Vec<f64>; 4],
    min: Vec<f64>,
    max: Vec<f64>,
    /// The quarter of the recording the next samples fall in.
    window: usize,
    /// The vector extension `add` runs with.
    simd: Simd,
    /// Per lane, this quarter's finite recorded values, Σ (q − shift) and Σ (q − shift)².
    lane_window_counts: Vec<u64>,
    lane_window_sums: [Vec<f64>; 2],
    window_counts: [u64; 4],
    window_sums: [f64; 4],
    window_squares: [f64; 4],
}

/// The grid constants of one lane's update ([`SlotGrid::update`]).
#[derive(Clone, Copy)]
struct SlotGrid {
    lo: f64,
    /// Bins per unit of the quantity.
    inv_width: f64,
    /// The value the power sums are taken about (the grid's centre).
    shift: f64,
    /// The slot above the grid, `bins + 1`.
    top: f64,
    /// The slot of a lane not recorded, `bins + 2`.
    skipped: u32,
    /// The slot of a non-finite value, `bins + 3`.
    invalid: u32,
}

/// One lane's running sums, updated in place by [`SlotGrid::update`]: elements of the
/// accumulator's columns in `add_body`, of register arrays in `add_lanes`.
struct LaneSums<'a> {
    /// Σ d³ and Σ d⁴ of d = q − shift (Σ d and Σ d² are the quarters', added up when
    /// each ends).
    powers: [&'a mut f64; 2],
    min: &'a mut f64,
    max: &'a mut f64,
    /// This quarter's Σ d and Σ d² (its count of finite recorded values is kept apart: the
    /// fast form adds a whole chunk's at once).
    window_sum: &'a mut f64,
    window_square: &'a mut f64,
}

/// The running sums of a block of `L` lanes, kept in registers through a chunk of the
/// fused recording (`Accumulator::load_block` / `store_block`).
struct Block<const L: usize> {
    /// Σ d³ and Σ d⁴.
    powers: [[f64; L]; 2],
    min: [f64; L],
    max: [f64; L],
    window_sum: [f64; L],
    window_square: [f64; L],
    window_count: [u64; L],
}

impl<const L: usize> Block<L> {
    /// Lane `l`'s sums, and its window count.
    #[inline(always)]
    fn lane(&mut self, l: usize) -> (LaneSums<'_>, &mut u64) {
        let [s3, s4] = &mut self.powers;
        let lane = LaneSums {
            powers: [&mut s3[l], &mut s4[l]],
            min: &mut self.min[l],
            max: &mut self.max[l],
            window_sum: &mut self.window_sum[l],
            window_square: &mut self.window_square[l],
        };
        (lane, &mut self.window_count[l])
    }
}

impl SlotGrid {
    /// Adds the value `q` to `lane`'s sums (and 1 to `window_count`) when `record` and
    /// finite, and returns its slot (before the lane's copy offset): 0 below the grid,
    /// 1..=bins the bins, bins + 1 above, `skipped` when not `record`, `invalid` when not
    /// finite. The one lane update of both `add_body` (vectorised over the columns) and
    /// `add_lanes` (over register arrays), so the two recordings give the same bits.
    #[inline(always)]
    fn update(self, q: f64, record: bool, lane: LaneSums<'_>, window_count: &mut u64) -> u32 {
        let finite = q.is_finite();
        let ok = record && finite;
        let d = if ok { q - self.shift } else { 0.0 };
        *window_count += ok as u64;
        // The extremes, `ok && q < min ? q : min`, as a comparison of the value or ±∞ (the
        // same result: ∞ < min never holds), which compiles to min/max in registers in
        // `add_lanes` (the conditional form became a masked store to the stack that the
        // next sample's load waited for: half the fused recording's time) and vectorises in
        // `add_body` (comparisons, where `f64::min`/`max` do not).
        let low = if ok { q } else { f64::INFINITY };
        let high = if ok { q } else { f64::NEG_INFINITY };
        Self::add(d, low, high, lane);
        let slot = self.slot(q);
        let slot = if finite { slot } else { self.invalid };
        if record {
            slot
        } else {
            self.skipped
        }
    }

    /// [`SlotGrid::update`] of a finite `q` with `record` set, without the window count
    /// (the caller adds a chunk's at once): the same operations on the same values, since
    /// there `ok` and `finite` are true, `d = q − shift`, `low = high = q` and the slot is
    /// [`SlotGrid::slot`]'s.
    #[inline(always)]
    fn update_finite(self, q: f64, lane: LaneSums<'_>) -> u32 {
        debug_assert!(q.is_finite());
        Self::add(q - self.shift, q, q, lane);
        self.slot(q)
    }

    /// The sums' part of the update: `d` into the quarter's sums and the third and fourth
    /// powers, `low` and `high` into the extremes. (Σ d and Σ d² over the run are the
    /// quarters' sums added up when each quarter ends, [`Accumulator::flush_window`]: kept
    /// per sample as well, they were two of the update's operations.)
    #[inline(always)]
    fn add(d: f64, low: f64, high: f64, lane: LaneSums<'_>) {
        let d2 = d * d;
        let [s3, s4] = lane.powers;
        *s3 += d2 * d;
        *s4 += d2 * d2;
        *lane.window_sum += d;
        *lane.window_square += d2;
        *lane.min = if low < *lane.min { low } else { *lane.min };
        *lane.max = if high > *lane.max { high } else { *lane.max };
    }

    /// The slot of a finite `q` (of a NaN: 0): 1 + ⌊(q − lo)/w⌋ clamped into
    /// [0, bins + 1] (below / above the grid).
    #[inline(always)]
    fn slot(self, q: f64) -> u32 {
        // (Comparisons rather than `max`/`min`, and an unchecked conversion, so the loop
        // vectorises; a NaN goes to slot 0 here and to `invalid` in `update`.)
        let t = (q - self.lo) * self.inv_width + 1.0;
        let t = if t > 0.0 { t } else { 0.0 };
        let t = if t < self.top { t } else { self.top };
        // SAFETY: 0 ≤ t ≤ bins + 1 ≤ MAX_BINS + 1 < 2³¹ (a run's grids are checked against
        // `MAX_BINS` = 10⁷, in `McConfig` and in shard files, and `Accumulator::new`
        // asserts it), and t is not NaN (the first comparison maps NaN to 0), so the
        // truncation is in range. The checked `as` conversion, which handles NaN and
        // saturates, was a scalar sequence per lane: a quarter of the recording's time
        // (perf, vibro_duffing).
        let slot = unsafe { t.to_int_unchecked::<i32>() } as u32;
        // Rounding in `+ 1.0` must not lift a value just below the grid into bin 0.
        if q < self.lo {
            0
        } else {
            slot
        }
    }
}

/// Copies of the bin counts (a power of two), lane i counting into copy i mod COUNT_COPIES.
pub(crate) const COUNT_COPIES: usize = 4;

/// Rows of counter indices an [`IndexRing`] holds.
const RING_ROWS: usize = 16;

/// Rows [`Accumulator::add_lanes`] counts behind the row it computes.
///
/// Counting a row right after its update, or a whole block of rows after the block's
/// updates, leaves the counter increments (loads and stores) and the vector arithmetic of
/// the updates each waiting on their own units. Counting the row 8 behind interleaves them,
/// and the indices read back were stored long enough before not to wait on their store.
/// Eight rows was the fastest lag measured (about 5 % faster than counting a block at its
/// end on the numba peer's work, `benches/peers/compare_mc.sh`); shorter lags wait on the
/// stores again, longer ones keep more indices in flight than the ring's rows pay for.
const LAG: usize = 8;

/// The counter indices (a lane's copy offset plus its slot, as [`SlotGrid::update`] returns
/// it) of the last [`RING_ROWS`] rows of `L` lanes, row j in place `j % RING_ROWS`.
///
/// The indices are stored as vectors and read back for the counts apart from the
/// arithmetic: moving each lane's index out of its vector register (the extraction the
/// compiler made when the count followed each row's update) took as many vector
/// instructions as the update itself. They are read back two at a time, as one 64-bit
/// load (aligned: the rows start at the 64-byte alignment and a pair at an even lane):
/// the whole process 0.383 → 0.372 s (as for [`LAG`], medians of 11, in an experimental
/// build that counted a block at its end and fused the sums' multiply-adds).
#[repr(C, align(64))]
struct IndexRing<const L: usize> {
    rows: [[u32; L]; RING_ROWS],
}

impl<const L: usize> IndexRing<L> {
    fn new() -> Self {
        const { assert!(LAG < RING_ROWS) };
        IndexRing {
            rows: [[0; L]; RING_ROWS],
        }
    }

    /// Keeps the indices of row `j`.
    #[inline(always)]
    fn set(&mut self, j: usize, row: [u32; L]) {
        self.rows[j % RING_ROWS] = row;
    }

    /// Counts the indices of row `j` (kept, and not overwritten since) into `counts`.
    #[inline(always)]
    fn count(&self, j: usize, counts: &mut [u64]) {
        let row = &self.rows[j % RING_ROWS];
        let mut add = |k: u32| {
            let k = k as usize;
            debug_assert!(k < counts.len());
            // SAFETY: slot ≤ bins + 3 and the copy's offset ≤ (COUNT_COPIES − 1)·(bins + 4),
            // so k is below COUNT_COPIES·(bins + 4), the length of `slots` (the bounds check
            // per count was a third of the recording's time).
            unsafe { *counts.get_unchecked_mut(k) += 1 };
        };
        for pair in row.chunks_exact(2) {
            let p = pair.as_ptr().cast::<u64>();
            debug_assert!(p.is_aligned());
            // SAFETY: `pair` is two consecutive u32 of `rows`, at an offset of 4·(even lane)
            // bytes from a row's start; every row starts at a multiple of 8 bytes (the
            // struct's alignment is 64 and a row of an odd L has no pair), so `p` is an
            // aligned pointer to 8 initialised bytes. Volatile so that the compiler keeps
            // one 64-bit load (it split a plain one into two 32-bit loads).
            let w = unsafe { std::ptr::read_volatile(p) };
            // The two indices, in an order that depends on the byte order (a count does not).
            add(w as u32);
            add((w >> 32) as u32);
        }
        if L % 2 == 1 {
            add(row[L - 1]);
        }
    }
}

impl Accumulator {
    pub(crate) fn new(grid: Grid, lanes: usize) -> Accumulator {
        // `add`'s unchecked bin conversion relies on it (runs check their grids).
        assert!(
            grid.bins <= crate::mc::record::histogram::MAX_BINS,
            "a grid of {} bins",
            grid.bins
        );
        Accumulator {
            grid,
            inv_width: grid.bins as f64 / (grid.hi - grid.lo),
            shift: 0.5 * (grid.lo + grid.hi),
            slots: vec![0; COUNT_COPIES * (grid.bins + 4)],
            index: vec![0; lanes],
            sums: std::array::from_fn(|_| vec![0.0; lanes]),
            min: vec![f64::INFINITY; lanes],
            max: vec![f64::NEG_INFINITY; lanes],
            window: 0,
            simd: Simd::detect(),
            lane_window_counts: vec![0; lanes],
            lane_window_sums: std::array::from_fn(|_| vec![0.0; lanes]),
            window_counts: [0; 4],
            window_sums: [0.0; 4],
            window_squares: [0.0; 4],
        }
    }

    /// The constants of [`SlotGrid::update`] for this accumulator's grid.
    #[inline(always)]
    fn slot_grid(&self) -> SlotGrid {
        let bins = self.grid.bins;
        SlotGrid {
            lo: self.grid.lo,
            inv_width: self.inv_width,
            shift: self.shift,
            top: (bins + 1) as f64,
            skipped: bins as u32 + 2,
            invalid: bins as u32 + 3,
        }
    }

    /// Sets the quarter of the recording (0..4) the following samples belong to.
    pub(crate) fn set_window(&mut self, window: usize) {
        let window = window.min(3);
        if window != self.window {
            self.flush_window();
            self.window = window;
        }
    }

    /// Adds the lanes' sums of the current quarter to its totals, lanes in order, and each
    /// lane's to its Σ d and Σ d².
    fn flush_window(&mut self) {
        let k = self.window;
        let [ws, wq] = &mut self.lane_window_sums;
        let [s1, s2, _, _] = &mut self.sums;
        for ((((c, s), q), s1), s2) in self
            .lane_window_counts
            .iter_mut()
            .zip(ws.iter_mut())
            .zip(wq.iter_mut())
            .zip(s1.iter_mut())
            .zip(s2.iter_mut())
        {
            self.window_counts[k] += *c;
            self.window_sums[k] += *s;
            self.window_squares[k] += *q;
            *s1 += *s;
            *s2 += *q;
            (*c, *s, *q) = (0, 0.0, 0.0);
        }
    }

    /// Adds one sample value per lane, for the lanes with `record[i]`.
    pub(crate) fn add(&mut self, values: &[f64], record: &[bool]) {
        match self.simd {
            Simd::Baseline => self.add_body(values, record),
            // SAFETY: `simd` was detected on this CPU. The arithmetic is IEEE-exact whatever
            // the vector width (no fused multiply-add), so results do not change.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(_) => unsafe { self.add_avx2(values, record) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(_) => unsafe { self.add_avx512(values, record) },
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn add_avx2(&mut self, values: &[f64], record: &[bool]) {
        self.add_body(values, record);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn add_avx512(&mut self, values: &[f64], record: &[bool]) {
        self.add_body(values, record);
    }

    #[inline(always)]
    fn add_body(&mut self, values: &[f64], record: &[bool]) {
        let n = values.len();
        let (values, record) = (&values[..n], &record[..n]);
        let g = self.slot_grid();
        let stride = (self.grid.bins + 4) as u32;
        let [_, _, s3, s4] = &mut self.sums;
        let (s3, s4) = (&mut s3[..n], &mut s4[..n]);
        let (mn, mx, idx) = (&mut self.min[..n], &mut self.max[..n], &mut self.index[..n]);
        let [ws, wq] = &mut self.lane_window_sums;
        let (wc, ws, wq) = (
            &mut self.lane_window_counts[..n],
            &mut ws[..n],
            &mut wq[..n],
        );
        for i in 0..n {
            let lane = LaneSums {
                powers: [&mut s3[i], &mut s4[i]],
                min: &mut mn[i],
                max: &mut mx[i],
                window_sum: &mut ws[i],
                window_square: &mut wq[i],
            };
            let slot = g.update(values[i], record[i], lane, &mut wc[i]);
            idx[i] = slot + (i % COUNT_COPIES) as u32 * stride;
        }
        for &k in idx.iter() {
            self.slots[k as usize] += 1;
        }
    }

    /// [`Accumulator::add`] for `samples` consecutive sample points of the `L` lanes
    /// `first..first + L`, all in the current quarter: at sample j lane `first + l` has the
    /// state `(x, v)` = `(xs[k], vs[k])`, `k = j * stride + first + l`, the value
    /// `value(x, v)`, and is recorded when `record[k]`. The lanes' running sums are kept in
    /// registers through the samples and updated by `add_body`'s lane update
    /// ([`SlotGrid::update`]) in sample order, so the result is the same bits as `samples`
    /// calls of [`Accumulator::add`] with the values (tested).
    ///
    /// With `FINE` the caller knows that every lane is recorded at every sample point and
    /// every value is finite (`value` is finite at finite states, and it checked the states;
    /// `record` is not read): [`SlotGrid::update_finite`] in sample order, and the window
    /// count raised by `samples` at the end (an integer: the same as by 1 per sample), so the
    /// same bits as without `FINE` with `record` all set.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_lanes<const L: usize, const FINE: bool>(
        &mut self,
        first: usize,
        samples: usize,
        stride: usize,
        xs: &[f64],
        vs: &[f64],
        record: &[bool],
        value: impl Fn(f64, f64) -> f64,
    ) {
        let g = self.slot_grid();
        let b = &mut self.load_block::<L>(first);
        let copy = self.copies::<L>(first);
        let counts = &mut self.slots[..];
        // One bounds check for the block's rows, not one per row.
        let last = (samples.max(1) - 1) * stride + first + L;
        let (xs, vs) = (&xs[..last], &vs[..last]);
        let mut ring = IndexRing::<L>::new();
        for j in 0..samples {
            let row = j * stride + first;
            let x: &[f64; L] = xs[row..row + L].try_into().expect("L lanes");
            let v: &[f64; L] = vs[row..row + L].try_into().expect("L lanes");
            let mut slots = [0u32; L];
            if FINE {
                for l in 0..L {
                    let q = value(x[l], v[l]);
                    slots[l] = g.update_finite(q, b.lane(l).0);
                }
            } else {
                let rec: &[bool; L] = record[row..row + L].try_into().expect("L lanes");
                for l in 0..L {
                    let q = value(x[l], v[l]);
                    let (lane, count) = b.lane(l);
                    slots[l] = g.update(q, rec[l], lane, count);
                }
            }
            ring.set(j, std::array::from_fn(|l| copy[l] + slots[l]));
            if j >= LAG {
                ring.count(j - LAG, counts);
            }
        }
        for j in samples.saturating_sub(LAG)..samples {
            ring.count(j, counts);
        }
        if FINE {
            for c in &mut b.window_count {
                *c += samples as u64;
            }
        }
        self.store_block(first, b);
    }

    /// The running sums of the lanes `first..first + L`, to be kept in registers.
    #[inline(always)]
    fn load_block<const L: usize>(&self, first: usize) -> Block<L> {
        let r = first..first + L;
        let load = |s: &[f64]| -> [f64; L] { s[r.clone()].try_into().expect("L lanes") };
        let [_, _, s3, s4] = &self.sums;
        let [ws, wq] = &self.lane_window_sums;
        Block {
            powers: [load(s3), load(s4)],
            min: load(&self.min),
            max: load(&self.max),
            window_sum: load(ws),
            window_square: load(wq),
            window_count: self.lane_window_counts[r].try_into().expect("L lanes"),
        }
    }

    /// Stores the block's running sums back (`load_block`'s inverse).
    #[inline(always)]
    fn store_block<const L: usize>(&mut self, first: usize, b: &Block<L>) {
        let r = first..first + L;
        let store = |s: &mut [f64], a: &[f64; L]| s[r.clone()].copy_from_slice(a);
        for (s, a) in self.sums[2..].iter_mut().zip(&b.powers) {
            store(s, a);
        }
        store(&mut self.min, &b.min);
        store(&mut self.max, &b.max);
        let [ws, wq] = &mut self.lane_window_sums;
        store(ws, &b.window_sum);
        store(wq, &b.window_square);
        self.lane_window_counts[r].copy_from_slice(&b.window_count);
    }

    /// The offsets of the lanes `first..first + L`'s copies of the bins in `slots` (lane i
    /// counts into copy i mod COUNT_COPIES).
    #[inline(always)]
    fn copies<const L: usize>(&self, first: usize) -> [u32; L] {
        let stride = self.grid.bins + 4;
        // (≤ COUNT_COPIES·(MAX_BINS + 4) < 2³²)
        std::array::from_fn(|l| (((first + l) % COUNT_COPIES) * stride) as u32)
    }

    /// The batch's statistics, lanes added in order.
    pub(crate) fn finish(mut self) -> QuantityBatch {
        self.flush_window();
        let bins = self.grid.bins;
        let stride = bins + 4;
        let slot =
            |k: usize| -> u64 { (0..COUNT_COPIES).map(|c| self.slots[c * stride + k]).sum() };
        let mut sums = [0.0; 4];
        for (total, lanes) in sums.iter_mut().zip(&self.sums) {
            *total = lanes.iter().sum();
        }
        QuantityBatch {
            counts: (1..=bins).map(slot).collect(),
            under: slot(0),
            over: slot(bins + 1),
            invalid: slot(bins + 3),
            sums,
            min: self.min.iter().cloned().fold(f64::INFINITY, f64::min),
            max: self.max.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            window_counts: self.window_counts,
            window_sums: self.window_sums,
            window_squares: self.window_squares,
        }
    }
}
