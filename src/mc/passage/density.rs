//! The first-passage-time density of a run's exit times as a histogram on the output times:
//! bin k is (t_k, t_{k+1}], the fraction of paths leaving in it over its width, with the
//! binomial standard error. A path counts as leaving in a bin when its exit time T satisfies
//! t_k < T ≤ t_{k+1}, the complement of R's `T > t`, so the fraction in a bin is exactly
//! R(t_k) − R(t_{k+1}); censored paths (`INFINITY`) never count as exits.

/// The density and its standard errors, one per bin between consecutive times.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct BinnedDensity {
    /// The fraction of paths leaving in each bin over the bin's width.
    pub(super) density: Vec<f64>,
    /// √(p(1 − p)/n) over the width, p the fraction and n the paths.
    pub(super) stderr: Vec<f64>,
}

/// The histogram of `exits` (exit times of the paths that count: `INFINITY` for a censored
/// one, no NaN) on the bins between consecutive `times`. A bin of zero or negative width
/// (times repeated or out of order), or a run without paths, has NaN for both; fewer than
/// two times give no bin.
pub(super) fn binned_density(exits: &[f64], times: &[f64]) -> BinnedDensity {
    let mut left: Vec<f64> = exits.iter().copied().filter(|t| t.is_finite()).collect();
    left.sort_by(f64::total_cmp);
    let n = exits.len() as f64;
    // Paths that left at or before t.
    let by = |t: f64| left.partition_point(|&e| e <= t) as f64;
    let (mut density, mut stderr) = (Vec::new(), Vec::new());
    for pair in times.windows(2) {
        let width = pair[1] - pair[0];
        if !(width > 0.0 && n > 0.0) {
            density.push(f64::NAN);
            stderr.push(f64::NAN);
            continue;
        }
        let p = (by(pair[1]) - by(pair[0])) / n;
        density.push(p / width);
        stderr.push((p * (1.0 - p) / n).sqrt() / width);
    }
    BinnedDensity { density, stderr }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_made_exits_fill_their_bins() {
        // Ten paths: bins (0, 1], (1, 3], (3, 4] hold 3, 4 and 1 exits; an exit at a bin's
        // upper edge belongs to it; two are censored and count only in n.
        let inf = f64::INFINITY;
        let exits = [0.5, 1.0, 0.2, 1.5, 2.0, 3.0, 2.5, 3.5, inf, inf];
        let d = binned_density(&exits, &[0.0, 1.0, 3.0, 4.0]);
        let p = [0.3, 0.4, 0.1];
        let width = [1.0, 2.0, 1.0];
        for k in 0..3 {
            assert_eq!(d.density[k], p[k] / width[k], "bin {k}");
            let se = (p[k] * (1.0 - p[k]) / 10.0).sqrt() / width[k];
            assert!((d.stderr[k] - se).abs() < 1e-15, "bin {k}");
        }
        // The mass inside the bins is what R loses over them: 1 − R(4) = 0.8 here.
        let mass: f64 = d.density.iter().zip(width).map(|(d, w)| d * w).sum();
        assert!((mass - 0.8).abs() < 1e-15);
    }

    #[test]
    fn exits_outside_the_times_and_bad_bins() {
        // Exits before the first time or after the last are in no bin; a repeated time is a
        // bin of no width (NaN), and the bins after it are counted as usual.
        let exits = [0.5, 2.5, 9.0, f64::INFINITY];
        let d = binned_density(&exits, &[1.0, 2.0, 2.0, 3.0]);
        assert_eq!(d.density[0], 0.0);
        assert_eq!(d.stderr[0], 0.0);
        assert!(d.density[1].is_nan() && d.stderr[1].is_nan());
        assert_eq!(d.density[2], 0.25);
        assert!(binned_density(&exits, &[1.0]).density.is_empty());
        let none = binned_density(&[], &[0.0, 1.0]);
        assert!(none.density[0].is_nan() && none.stderr[0].is_nan());
        // Every path censored: a density of zero, not an exit.
        let censored = binned_density(&[f64::INFINITY; 4], &[0.0, 5.0]);
        assert_eq!((censored.density[0], censored.stderr[0]), (0.0, 0.0));
    }
}
