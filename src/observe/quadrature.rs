//! Adaptive Gauss–Kronrod (7–15) quadrature in one variable: the line integrals of the
//! exact observable method and the co-area line sums.
//!
//! The functions are `pub` inside this private module so that the `test-support` feature can
//! re-export one for the crate's integration tests; to the crate they are `pub(crate)`.

/// Adaptive Gauss–Kronrod (7–15) quadrature of `f` over [a, b] to relative tolerance `rel`
/// (with a floor of 1e−300 absolute, so an integrand that is zero gives zero).
// Used by the grid solver's tests and re-exported for the integration tests.
#[allow(dead_code)]
pub fn integrate_adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, rel: f64) -> f64 {
    integrate_adaptive_batch(&pointwise(f), a, b, rel)
}

/// [`integrate_adaptive`] of an integrand evaluated a panel's 15 nodes at a time:
/// `f(t, out)` sets `out[k]` = f(`t[k]`). The same nodes, sums and refinement, so the same
/// value bit for bit, with one call per panel instead of one per node (an integrand that
/// shares work between nodes, such as exp(Q) on a line, is cheaper that way).
pub fn integrate_adaptive_batch(f: &dyn Fn(&[f64], &mut [f64]), a: f64, b: f64, rel: f64) -> f64 {
    // Start from 16 panels so that a narrow peak is never missed between Kronrod nodes.
    let n0 = 16;
    let edges: Vec<f64> = (0..=n0)
        .map(|k| a + (b - a) * k as f64 / n0 as f64)
        .collect();
    integrate_panels_batch(f, &edges, rel)
}

/// Adaptive Gauss–Kronrod quadrature of `f` from `edges[0]` to its last element, starting from
/// the panels between consecutive `edges` (sorted), to relative tolerance `rel`.
pub fn integrate_panels(f: &dyn Fn(f64) -> f64, edges: &[f64], rel: f64) -> f64 {
    integrate_panels_batch(&pointwise(f), edges, rel)
}

/// A scalar integrand as a batch one.
fn pointwise(f: &dyn Fn(f64) -> f64) -> impl Fn(&[f64], &mut [f64]) + '_ {
    move |t: &[f64], out: &mut [f64]| {
        for (o, &t) in out.iter_mut().zip(t) {
            *o = f(t);
        }
    }
}

/// Panels split in one integral, at most: a smooth integrand needs hundreds, each jump of a
/// discontinuous one 40 (the depth cap). Beyond it the integral is not resolved, and NaN says
/// so; before this cap an integrand whose error estimate never fell (one returning NaN, whose
/// NaN total set the tolerance to 1e−300) split every panel to depth 40, 2^40 panels.
const MAX_SPLITS: usize = 1 << 18;

/// [`integrate_panels`] with the integrand evaluated a panel at a time (see
/// [`integrate_adaptive_batch`]). A non-finite value on a panel is the result (NaN, or ±∞
/// for an integrand infinite there), and so is NaN when [`MAX_SPLITS`] splits do not reach
/// the tolerance.
pub fn integrate_panels_batch(f: &dyn Fn(&[f64], &mut [f64]), edges: &[f64], rel: f64) -> f64 {
    integrate_panels_by(Rule::Kronrod15, f, edges, rel)
}

/// The pair of rules a panel is integrated and checked by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// Gauss–Kronrod 7–15: for integrands that may have kinks or peaks inside a panel.
    Kronrod15,
    /// Gauss–Kronrod 3–7 (exact to degree 11, half the evaluations): for panels already cut
    /// at every kink of the integrand, so that each is smooth and short.
    Kronrod7,
}

/// [`integrate_panels`] by the given pair of rules, a panel at a time.
pub fn integrate_panels_by(
    rule: Rule,
    f: &dyn Fn(&[f64], &mut [f64]),
    edges: &[f64],
    rel: f64,
) -> f64 {
    let gauss_kronrod = |f: &dyn Fn(&[f64], &mut [f64]), lo: f64, hi: f64| match rule {
        Rule::Kronrod15 => gauss_kronrod(f, lo, hi),
        Rule::Kronrod7 => gauss_kronrod7(f, lo, hi),
    };
    let mut stack: Vec<(f64, f64, f64, f64, u32)> = Vec::with_capacity(64);
    let mut total = 0.0;
    for w in edges.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        let (v, e) = gauss_kronrod(f, lo, hi);
        stack.push((lo, hi, v, e, 0));
        total += v;
    }
    let mut done = 0.0;
    let mut splits = 0;
    while let Some((lo, hi, v, e, depth)) = stack.pop() {
        if !(v.is_finite() && e.is_finite()) {
            return if v.is_infinite() { v } else { f64::NAN };
        }
        let tol = (rel * total.abs()).max(1e-300);
        // Refine a panel while its error is a noticeable share of the tolerance; the depth
        // cap only bites on a discontinuity, where halving no longer helps.
        if e <= tol / 64.0 || depth >= 40 {
            done += v;
            continue;
        }
        splits += 1;
        if splits > MAX_SPLITS {
            return f64::NAN;
        }
        let mid = 0.5 * (lo + hi);
        let (v1, e1) = gauss_kronrod(f, lo, mid);
        let (v2, e2) = gauss_kronrod(f, mid, hi);
        total += v1 + v2 - v;
        stack.push((lo, mid, v1, e1, depth + 1));
        stack.push((mid, hi, v2, e2, depth + 1));
    }
    done
}

/// One Gauss–Kronrod 7–15 panel: the Kronrod value and |Kronrod − Gauss| as error estimate.
fn gauss_kronrod(f: &dyn Fn(&[f64], &mut [f64]), a: f64, b: f64) -> (f64, f64) {
    const XK: [f64; 8] = [
        0.991_455_371_120_812_6,
        0.949_107_912_342_758_5,
        0.864_864_423_359_769_1,
        0.741_531_185_599_394_4,
        0.586_087_235_467_691_1,
        0.405_845_151_377_397_2,
        0.207_784_955_007_898_5,
        0.0,
    ];
    const WK: [f64; 8] = [
        0.022_935_322_010_529_22,
        0.063_092_092_629_978_55,
        0.104_790_010_322_250_2,
        0.140_653_259_715_525_9,
        0.169_004_726_639_267_9,
        0.190_350_578_064_785_4,
        0.204_432_940_075_298_9,
        0.209_482_141_084_727_8,
    ];
    const WG: [f64; 4] = [
        0.129_484_966_168_869_7,
        0.279_705_391_489_276_7,
        0.381_830_050_505_118_9,
        0.417_959_183_673_469_4,
    ];
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    // Nodes: the centre, then c − h·x_i and c + h·x_i for i = 0…6.
    let mut t = [c; 15];
    for i in 0..7 {
        t[1 + 2 * i] = c - h * XK[i];
        t[2 + 2 * i] = c + h * XK[i];
    }
    let mut v = [0.0; 15];
    f(&t, &mut v);
    let fc = v[0];
    let mut k = WK[7] * fc;
    let mut g = WG[3] * fc;
    for i in 0..7 {
        let (f1, f2) = (v[1 + 2 * i], v[2 + 2 * i]);
        k += WK[i] * (f1 + f2);
        if i % 2 == 1 {
            g += WG[i / 2] * (f1 + f2);
        }
    }
    (k * h, ((k - g) * h).abs())
}

/// One Gauss–Kronrod 3–7 panel: the Kronrod value and |Kronrod − Gauss| as error estimate.
fn gauss_kronrod7(f: &dyn Fn(&[f64], &mut [f64]), a: f64, b: f64) -> (f64, f64) {
    const XK: [f64; 3] = [
        0.960_491_268_708_020_3,
        0.774_596_669_241_483_4,
        0.434_243_749_346_802_6,
    ];
    const WK: [f64; 4] = [
        0.104_656_226_026_467_27,
        0.268_488_089_868_333_44,
        0.401_397_414_775_962_2,
        0.450_916_538_658_474_1,
    ];
    const WG: [f64; 2] = [5.0 / 9.0, 8.0 / 9.0];
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let mut t = [c; 7];
    for i in 0..3 {
        t[1 + 2 * i] = c - h * XK[i];
        t[2 + 2 * i] = c + h * XK[i];
    }
    let mut v = [0.0; 7];
    f(&t, &mut v);
    let mut k = WK[3] * v[0];
    for i in 0..3 {
        k += WK[i] * (v[1 + 2 * i] + v[2 + 2 * i]);
    }
    let g = WG[1] * v[0] + WG[0] * (v[3] + v[4]);
    (k * h, ((k - g) * h).abs())
}

/// ∫ f over [a, b] by composite Simpson on `n` (even) intervals: the tests' reference rule,
/// independent of the adaptive quadrature under test.
#[cfg(test)]
pub(crate) fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n)
        .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    (f(a) + f(b) + inner) * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn adaptive_quadrature_reaches_its_tolerance() {
        let f = |x: f64| (-x * x).exp();
        let v = integrate_adaptive(&f, 0.0, 30.0, 1e-12);
        assert!((v - PI.sqrt() / 2.0).abs() < 1e-13);
        // A narrow peak far from the panel midpoints is still found.
        let g = |x: f64| (-((x - 7.3) / 1e-3).powi(2)).exp();
        let v = integrate_adaptive(&g, 0.0, 10.0, 1e-10);
        assert!((v - 1e-3 * PI.sqrt()).abs() < 1e-12, "{v}");
    }

    /// Calls of `f` allowed in one of the tests below: far more than a bounded quadrature
    /// takes, far fewer than 2^40 panels (a test that would hang panics instead).
    const CALLS: usize = 20_000_000;

    fn counted<'a>(
        f: impl Fn(f64) -> f64 + 'a,
        calls: &'a std::cell::Cell<usize>,
    ) -> impl Fn(f64) -> f64 + 'a {
        move |x| {
            calls.set(calls.get() + 1);
            assert!(calls.get() < CALLS, "the quadrature did not stop");
            f(x)
        }
    }

    #[test]
    fn the_short_rule_is_exact_to_degree_eleven_and_adapts() {
        fn nodes(f: &dyn Fn(f64) -> f64) -> impl Fn(&[f64], &mut [f64]) + '_ {
            move |t: &[f64], out: &mut [f64]| {
                for (o, &t) in out.iter_mut().zip(t) {
                    *o = f(t);
                }
            }
        }
        for d in 0..=11 {
            let f = move |x: f64| x.powi(d);
            let (v, _) = gauss_kronrod7(&nodes(&f), -1.0, 1.0);
            let exact = if d % 2 == 0 {
                2.0 / (d as f64 + 1.0)
            } else {
                0.0
            };
            assert!((v - exact).abs() < 1e-15, "degree {d}: {v}");
        }
        let f = |x: f64| (-x * x).exp();
        let v = integrate_panels_by(Rule::Kronrod7, &nodes(&f), &[0.0, 10.0, 30.0], 1e-12);
        assert!((v - PI.sqrt() / 2.0).abs() < 1e-13, "{v}");
    }

    #[test]
    fn an_integrand_that_is_nan_or_infinite_somewhere_ends_at_once() {
        let calls = std::cell::Cell::new(0);
        let nan = counted(
            |x| if (0.4..0.5).contains(&x) { f64::NAN } else { x },
            &calls,
        );
        assert!(integrate_adaptive(&nan, 0.0, 1.0, 1e-10).is_nan());
        assert!(calls.get() < 1000, "{}", calls.get());
        let infinite = counted(|x| if x > 0.7 { f64::INFINITY } else { 1.0 }, &calls);
        assert_eq!(
            integrate_adaptive(&infinite, 0.0, 1.0, 1e-10),
            f64::INFINITY
        );
    }

    #[test]
    fn an_integral_the_splits_do_not_resolve_is_nan() {
        // A jump at every 1e−4: 40 splits each, 4e5 in all, beyond the cap.
        let calls = std::cell::Cell::new(0);
        let comb = counted(|x| ((x * 1e4 + 0.5).floor() % 2.0) * (1.0 + x), &calls);
        assert!(integrate_adaptive(&comb, 0.0, 1.0, 1e-12).is_nan());
        // A few jumps are resolved as before.
        let step = |x: f64| if x < 0.3 { 1.0 } else { 2.0 };
        let v = integrate_adaptive(&step, 0.0, 1.0, 1e-12);
        assert!((v - 1.7).abs() < 1e-9, "{v}");
    }
}
