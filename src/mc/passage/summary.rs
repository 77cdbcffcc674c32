//! The statistics of a first-passage run's exit times: R(t) with 95 % bands, the
//! first-passage-time density as a histogram on the same times, the mean and variance of T
//! with standard errors (or, when paths were censored, a lower bound on the mean and no
//! variance), the time-step bias from the 2·dt paths.

use serde::Serialize;

use super::density::binned_density;

/// The normal quantile of a two-sided 95 % band.
const Z95: f64 = 1.959_963_984_540_054;

/// A Monte Carlo estimate and its standard error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PassageEstimate {
    /// The estimate.
    pub value: f64,
    /// Its standard error.
    pub stderr: f64,
}

/// The time-step bias of the mean (or, when censored, of the mean of min(T, horizon)): the
/// first paths' value at dt minus theirs at 2·dt, the bias of the dt run for a first-order
/// convergence of the located exit time (and an over-estimate for a faster one).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PassageBias {
    /// dt minus 2·dt.
    pub value: f64,
    /// Its standard error (the two runs taken as independent).
    pub stderr: f64,
    /// Paths run again at 2·dt.
    pub paths: u64,
}

/// The result of a [`McPassage`](super::McPassage) run.
#[derive(Clone, Debug, Serialize)]
pub struct McPassageResult {
    /// Paths run at dt (blown-up ones included).
    pub paths: u64,
    /// The time step.
    pub dt: f64,
    /// The horizon.
    pub horizon: f64,
    /// The seed.
    pub seed: u64,
    /// Paths still inside at the horizon.
    pub censored: u64,
    /// `censored / paths`.
    pub censored_fraction: f64,
    /// Paths whose state stopped being finite (left out of every statistic).
    pub blowups: u64,
    /// The mean first-passage time; `None` when some path was censored (see
    /// `mean_lower_bound`).
    pub mean: Option<PassageEstimate>,
    /// The variance of T; `None` when some path was censored.
    pub variance: Option<PassageEstimate>,
    /// The mean of min(T, horizon): the mean itself when nothing was censored, else a lower
    /// bound on it.
    pub mean_lower_bound: PassageEstimate,
    /// The time-step bias.
    pub bias: PassageBias,
    /// The times of R(t).
    pub times: Vec<f64>,
    /// R(t) = P(T > t), the fraction of paths still inside at each time.
    pub reliability: Vec<f64>,
    /// The lower end of R's 95 % band (Wilson's interval).
    pub reliability_lo: Vec<f64>,
    /// The upper end of R's 95 % band.
    pub reliability_hi: Vec<f64>,
    /// The first-passage-time density as a histogram on `times`: bin k is (times\[k\],
    /// times[k+1]], its value the fraction of paths leaving in it over its width (so the
    /// bin's mass is exactly R(times\[k\]) − R(times\[k+1\])); censored paths never count as
    /// exits. One fewer than `times`, none for fewer than two; NaN for a bin of no width.
    pub pdf_binned: Vec<f64>,
    /// The binomial standard errors of `pdf_binned`: √(p(1 − p)/n) over the bin's width.
    pub pdf_binned_stderr: Vec<f64>,
}

/// The exit times of a run (`INFINITY` censored, NaN blown up).
pub(super) struct Run<'a> {
    pub(super) exits: &'a [f64],
    pub(super) coarse: &'a [f64],
    /// The dt run's paths that were run again at 2·dt.
    pub(super) coarse_fine: &'a [f64],
    pub(super) horizon: f64,
    pub(super) dt: f64,
    pub(super) seed: u64,
}

impl McPassageResult {
    pub(super) fn new(run: Run<'_>, times: Vec<f64>) -> McPassageResult {
        let valid: Vec<f64> = run.exits.iter().copied().filter(|t| !t.is_nan()).collect();
        let n = valid.len() as f64;
        let censored = valid.iter().filter(|t| t.is_infinite()).count() as u64;
        let blowups = (run.exits.len() - valid.len()) as u64;
        let capped = |ts: &[f64]| -> Vec<f64> {
            ts.iter()
                .filter(|t| !t.is_nan())
                .map(|t| t.min(run.horizon))
                .collect()
        };
        let lower = mean_se(&capped(run.exits));
        let (mean, variance) = if censored == 0 && valid.len() > 1 {
            (Some(lower), Some(variance_se(&valid)))
        } else {
            (None, None)
        };
        let (a, b) = (
            mean_se(&capped(run.coarse_fine)),
            mean_se(&capped(run.coarse)),
        );
        let bias = PassageBias {
            value: a.value - b.value,
            stderr: a.stderr.hypot(b.stderr),
            paths: run.coarse.len() as u64,
        };
        let mut reliability = Vec::with_capacity(times.len());
        let (mut lo, mut hi) = (Vec::new(), Vec::new());
        for &t in &times {
            let alive = valid.iter().filter(|&&e| e > t).count() as f64;
            let (l, h) = wilson(alive, n, Z95);
            reliability.push(if n > 0.0 { alive / n } else { f64::NAN });
            lo.push(l);
            hi.push(h);
        }
        let binned = binned_density(&valid, &times);
        McPassageResult {
            paths: run.exits.len() as u64,
            dt: run.dt,
            horizon: run.horizon,
            seed: run.seed,
            censored,
            censored_fraction: censored as f64 / n,
            blowups,
            mean,
            variance,
            mean_lower_bound: lower,
            bias,
            times,
            reliability,
            reliability_lo: lo,
            reliability_hi: hi,
            pdf_binned: binned.density,
            pdf_binned_stderr: binned.stderr,
        }
    }
}

/// The sample mean and its standard error.
fn mean_se(x: &[f64]) -> PassageEstimate {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    PassageEstimate {
        value: m,
        stderr: (var / n).sqrt(),
    }
}

/// The unbiased sample variance and its standard error, √((m₄ − s⁴)/n) to leading order.
fn variance_se(x: &[f64]) -> PassageEstimate {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let s2 = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    let m4 = x.iter().map(|v| (v - m).powi(4)).sum::<f64>() / n;
    PassageEstimate {
        value: s2,
        stderr: ((m4 - s2 * s2).max(0.0) / n).sqrt(),
    }
}

impl McPassageResult {
    /// Monte Carlo's standard error of R at output time `k` on the side of `value`: the
    /// distance from R to the end of Wilson's score interval at `z` standard errors on that
    /// side, over `z`. Near 0 or 1 (a few paths left, or a few gone) the binomial law is
    /// skewed: the interval reaches further on the side away from the boundary, and a
    /// symmetric error would flag a value that the counts do not contradict.
    ///
    /// ```
    /// # use fpsolve::model::load_model;
    /// # use fpsolve::mc::McPassage;
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let model = load_model(&path)?.with_safe("abs(z) < 1.2")?;
    /// # let bound = model.bind(&[])?;
    /// # let safe = model.safe().unwrap().bind(&bound)?;
    /// let r = McPassage::new(&bound, &safe).paths(256).dt(0.02).horizon(200.0)
    ///     .times(vec![0.0, 100.0]).run()?;
    /// // No path is left at t = 100: R = 0, and only a value above it has an error.
    /// assert_eq!(r.reliability[1], 0.0);
    /// assert_eq!(r.reliability_stderr_toward(1, -1.0, 3.0), 0.0);
    /// assert!(r.reliability_stderr_toward(1, 0.01, 3.0) > 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn reliability_stderr_toward(&self, k: usize, value: f64, z: f64) -> f64 {
        let n = (self.paths - self.blowups) as f64;
        let (lo, hi) = wilson(self.reliability[k] * n, n, z);
        if value >= self.reliability[k] {
            (hi - self.reliability[k]) / z
        } else {
            (self.reliability[k] - lo) / z
        }
    }
}

/// Wilson's score interval at `z` standard errors for `k` successes in `n` trials (never
/// outside [0, 1], not empty at 0 or n).
fn wilson(k: f64, n: f64, z: f64) -> (f64, f64) {
    if n <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let p = k / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / (1.0 + z2 / n);
    // At k = 0 (k = n) the lower (upper) end is 0 (1) exactly; the formula leaves rounding.
    let lo = if k <= 0.0 {
        0.0
    } else {
        (centre - half).max(0.0)
    };
    let hi = if k >= n {
        1.0
    } else {
        (centre + half).min(1.0)
    };
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run to the horizon 10 at dt 0.1 whose bias run gave the same `exits`.
    fn run_of(exits: &[f64]) -> Run<'_> {
        Run {
            exits,
            coarse: exits,
            coarse_fine: exits,
            horizon: 10.0,
            dt: 0.1,
            seed: 1,
        }
    }

    #[test]
    fn wilson_brackets_the_fraction_and_stays_in_the_unit_interval() {
        let (l, h) = wilson(0.0, 100.0, Z95);
        assert_eq!(l, 0.0);
        assert!(h > 0.03 && h < 0.04, "{h}");
        let (l, h) = wilson(50.0, 100.0, Z95);
        assert!(
            (l - 0.4038).abs() < 1e-3 && (h - 0.5962).abs() < 1e-3,
            "{l} {h}"
        );
    }

    #[test]
    fn the_error_of_a_tail_count_is_on_the_side_asked() {
        // One path of 4000 still inside at t = 2 (R = 2.5e-4): 6.7 expected from the grid's
        // 1.68e-3 is a p = 0.019 two-sided draw, not a 3-sigma one; the symmetric 95 %
        // band's error (3.5e-4) put it 3.2 errors away.
        let mut exits = vec![1.0; 3999];
        exits.push(f64::INFINITY);
        let run = run_of(&exits);
        let r = McPassageResult::new(run, vec![0.0, 2.0]);
        assert_eq!(r.reliability[1], 2.5e-4);
        let up = r.reliability_stderr_toward(1, 1.68e-3, 3.0);
        let down = r.reliability_stderr_toward(1, 0.0, 3.0);
        assert!(up > 4e-4 && down < 1e-4, "{up} {down}");
        // 3 of these errors above R is the end of Wilson's interval at 3: 2.72e-3.
        assert!((r.reliability[1] + 3.0 * up - 2.72e-3).abs() < 1e-5);
        // All paths inside at t = 0: no error above R = 1.
        assert_eq!(r.reliability_stderr_toward(0, 1.0, 3.0), 0.0);
    }

    #[test]
    fn a_censored_path_turns_the_mean_into_a_lower_bound() {
        let exits = [1.0, 2.0, 3.0, f64::INFINITY];
        let run = run_of(&exits);
        let r = McPassageResult::new(run, vec![0.0, 1.5, 10.0]);
        assert!(r.mean.is_none() && r.variance.is_none());
        assert_eq!(r.censored, 1);
        assert_eq!(r.mean_lower_bound.value, 4.0);
        assert_eq!(r.reliability, vec![1.0, 0.75, 0.25]);
        // Exit 1 in (0, 1.5], exits 2 and 3 in (1.5, 10]; the censored path in neither.
        assert_eq!(r.pdf_binned, vec![0.25 / 1.5, 0.5 / 8.5]);
        assert_eq!(r.pdf_binned_stderr.len(), 2);
        assert_eq!(r.bias.value, 0.0);
    }

    #[test]
    fn exit_times_without_censoring_give_mean_and_variance() {
        let exits = [1.0, 2.0, 3.0, 4.0, f64::NAN];
        let run = Run {
            coarse: &exits[..2],
            coarse_fine: &exits[..2],
            ..run_of(&exits)
        };
        let r = McPassageResult::new(run, vec![2.5]);
        let m = r.mean.unwrap();
        assert_eq!((m.value, r.blowups), (2.5, 1));
        assert!((m.stderr - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-12);
        assert!((r.variance.unwrap().value - 5.0 / 3.0).abs() < 1e-12);
        assert_eq!(r.reliability, vec![0.5]);
    }
}
