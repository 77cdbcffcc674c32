//! Whether exp(Q) is a density on the domain, and the box that holds it.
//!
//! exp(Q) is normalisable on D when Q → −∞ along every ray that stays in D: on the plane every
//! direction, above a lower barrier the directions with a non-negative x component (below an
//! upper one, non-positive), on a strip only v → ±∞. As the δ-term EPC does, this is checked
//! on rays (721 directions of the arc, from 5 points across the box; 41 points across a
//! strip): along each, the highest power of the distance whose coefficient is not negligible
//! (above 1e−10 of the largest) must have a negative coefficient. Nothing is cut: a Q that
//! grows along some ray of D is refused ([`Divergence::Ray`]), never normalised inside a box.
//!
//! The box is where exp(Q) exceeds e^−40 of its peak (found on a 161 × 161 sample of a box
//! half as large again as the current one, enlarged while that region reaches its free edges),
//! with a barrier as the edge on its side.

use super::error::Divergence;
use super::mechanics::{BarrierSide, Wall};
use super::rule::{free_x_edges, q_at, Window};

/// e-folds below the peak at which the density counts as negligible (e^−40 ≈ 4e−18).
pub(crate) const TAIL_E_FOLDS: f64 = 40.0;
/// Directions per arc.
const RAYS: usize = 720;
/// Sample points per axis of the box search.
const SAMPLES: usize = 161;
/// Enlargements of the box search at most.
const GROWTHS: usize = 8;

/// Coefficients of Q(b + t·u) as a polynomial in t (index = power).
fn along(exps: &[(usize, usize)], a: &[f64], b: [f64; 2], u: [f64; 2], n: usize) -> Vec<f64> {
    // (b0 + u0 t)^i and (b1 + u1 t)^j as coefficient vectors.
    let binom = |b0: f64, u0: f64| {
        let mut out = vec![vec![1.0]];
        for k in 1..=n {
            let prev: &Vec<f64> = &out[k - 1];
            let mut next = vec![0.0; k + 1];
            for (p, c) in prev.iter().enumerate() {
                next[p] += c * b0;
                next[p + 1] += c * u0;
            }
            out.push(next);
        }
        out
    };
    let px = binom(b[0], u[0]);
    let py = binom(b[1], u[1]);
    let mut c = vec![0.0; n + 1];
    for (&(i, j), coef) in exps.iter().zip(a) {
        for (p, x) in px[i].iter().enumerate() {
            for (q, y) in py[j].iter().enumerate() {
                c[p + q] += coef * x * y;
            }
        }
    }
    c
}

/// Checks that Q (scaled variables, coefficients `a` on `exps`) decays along every ray of the
/// domain bounded by `barriers` (positions in scaled units), from points across `xs`.
pub(crate) fn check(
    exps: &[(usize, usize)],
    a: &[f64],
    barriers: &[(f64, BarrierSide)],
    xs: [f64; 2],
) -> Result<(), Divergence> {
    let n = exps.iter().map(|e| e.0 + e.1).max().unwrap_or(0);
    let strip = barriers.len() == 2;
    let (arc, bases): (Vec<[f64; 2]>, Vec<[f64; 2]>) = if strip {
        let bases = (0..41)
            .map(|k| [xs[0] + (xs[1] - xs[0]) * k as f64 / 40.0, 0.0])
            .collect();
        (vec![[0.0, 1.0], [0.0, -1.0]], bases)
    } else {
        let (lo, hi) = match barriers.first().map(|b| b.1) {
            None => (-std::f64::consts::PI, std::f64::consts::PI),
            Some(BarrierSide::Above) => (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
            Some(BarrierSide::Below) => (std::f64::consts::FRAC_PI_2, 1.5 * std::f64::consts::PI),
        };
        let arc = (0..=RAYS)
            .map(|k| {
                let th = lo + (hi - lo) * k as f64 / RAYS as f64;
                [th.cos(), th.sin()]
            })
            .collect();
        let bases = (0..5)
            .map(|k| [xs[0] + (xs[1] - xs[0]) * k as f64 / 4.0, 0.0])
            .collect();
        (arc, bases)
    };
    for b in &bases {
        for u in &arc {
            let c = along(exps, a, *b, *u, n);
            let scale = c[1..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let lead = (1..=n).rev().find(|&k| c[k].abs() > 1e-10 * scale);
            match lead {
                Some(k) if c[k] < 0.0 => {}
                _ => {
                    let k = lead.unwrap_or(0);
                    return Err(Divergence::Ray {
                        from: *b,
                        direction: *u,
                        power: k,
                        coefficient: c[k],
                    });
                }
            }
        }
    }
    Ok(())
}

/// A box fitted to exp(Q), and how far below the peak it had to stop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fit {
    pub(crate) window: Window,
    /// e-folds from the peak to the lowest point of the highest path from the peak to the
    /// sample box's free edge: the ridge's pass when Q grows again beyond it, at least
    /// [`TAIL_E_FOLDS`] when it does not within the sample box.
    pub(crate) depth: f64,
}

/// A float ordered for the priority flood.
#[derive(Clone, Copy, PartialEq)]
struct Level(f64, usize);
impl Eq for Level {}
impl PartialOrd for Level {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Level {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
    }
}

/// The box (original units) of the part of exp(Q) around its peak, starting the search
/// from `start`; barrier edges stay where the barriers are.
///
/// On a sample of a box half as large again as `start`, a priority flood from the peak finds
/// the highest path to the sample box's free edge and the lowest value on it (the pass). When
/// Q `decays` (along every ray of the domain) and the pass is not yet [`TAIL_E_FOLDS`] below
/// the peak, the sample box grows. Otherwise the box is the bounding box of the connected
/// part of {Q > peak − L} holding the peak, L = [`TAIL_E_FOLDS`] or, inside a ridge, the
/// depth of the pass less one e-fold; that part must be all of {Q > peak − L} inside the box
/// (no second hump beyond a ridge inside it).
pub(crate) fn fit_box(
    exps: &[(usize, usize)],
    a: &[f64],
    sigma: [f64; 2],
    barriers: &[Wall],
    start: Window,
    mode: [f64; 2],
    decays: bool,
) -> Result<Fit, Divergence> {
    let free = free_x_edges(barriers);
    let mut w = start;
    let mut depth = 0.0;
    for _ in 0..GROWTHS {
        let dx = 0.25 * (w.x[1] - w.x[0]);
        let e = Window {
            x: [
                if free[0] { w.x[0] - dx } else { w.x[0] },
                if free[1] { w.x[1] + dx } else { w.x[1] },
            ],
            v: [1.5 * w.v[0], 1.5 * w.v[1]],
        };
        let n = SAMPLES;
        let at = |k: usize, r: [f64; 2]| r[0] + (r[1] - r[0]) * k as f64 / (n - 1) as f64;
        let mut q = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                q[i * n + j] = q_at(exps, a, at(i, e.x) / sigma[0], at(j, e.v) / sigma[1]);
            }
        }
        let on_free_edge = |k: usize| {
            let (i, j) = (k / n, k % n);
            (i == 0 && free[0]) || (i == n - 1 && free[1]) || j == 0 || j == n - 1
        };
        let neighbours = |k: usize| {
            let (i, j) = ((k / n) as isize, (k % n) as isize);
            [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)]
                .into_iter()
                .filter(|&(a, b)| a >= 0 && b >= 0 && a < n as isize && b < n as isize)
                .map(|(a, b)| a as usize * n + b as usize)
        };
        // The peak: the local maximum of the samples reached by steepest ascent from the
        // sample nearest to `mode` (beyond a ridge Q may be larger still).
        let nearest = |u: f64, r: [f64; 2]| {
            (((u - r[0]) / (r[1] - r[0]) * (n - 1) as f64)
                .round()
                .max(0.0) as usize)
                .min(n - 1)
        };
        let mut peak = nearest(mode[0], e.x) * n + nearest(mode[1], e.v);
        while let Some(up) = neighbours(peak).find(|&m| q[m] > q[peak]) {
            peak = neighbours(peak).fold(up, |b, m| if q[m] > q[b] { m } else { b });
        }
        let top = q[peak];
        // Priority flood: the running minimum when the free edge is first reached is the
        // pass of the highest path to it.
        let mut seen = vec![false; n * n];
        let mut heap = std::collections::BinaryHeap::new();
        heap.push(Level(top, peak));
        seen[peak] = true;
        let mut pass = top;
        while let Some(Level(v, k)) = heap.pop() {
            pass = pass.min(v);
            if on_free_edge(k) {
                break;
            }
            for m in neighbours(k) {
                if !seen[m] {
                    seen[m] = true;
                    heap.push(Level(q[m], m));
                }
            }
        }
        depth = top - pass;
        if depth < TAIL_E_FOLDS && decays {
            w = e;
            continue;
        }
        let level = top
            - if depth >= TAIL_E_FOLDS {
                TAIL_E_FOLDS
            } else {
                depth - 1.0
            };
        // The connected part of {Q > level} holding the peak.
        let mut part = vec![false; n * n];
        let mut stack = vec![peak];
        part[peak] = true;
        while let Some(k) = stack.pop() {
            for m in neighbours(k) {
                if !part[m] && q[m] > level {
                    part[m] = true;
                    stack.push(m);
                }
            }
        }
        let (mut ilo, mut ihi, mut jlo, mut jhi) = (n, 0, n, 0);
        for k in (0..n * n).filter(|&k| part[k]) {
            let (i, j) = (k / n, k % n);
            ilo = ilo.min(i);
            ihi = ihi.max(i);
            jlo = jlo.min(j);
            jhi = jhi.max(j);
        }
        let (ilo, ihi) = (ilo.saturating_sub(1), (ihi + 1).min(n - 1));
        let (jlo, jhi) = (jlo.saturating_sub(1), (jhi + 1).min(n - 1));
        let other = (ilo..=ihi)
            .flat_map(|i| (jlo..=jhi).map(move |j| i * n + j))
            .find(|&k| q[k] > level && !part[k]);
        if let Some(k) = other {
            return Err(Divergence::SecondHump {
                x: at(k / n, e.x),
                v: at(k % n, e.v),
                e_folds: top - q[k],
            });
        }
        let x = [
            if free[0] { at(ilo, e.x) } else { e.x[0] },
            if free[1] { at(ihi, e.x) } else { e.x[1] },
        ];
        let v = [
            at(jlo, e.v).min(-0.05 * e.v[1]),
            at(jhi, e.v).max(-0.05 * e.v[0]),
        ];
        return Ok(Fit {
            window: Window { x, v },
            depth,
        });
    }
    Err(Divergence::Unbounded {
        x: w.x,
        v: w.v,
        edge_e_folds: depth,
        limit: TAIL_E_FOLDS,
    })
}

/// e-folds from the peak of exp(Q) (over the rule's nodes) to its largest value on the free
/// edges of `w`, on 401 points per edge.
pub(crate) fn edge_e_folds(
    exps: &[(usize, usize)],
    a: &[f64],
    sigma: [f64; 2],
    barriers: &[Wall],
    w: Window,
    peak: f64,
) -> f64 {
    let free = free_x_edges(barriers);
    let mut edge = f64::NEG_INFINITY;
    let at = |k: usize, r: [f64; 2]| r[0] + (r[1] - r[0]) * k as f64 / 400.0;
    for k in 0..=400 {
        for v in w.v {
            edge = edge.max(q_at(exps, a, at(k, w.x) / sigma[0], v / sigma[1]));
        }
        for (side, x) in w.x.into_iter().enumerate() {
            if free[side] {
                edge = edge.max(q_at(exps, a, x / sigma[0], at(k, w.v) / sigma[1]));
            }
        }
    }
    peak - edge
}
