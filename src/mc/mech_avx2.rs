//! The vector group of `mech_kernel.rs` on AVX2 (4 lanes per vector): the same IEEE
//! operations in the same order as the scalar `lane` and the AVX-512 group, so every width
//! gives the same bits (tested by `vector_width_does_not_change_a_bit`). AVX2 has no mask
//! registers, no 64-bit rotate and no unsigned 64-bit compare: comparisons give all-ones
//! lanes used by `blendv`, rotates are two shifts, and the three-point thresholds are
//! compared signed (both sides are below 2³³).

use super::{refly_met, Columns, Steps};
use crate::mc::impact::Barrier;
use crate::mc::mech_form::{MechForm, SgnPoly, ZPoly};
use crate::mc::rng::THREE_POINT_T;
use std::arch::x86_64::*;

/// Vectors of 4 lanes a group interleaves.
const VECTORS: usize = 8;
/// Lanes of a group.
pub(super) const GROUP: usize = 4 * VECTORS;

type V = [__m256d; VECTORS];
type U = [__m256i; VECTORS];

#[inline(always)]
fn each(f: impl Fn(usize) -> __m256d) -> V {
    std::array::from_fn(f)
}

#[inline]
#[target_feature(enable = "avx2")]
fn horner(p: &ZPoly, z: &V) -> V {
    let mut it = p.coef.iter().rev();
    let Some(&top) = it.next() else {
        return [_mm256_setzero_pd(); VECTORS];
    };
    let mut acc = [_mm256_set1_pd(top); VECTORS];
    for &c in it {
        let c = _mm256_set1_pd(c);
        acc = each(|k| _mm256_add_pd(_mm256_mul_pd(acc[k], z[k]), c));
    }
    acc
}

#[inline]
#[target_feature(enable = "avx2")]
fn sgn_poly(p: &SgnPoly, z: &V, s: &V) -> V {
    let plain = horner(&p.plain, z);
    match &p.sgn {
        None => plain,
        // s·1 is s (s is ±1 or 0): the product left out, the same bits.
        Some(q) if q.coef == [1.0] => each(|k| _mm256_add_pd(plain[k], s[k])),
        Some(q) => {
            let q = horner(q, z);
            each(|k| _mm256_add_pd(plain[k], _mm256_mul_pd(s[k], q[k])))
        }
    }
}

/// Three-point values of the 32-bit numbers `u` (as `rng::three_point`).
#[inline]
#[target_feature(enable = "avx2")]
fn three_point(u: __m256i, a: __m256d) -> __m256d {
    let t = _mm256_set1_epi64x(THREE_POINT_T as i64);
    let t2 = _mm256_set1_epi64x(2 * THREE_POINT_T as i64);
    // u < t as t > u: signed is exact, u < 2³² and t, 2t < 2³³.
    let neg = _mm256_castsi256_pd(_mm256_cmpgt_epi64(t, u));
    let below2 = _mm256_castsi256_pd(_mm256_cmpgt_epi64(t2, u));
    let pos = _mm256_andnot_pd(neg, below2);
    let zero = _mm256_setzero_pd();
    // pos − neg of the scalar form: a − 0, 0 − a, or 0 − 0 = +0.
    let r = _mm256_blendv_pd(zero, a, pos);
    _mm256_blendv_pd(r, _mm256_sub_pd(zero, a), neg)
}

/// Rotation left by `L` of each 64-bit lane (`R` = 64 − `L`).
#[inline]
#[target_feature(enable = "avx2")]
fn rotl<const L: i32, const R: i32>(x: __m256i) -> __m256i {
    _mm256_or_si256(_mm256_slli_epi64::<L>(x), _mm256_srli_epi64::<R>(x))
}

/// `(s − b)·side`, the signed distance `meets()` compares with zero: for a barrier at zero
/// `s·side`, the same value but perhaps the sign of a zero, so the same comparisons.
#[inline]
#[target_feature(enable = "avx2")]
fn dist(b: f64, s: __m256d, side: __m256d) -> __m256d {
    if b == 0.0 {
        _mm256_mul_pd(s, side)
    } else {
        _mm256_mul_pd(_mm256_sub_pd(s, _mm256_set1_pd(b)), side)
    }
}

/// The flight x → x + v·τ of every lane of a group, impacts resolved lane by lane; `d`
/// holds each lane's [`dist`] to the barrier before the flight and after it.
#[inline]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn fly(
    bar: Option<&Barrier>,
    x: &mut V,
    v: &mut V,
    side: &mut V,
    d: &mut V,
    impacts: &mut [u64],
    tau: f64,
) {
    let zero = _mm256_setzero_pd();
    let vtau = _mm256_set1_pd(tau);
    let xn = each(|k| _mm256_add_pd(x[k], _mm256_mul_pd(v[k], vtau)));
    let mut met = [0i32; VECTORS];
    if let Some(bar) = bar {
        for k in 0..VECTORS {
            // meets(): d1 < 0 or (d1 = 0 and d0 > 0).
            let d1 = dist(bar.at, xn[k], side[k]);
            let m = _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_LT_OQ>(d1, zero),
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_EQ_OQ>(d1, zero),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(d[k], zero),
                ),
            );
            met[k] = _mm256_movemask_pd(m);
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
                    &mut impacts[4 * k..4 * k + 4],
                    tau,
                );
                d[k] = dist(bar.at, x[k], side[k]);
            }
        }
    }
}

/// The lanes of one vector whose flight met the barrier (bits of `met`): each flown again
/// by the scalar `flight` in [`refly_met`] (the same arithmetic), which resolves the impact.
#[cold]
#[inline(never)]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn impacts_of(
    bar: &Barrier,
    met: i32,
    x0: __m256d,
    x: &mut __m256d,
    v: &mut __m256d,
    side: &mut __m256d,
    impacts: &mut [u64],
    tau: f64,
) {
    let (mut xa, mut va, mut sa, mut xna) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
    // SAFETY: stores of 4 values into arrays of 4.
    unsafe {
        _mm256_storeu_pd(xa.as_mut_ptr(), x0);
        _mm256_storeu_pd(va.as_mut_ptr(), *v);
        _mm256_storeu_pd(sa.as_mut_ptr(), *side);
        _mm256_storeu_pd(xna.as_mut_ptr(), *x);
    }
    refly_met(
        bar, met as u32, &xa, &mut xna, &mut va, &mut sa, impacts, tau,
    );
    // SAFETY: loads of 4 values from arrays of 4.
    unsafe {
        *x = _mm256_loadu_pd(xna.as_ptr());
        *v = _mm256_loadu_pd(va.as_ptr());
        *side = _mm256_loadu_pd(sa.as_ptr());
    }
}

/// A group of [`GROUP`] lanes through all the steps of a call, as `super::lane` does each
/// of them.
#[target_feature(enable = "avx2")]
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
    // 4·VECTORS values and vector k covers 4k..4k+4.
    let load = |s: &[f64]| each(|k| unsafe { _mm256_loadu_pd(s[4 * k..4 * k + 4].as_ptr()) });
    let load_u = |s: &[u64]| -> U {
        std::array::from_fn(|k| unsafe { _mm256_loadu_si256(s[4 * k..4 * k + 4].as_ptr().cast()) })
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
        _mm256_set1_pd(h),
        _mm256_set1_pd(st.sqrt_h),
        _mm256_set1_pd(0.5),
        _mm256_set1_pd(st.a),
    );
    let (zero, one, neg_one) = (
        _mm256_setzero_pd(),
        _mm256_set1_pd(1.0),
        _mm256_set1_pd(-1.0),
    );
    let mut d: V = match bar {
        Some(bar) => each(|k| dist(bar.at, x[k], side[k])),
        None => [zero; VECTORS],
    };
    let mut use_pending = st.pending;
    for j in 0..st.samples {
        fly(bar, &mut x, &mut v, &mut side, &mut d, impacts, 0.5 * h);
        for step in 0..st.steps {
            let tau = if step + 1 == st.steps { 0.5 * h } else { h };
            let z: V = if use_pending {
                pending
            } else {
                // xoshiro256++, one output per lane (as `LaneRng::fill`).
                let mut out = [_mm256_setzero_si256(); VECTORS];
                for k in 0..VECTORS {
                    let (a0, b0, c0, d0) = (r0[k], r1[k], r2[k], r3[k]);
                    out[k] = _mm256_add_epi64(rotl::<23, 41>(_mm256_add_epi64(a0, d0)), a0);
                    let t = _mm256_slli_epi64::<17>(b0);
                    let c1 = _mm256_xor_si256(c0, a0);
                    let d1 = _mm256_xor_si256(d0, b0);
                    r1[k] = _mm256_xor_si256(b0, c1);
                    r0[k] = _mm256_xor_si256(a0, d1);
                    r2[k] = _mm256_xor_si256(c1, t);
                    r3[k] = rotl::<45, 19>(d1);
                }
                let low = _mm256_set1_epi64x(0xFFFF_FFFF);
                pending = each(|k| three_point(_mm256_srli_epi64::<32>(out[k]), a));
                each(|k| three_point(_mm256_and_si256(out[k], low), a))
            };
            use_pending = !use_pending;
            // s = sgn(x): 1, −1, or 0 (at zero and for NaN).
            let s = each(|k| {
                let p = _mm256_blendv_pd(zero, one, _mm256_cmp_pd::<_CMP_GT_OQ>(x[k], zero));
                _mm256_blendv_pd(p, neg_one, _mm256_cmp_pd::<_CMP_LT_OQ>(x[k], zero))
            });
            let f0 = sgn_poly(&form.force0, &x, &s);
            let f0 = match &form.force1 {
                None => f0,
                Some(b) => {
                    let b = sgn_poly(b, &x, &s);
                    each(|k| _mm256_add_pd(f0[k], _mm256_mul_pd(v[k], b[k])))
                }
            };
            let sigma = sgn_poly(&form.sigma, &x, &s);
            let slope = sgn_poly(&form.slope, &x, &s);
            for k in 0..VECTORS {
                let dw = _mm256_mul_pd(z[k], _mm256_mul_pd(sigma[k], vsqrt_h));
                let f1 = _mm256_add_pd(
                    f0[k],
                    _mm256_mul_pd(slope[k], _mm256_add_pd(_mm256_mul_pd(f0[k], vh), dw)),
                );
                let inc = _mm256_add_pd(
                    _mm256_mul_pd(_mm256_mul_pd(vhalf, _mm256_add_pd(f0[k], f1)), vh),
                    dw,
                );
                v[k] = _mm256_add_pd(v[k], inc);
            }
            fly(bar, &mut x, &mut v, &mut side, &mut d, impacts, tau);
        }
        if let Some(rows) = rows.as_mut() {
            let at = j as usize * rows.stride;
            for k in 0..VECTORS {
                let r = at + 4 * k..at + 4 * k + 4;
                // SAFETY: stores of 4 values into slices of 4.
                unsafe {
                    _mm256_storeu_pd(rows.x[r.clone()].as_mut_ptr(), x[k]);
                    _mm256_storeu_pd(rows.v[r].as_mut_ptr(), v[k]);
                }
            }
        }
    }
    let store = |s: &mut [f64], w: &V| {
        for k in 0..VECTORS {
            // SAFETY: as for the loads.
            unsafe { _mm256_storeu_pd(s[4 * k..4 * k + 4].as_mut_ptr(), w[k]) }
        }
    };
    store(xs, &x);
    store(vs, &v);
    store(sides, &side);
    store(pend, &pending);
    for (col, w) in rng.into_iter().zip([r0, r1, r2, r3]) {
        for k in 0..VECTORS {
            // SAFETY: as for the loads.
            unsafe { _mm256_storeu_si256(col[4 * k..4 * k + 4].as_mut_ptr().cast(), w[k]) }
        }
    }
}
