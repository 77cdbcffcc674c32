//! Exploring Q around its mode: the mode itself, each ray's fate (decays for good, or rises
//! again beyond a pass) and the saddle that is the exact pass.

use nalgebra::{Matrix2, Vector2};

use super::poly::{derivative, enclosure, horner, horner_block, rounding, Poly, BLOCK, MAX_POWER};
use super::report::NotNormalisable;

/// Below this many e-folds from the mode the density is treated as zero when choosing the box.
pub(super) const TAIL_E_FOLDS: f64 = 40.0;

/// Finds a local maximum of Q by Newton ascent from the best point of a coarse grid.
pub(super) fn find_mode(q: &Poly) -> Result<[f64; 2], NotNormalisable> {
    let mut best = ([0.0, 0.0], q.eval([0.0, 0.0]));
    for i in -16..=16 {
        for j in -16..=16 {
            let x = [i as f64 * 0.25, j as f64 * 0.25];
            let v = q.eval(x);
            if v > best.1 {
                best = (x, v);
            }
        }
    }
    let mut x = best.0;
    for _ in 0..100 {
        let (g, h) = gradient_and_hessian(q, x);
        // Newton where the Hessian is negative definite, gradient ascent elsewhere.
        let step = match h.try_inverse() {
            Some(inv) if h[(0, 0)] < 0.0 && h.determinant() > 0.0 => -(inv * g),
            _ => 0.05 * g,
        };
        let mut t = 1.0;
        let q0 = q.eval(x);
        while t > 1e-12 {
            let xn = [x[0] + t * step[0], x[1] + t * step[1]];
            if q.eval(xn) >= q0 {
                x = xn;
                break;
            }
            t *= 0.5;
        }
        if g[0].hypot(g[1]) < 1e-12 {
            break;
        }
    }
    let (g, h) = gradient_and_hessian(q, x);
    let strict = h[(0, 0)] < 0.0
        && h.determinant() > 0.0
        && g[0].hypot(g[1]) < 1e-8 * (1.0 + h[(0, 0)].abs());
    // A degenerate maximum (e.g. Q = −c(ξ1² + ξ2²)², whose Hessian vanishes at the mode):
    // a stationary point above every point of small circles around it.
    let degenerate = || {
        let q0 = q.eval(x);
        g[0].hypot(g[1]) < 1e-9
            && [1e-3, 1e-2, 1e-1].iter().all(|&rho| {
                (0..64).all(|k| {
                    let th = k as f64 / 64.0 * std::f64::consts::TAU;
                    q.eval([x[0] + rho * th.cos(), x[1] + rho * th.sin()]) < q0
                })
            })
    };
    if !(strict || degenerate()) {
        return Err(NotNormalisable::NoMode { at: x });
    }
    Ok(x)
}

/// The cut radius along a ray: either where Q falls TAIL_E_FOLDS below `q_max` for good, or
/// (if Q rises above `q_max` again) the lowest point before that rise.
pub(super) enum RayEnd {
    /// Q stays below the mode's value and falls TAIL_E_FOLDS below it for good beyond r.
    Decays(f64),
    /// Q rises above the mode's value again; its lowest point before that is at r.
    Pass {
        /// The lowest point's radius.
        r: f64,
        /// Q there.
        value: f64,
    },
}

/// The radii every ray is sampled at, r_{k+1} = r_k + 0.01·(1 + r_k) from r_0 = 0 (steps of
/// 1% of 1 + r), up to the first beyond [`MAX_RADIUS`]: the same for every ray, so computed
/// once (each value bit for bit what the running sum gives).
pub(super) struct RaySteps {
    r: Vec<f64>,
}

/// The farthest a ray is explored.
const MAX_RADIUS: f64 = 1e6;

impl RaySteps {
    /// The table, computed on first use.
    pub(super) fn get() -> &'static RaySteps {
        static STEPS: std::sync::OnceLock<RaySteps> = std::sync::OnceLock::new();
        STEPS.get_or_init(|| {
            let (mut r, mut all) = (0.0_f64, Vec::new());
            loop {
                r += 0.01 * (1.0 + r);
                all.push(r);
                if r > MAX_RADIUS {
                    return RaySteps { r: all };
                }
            }
        })
    }

    /// The largest radius at which Q (`c`, its coefficients along a ray) is at least `floor`
    /// among the radii below `limit` and `limit` itself (0 if none, or if `limit` ≤ 0): what
    /// a scan outwards in the steps of [`RaySteps`], clamped to `limit`, finds last, found by
    /// scanning inwards from `limit` instead (it usually stops at once).
    pub(super) fn last_at_or_above(&self, c: &[f64], limit: f64, floor: f64) -> f64 {
        // A NaN limit scans nothing, as `while r < limit` did.
        if limit.is_nan() || limit <= 0.0 {
            return 0.0;
        }
        let below = self.r.partition_point(|&r| r < limit);
        if below == self.r.len() {
            // Beyond the table (not reached by a ray's cut, which is one of its radii): the
            // outward scan itself.
            let (mut r, mut reach) = (0.0_f64, 0.0);
            while r < limit {
                r = (r + 0.01 * (1.0 + r)).min(limit);
                if horner(c, r) >= floor {
                    reach = r;
                }
            }
            return reach;
        }
        std::iter::once(limit)
            .chain(self.r[..below].iter().rev().copied())
            .find(|&r| horner(c, r) >= floor)
            .unwrap_or(0.0)
    }
}

/// Where the ray from the mode at angle `th`, along which Q has the coefficients `c` (a
/// polynomial in the radius), stops mattering (see [`RayEnd`]).
pub(super) fn explore_ray(
    c: &[f64],
    steps: &RaySteps,
    th: f64,
    q_max: f64,
) -> Result<RayEnd, NotNormalisable> {
    let mut c = c.to_vec();
    // Leading coefficients that vanish to rounding (e.g. along a direction the top-degree
    // part does not involve) are dropped, so that the next term decides.
    let big = c.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    while c.len() > 2 && c[c.len() - 1].abs() <= 1e-12 * big {
        c.pop();
    }
    let n = c.len() - 1;
    let lead = c[n];
    // Beyond r_dom (Fujiwara's bound on the roots of dQ/dr) dQ/dr has the leading sign.
    let mut b = vec![0.0; n];
    derivative(&c, &mut b);
    let m = b.len() - 1;
    let r_dom = if m == 0 {
        1.0
    } else {
        (1..=m)
            .map(|k| {
                let ratio = (b[m - k] / b[m]).abs() / if k == m { 2.0 } else { 1.0 };
                2.0 * ratio.powf(1.0 / k as f64)
            })
            .fold(1.0, f64::max)
    };
    let r_stop = r_dom.min(1e6) * 1.05 + 1.0;
    if lead > 0.0 {
        // Rises eventually (beyond the scan only if it is enormously far): the lowest point
        // seen bounds the pass along this ray.
        let (r, value) = match scan(&c, steps, r_stop, lead, q_max) {
            Scan::Rises { r, value } => (r, value),
            Scan::Ends { min_r, min_v, .. } => (min_r, min_v),
        };
        return Ok(RayEnd::Pass { r, value });
    }
    match scan_reach(&c, steps, r_stop, lead, q_max) {
        Reach::Rises { r, value } => Ok(RayEnd::Pass { r, value }),
        Reach::Ends { last_above } if lead < 0.0 => Ok(RayEnd::Decays(last_above)),
        Reach::Ends { .. } => Err(NotNormalisable::FlatDirection { theta: th }),
    }
}

/// What the scan of a ray's radii finds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scan {
    /// Q rises above the mode's value at a radius; the lowest point before it is at `r`.
    Rises { r: f64, value: f64 },
    /// The scan ended without such a rise: the last radius where Q stood within the tail
    /// of the mode's value (0 if none), and the lowest point seen (the mode's value at 0
    /// if none was lower).
    Ends {
        last_above: f64,
        min_r: f64,
        min_v: f64,
    },
}

/// The scan of a ray's radii in the steps of [`RaySteps`] until the first at or beyond
/// `r_stop` where Q (coefficients `c`, leading coefficient `lead`) is monotone and past the
/// tail (or beyond [`MAX_RADIUS`]), or until Q rises above `q_max`: the same, bit for bit, as
/// taking the radii one by one ([`scan_in_order`], tested). See [`blocks`].
fn scan(c: &[f64], steps: &RaySteps, r_stop: f64, lead: f64, q_max: f64) -> Scan {
    blocks(c, steps, r_stop, lead, q_max, true)
}

/// What the scan of a ray finds where its lowest point is not asked for (a ray whose leading
/// coefficient is not positive ends in a pass only where it rises within the scan).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reach {
    /// As [`Scan::Rises`].
    Rises { r: f64, value: f64 },
    /// As [`Scan::Ends`], without the lowest point.
    Ends { last_above: f64 },
}

/// [`scan`] without the lowest point unless Q rises: the scan's blocks are then proven
/// unchanging by their enclosure alone wherever Q stays on one side of the tail, falling or
/// not (what [`scan`] cannot skip while Q falls, each block lowering the lowest point). A
/// rise is scanned again in full, for the lowest point before it.
fn scan_reach(c: &[f64], steps: &RaySteps, r_stop: f64, lead: f64, q_max: f64) -> Reach {
    match blocks(c, steps, r_stop, lead, q_max, false) {
        Scan::Rises { .. } => match scan(c, steps, r_stop, lead, q_max) {
            Scan::Rises { r, value } => Reach::Rises { r, value },
            // Not reached: the same radii and values rise in both.
            Scan::Ends { last_above, .. } => Reach::Ends { last_above },
        },
        Scan::Ends { last_above, .. } => Reach::Ends { last_above },
    }
}

/// The scan of [`scan`] a block of radii at a time, the lowest point kept where `lowest`
/// (otherwise what `Ends` says of it is meaningless). A block is not evaluated where an
/// [`enclosure`] of Q over its radii proves that it changes nothing the scan keeps but what
/// its last radius says: no rise above the mode's value, Q above the tail at every radius
/// (the last of them before the stop is then the last within the tail) or below it at every
/// one, the stop, if in the block, known from the radii alone, and either no new lowest
/// point (where kept) or Q falling strictly from radius to radius as computed
/// ([`falls_strictly`]: the lowest is then the last radius's value, the one evaluation).
/// Otherwise Q is evaluated at the block's radii at once ([`horner_block`]), and the block's
/// rise, lowest point and last radius within the tail found over it.
fn blocks(c: &[f64], steps: &RaySteps, r_stop: f64, lead: f64, q_max: f64, lowest: bool) -> Scan {
    let top = q_max + 1e-9 * (1.0 + q_max.abs());
    let tail = q_max - TAIL_E_FOLDS;
    let mut last_above = 0.0;
    let (mut min_r, mut min_v) = (0.0, q_max);
    let mut r = [0.0; BLOCK];
    for radii in steps.r.chunks(BLOCK) {
        let n = radii.len();
        if let Some([lo, hi]) = enclosure(c, radii[0], radii[n - 1]) {
            let settled = hi <= top && (lo >= tail || hi < tail);
            let unchanging = settled && (!lowest || lo >= min_v);
            let falling = settled && !unchanging && falls_strictly(c, radii);
            if unchanging || falling {
                let below_tail = hi < tail;
                let stop = radii
                    .iter()
                    .position(|&r| r > MAX_RADIUS || (r >= r_stop && (lead > 0.0 || below_tail)))
                    .unwrap_or(n);
                if stop > 0 {
                    let last = radii[stop - 1];
                    if lo >= tail {
                        last_above = last;
                    }
                    if falling {
                        // Each radius lower than the one before: the scan in order ends
                        // with the last as the lowest, if it is lower than the lowest yet.
                        let v = horner(c, last);
                        if v < min_v {
                            (min_r, min_v) = (last, v);
                        }
                    }
                }
                if stop < n {
                    break;
                }
                continue;
            }
        }
        r[..n].copy_from_slice(radii);
        let v = horner_block(c, &r);
        // Past r_dom Q is monotone along the ray: the scan stops at the first radius at or
        // beyond r_stop where it has also fallen below the tail. The radii increase, so only
        // a block reaching r_stop (or MAX_RADIUS) can hold that radius.
        let ends =
            |k: usize| radii[k] > MAX_RADIUS || (radii[k] >= r_stop && (lead > 0.0 || v[k] < tail));
        let stop = if radii[n - 1] > MAX_RADIUS || radii[n - 1] >= r_stop {
            (0..n).find(|&k| ends(k)).unwrap_or(n)
        } else {
            n
        };
        let (radii, v) = (&radii[..stop], &v[..stop]);
        if v.iter().fold(false, |any, &v| any | (v > top)) {
            // A rise in this block: its lowest point before the rise, in order.
            for (&r, &v) in radii.iter().zip(v) {
                if v > top {
                    return Scan::Rises {
                        r: min_r,
                        value: min_v,
                    };
                }
                if v < min_v {
                    min_v = v;
                    min_r = r;
                }
            }
        }
        // The block's lowest value at its first occurrence, which is where the scan in order
        // keeps it (a NaN is never lower).
        let low = v
            .iter()
            .fold(f64::INFINITY, |m, &v| if v < m { v } else { m });
        if low < min_v {
            if let Some(k) = v.iter().position(|&v| v == low) {
                min_v = v[k];
                min_r = radii[k];
            }
        }
        if let Some(k) = v.iter().rposition(|&v| v >= tail) {
            last_above = radii[k];
        }
        if stop < n {
            break;
        }
    }
    Scan::Ends {
        last_above,
        min_r,
        min_v,
    }
}

/// Whether `horner(c, r)` as computed falls strictly from each of the increasing `radii` to
/// the next: an [`enclosure`] of Q' over them is negative, and the least fall it allows
/// between neighbours (|Q'| times the smallest spacing) exceeds twice the rounding of a
/// computed value ([`rounding`]; here four times that).
fn falls_strictly(c: &[f64], radii: &[f64]) -> bool {
    let (Some(&first), Some(&last)) = (radii.first(), radii.last()) else {
        return false;
    };
    if radii.len() < 2 || c.len() < 2 || c.len() > MAX_POWER + 1 {
        return false;
    }
    let mut slope = [0.0; MAX_POWER];
    let slope = &mut slope[..c.len() - 1];
    derivative(c, slope);
    let Some([_, steepest]) = enclosure(slope, first, last) else {
        return false;
    };
    let reach = first.abs().max(last.abs());
    let gap = radii
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    // Written so that a NaN refuses.
    -steepest * gap > 4.0 * rounding(c, reach)
}

/// [`scan`] one radius at a time: the definition it is tested against.
#[cfg(test)]
fn scan_in_order(c: &[f64], steps: &RaySteps, r_stop: f64, lead: f64, q_max: f64) -> Scan {
    let mut last_above = 0.0;
    let (mut min_r, mut min_v) = (0.0, q_max);
    for &r in &steps.r {
        let v = horner(c, r);
        if r > MAX_RADIUS || (r >= r_stop && (lead > 0.0 || v < q_max - TAIL_E_FOLDS)) {
            break;
        }
        if v > q_max + 1e-9 * (1.0 + q_max.abs()) {
            return Scan::Rises {
                r: min_r,
                value: min_v,
            };
        }
        if v < min_v {
            min_v = v;
            min_r = r;
        }
        if v >= q_max - TAIL_E_FOLDS {
            last_above = r;
        }
    }
    Scan::Ends {
        last_above,
        min_r,
        min_v,
    }
}

/// Newton on ∇Q = 0 from `x`; returns a saddle (indefinite Hessian) if it converges to one.
pub(super) fn saddle_near(q: &Poly, mut x: [f64; 2]) -> Option<([f64; 2], f64)> {
    for _ in 0..60 {
        let (g, h) = gradient_and_hessian(q, x);
        if h.determinant().abs() < 1e-300 {
            return None;
        }
        let step = -(h.try_inverse()? * g);
        x = [x[0] + step[0], x[1] + step[1]];
        if step[0].hypot(step[1]) < 1e-12 * (1.0 + x[0].hypot(x[1])) {
            let (_, h) = gradient_and_hessian(q, x);
            return (h.determinant() < 0.0).then(|| (x, q.eval(x)));
        }
    }
    None
}

/// ∇Q and the Hessian of Q at x.
fn gradient_and_hessian(q: &Poly, x: [f64; 2]) -> (Vector2<f64>, Matrix2<f64>) {
    let (g, h) = q.derivs(x);
    (
        Vector2::from(g),
        Matrix2::new(h[0][0], h[0][1], h[1][0], h[1][1]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block scan is the scan in order, bit for bit (radii and values compared by their
    /// bits), on rays that decay, rise above the mode near it or far out, rise eventually
    /// (positive leading coefficient), hover at the tail or the mode's value, or have NaN
    /// coefficients; with r_stop anywhere in a block.
    #[test]
    fn the_block_scan_is_the_scan_in_order() {
        let steps = RaySteps::get();
        let mut stream = crate::epc::uniform::Uniform::new(0x51_7c_c1_b7_27_22_0a_95);
        let mut uniform = || stream.next();
        let bits = |s: Scan| match s {
            Scan::Rises { r, value } => (0, r.to_bits(), value.to_bits(), 0),
            Scan::Ends {
                last_above,
                min_r,
                min_v,
            } => (1, last_above.to_bits(), min_r.to_bits(), min_v.to_bits()),
        };
        let (mut rises, mut ends) = (0, 0);
        for case in 0..3000 {
            let degree = 2 + case % 7;
            let mut c: Vec<f64> = (0..=degree)
                .map(|k| (uniform() - 0.5) * 4.0 / (1 + k * k) as f64)
                .collect();
            c[0] = 0.0;
            match case % 5 {
                // A peak at the mode falling for good.
                0 => c[degree] = -uniform().abs() - 1e-3,
                // A quadratic well with a hump beyond: a pass.
                1 => {
                    c.resize(4, 0.0);
                    c[2] = -0.5;
                    c[3] = 0.05 * uniform();
                    c.truncate(4);
                }
                // Rising eventually.
                2 => c[degree] = uniform() * 1e-4 + 1e-6,
                // Flat at the mode's value, then falling: ties at the minimum and at 0.
                3 => {
                    c.iter_mut().for_each(|v| *v = 0.0);
                    c[degree] = -1e-6;
                }
                _ => {
                    if case % 50 == 4 {
                        c[1] = f64::NAN;
                    }
                }
            }
            let lead = *c.last().unwrap();
            let q_max = if case % 3 == 0 { 0.0 } else { 0.5 * uniform() };
            let r_stop = 0.01 + 40.0 * uniform() * uniform();
            let got = scan(&c, steps, r_stop, lead, q_max);
            let want = scan_in_order(&c, steps, r_stop, lead, q_max);
            assert_eq!(bits(got), bits(want), "case {case}: {c:?}, r_stop {r_stop}");
            // Without the lowest point unless it rises: the rest bit for bit.
            let reach = match scan_reach(&c, steps, r_stop, lead, q_max) {
                Reach::Rises { r, value } => bits(Scan::Rises { r, value }),
                Reach::Ends { last_above } => (1, last_above.to_bits(), 0, 0),
            };
            let want_reach = match bits(want) {
                (1, last_above, _, _) => (1, last_above, 0, 0),
                rises => rises,
            };
            assert_eq!(
                reach, want_reach,
                "case {case} (reach): {c:?}, r_stop {r_stop}"
            );
            match want {
                Scan::Rises { .. } => rises += 1,
                Scan::Ends { .. } => ends += 1,
            }
        }
        assert!(rises > 300 && ends > 300, "{rises} rises, {ends} ends");
        // Q falling by less than a rounding step between radii (computed values that tie,
        // then drop): the lowest point is where the scan in order first meets the lowest
        // computed value, which no proof of a strict fall may claim is the block's last.
        // (A positive leading coefficient stops the scan at r_stop itself, in the ties.)
        for (c, r_stop) in [
            (vec![1e3, -1e-14, 1e-30], 3.0),
            (vec![1e3, -1e-14, 1e-30], 6.5),
            (vec![1e3, -1e-14, 1e-30], 9.0),
            (vec![1e3, -1e-14, 1e-30], 25.0),
            (vec![1e3, -3e-13], 900.0),
            (vec![1e3, -2e-12, 1e-16], 300.0),
        ] {
            let got = scan(&c, steps, r_stop, c[c.len() - 1], 1e3);
            let want = scan_in_order(&c, steps, r_stop, c[c.len() - 1], 1e3);
            assert_eq!(bits(got), bits(want), "Q = {c:?}");
        }
        // Q constant along the ray: every radius ties at the lowest value, which the scan in
        // order keeps at its first.
        for (c0, r_stop) in [(-50.0, 3.0), (-1.0, 0.5), (-0.0, 7.0)] {
            let c = [c0, 0.0];
            let got = scan(&c, steps, r_stop, 0.0, 0.0);
            let want = scan_in_order(&c, steps, r_stop, 0.0, 0.0);
            assert_eq!(bits(got), bits(want), "Q = {c0}");
            if c0 < 0.0 {
                assert!(matches!(want, Scan::Ends { min_r, .. } if min_r == steps.r[0]));
            }
        }
    }
}
