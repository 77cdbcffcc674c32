//! e^x over a slice, vectorised: what EPC's densities spend most of their evaluation on
//! (exp(Q) at every quadrature node of every line of the observables, 14 % of a degree-4
//! `solve` in glibc's scalar `exp`).
//!
//! The method is fdlibm's `__ieee754_exp` without its branches: x = k·ln2 + r with
//! |r| ≤ ln2/2 (Cody–Waite, ln2 in two parts), e^r = 1 + r + r·c/(2 − c) with c from a
//! degree-5 polynomial in r² (error below 1 ulp), then the scaling by 2^k as two exact
//! multiplications by powers of two (so that results in the subnormal range are rounded once
//! and the scale never overflows its exponent field). Each element takes the same IEEE
//! operations in the same order (no fused multiply-add) whatever the vector width, so the
//! results do not depend on the CPU; they differ from the platform's `f64::exp` by at most an
//! ulp or two (tested: the largest difference over 10⁶ arguments across the range).
//!
//! Special values as `f64::exp`: NaN → NaN, −∞ and anything below −745.2 → 0, +∞ and
//! anything above 709.79 → +∞.

use crate::base::simd::Simd;

/// 1.5·2⁵²: adding it rounds a number below 2⁵¹ in magnitude to an integer, which then sits
/// in the low bits of the sum.
const SHIFT: f64 = 6_755_399_441_055_744.0;
const LOG2_E: f64 = std::f64::consts::LOG2_E;
/// ln 2 in two parts (fdlibm's bits): the high one's 32 trailing zero bits make k·LN2_HI
/// exact for |k| < 2²⁰.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// fdlibm's minimax coefficients of (r·(e^r + 1)/(e^r − 1) − 2)/r² in r², by their bits.
const P1: f64 = f64::from_bits(0x3fc5_5555_5555_553e);
const P2: f64 = f64::from_bits(0xbf66_c16c_16be_bd93);
const P3: f64 = f64::from_bits(0x3f11_566a_af25_de2c);
const P4: f64 = f64::from_bits(0xbebb_bd41_c5d2_6bf1);
const P5: f64 = f64::from_bits(0x3e66_3769_72be_a4d0);
/// Arguments are clamped to [LOWEST, HIGHEST] (NaN kept): e^LOWEST rounds to 0 and
/// e^HIGHEST overflows to +∞, so the clamp changes no result, and k stays small.
const LOWEST: f64 = -746.0;
const HIGHEST: f64 = 710.0;

/// The integer a number of the form `n + SHIFT` holds (|n| < 2⁵¹).
#[inline(always)]
fn shifted_int(s: f64) -> i64 {
    (s.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64)
}

/// 2^n for −1022 ≤ n ≤ 1023, from its exponent bits.
#[inline(always)]
fn pow2(n: i64) -> f64 {
    f64::from_bits(((n + 1023) as u64) << 52)
}

/// e^x for one element: straight-line code (comparisons become selects) that the compiler
/// vectorises over a slice.
#[inline(always)]
fn exp1(x: f64) -> f64 {
    // Written so that a NaN passes through both comparisons.
    let x = if x < LOWEST { LOWEST } else { x };
    let x = if x > HIGHEST { HIGHEST } else { x };
    // k = round(x / ln2), as a number and in the low bits of `ks`.
    let ks = x * LOG2_E + SHIFT;
    let k = ks - SHIFT;
    let hi = x - k * LN2_HI;
    let lo = k * LN2_LO;
    let r = hi - lo;
    let t = r * r;
    let c = r - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))));
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    // 2^k as 2^k1 · 2^k2 with k1 = round(k/2): both within the normal exponents for
    // −1077 ≤ k ≤ 1025, and y·2^k1 is exact, so the result is rounded once.
    let k1s = k * 0.5 + SHIFT;
    let k1 = shifted_int(k1s);
    let k2 = shifted_int(ks) - k1;
    y * pow2(k1) * pow2(k2)
}

/// Elements taken together: a whole AVX-512 vector (two AVX2 ones, four SSE2 ones).
const CHUNK: usize = 8;

/// The slice by whole chunks, the last one padded (the observables' calls are of 15 or so
/// elements: element by element, the remainder was most of the work).
#[inline(always)]
fn exp_body(x: &mut [f64]) {
    let mut chunks = x.chunks_exact_mut(CHUNK);
    for chunk in &mut chunks {
        for v in chunk.iter_mut() {
            *v = exp1(*v);
        }
    }
    let rest = chunks.into_remainder();
    if !rest.is_empty() {
        let mut padded = [0.0; CHUNK];
        padded[..rest.len()].copy_from_slice(rest);
        for v in padded.iter_mut() {
            *v = exp1(*v);
        }
        rest.copy_from_slice(&padded[..rest.len()]);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn exp_avx2(x: &mut [f64]) {
    exp_body(x)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn exp_avx512(x: &mut [f64]) {
    exp_body(x)
}

/// e^x, the same bits as an element of [`exp_in_place`] (for the scalar evaluations that
/// must agree with the vectorised ones).
pub(crate) fn exp(x: f64) -> f64 {
    exp1(x)
}

/// Replaces every element x of `x` by e^x, with the widest vector extension of this CPU (the
/// same bits at every width).
pub(crate) fn exp_in_place(x: &mut [f64]) {
    exp_in_place_with(x, simd())
}

/// [`exp_in_place`] with the given extension (which must be this CPU's).
fn exp_in_place_with(x: &mut [f64], simd: Simd) {
    match simd {
        Simd::Baseline => exp_body(x),
        // SAFETY: `simd` names an extension only when it was detected on this CPU.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2(_) => unsafe { exp_avx2(x) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512(_) => unsafe { exp_avx512(x) },
    }
}

/// This CPU's widest extension, detected once.
fn simd() -> Simd {
    static SIMD: std::sync::OnceLock<Simd> = std::sync::OnceLock::new();
    *SIMD.get_or_init(Simd::detect)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance in ulps between two finite numbers of the same sign.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// Within 2 ulps of `f64::exp` everywhere (1 ulp is fdlibm's bound; the platform's exp
    /// is within about half an ulp of the truth), subnormal results included, and the same
    /// bits at every vector width.
    #[test]
    fn within_two_ulps_of_exp_at_every_width() {
        let mut stream = crate::epc::uniform::Uniform::new(0x2545_f491_4f6c_dd1d);
        let mut uniform = || stream.next();
        let mut x: Vec<f64> = (0..1_000_000)
            .map(|i| match i % 4 {
                0 => -745.0 + 1454.7 * uniform(),
                1 => -40.0 + 40.0 * uniform(),
                2 => 0.7 * (uniform() - 0.5),
                _ => -745.1 + 37.0 * uniform(),
            })
            .collect();
        // Halfway points of the reduction, where k changes.
        x.extend((-1075..1025).map(|k| (k as f64 + 0.5) * std::f64::consts::LN_2));
        let want: Vec<f64> = x.iter().map(|v| v.exp()).collect();
        let mut worst = 0;
        for simd in Simd::available() {
            let mut got = x.clone();
            exp_in_place_with(&mut got, simd);
            for (i, (&g, &w)) in got.iter().zip(&want).enumerate() {
                let d = ulps(g, w);
                assert!(d <= 2, "exp({}) = {g:e}, std {w:e}: {d} ulps", x[i]);
                worst = worst.max(d);
            }
            let mut base = x.clone();
            exp_in_place_with(&mut base, Simd::Baseline);
            assert!(got
                .iter()
                .zip(&base)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        assert!(worst >= 1, "compared against itself?");
    }

    /// The values `f64::exp` gives exactly: NaN, 0 and ∞ at the ends of the range (and
    /// beyond), 1 at ±0, the smallest subnormal just above −745.13.
    #[test]
    fn special_values_are_those_of_exp() {
        let mut x = [
            f64::NAN,
            f64::NEG_INFINITY,
            f64::INFINITY,
            -1e300,
            1e300,
            -745.2,
            -745.1,
            709.78,
            709.8,
            0.0,
            -0.0,
        ];
        let want: Vec<f64> = x.iter().map(|v| v.exp()).collect();
        exp_in_place(&mut x);
        for (g, w) in x.iter().zip(&want) {
            assert!(
                g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                "{g:e} vs {w:e}"
            );
        }
    }
}
