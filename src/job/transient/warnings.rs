//! What a finished transient warns about: grid variances and marginals the cells do not
//! resolve (their numbers are written all the same), and a Monte Carlo ensemble stuck at its
//! point start (a flag: its numbers are not the law's).

use super::TransientRun;
use crate::grid::{Snapshot, TransientHistory, POINT_CELLS, UNRESOLVED_L1};
use crate::model::BoundModel;

/// The relative error estimate of a state's variance above which a warning is given (the
/// numbers and their errors are in `moments_vs_t.csv` whatever they are).
const UNCERTAIN_VARIANCE: f64 = 0.05;

/// A warning about a finished transient, as both front ends word it.
///
/// ```
/// use fpsolve::job::transient::TransientWarning;
/// let w = TransientWarning::StuckAtStart { t: 1.0 };
/// assert!(w.flags() && w.to_string().contains("still at its start at t = 1"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TransientWarning {
    /// The grid's variance of a state has an estimated error above 5 % of itself at some
    /// output after the start (the worst one).
    #[error(
        "the grid's variance of {state} at t = {t} is {variance:.4} with an estimated error \
         of {:.0} % (from the run on half the cells): the cells do not resolve the density \
         yet (a point start is a Gaussian {} cells wide); finer --cells or a Gaussian \
         --initial narrow it",
        100.0 * relative,
        POINT_CELLS
    )]
    UncertainVariance {
        /// The state.
        state: String,
        /// The output time of the worst error.
        t: f64,
        /// The variance there.
        variance: f64,
        /// Its estimated error over itself.
        relative: f64,
    },
    /// The grid's marginal of a state has an estimated L1 error at or above
    /// [`UNRESOLVED_L1`] up to some output after the start (the last one).
    #[error(
        "the grid's marginal of {state} is not resolved by the cells up to t = {t} \
         (estimated L1 error {l1:.2} there: a number, not a bound); its curves before then \
         are not the law's"
    )]
    UnresolvedMarginal {
        /// The state.
        state: String,
        /// The last output time it is not resolved at.
        t: f64,
        /// Its estimated L1 error there.
        l1: f64,
    },
    /// Every Monte Carlo trajectory is still at its point start at an output after 0
    /// ([`crate::mc::McTransientHistory::stuck_at_start`]).
    #[error(
        "Monte Carlo: every trajectory is still at its start at t = {t} (both states' \
         variances are 0): the sampled drift and noise vanish there (e.g. sgn(0) = 0 in a \
         Zhuravlev form, whose noise is sgn(z)*xi); its numbers are not the law's. Start \
         beside it, e.g. --initial 'point z = 1e-6, v = 0'"
    )]
    StuckAtStart {
        /// The first such output time.
        t: f64,
    },
    /// The period map did not reach its residual: the outputs are the last iterate's.
    #[error("{0}")]
    PeriodicNotConverged(crate::grid::PeriodicOutcome),
    /// A state's mean or variance by the grid and by Monte Carlo further apart, at some
    /// output after the start, than [`DISAGREE_SE`] of Monte Carlo's standard errors plus the
    /// grid's estimated error (the worst output, by |grid − MC| over that sum).
    #[error(
        "the grid's {moment} of {state} at t = {} is {grid:.6}, Monte Carlo's {mc:.6} ± \
         {stderr:.2e} (SE): further apart than {DISAGREE_SE} standard errors plus the grid's \
         estimated error ({grid_error:.2e}); compare finer --cells, and Monte Carlo at a \
         smaller --dt",
        crate::report::short_number(*t)
    )]
    Disagree {
        /// The state.
        state: String,
        /// `mean` or `variance`.
        moment: &'static str,
        /// The output time.
        t: f64,
        /// The grid's value.
        grid: f64,
        /// Its estimated error (0 without the estimate's run).
        grid_error: f64,
        /// Monte Carlo's value.
        mc: f64,
        /// Its standard error.
        stderr: f64,
    },
}

/// How many Monte Carlo standard errors, beyond the grid's estimated error, the grid's and
/// Monte Carlo's mean or variance of a state may be apart before a warning
/// ([`TransientWarning::Disagree`]), as in the first-passage and stationary jobs.
pub const DISAGREE_SE: f64 = 3.0;

impl TransientWarning {
    /// Whether the run's numbers are not to be trusted (the command line exits 1 with its
    /// files written): a Monte Carlo ensemble stuck at its start, a periodic state not
    /// converged.
    pub fn flags(&self) -> bool {
        matches!(
            self,
            TransientWarning::StuckAtStart { .. } | TransientWarning::PeriodicNotConverged(_)
        )
    }
}

impl TransientRun {
    /// The warnings: each state's uncertain grid variance, then each state's unresolved grid
    /// marginal, then a periodic state not converged, then a Monte Carlo ensemble stuck at
    /// its start, then each state's mean and variance where the grid and Monte Carlo
    /// disagree.
    pub fn warnings(&self, model: &BoundModel) -> Vec<TransientWarning> {
        let states: Vec<String> = model.states().iter().map(|s| s.to_string()).collect();
        let mut out = Vec::new();
        if let Some(g) = &self.grid {
            out.extend(uncertain_variances(g, &states));
            out.extend(unresolved_marginals(g, &states));
        }
        if let Some(p) = self.periodic.as_ref().filter(|p| !p.outcome.converged()) {
            out.push(TransientWarning::PeriodicNotConverged(p.outcome));
        }
        let stuck = self.mc.as_ref().and_then(|m| m.stuck_at_start());
        if let Some(t) = stuck {
            out.push(TransientWarning::StuckAtStart { t });
        }
        // A stuck ensemble is flagged already; its distances say nothing more.
        if let (Some(g), Some(m), None) = (&self.grid, &self.mc, stuck) {
            out.extend(disagreements(g, m, &states));
        }
        out
    }
}

/// Per state and moment (mean, variance), the worst output after the start where the grid
/// and Monte Carlo are further apart than [`DISAGREE_SE`] standard errors plus the grid's
/// estimated error.
fn disagreements(
    g: &TransientHistory,
    m: &crate::mc::McTransientHistory,
    states: &[String],
) -> Vec<TransientWarning> {
    let mut out = Vec::new();
    for (a, state) in states.iter().enumerate() {
        for moment in ["mean", "variance"] {
            let worst = g
                .snapshots
                .iter()
                .zip(&m.snapshots)
                .filter(|(gs, _)| gs.t > 0.0)
                .filter_map(|(gs, ms)| {
                    let (grid, est, mc) = match moment {
                        "mean" => (
                            gs.moments[a].mean,
                            gs.estimate.as_ref().map(|e| e.moments[a].mean),
                            ms.moments[a].mean,
                        ),
                        _ => (
                            gs.moments[a].variance,
                            gs.estimate.as_ref().map(|e| e.moments[a].variance),
                            ms.moments[a].variance,
                        ),
                    };
                    let grid_error = est.filter(|e| e.is_finite()).unwrap_or(0.0);
                    let gap = (grid - mc.value).abs();
                    let over = gap - DISAGREE_SE * mc.stderr - grid_error;
                    (over > 0.0 && gap.is_finite()).then_some(TransientWarning::Disagree {
                        state: state.clone(),
                        moment,
                        t: gs.t,
                        grid,
                        grid_error,
                        mc: mc.value,
                        stderr: mc.stderr,
                    })
                })
                .max_by(|a, b| distance(a).total_cmp(&distance(b)));
            out.extend(worst);
        }
    }
    out
}

/// |grid − MC| / (SE + the grid's error) of a [`TransientWarning::Disagree`].
fn distance(w: &TransientWarning) -> f64 {
    match w {
        TransientWarning::Disagree {
            grid,
            grid_error,
            mc,
            stderr,
            ..
        } => (grid - mc).abs() / (stderr + grid_error),
        _ => 0.0,
    }
}

/// A warning per state whose grid variance has an estimated error above
/// [`UNCERTAIN_VARIANCE`] of itself at some output after the start, at its worst output.
fn uncertain_variances(g: &TransientHistory, states: &[String]) -> Vec<TransientWarning> {
    states
        .iter()
        .enumerate()
        .filter_map(|(a, q)| {
            let relative = |s: &Snapshot| {
                let e = s.estimate.as_ref()?.moments[a].variance;
                let r = e / s.moments[a].variance.abs();
                (s.t > 0.0 && r.is_finite()).then_some(r)
            };
            let (worst, r) = g
                .snapshots
                .iter()
                .filter_map(|s| relative(s).map(|r| (s, r)))
                .max_by(|a, b| a.1.total_cmp(&b.1))?;
            (r > UNCERTAIN_VARIANCE).then(|| TransientWarning::UncertainVariance {
                state: q.clone(),
                t: worst.t,
                variance: worst.moments[a].variance,
                relative: r,
            })
        })
        .collect()
}

/// A warning per state whose grid marginal is not resolved at some output after the start
/// (its L1 estimate at or above [`UNRESOLVED_L1`]), naming the last such time.
fn unresolved_marginals(g: &TransientHistory, states: &[String]) -> Vec<TransientWarning> {
    states
        .iter()
        .enumerate()
        .filter_map(|(a, q)| {
            let last = g.snapshots.iter().rev().find(|s| {
                s.t > 0.0
                    && s.estimate
                        .as_ref()
                        .is_some_and(|e| e.l1[a] >= UNRESOLVED_L1)
            })?;
            Some(TransientWarning::UnresolvedMarginal {
                state: q.clone(),
                t: last.t,
                l1: last.estimate.as_ref().map_or(f64::NAN, |e| e.l1[a]),
            })
        })
        .collect()
}
