//! Gauss rules for the standard normal weight φ(t) = exp(−t²/2)/√(2π) on intervals of the
//! line (half-lines included), so that integrands which are polynomials with kinks, times a
//! Gaussian, are integrated exactly once every axis is split at its kinks.
//!
//! A rule for φ on [a, b] is built by the discretised Stieltjes procedure (the measure is
//! replaced by a fine composite Gauss–Legendre discretisation, accurate to rounding for
//! polynomials of the degrees used here) followed by Golub–Welsch on the Jacobi matrix.
//! Rules are cached per thread, keyed by the interval and the number of nodes.

use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

use nalgebra::DMatrix;

/// 1/√(2π).
const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;

/// Beyond |t| = this the normal weight is below e^-128 of its peak; intervals are clipped here
/// (or a further 12 beyond a finite end that lies outside it).
const CLIP: f64 = 16.0;

/// The widest panel of the discretised measure, and its Gauss–Legendre points. The moments
/// t^k·φ(t), k ≤ 23 (the exactness of the largest rule here, 12 nodes), of the discretised
/// measure agree with those of panels a quarter as wide with 24 points to rounding (tested:
/// within 8e−16 of Σ w|t|^k on intervals that reach within 6 of 0, 6e−15 on [25, ∞), where
/// φ's own values carry a rounding of order t²ε), as with the 20 points per half unit used
/// before, at 40 % of the points: a rule's cost is its Stieltjes sweeps over them, and a solve
/// builds some fourteen rules (the Gaussian closure's frames, the Galerkin tables).
const PANEL_WIDTH: f64 = 1.0;
/// See [`PANEL_WIDTH`].
const PANEL_POINTS: usize = 16;

/// A Gauss rule: `∫ g(t) φ(t) dt ≈ Σ weights[i]·g(nodes[i])` over the rule's interval.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct QuadratureRule {
    /// The nodes, increasing.
    pub nodes: Vec<f64>,
    /// The weights (positive; they sum to the normal mass of the interval).
    pub weights: Vec<f64>,
}

/// The standard normal density.
pub(crate) fn normal_pdf(t: f64) -> f64 {
    INV_SQRT_2PI * (-0.5 * t * t).exp()
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on the Legendre recurrence).
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { z } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (z * pn - pm) / (z * z - 1.0);
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    (x, w)
}

/// A discretisation of φ on [a, b]: panels of width ≤ [`PANEL_WIDTH`] with [`PANEL_POINTS`]
/// Gauss–Legendre points each.
fn discretise(a: f64, b: f64) -> (Vec<f64>, Vec<f64>) {
    // The panels' Gauss–Legendre rule, computed once (each frame of the Gaussian closure
    // discretises afresh).
    static PANEL_RULE: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    let rule = PANEL_RULE.get_or_init(|| gauss_legendre(PANEL_POINTS));
    discretise_with(a, b, PANEL_WIDTH, rule)
}

/// A discretisation of φ on [a, b] by panels of width ≤ `width`, each with the Gauss–Legendre
/// rule `(nodes, weights)` on [−1, 1]. On an interval at a distance d > 6 from 0, where φ
/// falls by e^−d per unit (its mass at the near end), the panels are narrowed to 6/d.
fn discretise_with(
    a: f64,
    b: f64,
    width: f64,
    (gx, gw): &(Vec<f64>, Vec<f64>),
) -> (Vec<f64>, Vec<f64>) {
    let lo = a.max((-CLIP).min(b - 12.0));
    let hi = b.min(CLIP.max(a + 12.0));
    let distance = lo.max(-hi).max(0.0);
    let width = width.min(6.0 / distance);
    let panels = ((hi - lo) / width).ceil().max(1.0) as usize;
    let h = (hi - lo) / panels as f64;
    let mut t = Vec::with_capacity(panels * gx.len());
    let mut w = Vec::with_capacity(panels * gx.len());
    for p in 0..panels {
        let mid = lo + (p as f64 + 0.5) * h;
        for (x, wx) in gx.iter().zip(gw) {
            let ti = mid + 0.5 * h * x;
            t.push(ti);
            w.push(0.5 * h * wx * normal_pdf(ti));
        }
    }
    (t, w)
}

/// Σ f(i), i = 0…n−1, in four interleaved partial sums (four independent chains of
/// additions, where one sum waits on each addition before the next).
fn split_sum(n: usize, f: impl Fn(usize) -> f64) -> f64 {
    let mut acc = [0.0; 4];
    let whole = n - n % 4;
    for i in (0..whole).step_by(4) {
        for (l, a) in acc.iter_mut().enumerate() {
            *a += f(i + l);
        }
    }
    let rest: f64 = (whole..n).map(&f).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + rest
}

/// Builds the `n`-point Gauss rule for φ on [a, b] (either end may be infinite).
fn build_rule(a: f64, b: f64, n: usize) -> QuadratureRule {
    let (t, w) = discretise(a, b);
    let mass: f64 = w.iter().sum();
    if mass <= 0.0 || !mass.is_finite() {
        return QuadratureRule {
            nodes: vec![],
            weights: vec![],
        };
    }
    // Stieltjes with orthonormal vectors (no overflow); shift by the interval's centre so
    // that far-out intervals keep their relative precision.
    let centre = t.iter().zip(&w).map(|(t, w)| t * w).sum::<f64>() / mass;
    let u: Vec<f64> = t.iter().map(|t| t - centre).collect();
    let mut alpha = vec![0.0; n];
    let mut beta: Vec<f64> = vec![0.0; n];
    let mut p_prev = vec![0.0; t.len()];
    let mut p = vec![1.0 / mass.sqrt(); t.len()];
    let mut next = vec![0.0; t.len()];
    for k in 0..n {
        let a_k = split_sum(t.len(), |i| w[i] * u[i] * p[i] * p[i]);
        alpha[k] = a_k;
        let b_k = beta[k].sqrt();
        for (((o, &u), &p), &q) in next.iter_mut().zip(&u).zip(&p).zip(&p_prev) {
            *o = (u - a_k) * p - b_k * q;
        }
        if k + 1 < n {
            let norm2 = split_sum(t.len(), |i| w[i] * next[i] * next[i]);
            beta[k + 1] = norm2;
            let s = 1.0 / norm2.sqrt();
            next.iter_mut().for_each(|v| *v *= s);
            std::mem::swap(&mut p_prev, &mut p);
            std::mem::swap(&mut p, &mut next);
        }
    }
    let mut jac = DMatrix::<f64>::zeros(n, n);
    for k in 0..n {
        jac[(k, k)] = alpha[k];
        if k + 1 < n {
            let off = beta[k + 1].sqrt();
            jac[(k, k + 1)] = off;
            jac[(k + 1, k)] = off;
        }
    }
    let eig = nalgebra::SymmetricEigen::new(jac);
    let mut pairs: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let v0 = eig.eigenvectors[(0, i)];
            (eig.eigenvalues[i] + centre, mass * v0 * v0)
        })
        .collect();
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    QuadratureRule {
        nodes: pairs.iter().map(|p| p.0).collect(),
        weights: pairs.iter().map(|p| p.1).collect(),
    }
}

type RuleKey = (u64, u64, usize);

thread_local! {
    static CACHE: RefCell<HashMap<RuleKey, Arc<QuadratureRule>>> = RefCell::new(HashMap::new());
}

/// The `n`-point Gauss rule for the standard normal weight on [a, b]; `a` may be −∞ and `b`
/// may be +∞. Exact for polynomials of degree ≤ 2n − 1 (to rounding).
pub(crate) fn normal_rule(a: f64, b: f64, n: usize) -> Arc<QuadratureRule> {
    let key = (a.to_bits(), b.to_bits(), n);
    CACHE.with(|c| {
        if let Some(r) = c.borrow().get(&key) {
            return r.clone();
        }
        let r = Arc::new(build_rule(a, b, n));
        c.borrow_mut().insert(key, r.clone());
        r
    })
}

/// A rule for φ on the whole line, split at the given points (each piece with `n` nodes), so
/// that an integrand with kinks only at those points is integrated exactly when it is a
/// polynomial of degree ≤ 2n − 1 on every piece.
pub(crate) fn split_normal_rule(splits: &[f64], n: usize) -> QuadratureRule {
    let mut cuts: Vec<f64> = splits.iter().copied().filter(|s| s.is_finite()).collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-14);
    // Pieces far out in the tail carry no mass worth a rule.
    cuts.retain(|c| c.abs() < 30.0);
    let mut ends = vec![f64::NEG_INFINITY];
    ends.extend(cuts);
    ends.push(f64::INFINITY);
    let mut out = QuadratureRule {
        nodes: vec![],
        weights: vec![],
    };
    for w in ends.windows(2) {
        let r = normal_rule(w[0], w[1], n);
        out.nodes.extend(&r.nodes);
        out.weights.extend(&r.weights);
    }
    out
}

/// The `n`-point rule for ∫ g(t) φ(t)·N(t; m, s²) dt, the normal weight times a Gaussian
/// regulariser of centre `m` and width `s`: the product is a Gaussian, so this is a shifted and
/// scaled normal rule, exact for polynomials of degree ≤ 2n − 1.
pub(crate) fn regularised_rule(m: f64, s: f64, n: usize) -> QuadratureRule {
    let v = s * s;
    // φ(t)·N(t; m, v) = N(m; 0, 1 + v)·N(t; m/(1+v), v/(1+v)).
    let scale = normal_pdf(m / (1.0 + v).sqrt()) / (1.0 + v).sqrt();
    let centre = m / (1.0 + v);
    let sd = (v / (1.0 + v)).sqrt();
    let base = normal_rule(f64::NEG_INFINITY, f64::INFINITY, n);
    QuadratureRule {
        nodes: base.nodes.iter().map(|t| centre + sd * t).collect(),
        weights: base.weights.iter().map(|w| w * scale).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_line_rule_gives_the_half_normal_second_moment() {
        let r = normal_rule(0.0, f64::INFINITY, 6);
        // ∫_0^∞ t² φ(t) dt = 1/2
        let m2: f64 = r.nodes.iter().zip(&r.weights).map(|(t, w)| w * t * t).sum();
        assert!((m2 - 0.5).abs() < 1e-13);
    }

    #[test]
    fn split_rule_integrates_a_kink_exactly() {
        let r = split_normal_rule(&[0.0], 4);
        // E|t| = √(2/π)
        let e: f64 = r
            .nodes
            .iter()
            .zip(&r.weights)
            .map(|(t, w)| w * t.abs())
            .sum();
        assert!((e - (2.0 / std::f64::consts::PI).sqrt()).abs() < 1e-14);
    }
    use approx::assert_relative_eq;

    /// ∫_a^∞ t^k φ(t) dt by the recurrence I_k = a^{k−1}φ(a) + (k−1) I_{k−2}.
    fn upper_moment(a: f64, k: usize) -> f64 {
        let mut i0 = 0.5 * erfc_approx(a / std::f64::consts::SQRT_2);
        let mut i1 = normal_pdf(a);
        if k == 0 {
            return i0;
        }
        for j in 2..=k {
            let i2 = a.powi(j as i32 - 1) * normal_pdf(a) + (j - 1) as f64 * i0;
            i0 = i1;
            i1 = i2;
        }
        i1
    }

    /// erfc(x) by composite Simpson on [x, x + 30] (test reference only).
    fn erfc_approx(x: f64) -> f64 {
        let n = 20_000;
        let hi = x + 30.0;
        let h = (hi - x) / n as f64;
        let f = |t: f64| (-t * t).exp();
        let mut s = f(x) + f(hi);
        for i in 1..n {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x + i as f64 * h);
        }
        s * h / 3.0 * 2.0 / std::f64::consts::PI.sqrt()
    }

    #[test]
    fn half_line_rules_are_exact_for_polynomials() {
        for &a in &[0.0, 0.7, -1.3, 2.5] {
            let r = normal_rule(a, f64::INFINITY, 12);
            for k in 0..=23 {
                let q: f64 = r
                    .nodes
                    .iter()
                    .zip(&r.weights)
                    .map(|(t, w)| w * t.powi(k as i32))
                    .sum();
                let exact = upper_moment(a, k);
                assert_relative_eq!(q, exact, max_relative = 1e-9, epsilon = 1e-12);
            }
            assert!(r.nodes.iter().all(|t| *t > a));
        }
    }

    #[test]
    fn whole_line_rule_reproduces_normal_moments() {
        let r = split_normal_rule(&[], 10);
        let m = |k: i32| -> f64 {
            r.nodes
                .iter()
                .zip(&r.weights)
                .map(|(t, w)| w * t.powi(k))
                .sum()
        };
        assert_relative_eq!(m(0), 1.0, epsilon = 1e-14);
        assert_relative_eq!(m(4), 3.0, epsilon = 1e-12);
        assert_relative_eq!(m(18), 34_459_425.0, max_relative = 1e-11);
        assert!(m(7).abs() < 1e-10);
    }

    #[test]
    fn regularised_rule_tends_to_point_evaluation() {
        // ∫ t² φ(t) N(t; 0.5, s²) dt → 0.25·φ(0.5) as s → 0.
        let target = 0.25 * normal_pdf(0.5);
        let mut last = f64::INFINITY;
        for &s in &[0.1, 0.01, 0.001] {
            let r = regularised_rule(0.5, s, 4);
            let q: f64 = r.nodes.iter().zip(&r.weights).map(|(t, w)| w * t * t).sum();
            let err = (q - target).abs();
            assert!(err < last);
            last = err;
        }
        assert!(last < 1e-6);
    }

    #[test]
    fn the_discretised_measure_has_the_moments_of_a_four_times_finer_one() {
        // Moments up to t^23 (a 12-node rule's exactness) of φ on the intervals the rules
        // are built on, against panels a quarter as wide with 24 points: the same to within
        // rounding (measured: 8e−16 of Σ w|t|^k, 6e−15 on [25, ∞)). Uniform panels of width 1
        // fail on [25, ∞) (4e−14 in the mass).
        let fine_rule = gauss_legendre(24);
        for (a, b) in [
            (f64::NEG_INFINITY, 0.0),
            (0.0, f64::INFINITY),
            (-1.3, 2.5),
            (2.5, f64::INFINITY),
            (f64::NEG_INFINITY, -7.0),
            (25.0, f64::INFINITY),
        ] {
            let coarse = discretise(a, b);
            let fine = discretise_with(a, b, PANEL_WIDTH / 4.0, &fine_rule);
            for k in 0..=23 {
                let moment = |(t, w): &(Vec<f64>, Vec<f64>)| -> [f64; 2] {
                    let terms = t.iter().zip(w).map(|(t, w)| w * t.powi(k));
                    [terms.clone().sum(), terms.map(f64::abs).sum()]
                };
                let ([c, scale], [f, _]) = (moment(&coarse), moment(&fine));
                assert!(
                    (c - f).abs() <= 1e-14 * scale,
                    "[{a}, {b}] t^{k}: {c:e} against {f:e} (scale {scale:e})"
                );
            }
        }
    }
}
