//! The vectors the mechanical kernel (`kernel/mech`) is written over: one lane (`f64`,
//! every CPU), 4 lanes on AVX2 ([`Avx2`]) and 8 on AVX-512 ([`Avx512`]). The kernel is one
//! generic function; each type supplies the same IEEE operations (no fused multiply-add)
//! with its own instructions, so the vector width does not change a bit.
//!
//! The methods are `#[inline(always)]` and are only called from code compiled for the
//! extension (the kernel's `#[target_feature]` entry per width), where the intrinsics inline
//! into straight vector code. A value of `Avx2` or `Avx512` exists only inside such an entry,
//! which runs only after the extension was detected on this CPU (`Simd::detect`): that is the
//! safety argument of every `unsafe` block below (the `simd!` macro).

use crate::mc::kernel::rng::{THREE_POINT_BITS, THREE_POINT_T};
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// `[f(0), …, f(N − 1)]`, inlined with `f` into the caller (`std::array::from_fn` was left
/// as a call, and then every vector operation in `f` was a call too).
#[inline(always)]
pub(super) fn each<T: Copy, const N: usize>(mut f: impl FnMut(usize) -> T) -> [T; N] {
    let mut out = [f(0); N];
    for (k, o) in out.iter_mut().enumerate().skip(1) {
        *o = f(k);
    }
    out
}

/// The three-point thresholds of the field at the top of a 64-bit draw
/// (`rng::three_point_field` k = 0): its top 21 bits `u` satisfy `u < T` exactly when
/// `w < T·2⁴³`.
const T_HIGH: u64 = THREE_POINT_T << (64 - THREE_POINT_BITS);
const T2_HIGH: u64 = (2 * THREE_POINT_T) << (64 - THREE_POINT_BITS);

/// Lanes of f64 with the operations the kernel needs.
pub(crate) trait Vector: Copy {
    /// Lanes per vector.
    const LANES: usize;
    /// One bit of truth per lane.
    type Mask: Copy;
    /// 64-bit unsigned integers, one per lane (the generators' words).
    type Bits: Copy;

    fn splat(x: f64) -> Self;
    /// The first `LANES` values of `s`.
    fn load(s: &[f64]) -> Self;
    /// Into the first `LANES` places of `s`.
    fn store(self, s: &mut [f64]);
    fn load_bits(s: &[u64]) -> Self::Bits;
    fn store_bits(b: Self::Bits, s: &mut [u64]);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// Bitwise exclusive or of the two numbers' bits.
    fn xor(self, o: Self) -> Self;
    /// Bitwise and.
    fn and(self, o: Self) -> Self;
    /// Bitwise or.
    fn or(self, o: Self) -> Self;
    /// `self < o` (false for NaN), and so on.
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn eq(self, o: Self) -> Self::Mask;
    /// `m ? a : b` lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    fn mask_or(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    fn mask_and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `m ? self + o : self` lane by lane (one masked addition on AVX-512).
    #[inline(always)]
    fn add_where(self, m: Self::Mask, o: Self) -> Self {
        Self::select(m, self.add(o), self)
    }
    /// `m ? self − o : self` lane by lane.
    #[inline(always)]
    fn sub_where(self, m: Self::Mask, o: Self) -> Self {
        Self::select(m, self.sub(o), self)
    }
    /// `m ? −self : self` lane by lane (the sign bit flipped).
    #[inline(always)]
    fn neg_where(self, m: Self::Mask) -> Self {
        Self::select(m, self.xor(Self::splat(-0.0)), self)
    }
    /// Bit i set when lane i is.
    fn mask_bits(m: Self::Mask) -> u32;
    /// The next xoshiro256++ output of every lane (as `LaneRng::fill`), the state advanced.
    fn xoshiro(s: &mut [Self::Bits; 4]) -> Self::Bits;
    /// `w` with its field `k` (1 or 2, `rng::three_point_field`) moved to the top bits
    /// (`w << 21k`); `w` itself for k = 0.
    fn field_up(w: Self::Bits, k: u8) -> Self::Bits;
    /// The three-point variable of the top field `u` of `w` (as `rng::three_point`):
    /// (u < T: the value −a, u < 2T: a value other than 0).
    fn three_point_high(w: Self::Bits) -> (Self::Mask, Self::Mask);
}

impl Vector for f64 {
    const LANES: usize = 1;
    type Mask = bool;
    type Bits = u64;

    #[inline(always)]
    fn splat(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn load(s: &[f64]) -> f64 {
        s[0]
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[0] = self;
    }
    #[inline(always)]
    fn load_bits(s: &[u64]) -> u64 {
        s[0]
    }
    #[inline(always)]
    fn store_bits(b: u64, s: &mut [u64]) {
        s[0] = b;
    }
    #[inline(always)]
    fn add(self, o: f64) -> f64 {
        self + o
    }
    #[inline(always)]
    fn sub(self, o: f64) -> f64 {
        self - o
    }
    #[inline(always)]
    fn mul(self, o: f64) -> f64 {
        self * o
    }
    #[inline(always)]
    fn div(self, o: f64) -> f64 {
        self / o
    }
    #[inline(always)]
    fn xor(self, o: f64) -> f64 {
        f64::from_bits(self.to_bits() ^ o.to_bits())
    }
    #[inline(always)]
    fn and(self, o: f64) -> f64 {
        f64::from_bits(self.to_bits() & o.to_bits())
    }
    #[inline(always)]
    fn or(self, o: f64) -> f64 {
        f64::from_bits(self.to_bits() | o.to_bits())
    }
    #[inline(always)]
    fn lt(self, o: f64) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f64) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f64) -> bool {
        self > o
    }
    #[inline(always)]
    fn eq(self, o: f64) -> bool {
        self == o
    }
    #[inline(always)]
    fn select(m: bool, a: f64, b: f64) -> f64 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mask_or(a: bool, b: bool) -> bool {
        a | b
    }
    #[inline(always)]
    fn mask_and(a: bool, b: bool) -> bool {
        a & b
    }
    #[inline(always)]
    fn mask_bits(m: bool) -> u32 {
        u32::from(m)
    }
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
    #[inline(always)]
    fn field_up(w: u64, k: u8) -> u64 {
        w << (THREE_POINT_BITS * k as u32)
    }
    #[inline(always)]
    fn three_point_high(w: u64) -> (bool, bool) {
        (w < T_HIGH, w < T2_HIGH)
    }
}

/// Intrinsics, in code that runs only with the extension (see the module's documentation).
#[cfg(target_arch = "x86_64")]
macro_rules! simd {
    ($e:expr) => {{
        // SAFETY: values of this type exist only in the kernel's entry for its extension,
        // called only after the extension was detected on this CPU; loads and stores go
        // through slices indexed (bounds-checked) to the vector's length first.
        #[allow(unused_unsafe)]
        unsafe {
            $e
        }
    }};
}

/// 8 lanes in an AVX-512 register.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx512(__m512d);

#[cfg(target_arch = "x86_64")]
impl Vector for Avx512 {
    const LANES: usize = 8;
    type Mask = __mmask8;
    type Bits = __m512i;

    #[inline(always)]
    fn splat(x: f64) -> Self {
        simd!(Avx512(_mm512_set1_pd(x)))
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..8];
        simd!(Avx512(_mm512_loadu_pd(s.as_ptr())))
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        let s = &mut s[..8];
        simd!(_mm512_storeu_pd(s.as_mut_ptr(), self.0))
    }
    #[inline(always)]
    fn load_bits(s: &[u64]) -> __m512i {
        let s = &s[..8];
        simd!(_mm512_loadu_si512(s.as_ptr().cast()))
    }
    #[inline(always)]
    fn store_bits(b: __m512i, s: &mut [u64]) {
        let s = &mut s[..8];
        simd!(_mm512_storeu_si512(s.as_mut_ptr().cast(), b))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        simd!(Avx512(_mm512_add_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        simd!(Avx512(_mm512_sub_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        simd!(Avx512(_mm512_mul_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        simd!(Avx512(_mm512_div_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn xor(self, o: Self) -> Self {
        simd!(Avx512(_mm512_castsi512_pd(_mm512_xor_si512(
            _mm512_castpd_si512(self.0),
            _mm512_castpd_si512(o.0)
        ))))
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        simd!(Avx512(_mm512_castsi512_pd(_mm512_and_si512(
            _mm512_castpd_si512(self.0),
            _mm512_castpd_si512(o.0)
        ))))
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        simd!(Avx512(_mm512_castsi512_pd(_mm512_or_si512(
            _mm512_castpd_si512(self.0),
            _mm512_castpd_si512(o.0)
        ))))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> __mmask8 {
        simd!(_mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn le(self, o: Self) -> __mmask8 {
        simd!(_mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> __mmask8 {
        simd!(_mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> __mmask8 {
        simd!(_mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn select(m: __mmask8, a: Self, b: Self) -> Self {
        simd!(Avx512(_mm512_mask_blend_pd(m, b.0, a.0)))
    }
    #[inline(always)]
    fn mask_or(a: __mmask8, b: __mmask8) -> __mmask8 {
        a | b
    }
    #[inline(always)]
    fn add_where(self, m: __mmask8, o: Self) -> Self {
        simd!(Avx512(_mm512_mask_add_pd(self.0, m, self.0, o.0)))
    }
    #[inline(always)]
    fn sub_where(self, m: __mmask8, o: Self) -> Self {
        simd!(Avx512(_mm512_mask_sub_pd(self.0, m, self.0, o.0)))
    }
    #[inline(always)]
    fn neg_where(self, m: __mmask8) -> Self {
        simd!({
            let x = _mm512_castpd_si512(self.0);
            let sign = _mm512_set1_epi64(i64::MIN);
            Avx512(_mm512_castsi512_pd(_mm512_mask_xor_epi64(x, m, x, sign)))
        })
    }
    #[inline(always)]
    fn mask_and(a: __mmask8, b: __mmask8) -> __mmask8 {
        a & b
    }
    #[inline(always)]
    fn mask_bits(m: __mmask8) -> u32 {
        u32::from(m)
    }
    #[inline(always)]
    fn xoshiro(s: &mut [__m512i; 4]) -> __m512i {
        simd!({
            let [a, b, c, d] = *s;
            let out = _mm512_add_epi64(_mm512_rol_epi64::<23>(_mm512_add_epi64(a, d)), a);
            let t = _mm512_slli_epi64::<17>(b);
            let c = _mm512_xor_si512(c, a);
            let d = _mm512_xor_si512(d, b);
            *s = [
                _mm512_xor_si512(a, d),
                _mm512_xor_si512(b, c),
                _mm512_xor_si512(c, t),
                _mm512_rol_epi64::<45>(d),
            ];
            out
        })
    }
    #[inline(always)]
    fn field_up(w: __m512i, k: u8) -> __m512i {
        match k {
            0 => w,
            1 => simd!(_mm512_slli_epi64::<THREE_POINT_BITS>(w)),
            _ => simd!(_mm512_slli_epi64::<{ 2 * THREE_POINT_BITS }>(w)),
        }
    }
    #[inline(always)]
    fn three_point_high(w: __m512i) -> (__mmask8, __mmask8) {
        simd!((
            _mm512_cmplt_epu64_mask(w, _mm512_set1_epi64(T_HIGH as i64)),
            _mm512_cmplt_epu64_mask(w, _mm512_set1_epi64(T2_HIGH as i64)),
        ))
    }
}

/// 4 lanes in an AVX2 register. AVX2 has no mask registers, no 64-bit rotate and no
/// unsigned 64-bit compare: masks are all-ones lanes used by `blendv`, rotates are two
/// shifts, and the three-point thresholds are compared signed on the 32-bit halves.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx2(__m256d);

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// Rotation left by `L` of each 64-bit lane (`R` = 64 − `L`).
    #[inline(always)]
    fn rotl<const L: i32, const R: i32>(x: __m256i) -> __m256i {
        simd!(_mm256_or_si256(
            _mm256_slli_epi64::<L>(x),
            _mm256_srli_epi64::<R>(x)
        ))
    }

    /// The masks of a 21-bit number `u` (in a 64-bit lane): u < T as T > u, signed, which
    /// is exact because u < 2²¹ and T, 2T < 2²².
    #[inline(always)]
    fn three_point(u: __m256i) -> (__m256d, __m256d) {
        simd!((
            _mm256_castsi256_pd(_mm256_cmpgt_epi64(
                _mm256_set1_epi64x(THREE_POINT_T as i64),
                u
            )),
            _mm256_castsi256_pd(_mm256_cmpgt_epi64(
                _mm256_set1_epi64x(2 * THREE_POINT_T as i64),
                u
            )),
        ))
    }
}

#[cfg(target_arch = "x86_64")]
impl Vector for Avx2 {
    const LANES: usize = 4;
    type Mask = __m256d;
    type Bits = __m256i;

    #[inline(always)]
    fn splat(x: f64) -> Self {
        simd!(Avx2(_mm256_set1_pd(x)))
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..4];
        simd!(Avx2(_mm256_loadu_pd(s.as_ptr())))
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        let s = &mut s[..4];
        simd!(_mm256_storeu_pd(s.as_mut_ptr(), self.0))
    }
    #[inline(always)]
    fn load_bits(s: &[u64]) -> __m256i {
        let s = &s[..4];
        simd!(_mm256_loadu_si256(s.as_ptr().cast()))
    }
    #[inline(always)]
    fn store_bits(b: __m256i, s: &mut [u64]) {
        let s = &mut s[..4];
        simd!(_mm256_storeu_si256(s.as_mut_ptr().cast(), b))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        simd!(Avx2(_mm256_add_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        simd!(Avx2(_mm256_sub_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        simd!(Avx2(_mm256_mul_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        simd!(Avx2(_mm256_div_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn xor(self, o: Self) -> Self {
        simd!(Avx2(_mm256_xor_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        simd!(Avx2(_mm256_and_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        simd!(Avx2(_mm256_or_pd(self.0, o.0)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> __m256d {
        simd!(_mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn le(self, o: Self) -> __m256d {
        simd!(_mm256_cmp_pd::<_CMP_LE_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> __m256d {
        simd!(_mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> __m256d {
        simd!(_mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, o.0))
    }
    #[inline(always)]
    fn select(m: __m256d, a: Self, b: Self) -> Self {
        simd!(Avx2(_mm256_blendv_pd(b.0, a.0, m)))
    }
    #[inline(always)]
    fn mask_or(a: __m256d, b: __m256d) -> __m256d {
        simd!(_mm256_or_pd(a, b))
    }
    #[inline(always)]
    fn mask_and(a: __m256d, b: __m256d) -> __m256d {
        simd!(_mm256_and_pd(a, b))
    }
    #[inline(always)]
    fn mask_bits(m: __m256d) -> u32 {
        simd!(_mm256_movemask_pd(m) as u32)
    }
    #[inline(always)]
    fn xoshiro(s: &mut [__m256i; 4]) -> __m256i {
        simd!({
            let [a, b, c, d] = *s;
            let out = _mm256_add_epi64(Self::rotl::<23, 41>(_mm256_add_epi64(a, d)), a);
            let t = _mm256_slli_epi64::<17>(b);
            let c = _mm256_xor_si256(c, a);
            let d = _mm256_xor_si256(d, b);
            *s = [
                _mm256_xor_si256(a, d),
                _mm256_xor_si256(b, c),
                _mm256_xor_si256(c, t),
                Self::rotl::<45, 19>(d),
            ];
            out
        })
    }
    #[inline(always)]
    fn field_up(w: __m256i, k: u8) -> __m256i {
        const B: i32 = THREE_POINT_BITS as i32;
        match k {
            0 => w,
            1 => simd!(_mm256_slli_epi64::<B>(w)),
            _ => simd!(_mm256_slli_epi64::<{ 2 * B }>(w)),
        }
    }
    #[inline(always)]
    fn three_point_high(w: __m256i) -> (__m256d, __m256d) {
        simd!(Self::three_point(_mm256_srli_epi64::<
            { 64 - THREE_POINT_BITS as i32 },
        >(w)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::kernel::rng::{three_point, three_point_field};

    /// The masks pick the value `rng::three_point` gives for each field of a draw, at and
    /// around the thresholds, whatever the other fields hold.
    #[test]
    fn three_point_masks_are_rng_three_point() {
        let a = 1.7;
        let value = |(neg, nonzero): (bool, bool)| {
            if neg {
                -a
            } else if nonzero {
                a
            } else {
                0.0
            }
        };
        let (t, top) = (THREE_POINT_T, (1u64 << THREE_POINT_BITS) - 1);
        for u in [0, 1, t - 1, t, t + 1, 2 * t - 1, 2 * t, 2 * t + 1, top] {
            for other in [0, 1, t, 2 * t, top] {
                for k in 0..3u8 {
                    let w = (0..3u8).fold(1, |w, j| {
                        let f = if j == k { u } else { other };
                        w | f << (64 - THREE_POINT_BITS * (j as u32 + 1))
                    });
                    assert_eq!(three_point_field(w, k), u, "{u} {k}");
                    let masks = f64::three_point_high(f64::field_up(w, k));
                    assert_eq!(value(masks), three_point(u, a), "{u} {other} {k}");
                }
            }
        }
    }
}
