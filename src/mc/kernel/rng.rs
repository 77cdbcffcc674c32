//! Random streams: one xoshiro256++ generator per trajectory, kept structure-of-arrays so a
//! batch of trajectories draws its numbers in one vectorisable loop.
//!
//! Trajectory `j` of a run with seed `s` is seeded with four outputs of SplitMix64 started
//! from a key that mixes `s` and `j` (Vigna's recommended way to seed xoshiro), so a
//! trajectory's numbers depend on `(s, j)` only: never on the thread that runs it, the batch
//! size of a parallel loop or the shard it falls into.

use serde::{Deserialize, Serialize};

/// SplitMix64's output function (Stafford's "mix13").
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The xoshiro256++ state of trajectory `index` in the run seeded with `seed`.
///
/// The key mixes seed and index through the SplitMix64 finaliser twice, so neighbouring
/// indices start far apart in SplitMix64's sequence (seeding with `seed + index·γ` would
/// make trajectory j+1's state a shift of trajectory j's).
pub(crate) fn stream_state(seed: u64, index: u64) -> [u64; 4] {
    let mut key = mix64(seed ^ mix64(index ^ 0xD1B5_4A32_D192_ED03));
    let mut s = [0u64; 4];
    for w in &mut s {
        key = key.wrapping_add(GOLDEN_GAMMA);
        *w = mix64(key);
    }
    if s == [0; 4] {
        // The all-zero state is xoshiro's only fixed point.
        s[0] = GOLDEN_GAMMA;
    }
    s
}

/// xoshiro256++ generators of a batch of trajectories, one per lane, structure-of-arrays.
pub(crate) struct LaneRng {
    s0: Vec<u64>,
    s1: Vec<u64>,
    s2: Vec<u64>,
    s3: Vec<u64>,
}

impl LaneRng {
    /// Generators for trajectories `first, first + 1, …, first + lanes − 1`.
    pub(crate) fn new(seed: u64, first: u64, lanes: usize) -> LaneRng {
        let mut r = LaneRng {
            s0: vec![0; lanes],
            s1: vec![0; lanes],
            s2: vec![0; lanes],
            s3: vec![0; lanes],
        };
        for i in 0..lanes {
            let s = stream_state(seed, first + i as u64);
            r.s0[i] = s[0];
            r.s1[i] = s[1];
            r.s2[i] = s[2];
            r.s3[i] = s[3];
        }
        r
    }

    /// Lane `i`'s generator started over as trajectory `index`'s of the run seeded with
    /// `seed` ([`LaneRng::new`] gives lane i of a batch that starts at `index − i` this state).
    pub(crate) fn reseed_lane(&mut self, seed: u64, index: u64, i: usize) {
        let s = stream_state(seed, index);
        (self.s0[i], self.s1[i], self.s2[i], self.s3[i]) = (s[0], s[1], s[2], s[3]);
    }

    /// The next output of lane `i`'s generator alone (for rare per-lane events).
    pub(crate) fn next_lane(&mut self, i: usize) -> u64 {
        let (a, b, c, d) = (self.s0[i], self.s1[i], self.s2[i], self.s3[i]);
        let out = a.wrapping_add(d).rotate_left(23).wrapping_add(a);
        let t = b << 17;
        let c = c ^ a;
        let d = d ^ b;
        self.s1[i] = b ^ c;
        self.s0[i] = a ^ d;
        self.s2[i] = c ^ t;
        self.s3[i] = d.rotate_left(45);
        out
    }

    /// The four state words of every lane, for kernels that keep them in registers (they
    /// must advance them exactly as [`LaneRng::fill`] does).
    pub(crate) fn state_mut(&mut self) -> [&mut [u64]; 4] {
        [&mut self.s0, &mut self.s1, &mut self.s2, &mut self.s3]
    }

    /// One xoshiro256++ output per lane.
    #[inline(always)]
    pub(crate) fn fill(&mut self, out: &mut [u64]) {
        let n = out.len();
        let (s0, s1, s2, s3) = (
            &mut self.s0[..n],
            &mut self.s1[..n],
            &mut self.s2[..n],
            &mut self.s3[..n],
        );
        for i in 0..n {
            let (a, b, c, d) = (s0[i], s1[i], s2[i], s3[i]);
            out[i] = a.wrapping_add(d).rotate_left(23).wrapping_add(a);
            let t = b << 17;
            let c = c ^ a;
            let d = d ^ b;
            let b = b ^ c;
            let a = a ^ d;
            s0[i] = a;
            s1[i] = b;
            s2[i] = c ^ t;
            s3[i] = d.rotate_left(45);
        }
    }
}

/// The distribution of the standardised noise increments (mean 0, variance 1) a step uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Increments {
    /// Three-point variables: ±√3 with probability 1/6 each, 0 with probability 2/3.
    ///
    /// Their moments agree with a standard normal's up to the fifth, which is all a weak
    /// order-2 scheme needs (Kloeden & Platen, *Numerical Solution of SDE*, §14.2): the
    /// stationary law of the simulated states converges at the same rate as with Gaussian
    /// increments, while one 64-bit draw gives three increments (21 bits each) without
    /// logarithms or trigonometry. Sample paths are not Brownian; use [`Increments::Gaussian`] when paths
    /// matter.
    #[default]
    ThreePoint,
    /// Standard normal increments (Box–Muller on 53-bit uniforms).
    Gaussian,
}

/// Bits of a draw one three-point variable takes: a 64-bit draw gives three (its top 63
/// bits, most significant field first; the lowest bit is not used).
pub(crate) const THREE_POINT_BITS: u32 = 21;
/// Three-point variables per 64-bit draw.
pub(crate) const THREE_POINT_FIELDS: u8 = 3;
/// P(−a) = P(+a) = T/2²¹, T = ⌊2²¹/6⌋ (1/6 to 1e−6 relative); a = √(2²¹/2T) ≈ √3 makes
/// the variance exactly 1 despite the rounding of T, and the fourth moment a² = 3 + 2.9e−6
/// (a weak order-2 error far below any statistical error).
pub(crate) const THREE_POINT_T: u64 = 349_525;
const TWO_POW_BITS: f64 = (1u64 << THREE_POINT_BITS) as f64;

/// The three-point variables' value a ≈ √3 ([`THREE_POINT_T`]).
pub(crate) fn three_point_value() -> f64 {
    (TWO_POW_BITS / (2 * THREE_POINT_T) as f64).sqrt()
}

/// Field `k` (0, 1, 2) of the draw `w`: bits 63…43, 42…22, 21…1.
#[inline(always)]
pub(crate) fn three_point_field(w: u64, k: u8) -> u64 {
    (w << (THREE_POINT_BITS * k as u32)) >> (64 - THREE_POINT_BITS)
}

/// Standardised increments for a batch, drawn lane-parallel so that a lane's sequence
/// depends only on its own generator: three-point variables three to a 64-bit draw (its
/// fields in order, the draw kept for the next calls); Gaussians in pairs from two draws,
/// the second kept for the next call.
pub(crate) struct IncrementStream {
    kind: Increments,
    /// The lanes' last draws (three-point: the fields not yet taken are the next calls').
    bits: Vec<u64>,
    bits2: Vec<u64>,
    /// Gaussian: each lane's second normal of the last pair, and whether it is pending.
    pending: Vec<f64>,
    has_pending: bool,
    /// Three-point: the field of `bits` the next call takes (0: a new draw first).
    field: u8,
    three_point_value: f64,
}

/// The three-point state a kernel that draws its own increments keeps as
/// [`IncrementStream::next`] would ([`IncrementStream::three_point_mut`]).
pub(crate) struct ThreePointState<'a> {
    /// The lanes' last draws.
    pub(crate) draws: &'a mut [u64],
    /// The field of `draws` the next step takes (0: a new draw first).
    pub(crate) field: &'a mut u8,
    /// The value a ≈ √3.
    pub(crate) a: f64,
}

impl IncrementStream {
    pub(crate) fn new(kind: Increments, lanes: usize) -> IncrementStream {
        IncrementStream {
            kind,
            bits: vec![0; lanes],
            bits2: vec![0; lanes],
            pending: vec![0.0; lanes],
            has_pending: false,
            field: 0,
            three_point_value: three_point_value(),
        }
    }

    /// For three-point increments the stream's state ([`ThreePointState`]); `None` for
    /// Gaussian increments.
    pub(crate) fn three_point_mut(&mut self) -> Option<ThreePointState<'_>> {
        match self.kind {
            Increments::ThreePoint => Some(ThreePointState {
                draws: &mut self.bits,
                field: &mut self.field,
                a: self.three_point_value,
            }),
            Increments::Gaussian => None,
        }
    }

    /// Fills `out` (one value per lane) with standardised increments.
    #[inline(always)]
    pub(crate) fn next(&mut self, rng: &mut LaneRng, out: &mut [f64]) {
        let n = out.len();
        match self.kind {
            Increments::ThreePoint => {
                if self.field == 0 {
                    rng.fill(&mut self.bits[..n]);
                }
                let (a, k) = (self.three_point_value, self.field);
                for (o, &w) in out.iter_mut().zip(&self.bits[..n]) {
                    *o = three_point(three_point_field(w, k), a);
                }
                self.field = (k + 1) % THREE_POINT_FIELDS;
            }
            Increments::Gaussian => {
                if self.has_pending {
                    out.copy_from_slice(&self.pending[..n]);
                    self.has_pending = false;
                    return;
                }
                rng.fill(&mut self.bits[..n]);
                rng.fill(&mut self.bits2[..n]);
                for i in 0..n {
                    let (z0, z1) = box_muller(self.bits[i], self.bits2[i]);
                    out[i] = z0;
                    self.pending[i] = z1;
                }
                self.has_pending = true;
            }
        }
    }
}

/// The three-point variable of a field `h` (< 2²¹): −a below T, a below 2T, 0 above.
#[inline(always)]
pub(crate) fn three_point(h: u64, a: f64) -> f64 {
    let neg = if h < THREE_POINT_T { a } else { 0.0 };
    let pos = if (THREE_POINT_T..2 * THREE_POINT_T).contains(&h) {
        a
    } else {
        0.0
    };
    pos - neg
}

/// A uniform in (0, 1) from the top 53 bits (never 0, so the logarithm is finite).
#[inline(always)]
fn open01(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) * (1.0 / 9_007_199_254_740_992.0)
}

#[inline(always)]
fn box_muller(b1: u64, b2: u64) -> (f64, f64) {
    let r = (-2.0 * open01(b1).ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * open01(b2)).sin_cos();
    (r * c, r * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngCore;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    #[test]
    fn lanes_match_the_reference_xoshiro256plusplus() {
        let mut lanes = LaneRng::new(42, 10, 3);
        let mut refs: Vec<Xoshiro256PlusPlus> = (0..3)
            .map(|i| {
                let s = stream_state(42, 10 + i);
                let mut bytes = [0u8; 32];
                for (k, w) in s.iter().enumerate() {
                    bytes[8 * k..8 * k + 8].copy_from_slice(&w.to_le_bytes());
                }
                Xoshiro256PlusPlus::from_seed(bytes)
            })
            .collect();
        let mut out = [0u64; 3];
        for _ in 0..100 {
            lanes.fill(&mut out);
            for (o, r) in out.iter().zip(refs.iter_mut()) {
                assert_eq!(*o, r.next_u64());
            }
        }
    }

    #[test]
    fn streams_differ_between_indices_and_seeds() {
        assert_ne!(stream_state(1, 0), stream_state(1, 1));
        assert_ne!(stream_state(1, 0), stream_state(2, 0));
        // Trajectory j+1's state is not a shift of trajectory j's.
        let a = stream_state(7, 3);
        let b = stream_state(7, 4);
        assert!(!a[1..].iter().zip(&b[..3]).all(|(x, y)| x == y));
    }

    fn moments(kind: Increments) -> [f64; 4] {
        let lanes = 64;
        let mut rng = LaneRng::new(3, 0, lanes);
        let mut inc = IncrementStream::new(kind, lanes);
        let mut out = vec![0.0; lanes];
        let mut m = [0.0; 4];
        let rounds = 20_000;
        for _ in 0..rounds {
            inc.next(&mut rng, &mut out);
            for &z in &out {
                m[0] += z;
                m[1] += z * z;
                m[2] += z * z * z;
                m[3] += z * z * z * z;
            }
        }
        let n = (rounds * lanes) as f64;
        m.map(|s| s / n)
    }

    #[test]
    fn increments_have_normal_moments_to_fourth_order() {
        // 1.28e6 draws: standard errors ≈ 0.0009, 0.0013, 0.0034, 0.0085 for the four moments.
        for kind in [Increments::ThreePoint, Increments::Gaussian] {
            let m = moments(kind);
            assert!(m[0].abs() < 0.005, "{kind:?} mean {}", m[0]);
            assert!((m[1] - 1.0).abs() < 0.007, "{kind:?} var {}", m[1]);
            assert!(m[2].abs() < 0.02, "{kind:?} third {}", m[2]);
            assert!((m[3] - 3.0).abs() < 0.045, "{kind:?} fourth {}", m[3]);
        }
    }

    #[test]
    fn three_point_values_are_exactly_symmetric() {
        let a = 3f64.sqrt();
        assert_eq!(three_point(0, a), -a);
        assert_eq!(three_point(THREE_POINT_T, a), a);
        assert_eq!(three_point(2 * THREE_POINT_T, a), 0.0);
        assert_eq!(three_point((1 << THREE_POINT_BITS) - 1, a), 0.0);
    }

    /// A draw's three fields are its bits 63…43, 42…22 and 21…1, and the variable's first
    /// five moments are a standard normal's to within the rounding of T.
    #[test]
    fn three_fields_per_draw() {
        let w = (0x1A_BCDE_u64 << 43) | (0x0F_1234 << 22) | (0x15_5555 << 1) | 1;
        assert_eq!(
            [0, 1, 2].map(|k| three_point_field(w, k)),
            [0x1A_BCDE, 0x0F_1234, 0x15_5555]
        );
        let (t, n) = (THREE_POINT_T as f64, TWO_POW_BITS);
        let a = IncrementStream::new(Increments::ThreePoint, 1).three_point_value;
        let second = 2.0 * t / n * a * a;
        let fourth = 2.0 * t / n * a.powi(4);
        assert!((second - 1.0).abs() < 1e-15, "{second}");
        assert!((fourth - 3.0).abs() < 1e-5, "{fourth}");
        assert!(t / n < 1.0 / 6.0 && 1.0 / 6.0 - t / n < 1e-6);
    }
}
