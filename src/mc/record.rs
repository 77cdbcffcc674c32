//! The recording of a statistics batch on the fast mechanical path, fused with the kernel:
//! the kernel (`mech_kernel.rs`) writes the lanes' states at [`CHUNK_SAMPLES`] sample points
//! in a row each, and the recording takes them lane block by lane block, each block's
//! running sums in registers through the chunk ([`Accumulator::add_lanes`]), the
//! observables computed on the way. It applies when every observable is one of the
//! recognised functions of the states ([`Observed`]); the result is the same bits as the
//! general recording (`batch.rs`): each lane's sums take its samples in the same order by the
//! same operations, a quarter's lane sums are added up in lane order when it ends, and the
//! blow-ups are found in the same order.

use super::batch::LastState;
use super::eval::Simd;
use super::histogram::Accumulator;
use super::lanes::{LaneOp, LaneProgram};
use super::mech_form::sgn;
use super::scheme::Plan;
use super::settings::RunSettings;
use super::step::BatchState;
use crate::cancel::Cancel;
use crate::symbolic::TapeUnary as Unary;

/// Sample points the kernel advances between two recordings (rows of states kept: 16 of
/// 128 lanes are 32 kB).
const CHUNK_SAMPLES: u64 = 16;

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
    record: &mut [bool],
    blown: &mut Vec<Blown>,
    cancel: &Cancel,
) -> Option<bool> {
    let simd = b.simd();
    if st.steps_per_sample == 0 || !b.has_fast_rows(plan) {
        return Some(false);
    }
    let n = st.lanes;
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
        for j in 0..m {
            let r = j * n..(j + 1) * n;
            let (x, v, rec) = (&xs[r.clone()], &vs[r.clone()], &mut rec[r]);
            // Bitwise, so the loop vectorises.
            let mut lost = false;
            for i in 0..n {
                let ok = record[i] & x[i].is_finite() & v[i].is_finite();
                lost |= ok ^ record[i];
                rec[i] = ok;
            }
            if lost {
                let g = s + j as u64;
                let step = st.burn_in_steps + (g + 1) * st.steps_per_sample;
                for i in 0..n {
                    if record[i] && !rec[i] {
                        record[i] = false;
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
        }
        let chunk = Chunk {
            kinds,
            m,
            n,
            xs,
            vs,
            rec,
        };
        accumulate(acc, chunk, simd);
        prev_x.copy_from_slice(&xs[(m - 1) * n..]);
        prev_v.copy_from_slice(&vs[(m - 1) * n..]);
        s = end;
    }
    Some(true)
}

/// The quarter of the recording sample `s` of `samples` falls in (as `batch.rs`).
fn quarter(s: u64, samples: u64) -> u64 {
    ((s as u128 * 4) / samples as u128) as u64
}

/// A chunk of the recording: `m` rows of `n` lanes, lane i's state at row j
/// `(xs[j * n + i], vs[j * n + i])`, recorded when `rec[j * n + i]`, with the observables
/// `kinds` (after the states).
#[derive(Clone, Copy)]
struct Chunk<'a> {
    kinds: &'a [Observed],
    m: usize,
    n: usize,
    xs: &'a [f64],
    vs: &'a [f64],
    rec: &'a [bool],
}

/// Records `chunk` into the states' and the observables' accumulators, with the widest
/// vector extension (the same bits at every width: no fused multiply-add).
fn accumulate(acc: &mut [Accumulator], chunk: Chunk<'_>, simd: Simd) {
    match simd {
        Simd::Baseline => accumulate_body(acc, chunk),
        // SAFETY: `simd` was detected on this CPU.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2 => unsafe { accumulate_avx2(acc, chunk) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512 => unsafe { accumulate_avx512(acc, chunk) },
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn accumulate_avx2(acc: &mut [Accumulator], chunk: Chunk<'_>) {
    accumulate_body(acc, chunk);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn accumulate_avx512(acc: &mut [Accumulator], chunk: Chunk<'_>) {
    accumulate_body(acc, chunk);
}

/// Lanes a block of the recording keeps in registers.
const BLOCK: usize = 8;

#[inline(always)]
fn accumulate_body(acc: &mut [Accumulator], chunk: Chunk<'_>) {
    // Block by block, every quantity of a block while its rows are in the cache.
    let mut first = 0;
    while first + BLOCK <= chunk.n {
        block::<BLOCK>(acc, chunk, first);
        first += BLOCK;
    }
    for i in first..chunk.n {
        block::<1>(acc, chunk, i);
    }
}

/// The lanes `first..first + L` of every quantity.
#[inline(always)]
fn block<const L: usize>(acc: &mut [Accumulator], chunk: Chunk<'_>, first: usize) {
    let Chunk {
        kinds,
        m,
        n,
        xs,
        vs,
        rec,
    } = chunk;
    let all = [Observed::Z, Observed::V].iter().chain(kinds).copied();
    for (a, kind) in acc.iter_mut().zip(all) {
        // One monomorphised loop per kind, so the value is computed inline.
        match kind {
            Observed::Z => a.add_lanes::<L>(first, m, n, xs, vs, rec, |z, _| z),
            Observed::V => a.add_lanes::<L>(first, m, n, xs, vs, rec, |_, v| v),
            Observed::AbsZ => {
                a.add_lanes::<L>(first, m, n, xs, vs, rec, |z, v| Observed::AbsZ.at(z, v))
            }
            Observed::VSgnZ => {
                a.add_lanes::<L>(first, m, n, xs, vs, rec, |z, v| Observed::VSgnZ.at(z, v))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::mech_form::tests::plan;

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
                p.observables.eval_point(z, v, &mut out);
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
}
