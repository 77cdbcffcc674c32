//! The Monte Carlo periodic steady state of a model whose coefficients have period P (a
//! periodic force, a periodically modulated noise): the judge of the grid's period map
//! ([`crate::grid::GridPeriodic`]).
//!
//! * **How many periods to discard** is measured, never guessed: a pilot ensemble
//!   ([`PILOT_TRAJECTORIES`] trajectories from the run's start, its own random streams) is
//!   recorded stroboscopically, at t = kP for k = 0, 1, …, H (mean, variance and kurtosis of
//!   both states), and judged as the stationary run's burn-in pilot judges its moments: settled
//!   when the last quarter of the periods agrees with the quarter before within a few standard
//!   errors, else H doubles, up to a budget of trajectory steps
//!   ([`McTransientError::NoPeriodicState`] beyond it). From the settled series come t* (after
//!   which every statistic stays near its level) and one decay time τ; the run discards
//!   M = ⌈max(t*, [`DECAY_TIMES`]·τ)/P⌉ periods, so that what is left of the start lies far
//!   below the main run's own standard errors, which are smaller than the pilot's.
//! * **Recording.** Each trajectory is then recorded at every requested phase φ of K further
//!   periods (t = (M + j)P + φ, j < K): each trajectory gives K samples of the periodic state
//!   at φ, correlated with each other. The standard errors come from independent units only:
//!   a batch's samples over all K periods are one unit (batch means), and the moments' errors
//!   are the delete-one-group jackknife over groups of whole batches, as the transient's;
//!   a histogram bin's error is the same jackknife of its density over the groups.
//! * **Time-step bias** as the transient: the first quarter of the batches (at least two)
//!   run again at 2·dt, discarding the same M periods; (S_2dt − S_dt)/(2ᵖ − 1) for the
//!   scheme's weak order p.
//! * **The clock.** The coefficients repeat, so every period is stepped with the clock
//!   running from 0 to P again: every period takes the same steps at the same times, and the
//!   coefficients of a time-dependent form over each segment between phases are computed once
//!   for all periods and batches.
//! * **Determinism.** One random stream per trajectory (by index); per-batch sums kept in batch
//!   order, bin counts as integers: a seed gives the same numbers whatever the thread count.
//!
//! ```
//! use fpsolve::mc::McTransient;
//! // The forced linear oscillator: the periodic mean is the harmonic response.
//! let text = "model f\nstate x, v\ndrift x: v\ndrift v: -0.5*v - x + cos(t)\n\
//!     noise xi: intensity 0.5\ndiffusion v: xi\n";
//! let model = fpsolve::model::parse_model(text, None)?.bind(&[])?;
//! let p = 2.0 * std::f64::consts::PI;
//! let state = McTransient::new(&model)
//!     .times(vec![0.0, p / 4.0])
//!     .trajectories(512)
//!     .dt(0.02)
//!     .periodic(p)
//!     .run()?;
//! // In resonance (k = w² = 1) the response is x_p(t) = A sin(t)/(c w) = 2 sin t.
//! let mean = |k: usize| state.history.snapshots[k].moments[0].mean;
//! assert!((mean(1).value - 2.0).abs() < 5.0 * mean(1).stderr + 0.02, "{:?}", mean(1));
//! assert!(state.report.discarded_periods >= 1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::ops::Range;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::sums::{self, PowerSums, GROUPS};
use super::{
    count, density, steps_of, McSnapshot, McStateMoments, McTransient, McTransientError,
    McTransientHistory, McTransientSettings, MAX_SHARED_VALUES, MAX_TRANSIENT_STEPS,
    TRANSIENT_LANES,
};
use crate::mc::compile::scheme::Plan;
use crate::mc::record::histogram::Grid;
use crate::mc::relax::{relaxation, PILOT_STEP_BUDGET, PILOT_TRAJECTORIES};
use crate::mc::step::timed::SpanTable;

/// Periods recorded after the discarded ones unless [`McPeriodic::recorded_periods`] says
/// otherwise.
pub const RECORDED_PERIODS: u64 = 8;

/// The pilot's first horizon, in periods (doubled until its statistics settle).
pub const PILOT_PERIODS: u64 = 16;

/// Decay times of the pilot's relaxation the run discards (never less than the pilot's t*):
/// e^{−10} of the start's gap is left, far below the main run's standard errors.
pub const DECAY_TIMES: f64 = 10.0;

/// The box the period is probed on when no bins are given (with bins: the bins' box).
const PROBE_BOX: [[f64; 2]; 2] = [[-5.0, 5.0], [-5.0, 5.0]];

/// Mixed into the seed so that the pilot's trajectories are not the run's.
const PERIODIC_SALT: u64 = 0x5045_5249_4f44_4943;

/// A Monte Carlo periodic steady state: [`McTransient::periodic`], then
/// [`McPeriodic::run`]. The transient's times are the output phases, in [0, P]; its start
/// is where the pilot and the run begin (rest by default).
#[derive(Clone, Debug)]
pub struct McPeriodic<'a> {
    run: McTransient<'a>,
    period: f64,
    recorded: u64,
    /// The pilot's budget of trajectory steps ([`PILOT_STEP_BUDGET`]; lower in a test).
    budget: f64,
}

/// How the pilot decided the periods to discard.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct McPeriodicPilot {
    /// Its trajectories.
    pub trajectories: u64,
    /// Its last horizon, in periods (the one whose statistics settled).
    pub periods: u64,
    /// t*/P: every stroboscopic statistic stays near its level from this many periods on.
    pub settled_periods: f64,
    /// One decay time of the approach, in periods.
    pub decay_periods: f64,
}

/// How the periodic state was sampled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct McPeriodicReport {
    /// The period P.
    pub period: f64,
    /// Periods run and not recorded (M), decided by the pilot.
    pub discarded_periods: u64,
    /// Periods recorded at each phase (K): each trajectory gives K correlated samples, the
    /// error bars come from whole batches.
    pub recorded_periods: u64,
    /// The pilot.
    pub pilot: McPeriodicPilot,
}

/// The periodic state at the requested phases (each snapshot's `t` is its phase) and how
/// it was sampled.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct McPeriodicState {
    /// The ensemble's statistics at each phase over the K recorded periods;
    /// `settings.total_ms` includes the pilot.
    pub history: McTransientHistory,
    /// The discarded and recorded periods and the pilot.
    pub report: McPeriodicReport,
}

/// What one pass over a set of batches collects.
struct PeriodicPass {
    /// Per batch (in batch order), per phase, per state: its power sums over the K periods.
    sums: Vec<Vec<[PowerSums; 2]>>,
    /// Per group of batches, per phase, per state: bin counts, then the count outside.
    groups: Vec<Vec<[Vec<u64>; 2]>>,
    /// Per phase, per state: the counts of the batches paired with the 2·dt run.
    paired: Vec<[Vec<u64>; 2]>,
    /// Per phase: trajectories no longer finite there in the last period.
    blown_up: Vec<u64>,
}

impl PeriodicPass {
    /// Appends `other` (the batches after this one's).
    fn join(mut self, other: PeriodicPass) -> PeriodicPass {
        self.sums.extend(other.sums);
        for (a, b) in self.groups.iter_mut().zip(&other.groups) {
            super::add_counts(a, b);
        }
        super::add_counts(&mut self.paired, &other.paired);
        self.blown_up
            .iter_mut()
            .zip(&other.blown_up)
            .for_each(|(a, b)| *a += b);
        self
    }
}

impl<'a> McTransient<'a> {
    /// The periodic steady state for coefficients of period `period` instead of a history
    /// from the start: see [`McPeriodic`]. The times are then phases in [0, `period`].
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::mc::{McTransient, McTransientError};
    /// use fpsolve::model::PeriodError;
    /// // models/linear.sde has no t: its long-time density is the stationary one.
    /// let err = McTransient::new(&bound).times(vec![0.0]).periodic(1.0).check().unwrap_err();
    /// assert!(matches!(err, McTransientError::Period(PeriodError::NotTimeDependent { .. })));
    /// ```
    pub fn periodic(self, period: f64) -> McPeriodic<'a> {
        McPeriodic {
            run: self,
            period,
            recorded: RECORDED_PERIODS,
            budget: PILOT_STEP_BUDGET,
        }
    }
}

impl McPeriodic<'_> {
    /// The periods recorded at each phase after the discarded ones (default
    /// [`RECORDED_PERIODS`]).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// let _p = fpsolve::mc::McTransient::new(&bound).periodic(1.0).recorded_periods(16);
    /// ```
    pub fn recorded_periods(mut self, k: u64) -> Self {
        self.recorded = k;
        self
    }

    /// The checks of [`McPeriodic::run`] before any work.
    ///
    /// ```
    /// use fpsolve::mc::{McTransient, McTransientError};
    /// use fpsolve::model::PeriodError;
    /// let text = "model f\nstate x, v\ndrift x: v\ndrift v: -v - x + cos(2*t)\n\
    ///     noise xi: intensity 1\ndiffusion v: xi\n";
    /// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// let run = McTransient::new(&bound).times(vec![0.0, 1.0]);
    /// // cos(2t) has period pi, not 3.
    /// let err = run.clone().periodic(3.0).check().unwrap_err();
    /// assert!(matches!(err, McTransientError::Period(PeriodError::NotPeriodic { .. })), "{err}");
    /// assert!(run.periodic(std::f64::consts::PI).check().is_ok());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`McTransientError::Period`] (a period that is not finite and positive, a model
    /// without t, coefficients that differ at t and t + P on the bins' box, or ±5 without
    /// bins), [`McTransientError::Setting`] (`recorded_periods` below 1, phases beyond the
    /// period, more than 1e9 steps in the recorded periods, and the transient's settings),
    /// and the transient's refusals ([`McTransient::check`]).
    pub fn check(&self) -> Result<(), McTransientError> {
        self.plan().map(|_| ())
    }

    fn plan(&self) -> Result<Plan, McTransientError> {
        let p = self.period;
        let bounds = self
            .run
            .bins
            .map_or(PROBE_BOX, |b| [[b[0].lo, b[0].hi], [b[1].lo, b[1].hi]]);
        self.run.model.check_period(p, Some(bounds))?;
        let setting = |setting, value: String, expected| McTransientError::Setting {
            setting,
            value,
            expected,
        };
        if self.recorded < 1 {
            return Err(setting(
                "recorded_periods",
                format!("{}", self.recorded),
                "at least 1",
            ));
        }
        if self.run.times.iter().any(|t| *t > p) {
            return Err(setting(
                "times",
                format!("{:?}", self.run.times),
                "phases within [0, period]",
            ));
        }
        if self.recorded as f64 * p / self.run.dt > MAX_TRANSIENT_STEPS {
            return Err(setting(
                "dt",
                format!("{} ({} periods of {p})", self.run.dt, self.recorded),
                "at most 1e9 steps per trajectory",
            ));
        }
        self.run.plan()
    }

    /// Runs the pilot, then the ensemble (and the bias run at 2·dt) through the discarded
    /// periods and records the K periods after them.
    ///
    /// # Errors
    /// As [`McPeriodic::check`]; [`McTransientError::NoPeriodicState`] when the pilot's
    /// stroboscopic statistics never settle within its budget.
    pub fn run(&self) -> Result<McPeriodicState, McTransientError> {
        let start = Instant::now();
        let plan = self.plan()?;
        let (discard, pilot) = self.pilot()?;
        let run = &self.run;
        let batches = run.batches();
        let pairs = if run.bias {
            (batches / 4).max(2).min(batches)
        } else {
            0
        };
        let fine = self.pass(&plan, batches, pairs, run.dt, discard);
        let coarse = (pairs > 0).then(|| self.pass(&plan, pairs, 0, 2.0 * run.dt, discard));
        let order = plan.kind.weak_order();
        let total = (batches * TRANSIENT_LANES as u64).min(run.trajectories);
        let snapshots = run
            .times
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                let moments = std::array::from_fn(|a| {
                    let coarse = coarse.as_ref().map(|c| &c.sums[..]);
                    let ([mean, variance, kurtosis], bias) =
                        sums::moments(&fine.sums, coarse, k, a, order);
                    McStateMoments {
                        mean,
                        variance,
                        kurtosis,
                        bias,
                    }
                });
                let densities = run.bins.as_ref().map(|bins| {
                    std::array::from_fn(|a| {
                        let groups: Vec<&[u64]> =
                            fine.groups.iter().map(|g| &g[k][a][..]).collect();
                        // The 2·dt run's batches are all paired: its counts are its groups'.
                        let coarse_counts = coarse.as_ref().map(|c| {
                            let mut total = vec![0u64; bins[a].bins + 1];
                            for g in &c.groups {
                                total.iter_mut().zip(&g[k][a]).for_each(|(t, c)| *t += c);
                            }
                            total
                        });
                        batch_means_density(
                            bins[a],
                            &groups,
                            coarse_counts
                                .as_ref()
                                .map(|c| (&fine.paired[k][a], c, order)),
                        )
                    })
                });
                McSnapshot {
                    t,
                    moments,
                    densities,
                    blown_up: fine.blown_up[k],
                }
            })
            .collect();
        Ok(McPeriodicState {
            history: McTransientHistory {
                snapshots,
                settings: McTransientSettings {
                    trajectories: total,
                    dt: run.dt,
                    seed: run.seed,
                    scheme: plan.kind,
                    weak_order: order,
                    bias_pairs: pairs,
                    total_ms: start.elapsed().as_secs_f64() * 1e3,
                },
            },
            report: McPeriodicReport {
                period: self.period,
                discarded_periods: discard,
                recorded_periods: self.recorded,
                pilot,
            },
        })
    }

    /// The periods to discard, from the pilot's stroboscopic statistics.
    fn pilot(&self) -> Result<(u64, McPeriodicPilot), McTransientError> {
        let (p, dt) = (self.period, self.run.dt);
        let mut periods = PILOT_PERIODS;
        let mut spent = 0.0;
        loop {
            let steps = PILOT_TRAJECTORIES as f64 * (p / dt).ceil() * periods as f64;
            if spent + steps > self.budget {
                return Err(McTransientError::NoPeriodicState {
                    period: p,
                    periods: periods / 2,
                    spent,
                    budget: self.budget,
                });
            }
            spent += steps;
            let times: Vec<f64> = (0..=periods).map(|k| k as f64 * p).collect();
            let history = McTransient::new(self.run.model)
                .initial(self.run.initial)
                .times(times.clone())
                .dt(dt)
                .trajectories(PILOT_TRAJECTORIES)
                .seed(self.run.seed ^ PERIODIC_SALT)
                .bias(false)
                .run()?;
            let series = history.moment_series();
            if let Some(r) = relaxation(&times, &series) {
                let burn_in = (DECAY_TIMES * r.decay).max(r.settled);
                let discard = ((burn_in / p) * (1.0 - 1e-12)).ceil().max(1.0) as u64;
                return Ok((
                    discard,
                    McPeriodicPilot {
                        trajectories: PILOT_TRAJECTORIES,
                        periods,
                        settled_periods: r.settled / p,
                        decay_periods: r.decay / p,
                    },
                ));
            }
            periods *= 2;
        }
    }

    /// The segments of a period: from 0 to the first phase, between phases, from the last
    /// to P.
    fn segments(&self) -> Vec<(f64, f64)> {
        let mut now = 0.0;
        let mut out: Vec<(f64, f64)> = self
            .run
            .times
            .iter()
            .map(|&t| {
                let s = (now, t);
                now = t;
                s
            })
            .collect();
        out.push((now, self.period));
        out
    }

    /// Batches `0..batches` at step at most `dt`, `discard` periods then the recorded ones;
    /// the first `pairs` also counted apart.
    fn pass(&self, plan: &Plan, batches: u64, pairs: u64, dt: f64, discard: u64) -> PeriodicPass {
        let phases = self.run.times.len();
        let groups = GROUPS.min(batches as usize).max(1);
        let empty = || PeriodicPass {
            sums: Vec::new(),
            groups: vec![self.run.empty_counts(); groups],
            paired: self.run.empty_counts(),
            blown_up: vec![0; phases],
        };
        // The coefficients of a time-dependent form over each segment, for every period.
        let mut left = MAX_SHARED_VALUES;
        let spans: Vec<Option<SpanTable>> = self
            .segments()
            .into_iter()
            .map(|(from, to)| {
                if to <= from {
                    return None;
                }
                let (steps, h) = steps_of(to - from, dt);
                let table = SpanTable::of(plan, from, steps, h, left)?;
                left -= table.len();
                Some(table)
            })
            .collect();
        let threads = rayon::current_num_threads().max(1) as u64;
        let per = (batches / (4 * threads)).clamp(1, super::BLOCK_BATCHES);
        // Blocks are joined in their order (the sums are per batch, the counts integers),
        // whichever thread ran each.
        (0..batches.div_ceil(per))
            .into_par_iter()
            .map(|j| {
                let mut p = empty();
                let first = j * per;
                let range = first..(first + per).min(batches);
                self.block(plan, &spans, range, pairs, dt, discard, groups, &mut p);
                p
            })
            .reduce(empty, PeriodicPass::join)
    }

    /// The batches `batches` stepped side by side: `discard` periods, then the recorded
    /// ones, each batch's samples at each phase merged into its power sums and counted in
    /// its group's bins (batch k in group k mod `groups`).
    #[allow(clippy::too_many_arguments)]
    fn block(
        &self,
        plan: &Plan,
        spans: &[Option<SpanTable>],
        batches: Range<u64>,
        pairs: u64,
        dt: f64,
        discard: u64,
        groups: usize,
        pass: &mut PeriodicPass,
    ) {
        let run = &self.run;
        let (mut b, members) = run.start(plan, batches);
        let phases = run.times.len();
        let mut sums = vec![vec![[PowerSums::default(); 2]; phases]; members.len()];
        let segments = self.segments();
        let periods = discard + self.recorded;
        for period in 0..periods {
            // The coefficients repeat: every period runs the clock from 0 to P.
            b.t = 0.0;
            for (k, &(from, to)) in segments.iter().enumerate() {
                if to > from {
                    let (steps, h) = steps_of(to - from, dt);
                    b.advance_with(plan, steps, h, spans[k].as_ref());
                    b.t = to;
                }
                if period < discard || k == phases {
                    continue;
                }
                for ((batch, r), out) in members.iter().zip(&mut sums) {
                    let group = (*batch % groups as u64) as usize;
                    let states = [&b.x[r.clone()], &b.v[r.clone()]];
                    for a in 0..2 {
                        if let Some(bins) = &run.bins {
                            count(&bins[a], states[a], &mut pass.groups[group][k][a]);
                            if *batch < pairs {
                                count(&bins[a], states[a], &mut pass.paired[k][a]);
                            }
                        }
                        out[k][a] = out[k][a].merge(&PowerSums::of(states[a]));
                    }
                    if period + 1 == periods {
                        pass.blown_up[k] += r
                            .clone()
                            .filter(|&i| !(b.x[i].is_finite() && b.v[i].is_finite()))
                            .count() as u64;
                    }
                }
            }
        }
        pass.sums.extend(sums);
    }
}

/// The histogram on `g` of the counts of each group of batches (`groups[g]`: bin counts,
/// then outside), its error the delete-one-group jackknife of each bin's density (the
/// samples of a batch's K periods are correlated; the groups are independent), the bias from
/// (paired fine counts, coarse counts, order) as the transient's.
fn batch_means_density(
    g: Grid,
    groups: &[&[u64]],
    bias: Option<(&Vec<u64>, &Vec<u64>, u32)>,
) -> super::McDensity {
    let mut totals = vec![0u64; g.bins + 1];
    for c in groups {
        totals.iter_mut().zip(c.iter()).for_each(|(t, c)| *t += c);
    }
    let mut out = density(g, &totals, bias);
    let n_all = totals.iter().sum::<u64>() as f64;
    let w = g.width();
    let kept: Vec<(f64, &[u64])> = groups
        .iter()
        .map(|c| (c.iter().sum::<u64>() as f64, *c))
        .filter(|(n, _)| *n > 0.0 && *n < n_all)
        .collect();
    let m = kept.len() as f64;
    out.stderr = (0..g.bins)
        .map(|i| {
            if m < 2.0 {
                return f64::NAN;
            }
            let deleted: Vec<f64> = kept
                .iter()
                .map(|(n, c)| (totals[i] - c[i]) as f64 / (n_all - n))
                .collect();
            let mean = deleted.iter().sum::<f64>() / m;
            let ss: f64 = deleted.iter().map(|d| (d - mean).powi(2)).sum();
            ((m - 1.0) / m * ss).sqrt() / w
        })
        .collect();
    out
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::model::{parse_model, BoundModel, PeriodError};

    /// c, k, A, w, S of the forced linear oscillator (as tests/transient_periodic.rs).
    const LINEAR: [f64; 5] = [0.2, 1.0, 1.0, 0.8, 0.2];

    fn forced() -> BoundModel {
        let [c, k, a, w, s] = LINEAR;
        parse_model(
            &format!(
                "model forced\nstate x, v\ndrift x: v\ndrift v: -{c}*v - {k}*x + {a}*cos({w}*t)\n\
                 noise xi: intensity {s}\ndiffusion v: xi\n"
            ),
            None,
        )
        .unwrap()
        .bind(&[])
        .unwrap()
    }

    fn period() -> f64 {
        2.0 * PI / LINEAR[3]
    }

    /// The exact periodic mean (x, v) at phase t: the harmonic response.
    fn harmonic(t: f64) -> [f64; 2] {
        let [c, k, a, w, _] = LINEAR;
        let d = (k - w * w).powi(2) + (c * w).powi(2);
        let (p, q) = (a * (k - w * w) / d, a * c * w / d);
        [
            p * (w * t).cos() + q * (w * t).sin(),
            w * (-p * (w * t).sin() + q * (w * t).cos()),
        ]
    }

    fn phases() -> Vec<f64> {
        (0..8).map(|i| i as f64 * period() / 8.0).collect()
    }

    /// z-scores (MC − exact)/se of the means and variances of both states at each phase.
    fn z_scores(state: &McPeriodicState) -> Vec<f64> {
        let [c, k, _, _, s] = LINEAR;
        let var = [s / (2.0 * c * k), s / (2.0 * c)];
        let mut z = Vec::new();
        for snap in &state.history.snapshots {
            let mean = harmonic(snap.t);
            for a in 0..2 {
                let m = &snap.moments[a];
                let zm = (m.mean.value - mean[a]) / m.mean.stderr;
                let zv = (m.variance.value - var[a]) / m.variance.stderr;
                let bias = m.bias.map(|b| [b[0].value, b[1].value]);
                eprintln!(
                    "phase {:.3} state {a}: mean {:+.5} ± {:.1e} (exact {:+.5}, z {zm:+.2}), \
                     var {:.5} ± {:.1e} (exact {}, z {zv:+.2}); bias {bias:?}",
                    snap.t,
                    m.mean.value,
                    m.mean.stderr,
                    mean[a],
                    m.variance.value,
                    m.variance.stderr,
                    var[a]
                );
                z.push(zm);
                z.push(zv);
            }
        }
        z
    }

    /// The forced linear oscillator's periodic state (Gaussian: the harmonic response as
    /// mean, the unforced stationary covariance) at eight phases: every mean and variance
    /// within 4 standard errors of the exact value, and the standard errors honest (the
    /// z-scores' root mean square near 1, not all tiny).
    #[test]
    fn linear_periodic_moments_are_exact_within_their_errors() {
        let m = forced();
        let start = Instant::now();
        let state = McTransient::new(&m)
            .times(phases())
            .trajectories(8192)
            .dt(0.02)
            .seed(5)
            .periodic(period())
            .run()
            .unwrap();
        eprintln!(
            "{:?}; {:.0} ms",
            state.report,
            start.elapsed().as_secs_f64() * 1e3
        );
        let z = z_scores(&state);
        let rms = (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt();
        eprintln!("rms z {rms:.3}");
        assert!(z.iter().all(|z| z.abs() < 4.0), "{z:?}");
        assert!((0.4..2.0).contains(&rms), "{rms}");
        // The mean decays as e^{-ct/2} = e^{-0.1 t}: forgotten to 1e-4 of the response's
        // amplitude after ~90 time units, 12 periods; the pilot sees it settle.
        let r = state.report;
        assert!((6..=40).contains(&r.discarded_periods), "{r:?}");
        assert_eq!(r.recorded_periods, RECORDED_PERIODS);
    }

    /// The batch-means standard error of a periodic mean against the spread of the mean over
    /// independent seeds.
    #[test]
    fn standard_errors_match_the_spread_over_seeds() {
        let m = forced();
        let seeds = 10;
        let phase = [0.3 * period()];
        let runs: Vec<McPeriodicState> = (0..seeds)
            .map(|seed| {
                McTransient::new(&m)
                    .times(phase.to_vec())
                    .trajectories(1024)
                    .dt(0.04)
                    .seed(100 + seed)
                    .bias(false)
                    .periodic(period())
                    .recorded_periods(16)
                    .run()
                    .unwrap()
            })
            .collect();
        for (a, what) in [(0, "mean x"), (1, "mean v")] {
            let values: Vec<f64> = runs
                .iter()
                .map(|r| r.history.snapshots[0].moments[a].mean.value)
                .collect();
            let mean = values.iter().sum::<f64>() / seeds as f64;
            let spread = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / (seeds - 1) as f64)
                .sqrt();
            let stated = runs
                .iter()
                .map(|r| r.history.snapshots[0].moments[a].mean.stderr.powi(2))
                .sum::<f64>()
                / seeds as f64;
            let ratio = spread / stated.sqrt();
            eprintln!(
                "{what}: spread over seeds {spread:.2e}, stated se {:.2e}, ratio {ratio:.2}",
                stated.sqrt()
            );
            // 10 seeds: the spread's own relative error is about 24 %.
            assert!((0.45..1.8).contains(&ratio), "{what}: {ratio}");
        }
    }

    /// Histograms with batch-means errors, and the same numbers on one thread as on two.
    #[test]
    fn densities_have_errors_and_do_not_depend_on_threads() {
        let m = forced();
        let bins = [
            Grid::new(-4.0, 4.0, 16).unwrap(),
            Grid::new(-4.0, 4.0, 16).unwrap(),
        ];
        let run = || {
            McTransient::new(&m)
                .times(vec![0.0, 0.5 * period()])
                .trajectories(640)
                .dt(0.04)
                .bins(bins)
                .periodic(period())
                .recorded_periods(4)
                .run()
                .unwrap()
        };
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(run)
        };
        let (one, two) = (on(1), on(2));
        assert_eq!(one.history.snapshots, two.history.snapshots);
        assert_eq!(one.report, two.report);
        let d = &one.history.snapshots[1].densities.as_ref().unwrap()[0];
        let mass: f64 = d.density.iter().sum::<f64>() * d.grid.width();
        assert!(
            (mass + d.outside - 1.0).abs() < 1e-12,
            "{mass} {}",
            d.outside
        );
        // The binomial error of 640·4 independent samples would be smaller than the
        // batch-means one where the periods are correlated; both are positive in the bulk.
        let bulk = d.density.len() / 2;
        assert!(d.stderr[bulk] > 0.0 && d.stderr[bulk].is_finite());
        let bias = d.bias.as_ref().unwrap();
        assert!(bias.iter().all(|b| b.is_finite()), "{bias:?}");
    }

    /// Refusals before any work, then a pilot that never settles within its budget.
    #[test]
    fn refusals_and_a_state_that_never_settles() {
        let m = forced();
        let run = McTransient::new(&m).times(vec![0.0, 1.0]).trajectories(256);
        let err = run.clone().periodic(0.99 * period()).check().unwrap_err();
        assert!(
            matches!(&err, McTransientError::Period(PeriodError::NotPeriodic { coefficient, .. }) if coefficient == "the drift of `v`"),
            "{err}"
        );
        for p in [0.0, -1.0, f64::NAN] {
            let err = run.clone().periodic(p).check().unwrap_err();
            assert!(matches!(
                err,
                McTransientError::Period(PeriodError::NotPositive { .. })
            ));
        }
        let err = run
            .clone()
            .times(vec![0.0, 1.1 * period()])
            .periodic(period())
            .check();
        assert!(matches!(
            err,
            Err(McTransientError::Setting {
                setting: "times",
                ..
            })
        ));
        let err = run.clone().periodic(period()).recorded_periods(0).check();
        assert!(matches!(
            err,
            Err(McTransientError::Setting {
                setting: "recorded_periods",
                ..
            })
        ));
        // No damping: the variance grows for ever, the pilot never settles.
        let undamped = parse_model(
            "model u\nstate x, v\ndrift x: v\ndrift v: -x + cos(t)\nnoise xi: intensity 1\n\
             diffusion v: xi\n",
            None,
        )
        .unwrap()
        .bind(&[])
        .unwrap();
        let mut p = McTransient::new(&undamped)
            .times(vec![0.0])
            .trajectories(256)
            .dt(0.05)
            .periodic(2.0 * PI);
        p.budget = 2e7;
        let err = p.run().unwrap_err();
        assert!(
            matches!(err, McTransientError::NoPeriodicState { periods, .. } if periods >= PILOT_PERIODS),
            "{err}"
        );
    }
}
