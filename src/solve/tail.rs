//! Tail probabilities from a PDF tabulated on a grid: P(g > a) ([`tail_probability`], the
//! one meaning of "tail probability" in the crate's API) and P(|g| > a)
//! ([`two_sided_tail_probability`], for the sweep's symmetric `p_gt_<k>rms` columns). One
//! integration rule for both.

/// ∫ p over [u, w] ⊂ [x0, x1], with p interpolated log-linearly between (x0, p0) and
/// (x1, p1): exact for an exponential tail and much closer than a straight line for the
/// Gaussian-like tails of EPC densities, whose log is smooth. Cells with a zero end (the edge
/// of a support) fall back to linear interpolation.
fn cell_integral(x0: f64, x1: f64, p0: f64, p1: f64, u: f64, w: f64) -> f64 {
    if w <= u {
        return 0.0;
    }
    let h = x1 - x0;
    if p0 > 0.0 && p1 > 0.0 {
        let s = (p1 / p0).ln() / h;
        let pu = p0 * (s * (u - x0)).exp();
        let d = w - u;
        if (s * d).abs() < 1e-12 {
            pu * d
        } else {
            pu * (s * d).exp_m1() / s
        }
    } else {
        let at = |x: f64| p0 + (p1 - p0) * (x - x0) / h;
        0.5 * (at(u) + at(w)) * (w - u)
    }
}

/// ∫ p over (lo, hi) and the whole curve's mass, with p log-linear between grid points and
/// the last cell's exponential decay continued to infinity beyond each end of the grid (only
/// where the grid ends in a decaying tail, not at a support edge like |z| = 0: there the
/// continuation is 0). `lo < hi`; either may lie beyond the grid.
fn mass_between(x: &[f64], p: &[f64], lo: f64, hi: f64) -> (f64, f64) {
    let n = x.len();
    let mut mass = 0.0;
    let mut part = 0.0;
    for i in 1..n {
        let (x0, x1, p0, p1) = (x[i - 1], x[i], p[i - 1], p[i]);
        mass += cell_integral(x0, x1, p0, p1, x0, x1);
        part += cell_integral(x0, x1, p0, p1, x0.max(lo), x1.min(hi));
    }
    // ∫ beyond an end of p_end·exp(−λ|x − x_end|) = p_end/λ, λ the last cell's decay rate.
    let peak = p.iter().copied().fold(0.0, f64::max);
    let beyond = |p_in: f64, p_end: f64, h: f64| {
        if p_in > p_end && p_end > 0.0 && p_end < 1e-6 * peak {
            p_end * h / (p_in / p_end).ln()
        } else {
            0.0
        }
    };
    let right = beyond(p[n - 2], p[n - 1], x[n - 1] - x[n - 2]);
    let left = beyond(p[1], p[0], x[1] - x[0]);
    mass += right + left;
    if hi > x[n - 1] {
        part += right;
    }
    if lo < x[0] {
        part += left;
    }
    (part, mass)
}

/// The fraction `part / mass`, normalising by the curve's own mass so that quadrature error
/// largely cancels; `None` for a curve without positive finite mass.
fn fraction((part, mass): (f64, f64)) -> Option<f64> {
    (mass > 0.0 && part.is_finite()).then(|| (part / mass).min(1.0))
}

/// P(g > a) from g's PDF tabulated on the grid `x` (log-linear between grid points, the
/// exponential decay of the last cell continued beyond the grid's ends, where the density is
/// below about 1e−8 of its peak). 1 for `a` below the grid (the whole mass), never more;
/// `None` when `a` lies at or beyond the grid's upper end, where the curve does not resolve
/// the tail, or when the curve has no mass.
pub(crate) fn tail_probability(x: &[f64], p: &[f64], a: f64) -> Option<f64> {
    let n = x.len();
    if n < 2 || p.len() != n || a.is_nan() || x[n - 1] <= a {
        return None;
    }
    fraction(mass_between(x, p, a, f64::INFINITY))
}

/// P(|g| > a) from g's PDF tabulated on the grid `x`, by the rule of [`tail_probability`]:
/// the two tails g > a and g < −a. 1 for a < 0 (every value has |g| > a), never more; `None`
/// when a lies beyond the grid on both sides, or when the curve has no mass.
pub(crate) fn two_sided_tail_probability(x: &[f64], p: &[f64], a: f64) -> Option<f64> {
    let n = x.len();
    if n < 2 || p.len() != n || a.is_nan() {
        return None;
    }
    if a < 0.0 {
        let (_, mass) = mass_between(x, p, 0.0, 0.0);
        return (mass > 0.0 && mass.is_finite()).then_some(1.0);
    }
    if x[n - 1] <= a && x[0] >= -a {
        return None;
    }
    let (upper, mass) = mass_between(x, p, a, f64::INFINITY);
    let (lower, _) = mass_between(x, p, f64::NEG_INFINITY, -a);
    fraction((upper + lower, mass))
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_integral_is_exact_for_an_exponential() {
        let f = |x: f64| 3.0 * (-1.7 * x).exp();
        let got = cell_integral(0.5, 1.5, f(0.5), f(1.5), 0.8, 1.2);
        let exact = 3.0 / 1.7 * ((-1.7f64 * 0.8).exp() - (-1.7f64 * 1.2).exp());
        approx::assert_relative_eq!(got, exact, max_relative = 1e-13);
        // A zero end falls back to the straight line.
        approx::assert_relative_eq!(cell_integral(0.0, 1.0, 0.0, 2.0, 0.0, 1.0), 1.0);
    }

    /// P(|g| > a) = 2 P(g > a) for a standard normal, by Simpson's rule on a fine grid.
    fn normal_tail(a: f64) -> f64 {
        let n = 20_000;
        let b = a + 14.0;
        let h = (b - a) / n as f64;
        let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let mut s = phi(a) + phi(b);
        for i in 1..n {
            s += phi(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        2.0 * s * h / 3.0
    }

    #[test]
    fn tail_of_a_gaussian_curve() {
        // A grid like the study's: 401 points to where the density is 1e-8 of its peak.
        let end = (2.0 * 1e8f64.ln()).sqrt();
        let x: Vec<f64> = (0..401)
            .map(|i| -end + 2.0 * end * i as f64 / 400.0)
            .collect();
        let p: Vec<f64> = x.iter().map(|x| (-0.5 * x * x).exp()).collect();
        for a in [1.0, 2.0, 3.0, 4.0, 5.5] {
            // P(g > a) is one tail, P(g > −a) all but the other one, P(|g| > a) both.
            let upper = tail_probability(&x, &p, a).unwrap();
            approx::assert_relative_eq!(upper, 0.5 * normal_tail(a), max_relative = 2e-3);
            let most = tail_probability(&x, &p, -a).unwrap();
            approx::assert_relative_eq!(most, 1.0 - 0.5 * normal_tail(a), max_relative = 1e-5);
            let both = two_sided_tail_probability(&x, &p, a).unwrap();
            approx::assert_relative_eq!(both, normal_tail(a), max_relative = 2e-3);
        }
        approx::assert_relative_eq!(tail_probability(&x, &p, 0.0).unwrap(), 0.5);
        // Below every value: the whole mass, never more (P(|g| > a) was 2 for a < 0).
        let all = tail_probability(&x, &p, -end - 1.0).unwrap();
        approx::assert_relative_eq!(all, 1.0, max_relative = 1e-15);
        assert!(all <= 1.0);
        for a in [-0.5, -3.0, -end - 1.0] {
            assert_eq!(two_sided_tail_probability(&x, &p, a), Some(1.0));
        }
        let zero = two_sided_tail_probability(&x, &p, 0.0).unwrap();
        approx::assert_relative_eq!(zero, 1.0, max_relative = 1e-14);
        assert!(zero <= 1.0);
        // Beyond the tabulated range the tail is not resolved.
        assert_eq!(tail_probability(&x, &p, end + 0.1), None);
        assert_eq!(two_sided_tail_probability(&x, &p, end + 0.1), None);
        assert_eq!(tail_probability(&x, &p, f64::NAN), None);
    }

    #[test]
    fn one_sided_grid_of_an_absolute_value() {
        // |g| for a standard normal g: density 2φ on [0, end], support edge at 0.
        let end = (2.0 * 1e8f64.ln()).sqrt();
        let x: Vec<f64> = (0..401).map(|i| end * i as f64 / 400.0).collect();
        let p: Vec<f64> = x.iter().map(|x| 2.0 * (-0.5 * x * x).exp()).collect();
        for tail in [tail_probability, two_sided_tail_probability] {
            approx::assert_relative_eq!(
                tail(&x, &p, 3.0).unwrap(),
                normal_tail(3.0),
                max_relative = 2e-3
            );
            // Below the support edge: all of it.
            let all = tail(&x, &p, -1.0).unwrap();
            approx::assert_relative_eq!(all, 1.0, max_relative = 1e-15);
        }
    }
}
