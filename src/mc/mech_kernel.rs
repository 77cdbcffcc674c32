//! The fast mechanical path: the Strang splitting of `scheme.rs` for a model in the
//! recognised form ([`MechForm`]), at most one barrier and three-point increments, with
//! the loops interchanged. Each group of lanes keeps its whole state (position, velocity,
//! barrier side, generator, pending increment) in registers for all the steps of a call,
//! draws its increments inside the step and evaluates f, σ, ∂f/∂v by Horner's rule with
//! the coefficients hoisted: no pass over arrays per step, no dispatch per instruction.
//! Impacts (rare) are resolved lane by lane where they happen, with the same
//! `impact_in_flight` as the lane-evaluator path.
//!
//! On AVX-512 groups of [`GROUP`] lanes run in vector registers, on AVX2 groups of 32 lanes
//! (`mech_avx2.rs`); the remaining lanes, and every lane on other CPUs, run [`lane`] one at
//! a time: the same IEEE operations in the
//! same order (no fused multiply-add), so the vector width does not change a bit (tested).

use super::eval::Simd;
use super::impact::{impact_in_flight, meets, Barrier};
use super::mech_form::MechForm;
use super::rng::three_point;

/// Vectors of 8 lanes a group interleaves (the step is one long dependency chain; two
/// independent chains keep the vector units busy).
#[cfg(target_arch = "x86_64")]
const VECTORS: usize = 4;
/// Lanes of a vector group.
#[cfg(target_arch = "x86_64")]
const GROUP: usize = 8 * VECTORS;

/// The batch's columns the kernel advances in place.
pub(crate) struct Columns<'a> {
    pub(crate) x: &'a mut [f64],
    pub(crate) v: &'a mut [f64],
    pub(crate) side: &'a mut [f64],
    pub(crate) impacts: &'a mut [u64],
    /// The xoshiro256++ state words of each lane.
    pub(crate) rng: [&'a mut [u64]; 4],
    /// Each lane's pending second three-point value.
    pub(crate) pending: &'a mut [f64],
    /// Where the states at each sample point go, when the call records them.
    pub(crate) rows: Option<Rows<'a>>,
}

/// The states of the lanes at each sample point of a call: lane i's state at sample j at
/// `x[j * stride + i]`, `v[j * stride + i]`.
pub(crate) struct Rows<'a> {
    pub(crate) x: &'a mut [f64],
    pub(crate) v: &'a mut [f64],
    pub(crate) stride: usize,
}

impl Rows<'_> {
    /// Stores lane `i`'s state as sample `j`'s.
    #[inline(always)]
    fn put(&mut self, j: u64, i: usize, x: f64, v: f64) {
        let k = j as usize * self.stride + i;
        self.x[k] = x;
        self.v[k] = v;
    }
}

impl Columns<'_> {
    /// The lanes `r` of every column.
    #[cfg(target_arch = "x86_64")]
    fn slice(&mut self, r: std::ops::Range<usize>) -> Columns<'_> {
        let [s0, s1, s2, s3] = &mut self.rng;
        Columns {
            x: &mut self.x[r.clone()],
            v: &mut self.v[r.clone()],
            side: &mut self.side[r.clone()],
            impacts: &mut self.impacts[r.clone()],
            rng: [
                &mut s0[r.clone()],
                &mut s1[r.clone()],
                &mut s2[r.clone()],
                &mut s3[r.clone()],
            ],
            pending: &mut self.pending[r.clone()],
            rows: self.rows.as_mut().map(|w| Rows {
                x: &mut w.x[r.start..],
                v: &mut w.v[r.start..],
                stride: w.stride,
            }),
        }
    }
}

/// The step sizes and the three-point value of a call.
#[derive(Clone, Copy)]
struct Steps {
    /// Steps per sample point.
    steps: u64,
    /// Sample points: the call advances `samples · steps` steps, by `steps` at a time.
    samples: u64,
    h: f64,
    sqrt_h: f64,
    /// ±a are the three-point values.
    a: f64,
    /// Whether the first step takes the pending increment (no draw).
    pending: bool,
}

/// Advances every lane by `samples` times `steps` steps of size `h`, each `steps` exactly
/// as one `BatchState::advance` on the lane-evaluator path (half flight, then velocity
/// update and flight per step, the last flight a half), with f, σ, ∂f/∂v from `form`; the
/// states after each `steps` go to `c.rows` when given. `has_pending` is the increment
/// stream's flag, updated; `a` its three-point value.
#[allow(clippy::too_many_arguments)]
pub(crate) fn advance(
    form: &MechForm,
    bar: Option<&Barrier>,
    c: Columns<'_>,
    has_pending: &mut bool,
    a: f64,
    samples: u64,
    steps: u64,
    h: f64,
    simd: Simd,
) {
    if steps == 0 || samples == 0 {
        return;
    }
    let n = c.x.len();
    let st = Steps {
        steps,
        samples,
        h,
        sqrt_h: h.sqrt(),
        a,
        pending: *has_pending,
    };
    let mut c = c;
    #[allow(unused_mut)]
    let mut start = 0;
    #[cfg(target_arch = "x86_64")]
    {
        type Group = unsafe fn(&MechForm, Option<&Barrier>, Columns<'_>, &Steps);
        let group: Option<(usize, Group)> = match simd {
            Simd::Avx512 => Some((GROUP, avx512::group)),
            Simd::Avx2 => Some((avx2::GROUP, avx2::group)),
            _ => None,
        };
        if let Some((size, run)) = group {
            while start + size <= n {
                // SAFETY: `simd` names an extension only when it was detected on this CPU.
                unsafe { run(form, bar, c.slice(start..start + size), &st) };
                start += size;
            }
        }
    }
    let Columns {
        x,
        v,
        side,
        impacts,
        rng: [s0, s1, s2, s3],
        pending,
        mut rows,
    } = c;
    let _ = simd;
    for i in start..n {
        let mut s = [s0[i], s1[i], s2[i], s3[i]];
        let mut use_pending = st.pending;
        for j in 0..samples {
            lane(
                form,
                bar,
                &mut x[i],
                &mut v[i],
                &mut side[i],
                &mut impacts[i],
                &mut s,
                &mut pending[i],
                &mut use_pending,
                &st,
            );
            if let Some(rows) = rows.as_mut() {
                rows.put(j, i, x[i], v[i]);
            }
        }
        [s0[i], s1[i], s2[i], s3[i]] = s;
    }
    if (steps & samples) % 2 == 1 {
        *has_pending = !*has_pending;
    }
}

/// The next xoshiro256++ output of one lane (as `LaneRng::fill`).
#[inline(always)]
fn xoshiro(s: &mut [u64; 4]) -> u64 {
    let [a, b, c, d] = *s;
    let out = a.wrapping_add(d).rotate_left(23).wrapping_add(a);
    let t = b << 17;
    let c = c ^ a;
    let d = d ^ b;
    *s = [a ^ d, b ^ c, c ^ t, d.rotate_left(45)];
    out
}

/// The flight `x → x + v·τ` of one lane, with its impact if it meets the barrier.
#[inline(always)]
fn flight(
    bar: Option<&Barrier>,
    x: &mut f64,
    v: &mut f64,
    side: &mut f64,
    hits: &mut u64,
    tau: f64,
) {
    let mut xn = *x + *v * tau;
    if let Some(bar) = bar {
        if meets(bar.at, *side, *x, xn) {
            impact_in_flight(*x, &mut xn, v, side, tau, bar);
            *hits += 1;
        }
    }
    *x = xn;
}

/// The lanes of one vector (`L` of them, spilled to arrays) whose flight from `x0` met the
/// barrier (bits of `met`): each flown again from `x0` by the scalar [`flight`] (the same
/// arithmetic), which resolves the impact; the other lanes keep their `x`. The one lane
/// loop of every vector width's `impacts_of`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn refly_met<const L: usize>(
    bar: &Barrier,
    met: u32,
    x0: &[f64; L],
    x: &mut [f64; L],
    v: &mut [f64; L],
    side: &mut [f64; L],
    impacts: &mut [u64],
    tau: f64,
) {
    for i in 0..L {
        if met >> i & 1 == 1 {
            let mut xi = x0[i];
            flight(
                Some(bar),
                &mut xi,
                &mut v[i],
                &mut side[i],
                &mut impacts[i],
                tau,
            );
            x[i] = xi;
        }
    }
}

/// One lane through the steps of one sample point (`use_pending` the increment stream's
/// flag, carried from one sample point to the next): the reference the vector groups agree
/// with.
#[allow(clippy::too_many_arguments)]
fn lane(
    form: &MechForm,
    bar: Option<&Barrier>,
    x: &mut f64,
    v: &mut f64,
    side: &mut f64,
    hits: &mut u64,
    rng: &mut [u64; 4],
    pending: &mut f64,
    use_pending: &mut bool,
    st: &Steps,
) {
    let h = st.h;
    flight(bar, x, v, side, hits, 0.5 * h);
    for k in 0..st.steps {
        let tau = if k + 1 == st.steps { 0.5 * h } else { h };
        let z = if *use_pending {
            *pending
        } else {
            let bits = xoshiro(rng);
            *pending = three_point(bits >> 32, st.a);
            three_point(bits & 0xFFFF_FFFF, st.a)
        };
        *use_pending = !*use_pending;
        let (f0, sigma, slope) = form.eval(*x, *v);
        let dw = z * (sigma * st.sqrt_h);
        let f1 = f0 + slope * (f0 * h + dw);
        *v += 0.5 * (f0 + f1) * h + dw;
        flight(bar, x, v, side, hits, tau);
    }
}

#[cfg(target_arch = "x86_64")]
#[path = "mech_avx2.rs"]
mod avx2;

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::{refly_met, Columns, Steps, VECTORS};
    use crate::mc::impact::Barrier;
    use crate::mc::mech_form::{MechForm, SgnPoly, ZPoly};
    use crate::mc::rng::THREE_POINT_T;
    use std::arch::x86_64::*;

    type V = [__m512d; VECTORS];
    type U = [__m512i; VECTORS];

    #[inline(always)]
    fn each(f: impl Fn(usize) -> __m512d) -> V {
        std::array::from_fn(f)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn horner(p: &ZPoly, z: &V) -> V {
        let mut it = p.coef.iter().rev();
        let Some(&top) = it.next() else {
            return [_mm512_setzero_pd(); VECTORS];
        };
        let mut acc = [_mm512_set1_pd(top); VECTORS];
        for &c in it {
            let c = _mm512_set1_pd(c);
            acc = each(|k| _mm512_add_pd(_mm512_mul_pd(acc[k], z[k]), c));
        }
        acc
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn sgn_poly(p: &SgnPoly, z: &V, s: &V) -> V {
        let plain = horner(&p.plain, z);
        match &p.sgn {
            None => plain,
            // s·1 is s (s is ±1 or 0): the product left out, the same bits.
            Some(q) if q.coef == [1.0] => each(|k| _mm512_add_pd(plain[k], s[k])),
            Some(q) => {
                let q = horner(q, z);
                each(|k| _mm512_add_pd(plain[k], _mm512_mul_pd(s[k], q[k])))
            }
        }
    }

    /// Three-point values of the 32-bit numbers `u` (as `rng::three_point`).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn three_point(u: __m512i, a: __m512d) -> __m512d {
        let t = _mm512_set1_epi64(THREE_POINT_T as i64);
        let t2 = _mm512_set1_epi64(2 * THREE_POINT_T as i64);
        let neg = _mm512_cmplt_epu64_mask(u, t);
        let pos = !neg & _mm512_cmplt_epu64_mask(u, t2);
        let zero = _mm512_setzero_pd();
        // pos − neg of the scalar form: a − 0, 0 − a, or 0 − 0 = +0.
        let r = _mm512_mask_blend_pd(pos, zero, a);
        _mm512_mask_blend_pd(neg, r, _mm512_sub_pd(zero, a))
    }

    /// The flight x → x + v·τ of every lane of a group, impacts resolved lane by lane (a
    /// macro: as a function it was not inlined, and a target-feature function cannot be
    /// forced to be).
    /// `(s − b)·side` of every lane, the signed distance `meets()` compares with zero: for
    /// a barrier at zero `s·side`, the same value but perhaps the sign of a zero (s − 0 is
    /// s; s + 0 for b = −0 turns −0 into +0), so the same comparisons.
    macro_rules! dist {
        ($b:expr, $s:expr, $side:expr) => {{
            let (b, s, side): (f64, __m512d, __m512d) = ($b, $s, $side);
            if b == 0.0 {
                _mm512_mul_pd(s, side)
            } else {
                _mm512_mul_pd(_mm512_sub_pd(s, _mm512_set1_pd(b)), side)
            }
        }};
    }

    /// The flight x → x + v·τ of every lane of a group, impacts resolved lane by lane (a
    /// macro: as a function it was not inlined, and a target-feature function cannot be
    /// forced to be). `d` holds each lane's distance to the barrier ([`dist`]) before the
    /// flight and after it: the end of one flight is the start of the next.
    macro_rules! fly {
        ($bar:expr, $x:expr, $v:expr, $side:expr, $d:expr, $impacts:expr, $tau:expr) => {{
            let (bar, x, v, side, d, impacts, tau): (
                Option<&Barrier>,
                &mut V,
                &mut V,
                &mut V,
                &mut V,
                &mut [u64],
                f64,
            ) = ($bar, $x, $v, $side, $d, $impacts, $tau);
            let zero = _mm512_setzero_pd();
            let vtau = _mm512_set1_pd(tau);
            let xn = each(|k| _mm512_add_pd(x[k], _mm512_mul_pd(v[k], vtau)));
            let mut met = [0u8; VECTORS];
            if let Some(bar) = bar {
                for k in 0..VECTORS {
                    // meets(): d1 < 0 or (d1 = 0 and d0 > 0).
                    let d1 = dist!(bar.at, xn[k], side[k]);
                    met[k] = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(d1, zero)
                        | (_mm512_cmp_pd_mask::<_CMP_EQ_OQ>(d1, zero)
                            & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(d[k], zero));
                    d[k] = d1;
                }
            }
            let x0 = *x;
            *x = xn;
            if met != [0; VECTORS] {
                let bar = bar.expect("only a barrier is met");
                for k in 0..VECTORS {
                    if met[k] != 0 {
                        impacts_of(
                            bar,
                            met[k],
                            x0[k],
                            &mut x[k],
                            &mut v[k],
                            &mut side[k],
                            &mut impacts[8 * k..8 * k + 8],
                            tau,
                        );
                        d[k] = dist!(bar.at, x[k], side[k]);
                    }
                }
            }
        }};
    }

    /// The lanes of one vector whose flight to `xn` met the barrier (bits of `met`): each
    /// flown again by the scalar `flight` in [`refly_met`] (the same arithmetic), which
    /// resolves the impact.
    #[cold]
    #[inline(never)]
    #[target_feature(enable = "avx512f")]
    #[allow(clippy::too_many_arguments)]
    fn impacts_of(
        bar: &Barrier,
        met: u8,
        x0: __m512d,
        x: &mut __m512d,
        v: &mut __m512d,
        side: &mut __m512d,
        impacts: &mut [u64],
        tau: f64,
    ) {
        let (mut xa, mut va, mut sa, mut xna) = ([0.0; 8], [0.0; 8], [0.0; 8], [0.0; 8]);
        // SAFETY: stores of 8 values into arrays of 8.
        unsafe {
            _mm512_storeu_pd(xa.as_mut_ptr(), x0);
            _mm512_storeu_pd(va.as_mut_ptr(), *v);
            _mm512_storeu_pd(sa.as_mut_ptr(), *side);
            _mm512_storeu_pd(xna.as_mut_ptr(), *x);
        }
        refly_met(
            bar,
            u32::from(met),
            &xa,
            &mut xna,
            &mut va,
            &mut sa,
            impacts,
            tau,
        );
        // SAFETY: loads of 8 values from arrays of 8.
        unsafe {
            *x = _mm512_loadu_pd(xna.as_ptr());
            *v = _mm512_loadu_pd(va.as_ptr());
            *side = _mm512_loadu_pd(sa.as_ptr());
        }
    }

    /// A group of `GROUP` lanes through all the steps of a call, as [`super::lane`] does
    /// each of them.
    #[target_feature(enable = "avx512f")]
    pub(super) fn group(form: &MechForm, bar: Option<&Barrier>, c: Columns<'_>, st: &Steps) {
        let Columns {
            x: xs,
            v: vs,
            side: sides,
            impacts,
            rng,
            pending: pend,
            mut rows,
        } = c;
        // SAFETY (every load and store below): each column of the group holds GROUP =
        // 8·VECTORS values and vector k covers 8k..8k+8.
        let load = |s: &[f64]| each(|k| unsafe { _mm512_loadu_pd(s[8 * k..8 * k + 8].as_ptr()) });
        let load_u = |s: &[u64]| -> U {
            std::array::from_fn(|k| unsafe {
                _mm512_loadu_si512(s[8 * k..8 * k + 8].as_ptr().cast())
            })
        };
        let (mut x, mut v, mut side, mut pending) = (load(xs), load(vs), load(sides), load(pend));
        let (mut r0, mut r1, mut r2, mut r3) = (
            load_u(rng[0]),
            load_u(rng[1]),
            load_u(rng[2]),
            load_u(rng[3]),
        );
        let h = st.h;
        let (vh, vsqrt_h, vhalf, a) = (
            _mm512_set1_pd(h),
            _mm512_set1_pd(st.sqrt_h),
            _mm512_set1_pd(0.5),
            _mm512_set1_pd(st.a),
        );
        let (zero, one) = (_mm512_setzero_pd(), _mm512_set1_pd(1.0));
        let mut d: V = match bar {
            Some(bar) => each(|k| dist!(bar.at, x[k], side[k])),
            None => [zero; VECTORS],
        };
        let mut use_pending = st.pending;
        let neg_one = _mm512_set1_pd(-1.0);
        for j in 0..st.samples {
            fly!(bar, &mut x, &mut v, &mut side, &mut d, impacts, 0.5 * h);
            for step in 0..st.steps {
                let tau = if step + 1 == st.steps { 0.5 * h } else { h };
                let z: V = if use_pending {
                    pending
                } else {
                    // xoshiro256++, one output per lane (as `LaneRng::fill`).
                    let mut out = [_mm512_setzero_si512(); VECTORS];
                    for k in 0..VECTORS {
                        let (a0, b0, c0, d0) = (r0[k], r1[k], r2[k], r3[k]);
                        out[k] =
                            _mm512_add_epi64(_mm512_rol_epi64::<23>(_mm512_add_epi64(a0, d0)), a0);
                        let t = _mm512_slli_epi64::<17>(b0);
                        let c1 = _mm512_xor_si512(c0, a0);
                        let d1 = _mm512_xor_si512(d0, b0);
                        r1[k] = _mm512_xor_si512(b0, c1);
                        r0[k] = _mm512_xor_si512(a0, d1);
                        r2[k] = _mm512_xor_si512(c1, t);
                        r3[k] = _mm512_rol_epi64::<45>(d1);
                    }
                    let low = _mm512_set1_epi64(0xFFFF_FFFF);
                    pending = each(|k| three_point(_mm512_srli_epi64::<32>(out[k]), a));
                    each(|k| three_point(_mm512_and_si512(out[k], low), a))
                };
                use_pending = !use_pending;
                // s = sgn(x): 1, −1, or 0 (at zero and for NaN).
                let s = each(|k| {
                    let p = _mm512_mask_blend_pd(
                        _mm512_cmp_pd_mask::<_CMP_GT_OQ>(x[k], zero),
                        zero,
                        one,
                    );
                    _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_LT_OQ>(x[k], zero), p, neg_one)
                });
                let f0 = sgn_poly(&form.force0, &x, &s);
                let f0 = match &form.force1 {
                    None => f0,
                    Some(b) => {
                        let b = sgn_poly(b, &x, &s);
                        each(|k| _mm512_add_pd(f0[k], _mm512_mul_pd(v[k], b[k])))
                    }
                };
                let sigma = sgn_poly(&form.sigma, &x, &s);
                let slope = sgn_poly(&form.slope, &x, &s);
                for k in 0..VECTORS {
                    let dw = _mm512_mul_pd(z[k], _mm512_mul_pd(sigma[k], vsqrt_h));
                    let f1 = _mm512_add_pd(
                        f0[k],
                        _mm512_mul_pd(slope[k], _mm512_add_pd(_mm512_mul_pd(f0[k], vh), dw)),
                    );
                    let inc = _mm512_add_pd(
                        _mm512_mul_pd(_mm512_mul_pd(vhalf, _mm512_add_pd(f0[k], f1)), vh),
                        dw,
                    );
                    v[k] = _mm512_add_pd(v[k], inc);
                }
                fly!(bar, &mut x, &mut v, &mut side, &mut d, impacts, tau);
            }
            if let Some(rows) = rows.as_mut() {
                let at = j as usize * rows.stride;
                for k in 0..VECTORS {
                    let r = at + 8 * k..at + 8 * k + 8;
                    // SAFETY: stores of 8 values into slices of 8.
                    unsafe {
                        _mm512_storeu_pd(rows.x[r.clone()].as_mut_ptr(), x[k]);
                        _mm512_storeu_pd(rows.v[r].as_mut_ptr(), v[k]);
                    }
                }
            }
        }
        let store = |s: &mut [f64], w: &V| {
            for k in 0..VECTORS {
                // SAFETY: as for the loads.
                unsafe { _mm512_storeu_pd(s[8 * k..8 * k + 8].as_mut_ptr(), w[k]) }
            }
        };
        store(xs, &x);
        store(vs, &v);
        store(sides, &side);
        store(pend, &pending);
        for (col, w) in rng.into_iter().zip([r0, r1, r2, r3]) {
            for k in 0..VECTORS {
                // SAFETY: as for the loads.
                unsafe { _mm512_storeu_si512(col[8 * k..8 * k + 8].as_mut_ptr().cast(), w[k]) }
            }
        }
    }
}
