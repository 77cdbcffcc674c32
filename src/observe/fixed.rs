//! Nested Clenshaw–Curtis rules for the line integrals of an analytic density.
//!
//! A density C·exp(Q) (EPC on the plane) is analytic and decays fast along every line, so a
//! fixed polynomial rule over the window converges geometrically and needs far fewer
//! evaluations than adaptive panels. Clenshaw–Curtis rules of N = 16, 32, 64, 128 intervals
//! are nested (the nodes of N are every other node of 2N), so each doubling reuses every value
//! already taken: the doubling test |I_2N − I_N| ≤ rel·|I_2N| is the a-posteriori error check,
//! and I_2N, far more accurate than the I_N the test bounds, is returned. When the finest rule
//! still fails the test the caller is told so (`None`) and integrates adaptively: never a
//! silently worse number.

use std::sync::OnceLock;

/// The numbers of intervals of the nested rules, coarsest first.
const LEVELS: [usize; 4] = [16, 32, 64, 128];
/// The finest rule's number of intervals.
const FINEST: usize = LEVELS[LEVELS.len() - 1];

/// The finest rule's nodes on [−1, 1] and each level's weights there.
struct Rules {
    /// cos(kπ/FINEST), k = 0…FINEST.
    nodes: Vec<f64>,
    /// `weights[l][k]`: the weight of node k·(FINEST/LEVELS[l]) in the rule of level l.
    weights: Vec<Vec<f64>>,
}

/// The rules, computed once.
fn rules() -> &'static Rules {
    static RULES: OnceLock<Rules> = OnceLock::new();
    RULES.get_or_init(|| Rules {
        nodes: (0..=FINEST)
            .map(|k| (std::f64::consts::PI * k as f64 / FINEST as f64).cos())
            .collect(),
        weights: LEVELS.iter().map(|&n| clenshaw_curtis_weights(n)).collect(),
    })
}

/// Computes the rule tables now (a few tens of thousands of cosines, a millisecond), for a
/// caller that can do it beside other work before the first line integral needs them.
pub(crate) fn prepare() {
    rules();
    doubled_nodes();
}

/// The weights of the (n+1)-point Clenshaw–Curtis rule on [−1, 1] (n even), nodes
/// cos(kπ/n): w_k = c_k/n·(1 − Σ_{j=1}^{n/2} b_j cos(2jkπ/n)/(4j² − 1)), c_0 = c_n = 1, other
/// c_k = 2, b_{n/2} = 1, other b_j = 2 (Trefethen, Spectral Methods in MATLAB, `clencurt`).
/// The angle 2jkπ/n is the multiple (2jk mod 2n)·π/n of a period's 2n cosines, computed
/// once: 2n cosines instead of (n + 1)·n/2 (33 thousand for the doubled rule, a millisecond).
fn clenshaw_curtis_weights(n: usize) -> Vec<f64> {
    let period: Vec<f64> = (0..2 * n)
        .map(|m| (std::f64::consts::PI * m as f64 / n as f64).cos())
        .collect();
    let inverse: Vec<f64> = (1..=n / 2)
        .map(|j| {
            let b = if j == n / 2 { 1.0 } else { 2.0 };
            b / (4.0 * (j * j) as f64 - 1.0)
        })
        .collect();
    (0..=n)
        .map(|k| {
            let mut s = 1.0;
            for (j, b) in (1..=n / 2).zip(&inverse) {
                s -= b * period[(2 * j * k) % (2 * n)];
            }
            let c = if k == 0 || k == n { 1.0 } else { 2.0 };
            c * s / n as f64
        })
        .collect()
}

/// The nodes of the finest rule (FINEST intervals) mapped to [`lo`, `hi`], with their weights
/// in that rule and in the rule of half as many intervals (0 at the nodes it lacks): a tensor
/// product of these integrates a smooth function twice at the price of once.
pub(crate) fn finest_pair(lo: f64, hi: f64) -> Vec<(f64, [f64; 2])> {
    let r = rules();
    with_half(
        nodes(lo, hi, FINEST),
        &r.weights[LEVELS.len() - 1],
        &r.weights[LEVELS.len() - 2],
        hi - lo,
    )
}

/// The nodes `x` of a rule on an interval of length `length`, with the rule's weights `fine`
/// (on [−1, 1]) and those of its half `coarse` (0 at the nodes it lacks), scaled to it.
fn with_half(x: Vec<f64>, fine: &[f64], coarse: &[f64], length: f64) -> Vec<(f64, [f64; 2])> {
    let h = 0.5 * length;
    x.into_iter()
        .enumerate()
        .map(|(k, x)| {
            let wc = if k % 2 == 0 { coarse[k / 2] } else { 0.0 };
            (x, [fine[k] * h, wc * h])
        })
        .collect()
}

/// The nodes on [−1, 1] of the rule of twice [`FINEST`] intervals, for the outer integral of
/// a function that the finest rule does not resolve to a check's tolerance:
/// cos(kπ/(2·FINEST)), k = 0…2·FINEST, at even k bit for bit the finest rule's nodes. Computed
/// once.
fn doubled_nodes() -> &'static [f64] {
    static NODES: OnceLock<Vec<f64>> = OnceLock::new();
    NODES.get_or_init(|| {
        (0..=2 * FINEST)
            .map(|k| (std::f64::consts::PI * k as f64 / (2 * FINEST) as f64).cos())
            .collect()
    })
}

/// The weights of the rule of twice [`FINEST`] intervals, computed when first needed (when a
/// check of the finest rule fails): 2·FINEST + 1 weights of FINEST cosines each, the most
/// expensive table here by far.
fn doubled_weights() -> &'static [f64] {
    static WEIGHTS: OnceLock<Vec<f64>> = OnceLock::new();
    WEIGHTS.get_or_init(|| clenshaw_curtis_weights(2 * FINEST))
}

/// The nodes of the Clenshaw–Curtis rule of `n` intervals (`n` = 128 or 256) on [`lo`, `hi`],
/// bit for bit those of [`pair`], without its weights.
///
/// # Panics
/// If `n` is neither.
pub(crate) fn nodes(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let on_unit: &[f64] = if n == FINEST {
        &rules().nodes
    } else {
        assert_eq!(n, 2 * FINEST, "fixed::nodes: {n} intervals");
        doubled_nodes()
    };
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    on_unit.iter().map(|x| c + h * x).collect()
}

/// The nodes of the Clenshaw–Curtis rule of `n` intervals on [`lo`, `hi`] (`n` = 128, as
/// [`finest_pair`], or 256), with their weights in that rule and in the rule of half as many
/// intervals (0 at its odd nodes). The nodes of the 128-interval rule are bit for bit the
/// even nodes of the 256-interval one, so values taken at the first are reused by the second.
///
/// # Panics
/// If `n` is neither.
pub(crate) fn pair(lo: f64, hi: f64, n: usize) -> Vec<(f64, [f64; 2])> {
    if n == FINEST {
        return finest_pair(lo, hi);
    }
    assert_eq!(n, 2 * FINEST, "fixed::pair: {n} intervals");
    with_half(
        nodes(lo, hi, n),
        doubled_weights(),
        &rules().weights[LEVELS.len() - 1],
        hi - lo,
    )
}

/// ∫ f over [`lo`, `hi`] by the nested Clenshaw–Curtis rules, `f` evaluated a batch of nodes
/// at a time (`f(t, out)` sets `out[k]` = f(`t[k]`)): the first rule I_2N whose difference
/// from I_N is at most `rel`·|I_2N| (with an absolute floor of 1e−300, so an integrand that
/// is zero gives zero), `None` if even the finest rule fails that test. `f` must be smooth
/// (analytic) on the closed interval; the caller splits at any point where it is not.
#[cfg(test)]
pub(crate) fn integrate_nested(
    f: &dyn Fn(&[f64], &mut [f64]),
    lo: f64,
    hi: f64,
    rel: f64,
) -> Option<f64> {
    nested_moments(f, lo, hi, rel, [1e-300]).map(|[v]| v)
}

/// The moments ∫ t^j f(t) dt, j = 0…K−1, over [`lo`, `hi`] by the nested rules on one set of
/// values of f: the first level I_2N whose every moment passes the doubling test
/// |I_2N − I_N| ≤ max(`rel`·|I_2N|, `abs[j]`) (an absolute tolerance for a part of a sum whose
/// error matters only relative to the whole), `None` if even the finest rule does not. For
/// K = 1 and `abs` = 1e−300 this is [`integrate_nested`]. Meant for an
/// interval on one side of t = 0, where each moment's integrand has one sign and the
/// relative test means what it says.
pub(crate) fn nested_moments<const K: usize>(
    f: &dyn Fn(&[f64], &mut [f64]),
    lo: f64,
    hi: f64,
    rel: f64,
    abs: [f64; K],
) -> Option<[f64; K]> {
    let r = rules();
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    // Values and nodes at the finest rule's nodes, filled level by level.
    let (mut values, mut nodes) = ([0.0; FINEST + 1], [0.0; FINEST + 1]);
    // A batch of new nodes (at most FINEST/2 + 1: the two coarsest levels' 33 or the odd
    // half of a finer one's), on the stack: a line integral allocates nothing.
    const NEW: usize = FINEST / 2 + 1;
    let (mut index, mut t, mut out) = ([0; NEW], [0.0; NEW], [0.0; NEW]);
    let mut previous: Option<[f64; K]> = None;
    for (level, &n) in LEVELS.iter().enumerate() {
        let stride = FINEST / n;
        // The nodes new at this level: at the first, those of the second level too (the
        // first test compares the two, so both are always needed: one call of `f` for
        // both); at the second none; the odd ones at every finer level. As (first index,
        // step) among the finest rule's nodes.
        let fresh = match level {
            0 => Some((0, FINEST / LEVELS[1])),
            1 => None,
            _ => Some((stride, 2 * stride)),
        };
        if let Some((from, step)) = fresh {
            let mut new = 0;
            for i in (from..=FINEST).step_by(step) {
                index[new] = i;
                t[new] = c + h * r.nodes[i];
                new += 1;
            }
            out[..new].fill(0.0);
            f(&t[..new], &mut out[..new]);
            for ((&i, &v), &x) in index[..new].iter().zip(&out[..new]).zip(&t[..new]) {
                values[i] = v;
                nodes[i] = x;
            }
        }
        let value = weighted_sums(&r.weights[level], stride, &values, &nodes).map(|s| s * h);
        if let Some(p) = previous {
            let passes =
                (0..K).all(|j| (value[j] - p[j]).abs() <= (rel * value[j].abs()).max(abs[j]));
            if passes {
                return Some(value);
            }
        }
        previous = Some(value);
    }
    None
}

/// Σ_k w_k·v_k·t_k^j, j = 0…K−1, over the nodes `k·stride` of the finest rule's `values` and
/// `nodes`, each sum taken in the order of the nodes from −0 (where `Iterator::sum` starts, so
/// that moment 0 is that sum bit for bit).
#[inline(always)]
fn weighted_sums<const K: usize>(
    weights: &[f64],
    stride: usize,
    values: &[f64],
    nodes: &[f64],
) -> [f64; K] {
    let mut sums = [-0.0; K];
    for (k, w) in weights.iter().enumerate() {
        let (wv, t) = (w * values[k * stride], nodes[k * stride]);
        let mut power = 1.0;
        for s in &mut sums {
            *s += wv * power;
            power *= t;
        }
    }
    sums
}

/// ∫ f over [`lo`, `hi`] by the coarsest of the rules (16 intervals, 17 nodes), unchecked:
/// for an integrand known to lie between 0 and a bound M on the interval, whose integral
/// matters only to within M·(hi − lo). The weights are positive, so the value lies in
/// [0, M·(hi − lo)] as the integral does, and its error is at most that.
#[cfg(test)]
pub(crate) fn coarsest(f: &dyn Fn(&[f64], &mut [f64]), lo: f64, hi: f64) -> f64 {
    let [v] = coarsest_moments(f, lo, hi);
    v
}

/// The moments ∫ t^j f(t) dt, j = 0…K−1, by the coarsest rule, unchecked (see
/// [`coarsest`]: for f between 0 and M on an interval on one side of 0, moment j lies
/// between 0 and M·∫|t|^j, as its value by the rule does). For K = 1, [`coarsest`] bit for
/// bit.
pub(crate) fn coarsest_moments<const K: usize>(
    f: &dyn Fn(&[f64], &mut [f64]),
    lo: f64,
    hi: f64,
) -> [f64; K] {
    let r = rules();
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let stride = FINEST / LEVELS[0];
    let t: [f64; LEVELS[0] + 1] = std::array::from_fn(|k| c + h * r.nodes[k * stride]);
    let mut out = [0.0; LEVELS[0] + 1];
    f(&t, &mut out);
    weighted_sums(&r.weights[0], 1, &out, &t).map(|s| s * h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn pointwise(g: impl Fn(f64) -> f64) -> impl Fn(&[f64], &mut [f64]) {
        move |t: &[f64], out: &mut [f64]| {
            for (o, &t) in out.iter_mut().zip(t) {
                *o = g(t);
            }
        }
    }

    #[test]
    fn weights_integrate_polynomials_exactly() {
        // An (n+1)-point Clenshaw–Curtis rule is exact for degree n: ∫_{−1}^{1} x^k = 2/(k+1)
        // for even k.
        for n in LEVELS.into_iter().chain([2 * FINEST]) {
            let w = clenshaw_curtis_weights(n);
            // The weights from a period's cosines are those of the formula with each angle's
            // own cosine, to rounding.
            for (k, &wk) in w.iter().enumerate() {
                let mut s = 1.0;
                for j in 1..=n / 2 {
                    let b = if j == n / 2 { 1.0 } else { 2.0 };
                    let angle = PI * (2 * j * k) as f64 / n as f64;
                    s -= b * angle.cos() / (4.0 * (j * j) as f64 - 1.0);
                }
                let direct = if k == 0 || k == n { 1.0 } else { 2.0 } * s / n as f64;
                // To 1e−15 of the mean weight 2/n (the end weights, about 1/n², carry the
                // rounding of a sum of n/2 terms of order 1).
                assert!((wk - direct).abs() <= 2e-15 / n as f64, "n={n} k={k}");
            }
            for k in (0..=n).step_by(2) {
                let s: f64 = w
                    .iter()
                    .enumerate()
                    .map(|(j, w)| w * (PI * j as f64 / n as f64).cos().powi(k as i32))
                    .sum();
                let exact = 2.0 / (k + 1) as f64;
                assert!((s - exact).abs() < 1e-13, "n={n} k={k}: {s} vs {exact}");
            }
        }
    }

    #[test]
    fn gaussian_half_line_to_the_tolerance() {
        // ∫_0^9 e^{−x²/2} = √(π/2)·erf(9/√2); erf(9/√2) = 1 − 2e−19, below one ulp.
        let f = pointwise(|x: f64| (-0.5 * x * x).exp());
        let v = integrate_nested(&f, 0.0, 9.0, 1e-10).expect("converges");
        let exact = (PI / 2.0).sqrt();
        assert!((v / exact - 1.0).abs() < 1e-13, "{v} vs {exact}");
        // A quartic exponential on a window reaching e^−40: its value by a fine trapezoid rule
        // (spectrally accurate for a function that vanishes to all orders at both ends).
        let g = |x: f64| (-x.powi(4) / 4.0 + 0.3 * x * x - 0.2 * x).exp();
        let (a, b) = (-3.8, 3.8);
        let n = 20_000;
        let step = (b - a) / n as f64;
        let exact: f64 = (0..=n).map(|k| g(a + k as f64 * step)).sum::<f64>() * step;
        let halves = integrate_nested(&pointwise(g), a, 0.0, 1e-10).unwrap()
            + integrate_nested(&pointwise(g), 0.0, b, 1e-10).unwrap();
        assert!((halves / exact - 1.0).abs() < 1e-12, "{halves} vs {exact}");
    }

    /// Every moment is held to the doubling test, not only the integral: e^−10t with a bump
    /// of height 1e−10 at t = 0.95 (width 0.01), which the integral does not see at 1e−10
    /// (2e−11 of it) but the fourth moment does (6e−9 of it), so that the rule that passes
    /// for the integral alone gets the fourth moment wrong. Each moment within the tolerance
    /// of its adaptive value; K = 1 is the scalar rule bit for bit.
    #[test]
    fn every_moment_passes_its_own_test() {
        let g = |t: f64| (-10.0 * t).exp() + 1e-10 * (-((t - 0.95) / 0.01).powi(2)).exp();
        let f = pointwise(g);
        let m = nested_moments::<5>(&f, 0.0, 1.0, 1e-10, [1e-300; 5]).expect("converges");
        for (j, &m) in m.iter().enumerate() {
            let exact = crate::observe::quadrature::integrate_adaptive(
                &|t: f64| t.powi(j as i32) * g(t),
                0.0,
                1.0,
                1e-14,
            );
            assert!(
                (m / exact - 1.0).abs() < 1e-10,
                "moment {j}: {m:e} vs {exact:e}"
            );
        }
        let alone = nested_moments::<1>(&f, 0.0, 1.0, 1e-10, [1e-300]).unwrap();
        assert_eq!(alone, [integrate_nested(&f, 0.0, 1.0, 1e-10).unwrap()]);
        // The coarsest rule's moments, the scalar rule's bits for K = 1.
        assert_eq!(
            coarsest_moments::<1>(&f, 0.0, 1.0),
            [coarsest(&f, 0.0, 1.0)]
        );
    }

    #[test]
    fn the_doubled_rule_extends_the_finest() {
        let (fine, doubled) = (pair(-1.3, 2.9, 128), pair(-1.3, 2.9, 256));
        for (k, (x, w)) in doubled.iter().enumerate() {
            if k % 2 == 0 {
                // The same node bit for bit, and the finest rule's weight as the coarse one.
                assert_eq!(x.to_bits(), fine[k / 2].0.to_bits());
                assert_eq!(w[1], fine[k / 2].1[0]);
            } else {
                assert_eq!(w[1], 0.0);
            }
        }
        // `nodes` gives the same nodes, bit for bit, at both sizes.
        for (n, rule) in [(128, &fine), (256, &doubled)] {
            let bare = nodes(-1.3, 2.9, n);
            assert_eq!(bare.len(), rule.len());
            for (x, (y, _)) in bare.iter().zip(rule.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        // Exact for polynomials up to its degree: ∫ x^200 over [−1, 1] = 2/201.
        let s: f64 = pair(-1.0, 1.0, 256)
            .iter()
            .map(|(x, w)| w[0] * x.powi(200))
            .sum();
        assert!((s - 2.0 / 201.0).abs() < 1e-14, "{s}");
    }

    #[test]
    fn refuses_what_it_cannot_resolve() {
        // A step and a kink: the doubling test fails at every level, and nothing is returned.
        let step = pointwise(|x: f64| if x < 0.3 { 1.0 } else { 0.0 });
        assert_eq!(integrate_nested(&step, 0.0, 1.0, 1e-10), None);
        let kink = pointwise(|x: f64| (x - 0.3).abs());
        assert_eq!(integrate_nested(&kink, 0.0, 1.0, 1e-10), None);
        // Zero integrates to zero.
        assert_eq!(
            integrate_nested(&pointwise(|_| 0.0), 0.0, 1.0, 1e-10),
            Some(0.0)
        );
    }
}
