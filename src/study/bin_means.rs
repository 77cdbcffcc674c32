//! A density averaged over histogram bins, as a histogram measures it: 4-point
//! Gauss–Legendre on a bin where the density is smooth; where it is infinite at a value in
//! or next to the bin (a log singularity at a saddle value of the map, u^(−1/2) at a
//! degenerate one, e.g. v² at 0), a graded mesh towards that value and the last sliver next
//! to it from the local power law.

use crate::mc::Grid;
use crate::observe::quadrature::integrate_panels_batch;
use crate::observe::ObservableDensity;

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points (exact for cubics): enough for a bin
/// average of a smooth density sampled by a histogram of ≥ 50 bins.
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// The sliver next to a singular value left to the power law, as a fraction of the grid's
/// span: far above the distance (1e−12 of the map's spread) within which the density
/// reports +∞, small enough that the law's next term is below 1e−10 of a bin's mass.
const SLIVER: f64 = 1e-8;

/// Relative tolerance of the graded quadrature of a singular bin.
const REL_TOL: f64 = 1e-11;
/// The same for a piecewise density (the grid's interpolant), whose PDF of a map kinks
/// wherever the level set meets a line of its pieces: a tighter tolerance would only chase
/// those kinks, far below the density's own error (1e−6 of it or more).
const PIECEWISE_REL_TOL: f64 = 1e-8;

/// Bins within this many bin widths of a singular value are integrated adaptively: the
/// 4-point rule's error on a bin k widths away from u^(−1/2) is about (4k + 2)^(−8) of its
/// mass (2e−10 at 4 widths, 2e−12 at 8), above the 1e−10 a comparison needs.
const NEAR_BINS: f64 = 16.0;
/// The same for a piecewise density: 2 widths away the 4-point rule's error, 1e−7 of the
/// bin's mass, is below the density's own.
const PIECEWISE_NEAR_BINS: f64 = 2.0;

/// The density averaged over each bin of `grid`.
pub(super) fn bin_means(density: &ObservableDensity, grid: &Grid) -> Vec<f64> {
    let (rel, near) = if density.piecewise() {
        (PIECEWISE_REL_TOL, PIECEWISE_NEAR_BINS)
    } else {
        (REL_TOL, NEAR_BINS)
    };
    bin_means_with(
        &|x: &[f64]| density.pdf(x),
        &density.singular_values(),
        grid,
        (rel, near),
    )
}

/// [`bin_means`] of the density `pdf` (evaluated at many points at a time), infinite at the
/// values `singular`, singular bins to relative tolerance `rel`.
fn bin_means_with(
    pdf: &dyn Fn(&[f64]) -> Vec<f64>,
    singular: &[f64],
    grid: &Grid,
    (rel, near_bins): (f64, f64),
) -> Vec<f64> {
    let (lo, w) = (grid.lo, grid.width());
    let edge = |b: usize| lo + b as f64 * w;
    let near = |b: usize| {
        singular
            .iter()
            .any(|&c| c >= edge(b) - near_bins * w && c <= edge(b + 1) + near_bins * w)
    };
    let smooth: Vec<usize> = (0..grid.bins).filter(|&b| !near(b)).collect();
    let nodes: Vec<f64> = smooth
        .iter()
        .flat_map(|&b| {
            let c = lo + (b as f64 + 0.5) * w;
            GL4.iter().map(move |(t, _)| c + 0.5 * w * t)
        })
        .collect();
    let values = pdf(&nodes);
    let mut means = vec![0.0; grid.bins];
    for (&b, chunk) in smooth.iter().zip(values.chunks(GL4.len())) {
        means[b] = chunk
            .iter()
            .zip(&GL4)
            .map(|(v, (_, wt))| v * wt)
            .sum::<f64>()
            / 2.0;
    }
    let sliver = SLIVER * (grid.hi - grid.lo);
    for b in (0..grid.bins).filter(|&b| near(b)) {
        let (a, z) = (edge(b), edge(b + 1));
        means[b] = singular_integral(pdf, [a, z], singular, sliver, rel) / w;
    }
    means
}

/// ∫ pdf over `[a, b]`, the density infinite at the values `singular` (those within a
/// sliver of the interval taken to be on it). The interval is cut at each singular value
/// inside it and meshed towards each singular value within its own width (in it or beside
/// it) in panels that double in width from `sliver` (on each, the singularity is a panel's
/// width or more away: a polynomial rule converges fast), integrated by adaptive
/// Gauss–Kronrod; the sliver next to a singular value on the interval is ∫₀^d A·t^α dt with
/// A and α from the density at d and d/16 from it.
fn singular_integral(
    pdf: &dyn Fn(&[f64]) -> Vec<f64>,
    [a, b]: [f64; 2],
    singular: &[f64],
    sliver: f64,
    rel: f64,
) -> f64 {
    let w = b - a;
    let close: Vec<f64> = singular
        .iter()
        .copied()
        .filter(|&c| c >= a - w && c <= b + w)
        .collect();
    let on: Vec<f64> = close
        .iter()
        .filter(|&&c| c >= a - sliver && c <= b + sliver)
        .map(|c| c.clamp(a, b))
        .collect();
    let mut edges = vec![a, b];
    for &c in &close {
        let s = c.clamp(a, b);
        edges.push(s);
        let mut d = sliver;
        while d < w {
            edges.extend([s - d, s + d]);
            d *= 2.0;
        }
    }
    edges.retain(|&x| (a..=b).contains(&x));
    edges.sort_by(f64::total_cmp);
    edges.dedup_by(|x, y| (*x - *y).abs() <= 1e-3 * sliver);
    let batch = |t: &[f64], out: &mut [f64]| out.copy_from_slice(&pdf(t));
    // A panel one of whose ends is a singular value on the interval is the power law's.
    let is_sliver =
        |p: &[f64]| on.iter().any(|&s| p[0] == s || p[1] == s) && p[1] - p[0] <= 1.001 * sliver;
    let flush = |run: &mut Vec<f64>, total: &mut f64| {
        if run.len() >= 2 {
            *total += integrate_panels_batch(&batch, run, rel);
        }
        run.clear();
    };
    let mut total = 0.0;
    let mut run: Vec<f64> = Vec::new();
    for p in edges.windows(2) {
        if is_sliver(p) {
            flush(&mut run, &mut total);
            let (s, inward) = if on.contains(&p[0]) {
                (p[0], 1.0)
            } else {
                (p[1], -1.0)
            };
            total += power_law_sliver(pdf, s, inward * (p[1] - p[0]));
        } else {
            if run.last() != Some(&p[0]) {
                flush(&mut run, &mut total);
                run.push(p[0]);
            }
            run.push(p[1]);
        }
    }
    flush(&mut run, &mut total);
    total
}

/// ∫ over the sliver between the singular value `s` and `s + d` (d < 0: to the left) of
/// the density taken as A·t^α + B in the distance t to `s`, fitted to its values at |d|,
/// |d|/16 and |d|/256: exact for an inverse power (α = −1/2 for v² at 0) and, in the limit
/// α → 0 with A·α fixed, for a log singularity −A′·ln t + B (a saddle value).
fn power_law_sliver(pdf: &dyn Fn(&[f64]) -> Vec<f64>, s: f64, d: f64) -> f64 {
    let p = pdf(&[s + d, s + d / 16.0, s + d / 256.0]);
    let width = d.abs();
    if !p.iter().all(|v| v.is_finite() && *v >= 0.0) {
        return if p[0].is_finite() {
            p[0].max(0.0) * width
        } else {
            0.0
        };
    }
    let (d1, d2) = (p[1] - p[0], p[2] - p[1]);
    let ln16 = 16f64.ln();
    if d1 == 0.0 || d2 / d1 <= 0.0 {
        // Flat or not monotone towards s: no singular term to fit.
        return p[0] * width;
    }
    // d2/d1 = 16^(−α); α ≤ −1 would not be integrable: no density of a map behaves so.
    let alpha = (-(d2 / d1).ln() / ln16).max(-0.99);
    // ∫₀^w (A t^α + B) dt = w·(p(w) − A·w^α·α/(α + 1)), with A·w^α = d1/(16^(−α) − 1).
    let singular = if alpha.abs() < 1e-9 {
        -d1 / ln16
    } else {
        d1 * alpha / ((16f64.powf(-alpha) - 1.0) * (alpha + 1.0))
    };
    width * (p[0] - singular)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::integrate_adaptive;
    use std::f64::consts::PI;

    /// χ²₁ scaled: the density of u = v² for v ~ N(0, s²).
    fn chi2(s: f64) -> impl Fn(&[f64]) -> Vec<f64> {
        move |u: &[f64]| {
            u.iter()
                .map(|&u| {
                    if u <= 0.0 {
                        if u == 0.0 {
                            f64::INFINITY
                        } else {
                            0.0
                        }
                    } else {
                        (-u / (2.0 * s * s)).exp() / (s * (2.0 * PI * u).sqrt())
                    }
                })
                .collect()
        }
    }

    /// P(a < v² < b) = 2 ∫_{√a}^{√b} φ_s: a smooth integral.
    fn chi2_mass(s: f64, a: f64, b: f64) -> f64 {
        if b <= 0.0 {
            return 0.0;
        }
        let phi = |t: f64| (-t * t / (2.0 * s * s)).exp() / (s * (2.0 * PI).sqrt());
        2.0 * integrate_adaptive(&phi, a.max(0.0).sqrt(), b.sqrt(), 1e-12)
    }

    #[test]
    fn bin_means_of_chi_squared_are_its_cdf_differences() {
        let s = 1.3;
        // The grid starts on the singular value (as the report grid of v² does), then one
        // that starts before it and one that starts a little after it.
        for (lo, hi) in [(0.0, 30.0), (-0.7, 25.0), (0.01, 20.0)] {
            let grid = Grid::new(lo, hi, 100).unwrap();
            let means = bin_means_with(&chi2(s), &[0.0], &grid, (REL_TOL, NEAR_BINS));
            for (b, m) in means.iter().enumerate() {
                let (a, z) = (
                    lo + b as f64 * grid.width(),
                    lo + (b + 1) as f64 * grid.width(),
                );
                let exact = chi2_mass(s, a, z) / grid.width();
                assert!(
                    (m - exact).abs() <= 1e-10 * exact.max(1e-3),
                    "grid [{lo}, {hi}] bin {b}: {m} against {exact}"
                );
            }
        }
    }

    /// A log singularity: −ln|u − c|·e^{−(u − c)²/2}, normalised or not (bin means of the
    /// function itself), against adaptive quadrature of the bin with the singular point as an
    /// edge (the substitution t = |u − c|² that makes −ln t smooth enough).
    #[test]
    fn bin_means_across_a_log_singularity_are_exact() {
        let c = 0.37;
        let f = move |u: f64| -((u - c).abs()).ln() * (-(u - c) * (u - c) / 2.0).exp();
        let pdf = move |u: &[f64]| -> Vec<f64> {
            u.iter()
                .map(|&u| if u == c { f64::INFINITY } else { f(u) })
                .collect()
        };
        // ∫ over [c, c + d] (or [c − d, c]: f is even about c) of f by t = √|u − c|:
        // −ln(t²)·e^{−t⁴/2}·2t, a continuous integrand.
        let side = move |d: f64| {
            let g = |t: f64| -(t * t).ln() * (-(t.powi(4)) / 2.0).exp() * 2.0 * t;
            integrate_adaptive(&g, 0.0, d.abs().sqrt(), 1e-12)
        };
        let exact = |a: f64, b: f64| -> f64 {
            if a >= c {
                side(b - c) - side(a - c)
            } else if b <= c {
                side(c - a) - side(c - b)
            } else {
                side(c - a) + side(b - c)
            }
        };
        let grid = Grid::new(-2.0, 3.0, 50).unwrap();
        let means = bin_means_with(&pdf, &[c], &grid, (REL_TOL, NEAR_BINS));
        for (b, m) in means.iter().enumerate() {
            let (a, z) = (
                -2.0 + b as f64 * grid.width(),
                -2.0 + (b + 1) as f64 * grid.width(),
            );
            let want = exact(a, z) / grid.width();
            assert!(
                (m - want).abs() <= 1e-10 * want.abs().max(1e-2),
                "bin {b} [{a}, {z}]: {m} against {want}"
            );
        }
    }

    /// Bins away from every singular value keep the 4-point rule (one batch, bit for bit).
    #[test]
    fn smooth_bins_keep_the_four_point_rule() {
        let gauss = |u: &[f64]| -> Vec<f64> { u.iter().map(|&u| (-u * u / 2.0).exp()).collect() };
        let grid = Grid::new(-5.0, 5.0, 40).unwrap();
        let plain = bin_means_with(&gauss, &[], &grid, (REL_TOL, NEAR_BINS));
        let with_far = bin_means_with(&gauss, &[100.0], &grid, (REL_TOL, NEAR_BINS));
        assert_eq!(plain, with_far);
        let w = grid.width();
        let c = -5.0 + 0.5 * w;
        let gl4: f64 = GL4
            .iter()
            .map(|(t, wt)| wt * (-(c + 0.5 * w * t).powi(2) / 2.0).exp())
            .sum::<f64>()
            / 2.0;
        assert_eq!(plain[0], gl4);
    }
}
