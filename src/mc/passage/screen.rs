//! A cheap test that a path stayed inside the safe set over several steps, so that the test of
//! each step (`locate.rs`, four evaluations of the quantity) runs only where a path may have
//! left: the box of the states the step tests would sample, over a part of a block of steps,
//! and the quantity's enclosure over that box ([`BoundSafe::surely_inside`]).
//!
//! The box holds every sample `locate::left_within` takes, rounding included: on the step
//! from (x₀, v₀) to (x₁, v₁) the Hermite interpolant at s is the chord plus
//! s(1−s)[(1−2s)(x₀−x₁) + (1−s)h·v₀ − s·h·v₁], at most 3/32·|x₁−x₀| + h·max(|v₀|, |v₁|)/4
//! at the samples s = ¼, ½, ¾; the linear velocity stays between v₀ and v₁.

use std::ops::Range;

use crate::base::simd::Simd;
use crate::model::BoundSafe;
use crate::symbolic::Interval;

/// What the steps of a part of a block span: the ranges of their end states, the largest
/// move of the position in one step and the largest speed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Span {
    x: [f64; 2],
    v: [f64; 2],
    jump: f64,
    speed: f64,
    /// 0 when every state was finite, NaN otherwise.
    finite: f64,
}

impl Span {
    /// The span of both.
    pub(super) fn union(self, o: Span) -> Span {
        Span {
            x: [self.x[0].min(o.x[0]), self.x[1].max(o.x[1])],
            v: [self.v[0].min(o.v[0]), self.v[1].max(o.v[1])],
            jump: self.jump.max(o.jump),
            speed: self.speed.max(o.speed),
            finite: self.finite + o.finite,
        }
    }

    /// Whether every sample of these steps of size `h` is surely inside `safe`.
    pub(super) fn inside(&self, safe: &BoundSafe, h: f64, scratch: &mut Vec<Interval>) -> bool {
        if self.finite != 0.0 {
            return false;
        }
        let scale = self.x[0].abs().max(self.x[1].abs()) + h * self.speed + self.jump;
        // The interpolant's reach beyond the chord, with room for its rounding (a few ulps
        // of `scale`).
        let reach = (0.1 * self.jump + 0.25 * h * self.speed) * (1.0 + 1e-9) + 1e-12 * scale;
        let slack = 1e-12 * self.speed;
        match (
            Interval::new(self.x[0] - reach, self.x[1] + reach),
            Interval::new(self.v[0] - slack, self.v[1] + slack),
        ) {
            (Some(x), Some(v)) => safe.surely_inside(x, v, scratch),
            _ => false,
        }
    }
}

/// The spans of the parts of a block, for every lane, worked out a group of lanes at a time
/// (the group's spans in registers while the loop runs over the steps).
#[derive(Default)]
pub(super) struct Spans {
    lanes: usize,
    /// Part p of lane i at `spans[p * lanes + i]`.
    spans: Vec<Span>,
}

/// Lanes per group: one AVX-512 vector.
const GROUP: usize = 8;

impl Spans {
    /// The spans of parts of `part` steps of a block of `rows_x.len() / before_x.len()`
    /// steps: lane i's state after step j at `rows_x[j * lanes + i]`, `rows_v[..]`, before
    /// the block at `before_x[i]`, `before_v[i]`. The loops run with `simd`.
    pub(super) fn fill(
        &mut self,
        simd: Simd,
        before_x: &[f64],
        before_v: &[f64],
        rows_x: &[f64],
        rows_v: &[f64],
        part: usize,
    ) {
        let lanes = before_x.len();
        let steps = rows_x.len() / lanes.max(1);
        self.lanes = lanes;
        self.spans.clear();
        let empty = Span {
            x: [0.0; 2],
            v: [0.0; 2],
            jump: 0.0,
            speed: 0.0,
            finite: 0.0,
        };
        self.spans.resize(steps.div_ceil(part) * lanes, empty);
        let block = Block {
            before_x,
            before_v,
            rows_x,
            rows_v,
            part,
        };
        match simd {
            Simd::Baseline => block.spans(&mut self.spans),
            // SAFETY: `simd` names an extension only when it was detected on this CPU.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(_) => unsafe { block.spans_avx2(&mut self.spans) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(_) => unsafe { block.spans_avx512(&mut self.spans) },
        }
    }

    /// Part `p` of lane `i`.
    pub(super) fn get(&self, p: usize, i: usize) -> Span {
        self.spans[p * self.lanes + i]
    }

    /// How many parts the block has.
    pub(super) fn parts(&self) -> usize {
        self.spans.len() / self.lanes.max(1)
    }
}

/// The states of a block, as [`Spans::fill`] takes them.
struct Block<'a> {
    before_x: &'a [f64],
    before_v: &'a [f64],
    rows_x: &'a [f64],
    rows_v: &'a [f64],
    part: usize,
}

impl Block<'_> {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn spans_avx512(&self, out: &mut [Span]) {
        self.spans(out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn spans_avx2(&self, out: &mut [Span]) {
        self.spans(out);
    }

    /// Every part's span of every lane into `out` (part p of lane i at `p * lanes + i`).
    #[inline(always)]
    fn spans(&self, out: &mut [Span]) {
        let lanes = self.before_x.len();
        let steps = self.rows_x.len() / lanes.max(1);
        let mut first = 0;
        while first < steps {
            let last = (first + self.part).min(steps);
            let out = &mut out[first / self.part * lanes..][..lanes];
            let mut i = 0;
            while i + GROUP <= lanes {
                self.group::<GROUP>(i, first..last, &mut out[i..i + GROUP]);
                i += GROUP;
            }
            for i in i..lanes {
                self.group::<1>(i, first..last, &mut out[i..=i]);
            }
            first = last;
        }
    }

    /// The spans of lanes `i..i + W` over the steps `steps` into `out`.
    #[inline(always)]
    fn group<const W: usize>(&self, i: usize, steps: Range<usize>, out: &mut [Span]) {
        let lanes = self.before_x.len();
        let load =
            |s: &[f64], at: usize| -> [f64; W] { s[at..at + W].try_into().expect("W lanes") };
        // The state before the first step: before the block, or after the previous step.
        let (mut px, v) = match steps.start {
            0 => (load(self.before_x, i), load(self.before_v, i)),
            j => (
                load(self.rows_x, (j - 1) * lanes + i),
                load(self.rows_v, (j - 1) * lanes + i),
            ),
        };
        let (mut xlo, mut xhi, mut vlo, mut vhi) = (px, px, v, v);
        let mut jump = [0.0; W];
        let mut speed = v.map(f64::abs);
        // x·0 is ±0 for a finite x and NaN otherwise: the sum records any state that is not.
        let mut finite: [f64; W] = std::array::from_fn(|k| px[k] * 0.0 + v[k] * 0.0);
        for j in steps {
            let x = load(self.rows_x, j * lanes + i);
            let v = load(self.rows_v, j * lanes + i);
            for k in 0..W {
                // Comparisons that keep the old value for NaN; `finite` records it instead.
                xlo[k] = if x[k] < xlo[k] { x[k] } else { xlo[k] };
                xhi[k] = if x[k] > xhi[k] { x[k] } else { xhi[k] };
                vlo[k] = if v[k] < vlo[k] { v[k] } else { vlo[k] };
                vhi[k] = if v[k] > vhi[k] { v[k] } else { vhi[k] };
                let d = (x[k] - px[k]).abs();
                jump[k] = if d > jump[k] { d } else { jump[k] };
                let s = v[k].abs();
                speed[k] = if s > speed[k] { s } else { speed[k] };
                finite[k] += x[k] * 0.0 + v[k] * 0.0;
            }
            px = x;
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = Span {
                x: [xlo[k], xhi[k]],
                v: [vlo[k], vhi[k]],
                jump: jump[k],
                speed: speed[k],
                finite: finite[k],
            };
        }
    }
}
