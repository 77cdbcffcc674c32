//! Moments with standard errors from per-batch power sums: each batch's sums are taken about
//! its own mean (so that a variance far below the squared mean loses no digits), moved to a
//! common centre exactly by the binomial theorem, pooled into groups of batches, and the
//! standard errors read from the delete-one-group jackknife.

use crate::stats::Estimate;

/// Groups of batches the jackknife deletes one at a time (fewer when there are fewer
/// batches).
pub(super) const GROUPS: usize = 32;

/// Power sums of q − `shift` over the `n` finite samples of one batch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct PowerSums {
    n: f64,
    shift: f64,
    s: [f64; 4],
}

impl PowerSums {
    /// The sums of the finite `values` about their mean.
    pub(super) fn of(values: &[f64]) -> PowerSums {
        let finite = || values.iter().copied().filter(|q| q.is_finite());
        let n = finite().count() as f64;
        if n == 0.0 {
            return PowerSums::default();
        }
        let shift = finite().sum::<f64>() / n;
        let mut s = [0.0; 4];
        for q in finite() {
            let d = q - shift;
            let mut dk = d;
            for sk in s.iter_mut() {
                *sk += dk;
                dk *= d;
            }
        }
        PowerSums { n, shift, s }
    }

    /// The sums of both samples together, about their common mean (a trajectory's values
    /// at one phase over several periods are one batch's samples).
    pub(super) fn merge(&self, other: &PowerSums) -> PowerSums {
        let n = self.n + other.n;
        if n == 0.0 {
            return PowerSums::default();
        }
        let shift = (self.n * self.shift + other.n * other.shift) / n;
        let (a, b) = (self.about(shift), other.about(shift));
        PowerSums {
            n,
            shift,
            s: std::array::from_fn(|k| a[k + 1] + b[k + 1]),
        }
    }

    /// [n, Σ(q − c), …, Σ(q − c)⁴].
    fn about(&self, c: f64) -> [f64; 5] {
        let delta = self.shift - c;
        let sums = [self.n, self.s[0], self.s[1], self.s[2], self.s[3]];
        let mut out = [0.0; 5];
        // Σ(d + δ)^k = Σ_j C(k, j) δ^(k−j) Σ d^j.
        const BINOMIAL: [[f64; 5]; 5] = [
            [1.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0, 0.0, 0.0],
            [1.0, 2.0, 1.0, 0.0, 0.0],
            [1.0, 3.0, 3.0, 1.0, 0.0],
            [1.0, 4.0, 6.0, 4.0, 1.0],
        ];
        for (k, o) in out.iter_mut().enumerate() {
            *o = (0..=k)
                .map(|j| BINOMIAL[k][j] * delta.powi((k - j) as i32) * sums[j])
                .sum();
        }
        out
    }
}

/// Mean, variance (unbiased) and kurtosis from sums about `c`; NaN where undefined (no
/// samples; the kurtosis of a zero variance, as at a point start).
fn statistics(t: &[f64; 5], c: f64) -> [f64; 3] {
    let n = t[0];
    if n < 2.0 {
        return [f64::NAN; 3];
    }
    let [a1, a2, a3, a4] = [t[1] / n, t[2] / n, t[3] / n, t[4] / n];
    let m2 = a2 - a1 * a1;
    let c4 = a4 - 4.0 * a1 * a3 + 6.0 * a1 * a1 * a2 - 3.0 * a1.powi(4);
    let kurtosis = if m2 > 0.0 { c4 / (m2 * m2) } else { f64::NAN };
    [c + a1, m2 * n / (n - 1.0), kurtosis]
}

/// Sums of each group of batches (batch k in group k mod G) about `c`.
fn grouped(batches: &[PowerSums], c: f64, groups: usize) -> Vec<[f64; 5]> {
    let mut g = vec![[0.0; 5]; groups];
    for (k, b) in batches.iter().enumerate() {
        let t = b.about(c);
        g[k % groups].iter_mut().zip(t).for_each(|(a, t)| *a += t);
    }
    g
}

fn total(groups: &[[f64; 5]]) -> [f64; 5] {
    let mut t = [0.0; 5];
    for g in groups {
        t.iter_mut().zip(g).for_each(|(a, b)| *a += b);
    }
    t
}

fn minus(a: &[f64; 5], b: &[f64; 5]) -> [f64; 5] {
    std::array::from_fn(|k| a[k] - b[k])
}

/// The delete-one-group jackknife's standard error of `theta` over `groups` deletions.
fn jackknife(deleted: &[[f64; 3]]) -> [f64; 3] {
    let g = deleted.len() as f64;
    std::array::from_fn(|k| {
        let mean = deleted.iter().map(|d| d[k]).sum::<f64>() / g;
        let ss: f64 = deleted.iter().map(|d| (d[k] - mean).powi(2)).sum();
        ((g - 1.0) / g * ss).sqrt()
    })
}

/// The common centre of `batches`: the sample-weighted mean of their shifts.
fn centre(batches: &[PowerSums]) -> f64 {
    let n: f64 = batches.iter().map(|b| b.n).sum();
    if n == 0.0 {
        return 0.0;
    }
    batches.iter().map(|b| b.n * b.shift).sum::<f64>() / n
}

/// Mean, variance and kurtosis of the pooled batches with their jackknife standard errors.
pub(super) fn estimate(batches: &[PowerSums]) -> [Estimate; 3] {
    let c = centre(batches);
    let groups = GROUPS.min(batches.len()).max(1);
    let g = grouped(batches, c, groups);
    let all = total(&g);
    let value = statistics(&all, c);
    let deleted: Vec<[f64; 3]> = g.iter().map(|gi| statistics(&minus(&all, gi), c)).collect();
    let se = jackknife(&deleted);
    std::array::from_fn(|k| Estimate {
        value: value[k],
        stderr: se[k],
    })
}

/// The time-step bias S_dt − S_exact ≈ (S_2dt − S_dt)/(2ᵖ − 1) of mean, variance and
/// kurtosis from the same batches run at dt (`fine`) and 2·dt (`coarse`), the standard error
/// from the jackknife over groups of pairs (the pairing cancels most of the sampling noise).
pub(super) fn bias(fine: &[PowerSums], coarse: &[PowerSums], order: u32) -> [Estimate; 3] {
    let scale = 1.0 / (2f64.powi(order as i32) - 1.0);
    let c = centre(fine);
    let groups = GROUPS.min(fine.len()).max(1);
    let (gf, gc) = (grouped(fine, c, groups), grouped(coarse, c, groups));
    let (tf, tc) = (total(&gf), total(&gc));
    let diff = |f: &[f64; 5], co: &[f64; 5]| -> [f64; 3] {
        let (a, b) = (statistics(f, c), statistics(co, c));
        std::array::from_fn(|k| (b[k] - a[k]) * scale)
    };
    let value = diff(&tf, &tc);
    let deleted: Vec<[f64; 3]> = gf
        .iter()
        .zip(&gc)
        .map(|(f, co)| diff(&minus(&tf, f), &minus(&tc, co)))
        .collect();
    let se = jackknife(&deleted);
    std::array::from_fn(|k| Estimate {
        value: value[k],
        stderr: se[k],
    })
}

/// A state's mean, variance and kurtosis at one output from the per-batch sums of a pass
/// at dt (`fine`), with their time-step bias when the first batches ran again at 2·dt
/// (`coarse`): output `k`, state `a`, the scheme's weak `order`.
pub(super) fn moments(
    fine: &[Vec<[PowerSums; 2]>],
    coarse: Option<&[Vec<[PowerSums; 2]>]>,
    k: usize,
    a: usize,
    order: u32,
) -> ([Estimate; 3], Option<[Estimate; 3]>) {
    let all: Vec<PowerSums> = fine.iter().map(|b| b[k][a]).collect();
    let bias = coarse.map(|c| {
        let co: Vec<PowerSums> = c.iter().map(|b| b[k][a]).collect();
        bias(&all[..co.len()], &co, order)
    });
    (estimate(&all), bias)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pooling batches about a common centre gives the moments of all samples at once, and
    /// the standard error of the mean is about sd/√n.
    #[test]
    fn pooled_batches_are_the_whole_sample() {
        // A deterministic sample with mean 1e3 (far above its spread: the shift matters).
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = || {
            // SplitMix64.
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / 9_007_199_254_740_992.0
        };
        let all: Vec<f64> = (0..4096).map(|_| 1e3 + uniform() - 0.5).collect();
        let batches: Vec<PowerSums> = all.chunks(64).map(PowerSums::of).collect();
        let [mean, var, kurt] = estimate(&batches);
        let n = all.len() as f64;
        let m = all.iter().sum::<f64>() / n;
        let v = all.iter().map(|q| (q - m).powi(2)).sum::<f64>() / (n - 1.0);
        assert!((mean.value - m).abs() < 1e-12 * m);
        assert!((var.value / v - 1.0).abs() < 1e-9, "{} {v}", var.value);
        // A uniform law: kurtosis 1.8.
        assert!((kurt.value - 1.8).abs() < 0.1, "{}", kurt.value);
        let se = (v / n).sqrt();
        assert!(
            mean.stderr > 0.2 * se && mean.stderr < 5.0 * se,
            "{} {se}",
            mean.stderr
        );
        // Merging the batches one by one is the whole sample too.
        let merged = batches[1..].iter().fold(batches[0], |acc, b| acc.merge(b));
        let whole = PowerSums::of(&all);
        assert_eq!(merged.n, whole.n);
        assert!((merged.shift - whole.shift).abs() < 1e-12 * m);
        for k in 1..4 {
            let (a, b) = (merged.s[k], whole.s[k]);
            // Σd³ of a symmetric sample is near 0: judged on the scale of Σd⁴.
            assert!(
                (a - b).abs() < 1e-9 * whole.s[3].max(b.abs()),
                "{k}: {a} {b}"
            );
        }
        // The same batches at both steps: no bias, exactly.
        let b = bias(&batches, &batches, 1);
        assert!(b.iter().all(|e| e.value == 0.0 && e.stderr == 0.0), "{b:?}");
    }
}
