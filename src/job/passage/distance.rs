//! The distances between the grid's and Monte Carlo's first-passage numbers: for the mean
//! time from the start and for R(t) at each output time, |grid − MC| divided by the sum of
//! Monte Carlo's standard error and the grid's stated error, the measure of the closing
//! note's tables: above 1 the two are apart by more than their combined one-σ bars. A number
//! is flagged (the run warns) when |grid − MC| exceeds [`DISAGREE_SE`] of Monte Carlo's
//! standard errors plus the grid's stated error, as the main job flags two methods further
//! apart than their tolerance plus the reference's stated error: the statistical error
//! scaled to a confidence, the grid's error (a bound already, with its safety factor) once.
//! R(t)'s standard error is taken on the grid's side from Wilson's score interval at
//! [`DISAGREE_SE`] ([`McPassageResult::reliability_stderr_toward`]): with a few paths left
//! in the tail the binomial law is skewed, and R is flagged exactly when the grid's value
//! less its error lies outside that interval.

use serde::Serialize;

use super::DISAGREE_SE;
use crate::grid::PassageSolution;
use crate::mc::McPassageResult;

/// What a distance compares.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "number", rename_all = "snake_case")]
pub enum Compared {
    /// The mean first-passage time from the start.
    MeanAtStart,
    /// The grid's mean first-passage time from the start against Monte Carlo's lower bound
    /// on it, the mean of min(T, horizon) when paths were censored: one-sided, only a grid
    /// mean below the bound is a gap.
    MeanLowerBound,
    /// R(t) at an output time.
    Reliability {
        /// The time.
        t: f64,
    },
}

impl std::fmt::Display for Compared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Compared::MeanAtStart => write!(f, "mean first-passage time from the start"),
            Compared::MeanLowerBound => write!(
                f,
                "mean first-passage time from the start against Monte Carlo's lower bound"
            ),
            Compared::Reliability { t } => {
                write!(f, "R(t) at t = {}", crate::report::short_number(*t))
            }
        }
    }
}

/// One number by both methods and their distance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MethodDistance {
    /// The number.
    #[serde(flatten)]
    pub compared: Compared,
    /// The grid's value.
    pub grid: f64,
    /// The grid's stated error (0 without an estimate).
    pub grid_error: f64,
    /// Monte Carlo's value.
    pub mc: f64,
    /// Monte Carlo's standard error.
    pub mc_stderr: f64,
    /// |grid − MC| / (MC's standard error + the grid's stated error); `None` when both
    /// errors are 0 (R(0) = 1 by both) or a number is not finite.
    pub distance: Option<f64>,
    /// Whether |grid − MC| > [`DISAGREE_SE`] · `mc_stderr` + `grid_error`: the run warns.
    pub flagged: bool,
}

impl MethodDistance {
    fn new(compared: Compared, grid: f64, grid_error: f64, mc: f64, mc_stderr: f64) -> Self {
        let gap = match compared {
            // A grid mean at or above the bound does not contradict it.
            Compared::MeanLowerBound => (mc - grid).max(0.0),
            _ => (grid - mc).abs(),
        };
        let d = gap / (mc_stderr + grid_error);
        MethodDistance {
            compared,
            grid,
            grid_error,
            mc,
            mc_stderr,
            distance: d.is_finite().then_some(d),
            flagged: gap > DISAGREE_SE * mc_stderr + grid_error,
        }
    }
}

/// The grid's and Monte Carlo's first-passage numbers side by side (`summary.json`'s
/// `method_distances`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodDistances {
    /// The mean time from the start; `None` when Monte Carlo censored paths (its mean is
    /// then only a lower bound).
    pub mean_at_start: Option<MethodDistance>,
    /// When Monte Carlo censored paths: the grid's mean time from the start against Monte
    /// Carlo's lower bound on it ([`Compared::MeanLowerBound`], one-sided); `None` otherwise.
    pub mean_lower_bound: Option<MethodDistance>,
    /// R(t) at each output time.
    pub reliability: Vec<MethodDistance>,
    /// The largest distance of them all.
    pub worst: Option<MethodDistance>,
    /// The Monte Carlo standard errors, beyond the grid's stated error, two values may be
    /// apart before they are flagged ([`DISAGREE_SE`]).
    pub flag_above_se: f64,
}

impl MethodDistances {
    /// The distances of `grid` and `mc` (on the same output times).
    ///
    /// ```
    /// use fpsolve::job::passage::MethodDistances;
    /// # use fpsolve::grid::GridPassage;
    /// # use fpsolve::mc::McPassage;
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let model = fpsolve::model::load_model(&path)?.with_safe("abs(z) < 1.2")?;
    /// let bound = model.bind(&[fpsolve::model::Override::number("c", 1.0)])?;
    /// let safe = model.safe().unwrap().bind(&bound)?;
    /// let times = vec![0.0, 2.0, 4.0];
    /// let g = GridPassage::new(&bound, &safe).cells(40, 60).times(times.clone()).run()?;
    /// let m = McPassage::new(&bound, &safe).paths(512).dt(0.02).horizon(100.0).times(times).run()?;
    /// let d = MethodDistances::between(&g, &m);
    /// assert_eq!(d.reliability.len(), 3);
    /// assert!(d.worst.unwrap().distance.unwrap() >= d.mean_at_start.unwrap().distance.unwrap());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn between(grid: &PassageSolution, mc: &McPassageResult) -> MethodDistances {
        let errors = grid.errors.as_ref();
        let mean_at_start = mc.mean.map(|m| {
            MethodDistance::new(
                Compared::MeanAtStart,
                grid.mean_at_start,
                errors.map_or(0.0, |e| e.mean_at_start),
                m.value,
                m.stderr,
            )
        });
        let mean_lower_bound = mc.mean.is_none().then(|| {
            MethodDistance::new(
                Compared::MeanLowerBound,
                grid.mean_at_start,
                errors.map_or(0.0, |e| e.mean_at_start),
                mc.mean_lower_bound.value,
                mc.mean_lower_bound.stderr,
            )
        });
        let n = grid.times.len().min(mc.times.len());
        let reliability: Vec<MethodDistance> = (0..n)
            .map(|k| {
                MethodDistance::new(
                    Compared::Reliability { t: grid.times[k] },
                    grid.reliability[k],
                    errors.map_or(0.0, |e| e.reliability[k]),
                    mc.reliability[k],
                    mc.reliability_stderr_toward(k, grid.reliability[k], DISAGREE_SE),
                )
            })
            .collect();
        let worst = mean_at_start
            .iter()
            .chain(&mean_lower_bound)
            .chain(&reliability)
            .filter(|d| d.distance.is_some())
            .copied()
            .max_by(|a, b| a.distance.partial_cmp(&b.distance).expect("finite"));
        MethodDistances {
            mean_at_start,
            mean_lower_bound,
            reliability,
            worst,
            flag_above_se: DISAGREE_SE,
        }
    }

    /// The numbers flagged ([`MethodDistance::flagged`]).
    pub fn flagged(&self) -> impl Iterator<Item = &MethodDistance> {
        self.mean_at_start
            .iter()
            .chain(&self.mean_lower_bound)
            .chain(&self.reliability)
            .filter(|d| d.flagged)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_distance_is_the_gap_over_both_errors() {
        let d = MethodDistance::new(Compared::MeanAtStart, 10.0, 0.5, 11.0, 0.5);
        assert_eq!(d.distance, Some(1.0));
        assert!(!d.flagged);
        // 2.1 apart: beyond 3 standard errors (1.5) plus the grid's error (0.5).
        let far = MethodDistance::new(Compared::MeanAtStart, 10.0, 0.5, 12.1, 0.5);
        assert!(far.flagged && far.distance.unwrap() < 3.0);
        // Against a lower bound only a grid mean below it is a gap.
        let above = MethodDistance::new(Compared::MeanLowerBound, 30.0, 0.1, 20.0, 0.5);
        assert_eq!(above.distance, Some(0.0));
        assert!(!above.flagged);
        let below = MethodDistance::new(Compared::MeanLowerBound, 30.0, 0.1, 100.0, 0.0);
        assert!(below.flagged && below.distance.unwrap() > 100.0);
        let same = MethodDistance::new(Compared::Reliability { t: 0.0 }, 1.0, 0.0, 1.0, 0.0);
        assert_eq!(same.distance, None);
        assert!(!same.flagged);
        assert_eq!(
            serde_json::to_value(d).unwrap()["number"],
            serde_json::json!("mean_at_start")
        );
        assert_eq!(
            Compared::Reliability { t: 2.5 }.to_string(),
            "R(t) at t = 2.5"
        );
    }
}
