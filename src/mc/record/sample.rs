//! The recording of a statistics batch on the fast mechanical path, fused with the kernel:
//! the kernel (`kernel/mech`) writes the lanes' states at [`CHUNK_SAMPLES`] sample points
//! in a row each, and the recording takes them lane block by lane block, each block's
//! running sums in registers through the chunk ([`Accumulator::add_lanes`]), the
//! observables computed on the way. It applies when every observable is one of the
//! recognised functions of the states ([`Observed`]); the result is the same bits as the
//! general recording (`batch.rs`): each lane's sums take its samples in the same order by the
//! same operations, a quarter's lane sums are added up in lane order when it ends, and the
//! blow-ups are found in the same order. A block whose lanes are all recorded and finite
//! through the chunk (`scan_block`, run first while the block's rows are in the cache)
//! takes the fast form of the update (`Accumulator::add_lanes` with `FINE`): the same operations
//! on the same values without the blends for skipped and non-finite lanes.

use serde::{Deserialize, Serialize};

use crate::base::cancel::Cancel;
use crate::mc::compile::eval::Simd;
use crate::mc::compile::lanes::{LaneOp, LaneProgram};
use crate::mc::compile::mech_form::sgn;
use crate::mc::compile::scheme::Plan;
use crate::mc::compile::tally::ImpactMark;
use crate::mc::exact;
use crate::mc::record::accumulator::Accumulator;
use crate::mc::record::crossings::LevelCrossings;
use crate::mc::settings::RunSettings;
use crate::mc::step::state::BatchState;
use crate::symbolic::TapeUnary as Unary;

/// A recorded state of a trajectory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LastState {
    /// The step it was recorded at.
    pub step: u64,
    /// The two states.
    #[serde(with = "exact::array2")]
    pub state: [f64; 2],
}

/// Sample points the kernel advances between two recordings (rows of states kept: 32 of
/// the 32 lanes of a batch's part are 16 kB; at most 32, the rows of `record_chunk`'s mask).
const CHUNK_SAMPLES: u64 = 32;

/// An observable the fused recording computes itself: exactly the tape's operation on the
/// states `(z, v)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Observed {
    /// The first state.
    Z,
    /// The second state.
    V,
    /// `abs(z)`.
    AbsZ,
    /// `v·sgn(z)` (either order: the product is commutative bit for bit).
    VSgnZ,
}

impl Observed {
    /// The observables of `program` (one output each), `None` when one is not recognised.
    pub(crate) fn recognise(program: &LaneProgram) -> Option<Vec<Observed>> {
        /// The value of an instruction: a recognised function, `sgn(z)`, or other.
        #[derive(Clone, Copy, PartialEq)]
        enum Val {
            Is(Observed),
            SgnZ,
            Other,
        }
        let mut vals: Vec<Val> = Vec::with_capacity(program.ops().len());
        for &op in program.ops() {
            let get = |a: u32| vals[a as usize];
            let val = match op {
                LaneOp::Var(0) => Val::Is(Observed::Z),
                LaneOp::Var(_) => Val::Is(Observed::V),
                LaneOp::Unary(Unary::Abs, a) if get(a) == Val::Is(Observed::Z) => {
                    Val::Is(Observed::AbsZ)
                }
                LaneOp::Unary(Unary::Sgn, a) if get(a) == Val::Is(Observed::Z) => Val::SgnZ,
                LaneOp::Mul(a, b) => match (get(a), get(b)) {
                    (Val::Is(Observed::V), Val::SgnZ) | (Val::SgnZ, Val::Is(Observed::V)) => {
                        Val::Is(Observed::VSgnZ)
                    }
                    _ => Val::Other,
                },
                _ => Val::Other,
            };
            vals.push(val);
        }
        program
            .outputs()
            .iter()
            .map(|&o| match vals[o as usize] {
                Val::Is(q) => Some(q),
                _ => None,
            })
            .collect()
    }

    /// The value at the state `(z, v)`, as the tape computes it.
    #[inline(always)]
    fn at(self, z: f64, v: f64) -> f64 {
        match self {
            Observed::Z => z,
            Observed::V => v,
            Observed::AbsZ => z.abs(),
            Observed::VSgnZ => v * sgn(z),
        }
    }
}

/// A blown-up lane: its index, the step of the sample point that found it, its last finite
/// recorded state.
pub(crate) type Blown = (usize, u64, Option<LastState>);

/// The recording phase of a statistics batch on the fused path: `b` (after its burn-in)
/// advanced through the run's sample points, the states (then the `kinds`) recorded into
/// `acc` for the lanes with `record`, lanes that blow up unset there and listed in `blown`.
/// `None` when `cancel` was set (checked every [`CHUNK_SAMPLES`] sample points), and
/// `Some(false)` (nothing done) when the batch is not on the fast mechanical path.
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_batch(
    plan: &Plan,
    st: &RunSettings,
    kinds: &[Observed],
    b: &mut BatchState,
    acc: &mut [Accumulator],
    crossings: &mut LevelCrossings,
    record: &mut [bool],
    blown: &mut Vec<Blown>,
    cancel: &Cancel,
) -> Option<bool> {
    let simd = b.simd();
    if st.steps_per_sample == 0 || !b.has_fast_rows(plan) {
        return Some(false);
    }
    // The part's lanes (a part of the batch, see `batch::PART_LANES`).
    let n = record.len();
    let samples = st.samples_per_trajectory;
    let rows = (CHUNK_SAMPLES.min(samples) as usize) * n;
    let (mut xs, mut vs, mut rec) = (vec![0.0; rows], vec![0.0; rows], vec![false; rows]);
    // The states at the sample point before a chunk's first.
    let (mut prev_x, mut prev_v) = (vec![0.0; n], vec![0.0; n]);
    let mut s = 0;
    while s < samples {
        if cancel.is_cancelled() {
            return None;
        }
        // The chunk ends at the next quarter of the recording.
        let window = quarter(s, samples);
        let mut end = (s + CHUNK_SAMPLES).min(samples);
        while quarter(end - 1, samples) != window {
            end -= 1;
        }
        for a in acc.iter_mut() {
            a.set_window(window as usize);
        }
        let m = (end - s) as usize;
        let (xs, vs, rec) = (&mut xs[..m * n], &mut vs[..m * n], &mut rec[..m * n]);
        let done = b.advance_rows(plan, end - s, st.steps_per_sample, st.dt, xs, vs);
        // The rows are read next: a call that did not run must not pass unnoticed.
        assert!(done, "the fast path was checked (has_fast_rows)");
        let marks = b.tally.as_mut().and_then(|t| t.take_marks(m, n));
        // The periodic state recorded in its window (the rows are copies; the lanes run on).
        if let Some(p) = st.periodic {
            p.wrap(if p.state == 0 { xs } else { vs });
        }
        let chunk = Chunk {
            kinds,
            m,
            n,
            xs,
            vs,
            rec,
        };
        let lost = record_chunk(acc, chunk, record, simd);
        if crossings.any() {
            let rows = SampleRows { xs, vs, rec };
            count_crossings(crossings, kinds, s, n, rows, marks.as_deref());
        }
        // The lanes lost in the chunk, row by row and in lane order in a row (as `batch.rs`).
        for j in (0..m).filter(|&j| lost >> j & 1 == 1) {
            let g = s + j as u64;
            let step = st.burn_in_steps + (g + 1) * st.steps_per_sample;
            for i in 0..n {
                let before = if j == 0 {
                    record[i]
                } else {
                    rec[(j - 1) * n + i]
                };
                if before && !rec[j * n + i] {
                    let state = if j == 0 {
                        [prev_x[i], prev_v[i]]
                    } else {
                        [xs[(j - 1) * n + i], vs[(j - 1) * n + i]]
                    };
                    let last = (g > 0).then(|| LastState {
                        step: step - st.steps_per_sample,
                        state,
                    });
                    blown.push((i, step, last));
                }
            }
        }
        record.copy_from_slice(&rec[(m - 1) * n..]);
        prev_x.copy_from_slice(&xs[(m - 1) * n..]);
        prev_v.copy_from_slice(&vs[(m - 1) * n..]);
        s = end;
    }
    Some(true)
}

/// A chunk's sample rows: the states and which lanes are recorded, `n` lanes a row.
struct SampleRows<'a> {
    xs: &'a [f64],
    vs: &'a [f64],
    rec: &'a [bool],
}

/// The `rows` of a chunk from sample point `first` on (`n` lanes a row) into `crossings`:
/// the states as they are, the observables of `kinds` as the general recording's tape
/// computes them; `marks` the lanes' impacts in each row's interval, when logged.
fn count_crossings(
    crossings: &mut LevelCrossings,
    kinds: &[Observed],
    first: u64,
    n: usize,
    rows: SampleRows<'_>,
    marks: Option<&[ImpactMark]>,
) {
    let counted: Vec<usize> = crossings.quantities().collect();
    let mut g = vec![0.0; n];
    let pairs = rows.xs.chunks_exact(n).zip(rows.vs.chunks_exact(n));
    for (j, (x, v)) in pairs.enumerate() {
        let r = &rows.rec[j * n..(j + 1) * n];
        let m = marks.map(|m| &m[j * n..(j + 1) * n]);
        for (k, &q) in counted.iter().enumerate() {
            let values = match q {
                0 => x,
                1 => v,
                q => {
                    for i in 0..n {
                        g[i] = kinds[q - 2].at(x[i], v[i]);
                    }
                    &g[..]
                }
            };
            crossings.add(k, first + j as u64, values, r, m);
        }
    }
}

/// The quarter of the recording sample `s` of `samples` falls in (as `batch.rs`).
fn quarter(s: u64, samples: u64) -> u64 {
    ((s as u128 * 4) / samples as u128) as u64
}

/// A chunk of the recording: `m` (≤ 32) rows of `n` lanes, lane i's state at row j
/// `(xs[j * n + i], vs[j * n + i])`, with the observables `kinds` (after the states);
/// `rec` written by the scan (`scan_block`): lane i recorded at row j when
/// `rec[j * n + i]`.
struct Chunk<'a> {
    kinds: &'a [Observed],
    m: usize,
    n: usize,
    xs: &'a [f64],
    vs: &'a [f64],
    rec: &'a mut [bool],
}

/// Scans `chunk`'s states for the lanes still recorded (`record`, as at its start) and
/// records them into the states' and the observables' accumulators, with the widest vector
/// extension (the same bits at every width: no fused multiply-add); returns the rows at
/// which a lane was lost (bit j for row j).
fn record_chunk(acc: &mut [Accumulator], chunk: Chunk<'_>, record: &[bool], simd: Simd) -> u32 {
    match simd {
        Simd::Baseline => record_body(acc, chunk, record),
        // SAFETY: `simd` was detected on this CPU.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2(_) => unsafe { record_avx2(acc, chunk, record) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512(_) => unsafe { record_avx512(acc, chunk, record) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn record_avx2(acc: &mut [Accumulator], chunk: Chunk<'_>, record: &[bool]) -> u32 {
    record_body(acc, chunk, record)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn record_avx512(acc: &mut [Accumulator], chunk: Chunk<'_>, record: &[bool]) -> u32 {
    record_body(acc, chunk, record)
}

/// Lanes a block of the recording keeps in registers.
const BLOCK: usize = 8;

#[inline(always)]
fn record_body(acc: &mut [Accumulator], chunk: Chunk<'_>, record: &[bool]) -> u32 {
    let Chunk {
        kinds,
        m,
        n,
        xs,
        vs,
        rec,
    } = chunk;
    assert!(m <= 32 && xs.len() >= m * n && vs.len() >= m * n && rec.len() >= m * n);
    // Block by block, the scan and then every quantity while the block's rows are in the
    // cache.
    let mut lost = 0;
    let mut first = 0;
    while first < n {
        let block = Rows {
            m,
            n,
            first,
            xs,
            vs,
        };
        if first + BLOCK <= n {
            // The fast form where every lane of the block is recorded through the chunk
            // (the common case), the general one where a lane is skipped or lost.
            let (fine, l) = scan_block::<BLOCK>(block, record, rec);
            lost |= l;
            if fine {
                add_block::<BLOCK, true>(acc, kinds, block, rec);
            } else {
                add_block::<BLOCK, false>(acc, kinds, block, rec);
            }
        } else {
            for i in first..n {
                let one = Rows { first: i, ..block };
                lost |= scan_block::<1>(one, record, rec).1;
                add_block::<1, false>(acc, kinds, one, rec);
            }
        }
        first += BLOCK;
    }
    lost
}

/// The rows of a chunk's lanes `first..`.
#[derive(Clone, Copy)]
struct Rows<'a> {
    m: usize,
    n: usize,
    first: usize,
    xs: &'a [f64],
    vs: &'a [f64],
}

/// Scans the lanes `first..first + L` of `rows`: lane i is recorded at row j when it was at
/// the chunk's start (`record[i]`) and its states are finite at every row up to j (once
/// lost, a lane stays lost: as the row-by-row scan with `record` cleared at a loss).
/// Returns whether every lane is recorded at every row, and the rows at which one was lost.
#[inline(always)]
fn scan_block<const L: usize>(rows: Rows<'_>, record: &[bool], rec: &mut [bool]) -> (bool, u32) {
    let Rows {
        m,
        n,
        first,
        xs,
        vs,
    } = rows;
    let all = u32::MAX >> (32 - L);
    // Lane l of the block is bit l.
    let start = record[first..first + L]
        .iter()
        .enumerate()
        .fold(0u32, |m, (l, &r)| m | (r as u32) << l);
    if start == all {
        // The common case first: every lane recorded, and x·0 + v·0 summed over the rows is
        // ±0 when every state is finite, NaN when one is not (∞·0 and NaN·0 are NaN): four
        // vector operations a row.
        let mut zero = [0.0f64; L];
        for j in 0..m {
            let row = j * n + first;
            let x: &[f64; L] = xs[row..row + L].try_into().expect("L lanes");
            let v: &[f64; L] = vs[row..row + L].try_into().expect("L lanes");
            for l in 0..L {
                zero[l] += x[l] * 0.0 + v[l] * 0.0;
            }
        }
        if zero.iter().all(|&z| z == 0.0) {
            for j in 0..m {
                let row = j * n + first;
                rec[row..row + L].fill(true);
            }
            return (true, 0);
        }
    }
    // Else row by row, a row's finite lanes as a mask.
    let mut alive = [0u32; 32];
    let mut now = start;
    let mut lost = 0u32;
    for (j, alive) in alive.iter_mut().enumerate().take(m) {
        let row = j * n + first;
        let x: &[f64; L] = xs[row..row + L].try_into().expect("L lanes");
        let v: &[f64; L] = vs[row..row + L].try_into().expect("L lanes");
        let mut finite = 0u32;
        for l in 0..L {
            finite |= ((x[l].is_finite() & v[l].is_finite()) as u32) << l;
        }
        let next = now & finite;
        lost |= ((next != now) as u32) << j;
        now = next;
        *alive = now;
    }
    for (j, &alive) in alive.iter().enumerate().take(m) {
        let row = j * n + first;
        let rec: &mut [bool; L] = (&mut rec[row..row + L]).try_into().expect("L lanes");
        if now == all {
            *rec = [true; L];
        } else {
            for (l, r) in rec.iter_mut().enumerate() {
                *r = alive >> l & 1 == 1;
            }
        }
    }
    (now == all, lost)
}

/// Records the lanes `first..first + L` of `rows` into every quantity's accumulator:
/// with `add_lanes`'s fast form when `FINE` (every lane recorded at every row: the values of
/// every [`Observed`] are finite at finite states), else with `add_lanes` and `rec`.
#[inline(always)]
fn add_block<const L: usize, const FINE: bool>(
    acc: &mut [Accumulator],
    kinds: &[Observed],
    rows: Rows<'_>,
    rec: &[bool],
) {
    let all = [Observed::Z, Observed::V].iter().chain(kinds).copied();
    for (a, kind) in acc.iter_mut().zip(all) {
        // One monomorphised loop per kind, so the value is computed inline.
        match kind {
            Observed::Z => add_kind::<L, FINE>(a, rows, rec, |z, _| z),
            Observed::V => add_kind::<L, FINE>(a, rows, rec, |_, v| v),
            Observed::AbsZ => add_kind::<L, FINE>(a, rows, rec, |z, v| Observed::AbsZ.at(z, v)),
            Observed::VSgnZ => add_kind::<L, FINE>(a, rows, rec, |z, v| Observed::VSgnZ.at(z, v)),
        }
    }
}

/// One quantity of [`add_block`], its value `value(z, v)`.
#[inline(always)]
fn add_kind<const L: usize, const FINE: bool>(
    a: &mut Accumulator,
    rows: Rows<'_>,
    rec: &[bool],
    value: impl Fn(f64, f64) -> f64,
) {
    let Rows {
        m,
        n,
        first,
        xs,
        vs,
    } = rows;
    a.add_lanes::<L, FINE>(first, m, n, xs, vs, rec, value)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::compile::mech_form::tests::plan;

    #[test]
    fn the_bundled_observables_are_recognised_or_not() {
        let kinds = |name: &str| {
            let p = plan(name).unwrap();
            Observed::recognise(p.observables.program())
        };
        use Observed::*;
        assert_eq!(kinds("vibro_duffing"), Some(vec![AbsZ, VSgnZ]));
        assert_eq!(kinds("linear"), Some(vec![Z, V]));
        assert_eq!(kinds("vibro_impact_duffing"), Some(vec![]));
        // energy = (z² + v²)/2 is not one of them: the general recording.
        assert_eq!(kinds("van_der_pol"), None);
    }

    /// The value of each kind is the tape's, bit for bit, signed zeros and non-finite
    /// states included.
    #[test]
    fn each_kind_is_the_tapes_value() {
        let p = plan("vibro_duffing").unwrap();
        let zs = [0.0, -0.0, 1.5, -2.25, f64::INFINITY, f64::NAN, -1e-300];
        let vs = [0.0, -0.0, 0.75, -3.0, f64::NEG_INFINITY, f64::NAN];
        let kinds = Observed::recognise(p.observables.program()).unwrap();
        let mut out = [0.0; 2];
        for &z in &zs {
            for &v in &vs {
                p.observables
                    .eval_point(crate::mc::compile::eval::NO_TIME, z, v, &mut out);
                for (k, want) in kinds.iter().zip(out) {
                    let got = k.at(z, v);
                    assert!(
                        got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                        "{k:?} at ({z}, {v}): {got} vs {want}"
                    );
                }
            }
        }
    }
    /// A chunk whose blocks take each form of the recording: block 0 every lane recorded
    /// and finite (the fast form), block 1 a lane lost to a NaN at row 6, block 2 a lane
    /// not recorded, block 3 a lane lost to an infinite velocity at row 0, and three lanes
    /// alone, one lost at the last row. Its sums, counts and lost rows are the general
    /// recording's (`Accumulator::add` row by row, `record` cleared at a loss) bit for bit
    /// at every vector width, for a whole chunk (32 rows: the counts' ring of indices wraps),
    /// half a chunk and a short one.
    #[test]
    fn each_block_form_records_as_the_general_recording() {
        use crate::mc::record::histogram::Grid;
        let n = 4 * BLOCK + 3;
        let kinds = [Observed::AbsZ, Observed::VSgnZ, Observed::Z];
        let grids = [
            (-2.0, 1.5, 37),
            (-3.0, 2.0, 41),
            (0.0, 1.2, 13),
            (-2.5, 2.5, 9),
            (-1.0, 1.0, 5),
        ];
        for m in [32, 16, 5] {
            // Values on and off the grids, signed zeros.
            let value = |k: usize| ((k * 7919 % 1013) as f64 / 1013.0 - 0.5) * 5.0;
            let mut xs: Vec<f64> = (0..m * n).map(value).collect();
            let mut vs: Vec<f64> = (0..m * n).map(|k| value(k + 5000)).collect();
            xs[3] = 0.0;
            vs[4] = -0.0;
            xs[6.min(m - 1) * n + BLOCK + 3] = f64::NAN;
            vs[3 * BLOCK + 1] = f64::INFINITY;
            xs[(m - 1) * n + 4 * BLOCK + 1] = f64::NAN;
            let mut record = vec![true; n];
            record[2 * BLOCK + 5] = false;
            let new = || -> Vec<Accumulator> {
                grids
                    .iter()
                    .map(|&(lo, hi, bins)| Accumulator::new(Grid::new(lo, hi, bins).unwrap(), n))
                    .collect()
            };
            // The general recording.
            let mut want = new();
            let mut want_record = record.clone();
            let mut want_lost = 0u32;
            for j in 0..m {
                let (x, v) = (&xs[j * n..(j + 1) * n], &vs[j * n..(j + 1) * n]);
                for i in 0..n {
                    let ok = want_record[i] && x[i].is_finite() && v[i].is_finite();
                    want_lost |= ((ok != want_record[i]) as u32) << j;
                    want_record[i] = ok;
                }
                want[0].add(x, &want_record);
                want[1].add(v, &want_record);
                for (a, k) in want[2..].iter_mut().zip(kinds) {
                    let q: Vec<f64> = (0..n).map(|i| k.at(x[i], v[i])).collect();
                    a.add(&q, &want_record);
                }
            }
            let text = |acc: Vec<Accumulator>| -> Vec<String> {
                acc.into_iter()
                    .map(|a| format!("{:?}", a.finish()))
                    .collect()
            };
            let want = text(want);
            // The blocks' forms.
            let mut rec = vec![false; m * n];
            let rows = |first| Rows {
                m,
                n,
                first,
                xs: &xs,
                vs: &vs,
            };
            let fine: Vec<bool> = (0..4)
                .map(|b| scan_block::<BLOCK>(rows(b * BLOCK), &record, &mut rec).0)
                .collect();
            assert_eq!(fine, [true, false, false, false]);
            for simd in Simd::available() {
                let mut acc = new();
                let mut rec = vec![false; m * n];
                let chunk = Chunk {
                    kinds: &kinds,
                    m,
                    n,
                    xs: &xs,
                    vs: &vs,
                    rec: &mut rec,
                };
                let lost = record_chunk(&mut acc, chunk, &record, simd);
                assert_eq!(lost, want_lost, "m = {m}, {simd:?}");
                assert_eq!(&rec[(m - 1) * n..], &want_record[..], "m = {m}, {simd:?}");
                assert_eq!(text(acc), want, "m = {m}, {simd:?}");
            }
        }
    }
}
