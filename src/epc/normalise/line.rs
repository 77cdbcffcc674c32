//! A ridge density along a coordinate line, split where it is not analytic.
//!
//! Inside a ridge the density is exp(Q)·w, w = 0 off the region's masked cells and, on them,
//! the cutoff of Q ([`DensityGrid::in_mask`]): 0 for Q ≤ floor, a C^∞ (not analytic) rise
//! across the next [`TAPER_E_FOLDS`], 1 above, and 0 again above the band's top. Along a
//! line, the masked cells come in runs ([`DensityGrid::mask_runs`]); within a run each point
//! is in one of three *classes* by its Q alone: zero, transition (the cutoff's rise) or core
//! (w = 1, where the density is exp(Q), analytic). The class boundaries are found by
//! sampling Q every quarter of the grid spacing and bisecting every change of class to
//! rounding (where Q is proven monotone between the two samples, the float the bisection ends
//! at is found by Newton's method and a walk over adjacent floats instead: see
//! `DensityGrid::leave_by_root`). A block of samples is not evaluated one by one where an
//! enclosure of Q over the block proves that all of them are of the current class
//! (`DensityGrid::one_class`): the samples that can change the outcome are evaluated, so the
//! stretches are the same, bit for bit, as from every sample (tested). Two changes that cancel between samples are missed only where Q touches a level
//! without a sign change wider than a sample step can hide: Q then strays past the level by
//! far less than 1e−2 e-folds (Q'' is O(10) in scaled units across the region), where the
//! cutoff differs from 0 or 1 by less than e^−100, so the stretch stays analytic to far below
//! rounding.

use super::grid::{DensityGrid, TAPER_E_FOLDS};
use super::poly::{enclosure, horner, horner_block, BLOCK};
use crate::epc::exp::exp_in_place;

/// Points [`DensityGrid::times_transition`] takes at once, on the stack (more are taken a
/// chunk at a time).
pub(crate) const TRANSITION_CHUNK: usize = 64;

/// What the density is on a stretch of a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stretch {
    /// exp(Q): the cutoff is 1.
    Core,
    /// exp(Q)·taper: the cutoff's C^∞ rise from 0 to 1 (Q within TAPER_E_FOLDS above the
    /// floor), where the density is at most exp(floor + TAPER_E_FOLDS).
    Transition,
}

/// The class of a point by its Q: `None` where the density is zero (Q out of the band
/// [`DensityGrid::in_mask`] admits). The cutoff itself is not evaluated (two exponentials): a
/// transition point where it underflows to 0 is classed a transition, of value 0.
#[inline]
fn class(grid: &DensityGrid, q: f64) -> Option<Stretch> {
    if !grid.in_band(q) {
        None
    } else if (q - grid.floor) / TAPER_E_FOLDS >= 1.0 {
        Some(Stretch::Core)
    } else {
        Some(Stretch::Transition)
    }
}

/// Bisection steps from a sample interval (a quarter of a grid spacing) to rounding.
const BISECTIONS: usize = 60;

/// Samples of the first block [`DensityGrid::stretches`] tries to prove of one class; a
/// proven block doubles the next. An unproven one is not halved: its first [`BLOCK`] samples
/// are evaluated at once ([`horner_block`], the points side by side), then looked at in
/// order, and the next block is [`BLOCK`] samples again. Halving an unproven block would
/// evaluate its samples one by one, and a block that fails to prove one class usually holds
/// a class boundary, where the side-by-side evaluation of the whole block is the cheaper way
/// to find it (about a third of the enclosures and a seventh of the evaluations per line on
/// a degree-4 density).
const FIRST_BLOCK: usize = BLOCK;

/// Where Q = `q` falls among the levels that bound the classes: 0 at or below the floor, 1 in
/// the transition, 2 in the core, 3 above the band's top (0 and 3 are the zero class). A
/// non-decreasing function of a finite `q` (`class`'s comparisons and its `(q − floor)/E`
/// are monotone in q), so all of an interval of levels whose ends are in one region is in it.
#[inline]
fn region(grid: &DensityGrid, q: f64) -> u8 {
    match class(grid, q) {
        None if q <= grid.floor => 0,
        None => 3,
        Some(Stretch::Transition) => 1,
        Some(Stretch::Core) => 2,
    }
}

impl DensityGrid {
    /// The stretches of the runs `runs` (scaled units, in order) of a line on which Q is the
    /// polynomial `c` (Horner in the line's variable), into `out` (cleared first): the core
    /// and transition stretches in order, tiling each run but for its zero stretches.
    ///
    /// Every sample whose class is the current one only moves the last point known to be
    /// of it on; a block of them proven so ([`Self::one_class`]) does that at once.
    pub(crate) fn stretches(
        &self,
        c: &[f64],
        runs: &[[f64; 2]],
        out: &mut Vec<([f64; 2], Stretch)>,
    ) {
        out.clear();
        let step = 0.25 * self.h[0].min(self.h[1]);
        let class_at = |t: f64| class(self, horner(c, t));
        let mut t = [0.0; BLOCK];
        for &[a, b] in runs {
            let samples = ((b - a) / step).ceil().max(1.0) as usize;
            let at = |s: usize| {
                if s == samples {
                    b
                } else {
                    a + (b - a) * s as f64 / samples as f64
                }
            };
            let (mut start, mut current) = (a, class_at(a));
            // The last point known to be of the current class.
            let mut known = a;
            let (mut s, mut block) = (1, FIRST_BLOCK);
            while s <= samples {
                let last = (s + block - 1).min(samples);
                if last > s && self.one_class(c, at(s), at(last)) == Some(current) {
                    (known, s) = (at(last), last + 1);
                    block *= 2;
                    continue;
                }
                // The block's first samples at once (the rest of `t` repeats the last, whose
                // values are not looked at), each then taken in order.
                let n = (samples + 1 - s).min(BLOCK);
                for (k, t) in t.iter_mut().enumerate() {
                    *t = at(s + k.min(n - 1));
                }
                let q = horner_block(c, &t);
                for (&t, &q) in t[..n].iter().zip(&q[..n]) {
                    // `q` is `horner(c, t)`, bit for bit, so this is `class_at(t)`.
                    let here = class(self, q);
                    while here != current {
                        // Where the class first leaves `current` in (known, t]: hi is the
                        // first point found of another class, the stretch's end.
                        let hi = self.leave(c, known, t, current);
                        if let Some(kind) = current {
                            out.push(([start, hi], kind));
                        }
                        (start, current, known) = (hi, class_at(hi), hi);
                    }
                    known = t;
                }
                (s, block) = (s + n, FIRST_BLOCK);
            }
            if let Some(kind) = current {
                if start < b {
                    out.push(([start, b], kind));
                }
            }
        }
    }

    /// The class that Q, as `horner(c, t)` computes it, has at every t in [`lo`, `hi`], when
    /// its [`enclosure`] proves it to be one: when both ends of the enclosure are in one
    /// [`region`] of the levels, so is every computed value, and the class is that region's.
    /// `None` otherwise (or where there is no enclosure).
    fn one_class(&self, c: &[f64], lo: f64, hi: f64) -> Option<Option<Stretch>> {
        let [q_lo, q_hi] = enclosure(c, lo, hi)?;
        (region(self, q_lo) == region(self, q_hi)).then(|| class(self, q_lo))
    }

    /// The first point of (`lo`, `hi`] whose class is not `current` (that of `lo`; `hi`'s is
    /// another): what bisecting (`lo`, `hi`] to rounding gives ([`Self::leave_by_bisection`]),
    /// found by Newton's method where Q is monotone on the interval
    /// ([`Self::leave_by_root`]), by the bisection itself elsewhere.
    fn leave(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> f64 {
        self.leave_by_root(c, lo, hi, current)
            .unwrap_or_else(|| self.leave_by_bisection(c, lo, hi, current))
    }

    /// Bisection of (`lo`, `hi`] for where the class first leaves `current`, down to adjacent
    /// floating-point numbers (or [`BISECTIONS`] halvings): `hi` ends as the first point
    /// found of another class.
    fn leave_by_bisection(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> f64 {
        let (mut lo, mut hi) = (lo, hi);
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if class(self, horner(c, mid)) == current {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }

    /// The bisection's answer without its sixty evaluations of Q, where it can be had
    /// directly; `None` where it cannot (the caller bisects).
    ///
    /// Where Q is monotone on (`lo`, `hi`], the points of class `current` (whose Q lies in one
    /// interval of levels, or outside one for the zero class) form an interval starting at
    /// `lo`, so the class changes once: bisection, which keeps a point of class `current` at
    /// its low end and one of another class at its high end until the two are adjacent
    /// floating-point numbers, ends with `hi` at the first number of another class, s. That
    /// number is found here by Newton's method on Q = the level crossed, then a walk over
    /// adjacent numbers to the change. Refused (`None`) where that reasoning does not hold:
    /// - Q not proven monotone: |Q'| at the middle must exceed twice the bound on |Q''| times
    ///   the interval's length, so that Q' keeps its sign across it;
    /// - near t = 0, where sixty halvings stop short of adjacent numbers;
    /// - where the computed class flickers at the change (rounding of Q at the level): the
    ///   two numbers below s and the two above must agree with the single change, as the
    ///   ones bisection might visit;
    /// - where Newton's method or the walk does not settle within a few steps.
    fn leave_by_root(&self, c: &[f64], lo: f64, hi: f64, current: Option<Stretch>) -> Option<f64> {
        let is_current = |t: f64| class(self, horner(c, t)) == current;
        let width = hi - lo;
        // Sixty halvings of `width` reach adjacent numbers where |t| ≥ width·2^−6; this keeps
        // a margin of eight.
        let nearest = if lo <= 0.0 && hi >= 0.0 {
            0.0
        } else {
            lo.abs().min(hi.abs())
        };
        if nearest.is_nan() || nearest < width / 8.0 {
            return None;
        }
        let n = c.len() - 1;
        if n == 0 {
            return None;
        }
        let m = 0.5 * (lo + hi);
        let reach = lo.abs().max(hi.abs());
        let (mut slope, mut curvature) = (0.0, 0.0);
        for k in (1..=n).rev() {
            slope = slope * m + k as f64 * c[k];
        }
        for k in (2..=n).rev() {
            curvature = curvature * reach + (k * (k - 1)) as f64 * c[k].abs();
        }
        // Written so that a NaN refuses.
        if slope.is_nan() || slope.abs() <= 2.0 * curvature * width || curvature.is_nan() {
            return None;
        }
        let rising = slope > 0.0;
        // The level Q crosses where the class leaves `current` (see `class`).
        let top = self.q_max + 1e-9 * (1.0 + self.q_max.abs());
        let core = self.floor + TAPER_E_FOLDS;
        let level = match (current, rising) {
            (Some(Stretch::Core), true) => top,
            (Some(Stretch::Core), false) => core,
            (Some(Stretch::Transition), true) => core,
            (Some(Stretch::Transition), false) => self.floor,
            (None, true) => self.floor,
            (None, false) => top,
        };
        // Newton's method on Q − level from the middle, kept inside the interval.
        let mut x = m;
        let mut settled = false;
        for _ in 0..12 {
            let (mut q, mut dq) = (c[n], 0.0);
            for &ck in c[..n].iter().rev() {
                dq = dq * x + q;
                q = q * x + ck;
            }
            let next = (x - (q - level) / dq).clamp(lo, hi);
            if !next.is_finite() {
                return None;
            }
            let step = (next - x).abs();
            x = next;
            if step <= 4.0 * f64::EPSILON * x.abs() {
                settled = true;
                break;
            }
        }
        if !settled {
            return None;
        }
        // The walk to the change: s is of another class, the number below it of `current`.
        const WALK: usize = 16;
        let mut s = x.clamp(lo.next_up(), hi);
        if is_current(s) {
            let mut found = false;
            for _ in 0..WALK {
                s = s.next_up();
                if s > hi {
                    return None;
                }
                if !is_current(s) {
                    found = true;
                    break;
                }
            }
            if !found {
                return None;
            }
        } else {
            let mut found = false;
            for _ in 0..WALK {
                let below = s.next_down();
                if below <= lo || is_current(below) {
                    found = true;
                    break;
                }
                s = below;
            }
            if !found {
                return None;
            }
        }
        // No flicker next to the change.
        let below2 = s.next_down().next_down();
        let clean = (below2 <= lo || is_current(below2))
            && [s.next_up(), s.next_up().next_up()]
                .iter()
                .all(|&t| t > hi || !is_current(t));
        clean.then_some(s)
    }

    /// Multiplies each `out[i]` by the density's cutoff at Q = `q[i]` on a transition stretch
    /// (the stretch's own formula, so that at its ends it is the limit from inside; on a core
    /// stretch the cutoff is 1): [`taper`](super::grid::taper)'s formula to rounding, its two
    /// exponentials taken over the slice at once ([`exp_in_place`]).
    pub(crate) fn times_transition(&self, q: &[f64], out: &mut [f64]) {
        // A chunk at a time on the stack (the exponentials are elementwise, the same bits in
        // any chunking).
        const CHUNK: usize = TRANSITION_CHUNK;
        if q.len() > CHUNK {
            for (q, out) in q.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
                self.times_transition(q, out);
            }
            return;
        }
        let n = q.len().min(out.len());
        let (mut u, mut a, mut b) = ([0.0; CHUNK], [0.0; CHUNK], [0.0; CHUNK]);
        let (u, a, b) = (&mut u[..n], &mut a[..n], &mut b[..n]);
        // Outside (0, 1) the exponentials are not used; a NaN stays NaN, as in `taper`.
        let outside = |u: f64| u <= 0.0 || u >= 1.0;
        for (((u, a), b), q) in u.iter_mut().zip(a.iter_mut()).zip(b.iter_mut()).zip(q) {
            *u = (q - self.floor) / TAPER_E_FOLDS;
            (*a, *b) = if outside(*u) {
                (0.0, 0.0)
            } else {
                (-1.0 / *u, -1.0 / (1.0 - *u))
            };
        }
        exp_in_place(a);
        exp_in_place(b);
        for (((o, &u), &a), &b) in out.iter_mut().zip(&*u).zip(&*a).zip(&*b) {
            *o *= if u <= 0.0 {
                0.0
            } else if u >= 1.0 {
                1.0
            } else {
                a / (a + b)
            };
        }
    }

    /// The largest Q on a transition stretch, floor + TAPER_E_FOLDS: there the density is at
    /// most C·exp of this (the cutoff is at most 1), the bound callers use where a
    /// transition's share of a line integral is negligible.
    pub(crate) fn transition_max_q(&self) -> f64 {
        self.floor + TAPER_E_FOLDS
    }
}

#[cfg(test)]
mod tests {
    use super::super::grid::taper;
    use super::*;

    /// A ridge grid with the given levels (only `floor`, `q_max` and the spacing matter here).
    fn levels(floor: f64, q_max: f64) -> DensityGrid {
        DensityGrid {
            g1: vec![0.0, 1.0],
            g2: vec![0.0, 1.0],
            h: [0.2, 0.2],
            p: vec![0.0; 4],
            mask: Some(vec![true; 4]),
            floor,
            q_max,
            log_z: 0.0,
        }
    }

    /// Newton's answer is the bisection's, bit for bit, on every sample interval where a
    /// quartic's class changes, and it is the one taken at most of them.
    #[test]
    fn root_finds_what_bisection_finds() {
        let grid = levels(-15.0, 0.0);
        let mut stream = crate::epc::uniform::Uniform::new(0x2545_f491_4f6c_dd1d);
        let mut uniform = || stream.next();
        let (mut changes, mut by_root) = (0, 0);
        for _ in 0..400 {
            // −a t² + b t³ − d t⁴ + e t + f: a peak near the origin falling through the levels.
            let c = [
                -0.5 * uniform(),
                uniform() - 0.5,
                -(0.5 + uniform()),
                0.2 * (uniform() - 0.5),
                -0.05 * uniform(),
            ];
            let step = 0.05;
            let mut t = -8.0;
            while t < 8.0 {
                let (lo, hi) = (t, t + step);
                let current = class(&grid, horner(&c, lo));
                if class(&grid, horner(&c, hi)) != current {
                    changes += 1;
                    let bisected = grid.leave_by_bisection(&c, lo, hi, current);
                    if let Some(root) = grid.leave_by_root(&c, lo, hi, current) {
                        by_root += 1;
                        assert_eq!(root.to_bits(), bisected.to_bits(), "{c:?} on ({lo}, {hi}]");
                    }
                    assert_eq!(grid.leave(&c, lo, hi, current), bisected);
                }
                t += step;
            }
        }
        assert!(changes > 1000, "{changes}");
        assert!(by_root * 10 > changes * 9, "{by_root} of {changes}");
    }

    /// The stretches from every sample, one by one: what `stretches` gives without its
    /// proven blocks.
    fn by_every_sample(
        grid: &DensityGrid,
        c: &[f64],
        runs: &[[f64; 2]],
    ) -> Vec<([f64; 2], Stretch)> {
        let mut out = Vec::new();
        let step = 0.25 * grid.h[0].min(grid.h[1]);
        let class_at = |t: f64| class(grid, horner(c, t));
        for &[a, b] in runs {
            let samples = ((b - a) / step).ceil().max(1.0) as usize;
            let (mut start, mut current) = (a, class_at(a));
            let mut known = a;
            for s in 1..=samples {
                let t = if s == samples {
                    b
                } else {
                    a + (b - a) * s as f64 / samples as f64
                };
                while class_at(t) != current {
                    let hi = grid.leave(c, known, t, current);
                    if let Some(kind) = current {
                        out.push(([start, hi], kind));
                    }
                    (start, current, known) = (hi, class_at(hi), hi);
                }
                known = t;
            }
            if let Some(kind) = current {
                if start < b {
                    out.push(([start, b], kind));
                }
            }
        }
        out
    }

    /// The proven blocks change nothing: on random polynomials of degrees 2 to 12 (peaks
    /// reaching the top of the band, tangent to the levels, or far from them) and runs, the
    /// stretches are those of every sample, bit for bit; and most lines are proven in
    /// blocks.
    #[test]
    fn proven_blocks_give_the_stretches_of_every_sample() {
        let mut stream = crate::epc::uniform::Uniform::new(0x9e37_79b9_7f4a_7c15);
        let mut uniform = || stream.next();
        let mut out = Vec::new();
        let (mut lines, mut stretches) = (0, 0);
        for case in 0..600 {
            let grid = levels(-15.0 - 10.0 * uniform(), 0.0);
            let degree = 2 * (1 + case % 6);
            // A peak of height `top` near t0: top − a (t − t0)² − … with small odd terms.
            let t0 = 4.0 * (uniform() - 0.5);
            let top = match case % 3 {
                0 => grid.q_max,
                1 => grid.floor + TAPER_E_FOLDS * uniform(),
                _ => grid.q_max - 3.0 * uniform(),
            };
            let mut c = vec![0.0; degree + 1];
            c[0] = top;
            c[2] = -(0.2 + 2.0 * uniform());
            for (k, ck) in c.iter_mut().enumerate().skip(3) {
                let size = 0.3_f64.powi(k as i32);
                *ck = if k == degree {
                    -size * (0.5 + uniform())
                } else {
                    size * (uniform() - 0.5)
                };
            }
            // Shift the peak to t0 by evaluating at t − t0: Taylor coefficients at −t0.
            let mut d = c.clone();
            for i in 0..degree {
                for j in (i..degree).rev() {
                    d[j] -= t0 * d[j + 1];
                }
            }
            let mut runs = vec![[-6.0 + uniform(), -1.0 + uniform()]];
            runs.push([runs[0][1] + 0.1 * uniform(), 6.0 * (1.0 + uniform())]);
            grid.stretches(&d, &runs, &mut out);
            let reference = by_every_sample(&grid, &d, &runs);
            assert_eq!(out.len(), reference.len(), "case {case}: {d:?}");
            for (got, want) in out.iter().zip(&reference) {
                assert_eq!(got.1, want.1, "case {case}");
                assert_eq!(
                    got.0.map(f64::to_bits),
                    want.0.map(f64::to_bits),
                    "case {case}"
                );
            }
            lines += 1;
            stretches += out.len();
        }
        assert!(stretches > lines, "{stretches} stretches on {lines} lines");
    }

    /// The batch cutoff is `taper`'s to rounding, 0 and 1 outside (0, 1), NaN at NaN.
    #[test]
    fn times_transition_is_the_taper() {
        let grid = levels(-15.0, 0.0);
        let q: Vec<f64> = (-20..=100)
            .map(|k| grid.floor - 0.2 + 1.4 * k as f64 / 100.0)
            .chain([f64::NAN])
            .collect();
        let mut out = vec![2.0; q.len()];
        grid.times_transition(&q, &mut out);
        for (&q, &o) in q.iter().zip(&out) {
            let want = 2.0 * taper((q - grid.floor) / TAPER_E_FOLDS);
            if q.is_nan() {
                assert!(o.is_nan());
            } else {
                assert!(
                    (o - want).abs() <= 4e-15 * want.abs(),
                    "Q = {q}: {o} vs {want}"
                );
            }
        }
    }

    /// An enclosure proves a class only where every point of it has that class, and it
    /// proves the wide blocks away from the levels.
    #[test]
    fn one_class_is_the_class_of_every_point() {
        let grid = levels(-15.0, 0.0);
        // Q = −t²: core for |t| < √(15 − E), transition to √15, zero beyond.
        let c = [0.0, 0.0, -1.0];
        assert_eq!(
            grid.one_class(&c, -1.0, 1.0),
            Some(Some(Stretch::Core)),
            "max Q = 0"
        );
        assert_eq!(grid.one_class(&c, 0.5, 1.5), Some(Some(Stretch::Core)));
        // 0.5 − t² rises above the band's top for |t| < √0.5.
        let above = [0.5, 0.0, -1.0];
        assert_eq!(grid.one_class(&above, -1.0, 1.0), None);
        assert_eq!(grid.one_class(&above, -0.1, 0.1), Some(None));
        assert_eq!(grid.one_class(&c, 5.0, 9.0), Some(None));
        assert_eq!(grid.one_class(&c, 3.0, 4.5), None);
        let cases = [(c, 0.5, 1.5), (c, 5.0, 9.0), (c, -9.0, -5.0), (c, 0.1, 3.5)];
        for (c, lo, hi) in cases
            .into_iter()
            .chain([(above, -0.1, 0.1), (above, 0.8, 2.0)])
        {
            if let Some(kind) = grid.one_class(&c, lo, hi) {
                for k in 0..=1000 {
                    let t = lo + (hi - lo) * k as f64 / 1000.0;
                    assert_eq!(class(&grid, horner(&c, t)), kind, "t = {t}");
                }
            }
        }
        // A NaN coefficient proves nothing.
        assert_eq!(grid.one_class(&[f64::NAN, 0.0, -1.0], 4.0, 9.0), None);
    }
}
