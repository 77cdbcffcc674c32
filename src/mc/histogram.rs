//! Streaming histograms and moments on fixed grids: no sample is kept, only bin counts and
//! power sums per statistics batch.

use serde::{Deserialize, Serialize};

use super::error::McError;
use super::estimate::Estimate;
use super::eval::Simd;
use super::exact;
use crate::moments::Moments;

/// A fixed histogram grid: `bins` equal bins covering `[lo, hi)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Left edge of the first bin.
    #[serde(with = "exact")]
    pub lo: f64,
    /// Right edge of the last bin.
    #[serde(with = "exact")]
    pub hi: f64,
    /// Number of bins (≥ 1).
    pub bins: usize,
}

impl Grid {
    /// A grid of `bins` bins on `[lo, hi)`.
    ///
    /// ```
    /// let g = fpsolve::mc::Grid::new(0.0, 2.0, 4).unwrap();
    /// assert_eq!(g.width(), 0.5);
    /// assert!(fpsolve::mc::Grid::new(1.0, 1.0, 4).is_err());
    /// ```
    pub fn new(lo: f64, hi: f64, bins: usize) -> Result<Grid, McError> {
        if !(Grid { lo, hi, bins }).well_formed() {
            return Err(McError::BadSetting {
                name: "grid",
                reason: format!(
                    "need finite lo < hi and bins ≥ 1, got [{lo:?}, {hi:?}) with {bins}"
                ),
            });
        }
        Ok(Grid { lo, hi, bins })
    }

    /// Finite `lo < hi` and at least one bin: what every grid must be (a `Grid` built field
    /// by field, or read from a shard file, is checked with this).
    pub(crate) fn well_formed(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite() && self.lo < self.hi && self.bins > 0
    }

    /// The width of one bin.
    pub fn width(&self) -> f64 {
        (self.hi - self.lo) / self.bins as f64
    }

    /// The centres of the bins.
    ///
    /// ```
    /// let g = fpsolve::mc::Grid::new(0.0, 1.0, 2).unwrap();
    /// assert_eq!(g.centers(), vec![0.25, 0.75]);
    /// ```
    pub fn centers(&self) -> Vec<f64> {
        let w = self.width();
        (0..self.bins)
            .map(|j| self.lo + (j as f64 + 0.5) * w)
            .collect()
    }
}

/// A histogram grid for a named quantity, as the command line gives it: `NAME=LO:HI:BINS`.
///
/// ```
/// use fpsolve::mc::NamedGrid;
/// let g: NamedGrid = "y=0:8:300".parse().unwrap();
/// assert_eq!((g.name.as_str(), g.grid.bins), ("y", 300));
/// let err = "y=0:8".parse::<NamedGrid>().unwrap_err();
/// assert!(err.to_string().contains("expected NAME=LO:HI:BINS"));
/// assert!("y=8:0:10".parse::<NamedGrid>().is_err());
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NamedGrid {
    /// The state's or observable's name.
    pub name: String,
    /// The grid.
    pub grid: Grid,
}

/// Why a `NAME=LO:HI:BINS` text is not a grid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NamedGridError {
    /// Not of the form `NAME=LO:HI:BINS` with numbers and a whole number of bins.
    #[error("`{text}`: expected NAME=LO:HI:BINS (e.g. y=0:8:300)")]
    Shape {
        /// The text given.
        text: String,
    },
    /// Nothing before `=`.
    #[error("`{text}`: the quantity's name is missing")]
    NoName {
        /// The text given.
        text: String,
    },
    /// The numbers do not make a grid (lo ≥ hi, non-finite, no bins).
    #[error("`{text}`: {reason}")]
    Grid {
        /// The text given.
        text: String,
        /// What is wrong.
        reason: String,
    },
}

impl std::str::FromStr for NamedGrid {
    type Err = NamedGridError;

    fn from_str(text: &str) -> Result<NamedGrid, NamedGridError> {
        let shown = || text.chars().take(60).collect::<String>();
        let parsed = text.split_once('=').and_then(|(name, spec)| {
            let parts: Vec<&str> = spec.split(':').collect();
            let [lo, hi, bins] = parts.as_slice() else {
                return None;
            };
            Some((
                name.trim().to_string(),
                lo.trim().parse::<f64>().ok()?,
                hi.trim().parse::<f64>().ok()?,
                bins.trim().parse::<usize>().ok()?,
            ))
        });
        let Some((name, lo, hi, bins)) = parsed else {
            return Err(NamedGridError::Shape { text: shown() });
        };
        if name.is_empty() {
            return Err(NamedGridError::NoName { text: shown() });
        }
        let grid = Grid::new(lo, hi, bins).map_err(|e| NamedGridError::Grid {
            text: shown(),
            reason: e.to_string(),
        })?;
        Ok(NamedGrid { name, grid })
    }
}

/// One quantity's statistics over one batch: bin counts, out-of-range and invalid counts,
/// power sums of `q − shift` (`shift` is the grid's centre, to keep the sums well
/// conditioned), and the extremes of the finite values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct QuantityBatch {
    pub(crate) counts: Vec<u64>,
    pub(crate) under: u64,
    pub(crate) over: u64,
    /// Non-finite values of an observable at a finite state.
    pub(crate) invalid: u64,
    #[serde(with = "exact::array4")]
    pub(crate) sums: [f64; 4],
    #[serde(with = "exact")]
    pub(crate) min: f64,
    #[serde(with = "exact")]
    pub(crate) max: f64,
    /// Finite values recorded in each quarter of the recording (for the stationarity test).
    pub(crate) window_counts: [u64; 4],
    /// Σ (q − shift) per quarter of the recording.
    #[serde(with = "exact::array4")]
    pub(crate) window_sums: [f64; 4],
    /// Σ (q − shift)² per quarter of the recording.
    #[serde(with = "exact::array4")]
    pub(crate) window_squares: [f64; 4],
}

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
    /// Σ d, Σ d², Σ d³, Σ d⁴ of d = q − shift.
    powers: [&'a mut f64; 4],
    min: &'a mut f64,
    max: &'a mut f64,
    /// This quarter's finite recorded values, Σ d and Σ d².
    window_count: &'a mut u64,
    window_sum: &'a mut f64,
    window_square: &'a mut f64,
}

impl SlotGrid {
    /// Adds the value `q` to `lane`'s sums when `record` and finite, and returns its slot
    /// (before the lane's copy offset): 0 below the grid, 1..=bins the bins, bins + 1
    /// above, `skipped` when not `record`, `invalid` when not finite. The one lane update
    /// of both `add_body` (vectorised over the columns) and `add_lanes` (over register
    /// arrays), so the two recordings give the same bits.
    #[inline(always)]
    fn update(self, q: f64, record: bool, lane: LaneSums<'_>) -> u32 {
        let finite = q.is_finite();
        let ok = record && finite;
        let d = if ok { q - self.shift } else { 0.0 };
        let d2 = d * d;
        let [s1, s2, s3, s4] = lane.powers;
        *s1 += d;
        *s2 += d2;
        *s3 += d2 * d;
        *s4 += d2 * d2;
        *lane.window_count += ok as u64;
        *lane.window_sum += d;
        *lane.window_square += d2;
        // The extremes, `ok && q < min ? q : min`, as a comparison of the value or ±∞ (the
        // same result: ∞ < min never holds), which compiles to min/max in registers in
        // `add_lanes` (the conditional form became a masked store to the stack that the
        // next sample's load waited for: half the fused recording's time) and vectorises in
        // `add_body` (comparisons, where `f64::min`/`max` do not).
        let low = if ok { q } else { f64::INFINITY };
        let high = if ok { q } else { f64::NEG_INFINITY };
        *lane.min = if low < *lane.min { low } else { *lane.min };
        *lane.max = if high > *lane.max { high } else { *lane.max };
        // Slot 1 + ⌊(q − lo)/w⌋, clamped into [0, bins + 1] (below / above the grid).
        // (Comparisons rather than `max`/`min`, and an unchecked conversion, so the loop
        // vectorises; a NaN goes to slot 0 here and to `invalid` below.)
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
        let slot = if q < self.lo { 0 } else { slot };
        let slot = if finite { slot } else { self.invalid };
        if record {
            slot
        } else {
            self.skipped
        }
    }
}

/// Copies of the bin counts (a power of two), lane i counting into copy i mod COUNT_COPIES.
const COUNT_COPIES: usize = 4;

impl Accumulator {
    pub(crate) fn new(grid: Grid, lanes: usize) -> Accumulator {
        // `add`'s unchecked bin conversion relies on it (runs check their grids).
        assert!(grid.bins <= super::MAX_BINS, "a grid of {} bins", grid.bins);
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

    /// Adds the lanes' sums of the current quarter to its totals, lanes in order.
    fn flush_window(&mut self) {
        let k = self.window;
        let [ws, wq] = &mut self.lane_window_sums;
        for ((c, s), q) in self
            .lane_window_counts
            .iter_mut()
            .zip(ws.iter_mut())
            .zip(wq.iter_mut())
        {
            self.window_counts[k] += *c;
            self.window_sums[k] += *s;
            self.window_squares[k] += *q;
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
            Simd::Avx2 => unsafe { self.add_avx2(values, record) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => unsafe { self.add_avx512(values, record) },
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
        let [s1, s2, s3, s4] = &mut self.sums;
        let (s1, s2, s3, s4) = (&mut s1[..n], &mut s2[..n], &mut s3[..n], &mut s4[..n]);
        let (mn, mx, idx) = (&mut self.min[..n], &mut self.max[..n], &mut self.index[..n]);
        let [ws, wq] = &mut self.lane_window_sums;
        let (wc, ws, wq) = (
            &mut self.lane_window_counts[..n],
            &mut ws[..n],
            &mut wq[..n],
        );
        for i in 0..n {
            let lane = LaneSums {
                powers: [&mut s1[i], &mut s2[i], &mut s3[i], &mut s4[i]],
                min: &mut mn[i],
                max: &mut mx[i],
                window_count: &mut wc[i],
                window_sum: &mut ws[i],
                window_square: &mut wq[i],
            };
            let slot = g.update(values[i], record[i], lane);
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
    /// ([`SlotGrid::update`]) in sample order, so the result is the same bits as `samples` calls of
    /// [`Accumulator::add`] with the values (tested).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_lanes<const L: usize>(
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
        let stride_slots = self.grid.bins + 4;
        let r = first..first + L;
        let load = |s: &[f64]| -> [f64; L] { s[r.clone()].try_into().expect("L lanes") };
        let [s1, s2, s3, s4] = &mut self.sums;
        let (mut a1, mut a2, mut a3, mut a4) = (load(s1), load(s2), load(s3), load(s4));
        let (mut mn, mut mx) = (load(&self.min), load(&self.max));
        let [ws, wq] = &mut self.lane_window_sums;
        let (mut aws, mut awq) = (load(ws), load(wq));
        let mut awc: [u64; L] = self.lane_window_counts[r.clone()]
            .try_into()
            .expect("L lanes");
        // Each lane's copy of the bins (lane i counts into copy i mod COUNT_COPIES).
        let copy: [usize; L] = std::array::from_fn(|l| ((first + l) % COUNT_COPIES) * stride_slots);
        for j in 0..samples {
            let row = j * stride + first;
            let x: [f64; L] = xs[row..row + L].try_into().expect("L lanes");
            let v: [f64; L] = vs[row..row + L].try_into().expect("L lanes");
            let q: [f64; L] = std::array::from_fn(|l| value(x[l], v[l]));
            let rec: [bool; L] = record[row..row + L].try_into().expect("L lanes");
            let mut slots = [0u32; L];
            for l in 0..L {
                let lane = LaneSums {
                    powers: [&mut a1[l], &mut a2[l], &mut a3[l], &mut a4[l]],
                    min: &mut mn[l],
                    max: &mut mx[l],
                    window_count: &mut awc[l],
                    window_sum: &mut aws[l],
                    window_square: &mut awq[l],
                };
                slots[l] = g.update(q[l], rec[l], lane);
            }
            for l in 0..L {
                let k = copy[l] + slots[l] as usize;
                debug_assert!(k < self.slots.len());
                // SAFETY: slot ≤ bins + 3 and copy ≤ (COUNT_COPIES − 1)·(bins + 4), so k is
                // below COUNT_COPIES·(bins + 4), the length of `slots` (the bounds check per
                // count was a third of the recording's time).
                unsafe { *self.slots.get_unchecked_mut(k) += 1 };
            }
        }
        let store = |s: &mut [f64], a: &[f64; L]| s[r.clone()].copy_from_slice(a);
        let [s1, s2, s3, s4] = &mut self.sums;
        store(s1, &a1);
        store(s2, &a2);
        store(s3, &a3);
        store(s4, &a4);
        store(&mut self.min, &mn);
        store(&mut self.max, &mx);
        let [ws, wq] = &mut self.lane_window_sums;
        store(ws, &aws);
        store(wq, &awq);
        self.lane_window_counts[r].copy_from_slice(&awc);
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

/// One quantity's histogram over a run, with its moments: what Monte Carlo knows about a
/// state or an observable.
///
/// ```
/// # use fpsolve::mc::{McConfig, Simulation};
/// # use fpsolve::model::{load_model, Override};
/// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
/// # let file = load_model(path.as_ref()).unwrap();
/// # let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
/// # let config = McConfig { trajectories: 256, lanes: 32, samples: 100, ..McConfig::default() };
/// let result = Simulation::new(&model, &config)?.run()?;
/// let z = result.quantity("z").unwrap();
/// // Raw moments and the statistics built on them, each with its standard error.
/// let [m1, m2, _, m4] = z.moments.raw;
/// assert!((m1.value - z.moments.mean.value).abs() < 1e-12);
/// assert!(m2.value > 0.0 && m4.value > 0.0 && m4.stderr.is_finite());
/// # Ok::<(), fpsolve::mc::McError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuantityHistogram {
    /// The state's or observable's name.
    pub name: String,
    /// Whether it is a state (`true`) or an observable.
    pub is_state: bool,
    /// The histogram grid.
    pub grid: Grid,
    /// Density estimate per bin: count / (finite samples · bin width), so it integrates to the
    /// fraction of samples inside the grid.
    pub density: Vec<f64>,
    /// Standard error of each bin's density, from the spread over statistics batches.
    pub stderr: Vec<f64>,
    /// Finite samples recorded.
    pub samples: u64,
    /// Samples below the grid.
    pub underflow: u64,
    /// Samples at or above the grid's right edge.
    pub overflow: u64,
    /// Non-finite values of the quantity at a finite state (excluded from all statistics).
    pub invalid: u64,
    /// Sample raw moments E\[q\], …, E\[q⁴\], mean, variance and kurtosis m₄/m₂² (3 for a
    /// Gaussian), each with its standard error from the spread over statistics batches.
    pub moments: Moments<Estimate>,
    /// Smallest finite value seen.
    pub min: f64,
    /// Largest finite value seen.
    pub max: f64,
    /// The time-step bias of the moments and the density, estimated by
    /// Richardson extrapolation from a paired run at 2·dt (`None` when not estimated, as in
    /// the pilot run or with [`McConfig::bias_fraction`](super::McConfig::bias_fraction) 0).
    pub time_step_bias: Option<TimeStepBias>,
}

/// The estimated discretisation bias S_dt − S_exact ≈ (S_2dt − S_dt)/(2ᵖ − 1) of a
/// quantity's statistics (p the scheme's weak order), from statistics batches run twice,
/// at dt and at 2·dt with the same random streams; each value's standard error comes from
/// the spread of the per-batch differences. A bias smaller than about twice its standard
/// error is not resolved: only `|value| + 2·stderr` bounds it (see [`Estimate::resolved`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeStepBias {
    /// The weak order p used in the extrapolation.
    pub order: u32,
    /// The coarse time step (2·dt).
    pub coarse_dt: f64,
    /// The paired statistics batches it was estimated from.
    pub pairs: u64,
    /// Bias of each moment (raw moments, mean, variance, kurtosis).
    pub moments: Moments<Estimate>,
    /// Bias of each bin's density.
    pub density: Vec<f64>,
    /// Standard error of each bin's density bias.
    pub density_stderr: Vec<f64>,
}

/// Moments of one batch (or of the whole run) from the power sums of q − `shift` over `n`
/// samples: the mean about `shift` (kept apart, so that standard errors and bias pairs are
/// computed exactly as from the shifted sums), variance, kurtosis, and the raw moments about
/// zero.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BatchMoments {
    /// E\[q\] − shift.
    pub(crate) shifted_mean: f64,
    pub(crate) variance: f64,
    pub(crate) kurtosis: f64,
    /// E\[q\], …, E\[q⁴\].
    pub(crate) raw: [f64; 4],
}

fn central(sums: &[f64; 4], n: f64, shift: f64) -> BatchMoments {
    let m1 = sums[0] / n;
    let r2 = sums[1] / n;
    let r3 = sums[2] / n;
    let r4 = sums[3] / n;
    let var = r2 - m1 * m1;
    let c4 = r4 - 4.0 * m1 * r3 + 6.0 * m1 * m1 * r2 - 3.0 * m1.powi(4);
    // E[q^k] = Σ_j C(k, j) shift^(k−j) E[(q − shift)^j].
    let c = shift;
    let raw = [
        c + m1,
        c * c + 2.0 * c * m1 + r2,
        c.powi(3) + 3.0 * c * c * m1 + 3.0 * c * r2 + r3,
        c.powi(4) + 4.0 * c.powi(3) * m1 + 6.0 * c * c * r2 + 4.0 * c * r3 + r4,
    ];
    BatchMoments {
        shifted_mean: m1,
        variance: var,
        kurtosis: c4 / (var * var),
        raw,
    }
}

/// Combines one quantity's batch statistics, in batch order, into a [`QuantityHistogram`].
///
/// Standard errors treat the batches as independent replicas; the density's uses the ratio
/// estimator Var(p̂_j) ≈ B/(B−1) Σ_b (c_bj − p̂_j n_b)² / (N w)², which allows batches of
/// unequal size (batches that lost trajectories to blow-ups).
pub(crate) fn finalize(
    name: &str,
    is_state: bool,
    grid: Grid,
    batches: &[&QuantityBatch],
) -> QuantityHistogram {
    let nb = batches.len() as f64;
    let w = grid.width();
    let shift = 0.5 * (grid.lo + grid.hi);
    let finite = |b: &QuantityBatch| b.counts.iter().sum::<u64>() + b.under + b.over;
    let n_b: Vec<f64> = batches.iter().map(|b| finite(b) as f64).collect();
    let n: f64 = n_b.iter().sum();
    let mut counts = vec![0u64; grid.bins];
    let (mut under, mut over, mut invalid) = (0, 0, 0);
    let mut sums = [0.0; 4];
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for b in batches {
        for (c, bc) in counts.iter_mut().zip(&b.counts) {
            *c += bc;
        }
        under += b.under;
        over += b.over;
        invalid += b.invalid;
        for k in 0..4 {
            sums[k] += b.sums[k];
        }
        min = min.min(b.min);
        max = max.max(b.max);
    }
    let density: Vec<f64> = counts.iter().map(|&c| c as f64 / (n * w)).collect();
    let stderr: Vec<f64> = (0..grid.bins)
        .map(|j| {
            let f = counts[j] as f64 / n;
            let ss: f64 = batches
                .iter()
                .zip(&n_b)
                .map(|(b, &nb_)| {
                    let d = b.counts[j] as f64 - f * nb_;
                    d * d
                })
                .sum();
            (nb / (nb - 1.0) * ss).sqrt() / (n * w)
        })
        .collect();
    let all = central(&sums, n, shift);
    // Per-batch values for the moments' standard errors.
    // Batches that lost every trajectory to blow-ups carry no moments.
    let per_batch: Vec<BatchMoments> = batches
        .iter()
        .zip(&n_b)
        .filter(|(_, &k)| k > 0.0)
        .map(|(b, &k)| central(&b.sums, k, shift))
        .collect();
    let spread = |pick: &dyn Fn(&BatchMoments) -> f64| -> f64 {
        let m = per_batch.len() as f64;
        if m < 2.0 {
            return f64::INFINITY;
        }
        let mean = per_batch.iter().map(pick).sum::<f64>() / m;
        let ss: f64 = per_batch.iter().map(|t| (pick(t) - mean).powi(2)).sum();
        (ss / (m - 1.0) / m).sqrt()
    };
    let raw = std::array::from_fn(|k| Estimate {
        value: all.raw[k],
        stderr: spread(&|t| t.raw[k]),
    });
    QuantityHistogram {
        name: name.to_string(),
        is_state,
        grid,
        density,
        stderr,
        samples: n as u64,
        underflow: under,
        overflow: over,
        invalid,
        moments: Moments {
            raw,
            mean: Estimate {
                value: shift + all.shifted_mean,
                stderr: spread(&|t| t.shifted_mean),
            },
            variance: Estimate {
                value: all.variance,
                stderr: spread(&|t| t.variance),
            },
            kurtosis: Estimate {
                value: all.kurtosis,
                stderr: spread(&|t| t.kurtosis),
            },
        },
        min,
        max,
        time_step_bias: None,
    }
}

/// Per-batch moments of a quantity on `grid` (its mean about the grid's centre), `None` for
/// a batch without finite samples.
pub(crate) fn batch_moments(b: &QuantityBatch, grid: Grid) -> Option<BatchMoments> {
    let n = (b.counts.iter().sum::<u64>() + b.under + b.over) as f64;
    (n > 0.0).then(|| central(&b.sums, n, 0.5 * (grid.lo + grid.hi)))
}

/// The per-bin densities of one batch.
pub(crate) fn batch_density(b: &QuantityBatch, grid: Grid) -> Option<Vec<f64>> {
    let n = (b.counts.iter().sum::<u64>() + b.under + b.over) as f64;
    let w = grid.width();
    (n > 0.0).then(|| b.counts.iter().map(|&c| c as f64 / (n * w)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_edges_and_out_of_range_values() {
        let g = Grid::new(0.0, 1.0, 4).unwrap();
        let vals = [
            0.0,
            0.2499,
            0.25,
            0.99,
            1.0,
            -0.1,
            f64::NAN,
            0.5,
            -7.0,
            f64::INFINITY,
            -1e-18,
        ];
        let rec = [
            true, true, true, true, true, true, true, false, true, true, true,
        ];
        let mut a = Accumulator::new(g, vals.len());
        a.add(&vals, &rec);
        let out = a.finish();
        assert_eq!(out.counts, vec![2, 1, 0, 1]);
        assert_eq!((out.under, out.over, out.invalid), (3, 1, 2));
        assert_eq!((out.min, out.max), (-7.0, 1.0));
    }

    #[test]
    fn moments_and_errors_of_known_batches() {
        // Two batches of the values {0, 1, 2, 3} and {1, 2, 3, 4}.
        let g = Grid::new(0.0, 5.0, 5).unwrap();
        let mut a = Accumulator::new(g, 4);
        a.add(&[0.0, 1.0, 2.0, 3.0], &[true; 4]);
        let mut b = Accumulator::new(g, 2);
        b.add(&[1.0, 2.0], &[true; 2]);
        b.add(&[3.0, 4.0], &[true; 2]);
        let s = finalize("q", true, g, &[&a.finish(), &b.finish()]);
        assert_eq!(s.samples, 8);
        approx::assert_relative_eq!(s.moments.mean.value, 2.0, epsilon = 1e-14);
        // Batch means 1.5 and 2.5: standard error 0.5.
        approx::assert_relative_eq!(s.moments.mean.stderr, 0.5, epsilon = 1e-14);
        approx::assert_relative_eq!(s.moments.variance.value, 1.5, epsilon = 1e-14);
        // Values 0,1,1,2,2,3,3,4 about 2: m4 = (16+1+1+0+0+1+1+16)/8 = 4.5, m2 = 1.5.
        approx::assert_relative_eq!(s.moments.kurtosis.value, 2.0, epsilon = 1e-14);
        // Raw moments about zero: E x² = 44/8, E x³ = 136/8, E x⁴ = 452/8; the batches'
        // E x⁴ are 98/4 and 354/4, so its standard error is half their difference, 32.
        let raw: Vec<f64> = s.moments.raw.iter().map(|e| e.value).collect();
        for (r, e) in raw.iter().zip([2.0, 5.5, 17.0, 56.5]) {
            approx::assert_relative_eq!(*r, e, epsilon = 1e-12);
        }
        approx::assert_relative_eq!(s.moments.raw[3].stderr, 32.0, epsilon = 1e-12);
        assert_eq!(s.density, vec![1.0 / 8.0, 0.25, 0.25, 0.25, 1.0 / 8.0]);
        // Bin 0: counts 1 and 0 against 0.5 expected each: B/(B−1)·(0.25+0.25) = 1 → 1/8.
        approx::assert_relative_eq!(s.stderr[0], 1.0 / 8.0, epsilon = 1e-14);
        approx::assert_relative_eq!(s.stderr[2], 0.0, epsilon = 1e-14);
    }
}
