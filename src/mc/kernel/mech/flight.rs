//! A flight's impacts at the barrier, resolved out of line: the barrier as the kernel reads
//! it ([`Jump`]), a flight of `N` vectors of lanes ([`Flight`]), and [`Impacts`], the handler
//! each vector type compiles for its own extension and keeps out of the step loop (`#[cold]`,
//! never inlined), so the loop's registers are not spent on the rare impact.

use super::vector::Vector;
#[cfg(target_arch = "x86_64")]
use super::vector::{Avx2, Avx512};
use crate::mc::compile::impact::{impact_in_flight, Barrier};
use crate::mc::compile::tally::ImpactSink;

/// The barrier as the kernel reads it.
pub(super) struct Jump<'a> {
    pub(super) bar: &'a Barrier,
    /// `r` of a law `v → r·v` (then resolved in vector form).
    pub(super) gain: Option<f64>,
}

/// The flight of `N` vectors of lanes that the out-of-line impact handler
/// ([`Impacts::impacts`], [`impacts`]) resolves: positions `x0` before it, `x` after it, the
/// velocities `v` and the sign bits `side` of the barrier sides (−0 for side −1).
pub(crate) struct Flight<'a, 's, V: Vector, const N: usize> {
    pub(super) jump: &'a Jump<'a>,
    pub(super) x0: &'a [V; N],
    pub(super) x: &'a mut [V; N],
    pub(super) v: &'a mut [V; N],
    pub(super) side: &'a mut [V; N],
    pub(super) impacts: &'a mut ImpactSink<'s>,
    pub(super) tau: f64,
    /// Bit `k·V::LANES + i` set when lane i of vector k ended its flight on or beyond the
    /// barrier (the vectors without one are skipped).
    pub(super) near: u32,
}

/// `(s − b)·side` for side = ±1 as its sign bit `side` flipping the sign of `s − b`: the
/// same number, bit for bit (`s − 0` is `s`).
#[inline(always)]
pub(super) fn dist<V: Vector>(b: f64, s: V, side: V) -> V {
    if b == 0.0 {
        s.xor(side)
    } else {
        s.sub(V::splat(b)).xor(side)
    }
}

/// The lanes of a flight that met the barrier (as `impact::meets`), each given its impact
/// as `impact_in_flight` does it, and counted.
#[inline(always)]
pub(super) fn impacts<V: Vector, const N: usize>(f: &mut Flight<'_, '_, V, N>) {
    let (zero, b, w) = (V::splat(0.0), f.jump.bar.at, V::LANES);
    for k in 0..N {
        if (f.near >> (k * w)) & ((1 << w) - 1) == 0 {
            continue;
        }
        let d1 = dist(b, f.x[k], f.side[k]);
        let d0 = dist(b, f.x0[k], f.side[k]);
        let met = V::mask_or(d1.lt(zero), V::mask_and(d1.eq(zero), d0.gt(zero)));
        let bits = V::mask_bits(met);
        if bits == 0 {
            continue;
        }
        let mut before = [0.0; 8];
        f.v[k].store(&mut before);
        match f.jump.gain {
            Some(r) => {
                // impact_in_flight with the jump r·v, lane-parallel.
                let (bv, tau) = (V::splat(b), V::splat(f.tau));
                let t = bv.sub(f.x0[k]).div(f.v[k]);
                // f64::clamp(t, 0, τ): below 0 → 0, then above τ → τ, NaN kept.
                let t = V::select(t.lt(zero), zero, t);
                let t = V::select(t.gt(tau), tau, t);
                let vn = V::splat(r).mul(f.v[k]);
                // v_new·side < 0 flips the side: v_new·side is v_new with the side's sign.
                let flip = vn.xor(f.side[k]).lt(zero);
                let side = V::select(flip, f.side[k].xor(V::splat(-0.0)), f.side[k]);
                let xn = bv.add(vn.mul(tau.sub(t)));
                f.x[k] = V::select(met, xn, f.x[k]);
                f.v[k] = V::select(met, vn, f.v[k]);
                f.side[k] = V::select(met, side, f.side[k]);
            }
            None => {
                let (mut x0, mut x, mut v, mut side) = ([0.0; 8], [0.0; 8], [0.0; 8], [0.0; 8]);
                f.x0[k].store(&mut x0);
                f.x[k].store(&mut x);
                f.v[k].store(&mut v);
                f.side[k].or(V::splat(1.0)).store(&mut side);
                for i in (0..w).filter(|i| bits >> i & 1 == 1) {
                    impact_in_flight(x0[i], &mut x[i], &mut v[i], &mut side[i], f.tau, f.jump.bar);
                }
                f.x[k] = V::load(&x);
                f.v[k] = V::load(&v);
                f.side[k] = V::load(&side).and(V::splat(-0.0));
            }
        }
        let mut after = [0.0; 8];
        f.v[k].store(&mut after);
        for i in (0..w).filter(|i| bits >> i & 1 == 1) {
            f.impacts.hit(k * w + i, 0, before[i], after[i]);
        }
    }
}

/// The impacts of a flight ([`impacts`]), out of line and compiled for the vector type's
/// extension.
pub(crate) trait Impacts: Vector {
    /// Resolves the impacts of `f`.
    fn impacts<const N: usize>(f: &mut Flight<'_, '_, Self, N>);
}

impl Impacts for f64 {
    fn impacts<const N: usize>(f: &mut Flight<'_, '_, f64, N>) {
        #[cold]
        #[inline(never)]
        fn cold<const N: usize>(f: &mut Flight<'_, '_, f64, N>) {
            impacts(f)
        }
        cold(f)
    }
}

#[cfg(target_arch = "x86_64")]
impl Impacts for Avx512 {
    fn impacts<const N: usize>(f: &mut Flight<'_, '_, Avx512, N>) {
        #[cold]
        #[inline(never)]
        #[target_feature(enable = "avx512f")]
        fn cold<const N: usize>(f: &mut Flight<'_, '_, Avx512, N>) {
            impacts(f)
        }
        // SAFETY: values of this type exist only in the kernel's entry for its extension, called
        // only after the extension was detected on this CPU.
        unsafe { cold(f) }
    }
}

#[cfg(target_arch = "x86_64")]
impl Impacts for Avx2 {
    fn impacts<const N: usize>(f: &mut Flight<'_, '_, Avx2, N>) {
        #[cold]
        #[inline(never)]
        #[target_feature(enable = "avx2")]
        fn cold<const N: usize>(f: &mut Flight<'_, '_, Avx2, N>) {
            impacts(f)
        }
        // SAFETY: values of this type exist only in the kernel's entry for its extension, called
        // only after the extension was detected on this CPU.
        unsafe { cold(f) }
    }
}
