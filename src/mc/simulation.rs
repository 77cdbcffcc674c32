//! The simulation driver: a model compiled with its settings resolved (the pilot run fixes
//! the grids not given), run whole or in shards.

use super::compile::scheme::{Evaluator, Plan};
use super::config::{bad, McConfig, Resolved, PILOT_BATCHES, PILOT_SALT, PILOT_SAMPLES};
use super::error::McError;
use super::record::batch::{run_batch_pair, run_batches_to_end};
use super::record::histogram::{Grid, QuantityHistogram};
use super::settings::{BarrierSetting, ParamValue, PeriodicSetting, QuantitySpec, RunSettings};
use super::shard::index::Shard;
use super::shard::part::ShardOutput;
use super::stats::result::{finalize_run, McResult};
use crate::base::cancel::Cancel;
use crate::model::BoundModel;
use crate::model::{ModelSource, Provenance};

/// Half-width of an automatic grid, in pilot standard deviations.
const GRID_HALF_WIDTH_SDS: f64 = 6.0;

/// A model compiled for simulation with its run settings resolved: ready to run whole or
/// in shards.
pub struct Simulation {
    plan: Plan,
    settings: RunSettings,
    /// The model's name, file and text, for the provenance of its shards.
    source: ModelSource,
}

impl Simulation {
    /// Compiles `model`, checks `config`, fixes the burn-in and the histogram grids (running
    /// the pilot if some grid is not given).
    pub fn new(model: &BoundModel, config: &McConfig) -> Result<Simulation, McError> {
        Simulation::reading(&crate::dynamics::Dynamics::read(model), config)
    }

    /// [`Simulation::new`] of a model already read (its model is `dynamics.model()`).
    ///
    /// ```
    /// use fpsolve::mc::{McConfig, Simulation};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let model = fpsolve::model::load_model(path.as_ref())?.bind(&[])?;
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&model);
    /// let config = McConfig { trajectories: 256, ..McConfig::default() };
    /// let sim = Simulation::reading(&dynamics, &config)?;
    /// assert_eq!(sim.settings().model, "linear");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// As [`Simulation::new`].
    pub fn reading(
        dynamics: &crate::dynamics::Dynamics,
        config: &McConfig,
    ) -> Result<Simulation, McError> {
        let walls = super::compile::scheme::walls(dynamics)?;
        Simulation::from_dynamics(dynamics.model(), dynamics, config, walls)
    }

    /// [`Simulation::new`] with the impact laws `specs` in place of the model's own (tests
    /// that set the walls of a strip on a barrier-free model).
    #[cfg(test)]
    pub(crate) fn with_impacts(
        model: &BoundModel,
        config: &McConfig,
        specs: Vec<crate::dynamics::Barrier>,
    ) -> Result<Simulation, McError> {
        let dynamics = super::compile::scheme::read(model)?;
        Simulation::from_dynamics(model, &dynamics, config, specs)
    }

    fn from_dynamics(
        model: &BoundModel,
        dynamics: &crate::dynamics::Dynamics,
        config: &McConfig,
        specs: Vec<crate::dynamics::Barrier>,
    ) -> Result<Simulation, McError> {
        let Resolved {
            plan,
            names,
            steps_per_sample,
            burn_in_steps,
            batches,
            bias_batches,
            estimate,
        } = config.resolve_with(model, dynamics, specs)?;
        // The run may be split into as many shards as batches: the smallest shard must fit.
        estimate.within_limits(batches)?;
        let dt = config.dt;
        let placeholder = Grid::new(-1.0, 1.0, 1)?;
        let mut settings = RunSettings {
            model: model.name.clone(),
            params: model
                .params
                .iter()
                .map(|(n, v)| ParamValue {
                    name: n.to_string(),
                    value: *v,
                })
                .collect(),
            scheme: plan.kind,
            increments: config.increments,
            dt,
            steps_per_sample,
            burn_in_steps,
            samples_per_trajectory: config.samples,
            lanes: config.lanes,
            batches,
            seed: config.seed,
            has_barrier: !plan.barriers.is_empty(),
            barriers: plan
                .barriers
                .iter()
                .map(|b| BarrierSetting {
                    state: dynamics.states()[b.state].to_string(),
                    at: b.at,
                    map: b.expr.to_string(),
                    above: b.side > 0.0,
                })
                .collect(),
            quantities: names
                .iter()
                .map(|(n, s)| QuantitySpec {
                    name: n.clone(),
                    is_state: *s,
                    grid: config
                        .grids
                        .iter()
                        .find(|(g, _)| g == n)
                        .map_or(placeholder, |(_, g)| *g),
                    levels: config
                        .levels
                        .iter()
                        .find(|(g, _)| g == n)
                        .map_or_else(Vec::new, |(_, l)| l.clone()),
                })
                .collect(),
            bias_batches,
            evaluator: Some(Evaluator::of(&plan, config.increments)),
            impact_speeds: config.impact_speeds,
            periodic: model.periodic().map(|p| PeriodicSetting {
                state: p.state,
                period: p.period,
            }),
        };
        let given = |n: &str| config.grids.iter().any(|(g, _)| g == n);
        if settings.quantities.iter().any(|q| !given(&q.name)) {
            let mut pilot = RunSettings {
                seed: config.seed ^ PILOT_SALT,
                batches: PILOT_BATCHES,
                samples_per_trajectory: config.samples.min(PILOT_SAMPLES),
                bias_batches: 0,
                impact_speeds: None,
                ..settings.clone()
            };
            for q in &mut pilot.quantities {
                q.levels.clear();
            }
            crate::base::timeline::mark("mc: pilot start");
            let summaries = run_batches_to_end(&plan, &pilot, 0..PILOT_BATCHES, &|| {});
            crate::base::timeline::mark("mc: pilot end");
            let refs: Vec<_> = summaries.iter().collect();
            let res = finalize_run(&pilot, &refs, &[]).map_err(|_| McError::NoPilotRange {
                name: settings.quantities[0].name.clone(),
            })?;
            // A state held by walls (reflecting laws, with a side in the model) is never
            // beyond them: its grid ends on them, so no bin straddles a wall.
            let walls = |name: &str| {
                let mut range = [f64::NEG_INFINITY, f64::INFINITY];
                for wall in dynamics.barriers().iter().flat_map(|b| b.iter()) {
                    match wall.side() {
                        Some(side) if dynamics.states()[wall.state].as_ref() == name => {
                            match side {
                                crate::model::BarrierSide::Above => range[0] = wall.at,
                                crate::model::BarrierSide::Below => range[1] = wall.at,
                            }
                        }
                        _ => {}
                    }
                }
                range
            };
            let window = model.periodic().map(|p| (p.state, p.window()));
            for (k, (spec, stats)) in settings
                .quantities
                .iter_mut()
                .zip(&res.quantities)
                .enumerate()
            {
                // A periodic state's grid is its window: no bin straddles the seam.
                if let Some((_, [lo, hi])) = window.filter(|(s, _)| *s == k && !given(&spec.name)) {
                    spec.grid = Grid::new(lo, hi, config.bins)?;
                    continue;
                }
                if !given(&spec.name) {
                    let [lo, hi] = if spec.is_state {
                        walls(&spec.name)
                    } else {
                        [f64::NEG_INFINITY, f64::INFINITY]
                    };
                    spec.grid = auto_grid(stats, config.bins, [lo, hi])?;
                }
            }
        }
        Ok(Simulation {
            plan,
            settings,
            source: ModelSource::of_bound(model),
        })
    }

    /// The resolved settings (scheme, burn-in, grids, …).
    pub fn settings(&self) -> &RunSettings {
        &self.settings
    }

    /// Runs the whole simulation: the statistics batches at dt, then the first
    /// `bias_batches` again at 2·dt for the time-step bias. Trajectories that blow up are
    /// listed in the result and left out; if all do, that is an error. A finished run is
    /// returned even when its verdict fails ([`McResult::verdict`]).
    pub fn run(&self) -> Result<McResult, McError> {
        self.run_with_progress(&|_, _| {})
    }

    /// [`Simulation::run`], calling `progress(done, total)` (in statistics batches, the
    /// coarse ones included) from the worker threads as batches finish.
    ///
    /// ```
    /// use std::sync::atomic::{AtomicU64, Ordering};
    /// use fpsolve::mc::{McConfig, Simulation};
    /// use fpsolve::model::{load_model, Override};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let file = load_model(path.as_ref()).unwrap();
    /// let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
    /// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
    /// let sim = Simulation::new(&model, &config).unwrap();
    /// let seen = AtomicU64::new(0);
    /// sim.run_with_progress(&|_, _| { seen.fetch_add(1, Ordering::Relaxed); }).unwrap();
    /// // 4 batches, run again at 2·dt for the bias estimate (at least 8, here all 4).
    /// assert_eq!(seen.into_inner(), 4 + 4);
    /// ```
    pub fn run_with_progress(
        &self,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<McResult, McError> {
        // A flag nobody else holds is never set: the run goes to its end.
        self.run_cancellable(progress, &Cancel::new())
    }

    /// [`Simulation::run_with_progress`] that stops when `cancel` is set: checked before
    /// every part of a batch and at every sample point of a part in flight (every 32nd where the
    /// recording is fused with the fast mechanical kernel), so a run stops within at most
    /// 32 sample spacings' worth of steps per thread. A cancelled run returns
    /// [`McError::Cancelled`] and nothing else (its batches are not a sample of the run).
    ///
    /// ```
    /// use fpsolve::base::cancel::Cancel;
    /// use fpsolve::mc::{McConfig, McError, Simulation};
    /// use fpsolve::model::{load_model, Override};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let model = load_model(path.as_ref()).unwrap().bind(&[Override::number("c", 0.5)]).unwrap();
    /// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
    /// let sim = Simulation::new(&model, &config).unwrap();
    /// let cancel = Cancel::new();
    /// assert!(sim.run_cancellable(&|_, _| {}, &cancel).is_ok());
    /// cancel.cancel();
    /// assert!(matches!(sim.run_cancellable(&|_, _| {}, &cancel), Err(McError::Cancelled)));
    /// ```
    pub fn run_cancellable(
        &self,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &Cancel,
    ) -> Result<McResult, McError> {
        let st = &self.settings;
        let total = st.batches + st.bias_batches;
        let done = std::sync::atomic::AtomicU64::new(0);
        let tick = || {
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(k, total);
        };
        let (summaries, coarse) = run_batch_pair(
            &self.plan,
            (st, 0..st.batches),
            (&st.coarse(), 0..st.bias_batches),
            &tick,
            cancel,
        )
        .ok_or(McError::Cancelled)?;
        let refs: Vec<_> = summaries.iter().collect();
        let coarse_refs: Vec<_> = coarse.iter().collect();
        finalize_run(st, &refs, &coarse_refs)
    }

    /// Runs one shard of the simulation (its statistics batches, and those of them in the
    /// bias estimate's range again at 2·dt); see [`merge_shards`](super::merge_shards). The
    /// part carries its `provenance`: the model's name, file and text and the threads it ran
    /// with (those of the pool it is called on), which a merge reports
    /// ([`Provenance::merged`]).
    pub fn run_shard(&self, shard: Shard) -> Result<ShardOutput, McError> {
        let st = &self.settings;
        if shard.count == 0 || shard.index >= shard.count || shard.count > st.batches {
            return Err(bad(
                "shard",
                format!(
                    "shard {} of {} does not fit a run of {} statistics batches",
                    shard.index.saturating_add(1),
                    shard.count,
                    st.batches
                ),
            ));
        }
        let range = shard.batch_range(st.batches);
        let coarse = range.start.min(st.bias_batches)..range.end.min(st.bias_batches);
        let (batches, coarse) = run_batch_pair(
            &self.plan,
            (st, range),
            (&st.coarse(), coarse),
            &|| {},
            &Cancel::new(),
        )
        .expect("a run whose flag nobody holds is never cancelled");
        let mut part = ShardOutput::sealed(st.clone(), shard, batches, coarse)?;
        let provenance = Provenance::now_of(self.source.clone());
        part.provenance = Some(serde_json::to_value(provenance).expect("provenance serialises"));
        Ok(part)
    }
}

/// A grid covering mean ± 6 sd of the pilot samples, one-sided where the pilot saw only
/// values of one sign (|z|, energies), and cut at `walls` (the state's reflecting barriers).
fn auto_grid(stats: &QuantityHistogram, bins: usize, walls: [f64; 2]) -> Result<Grid, McError> {
    let (m, var) = (stats.moments.mean.value, stats.moments.variance.value);
    if stats.samples == 0 || !m.is_finite() || !var.is_finite() {
        return Err(McError::NoPilotRange {
            name: stats.name.clone(),
        });
    }
    let sd = var.max(0.0).sqrt();
    let half = if sd > 0.0 {
        GRID_HALF_WIDTH_SDS * sd
    } else {
        0.5 * m.abs().max(1.0)
    };
    let (mut lo, mut hi) = (m - half, m + half);
    if stats.min >= 0.0 && lo < 0.0 && hi > 0.0 {
        lo = 0.0;
    }
    if stats.max <= 0.0 && hi > 0.0 && lo < 0.0 {
        hi = 0.0;
    }
    if lo < walls[0] && walls[0] < hi {
        lo = walls[0];
    }
    if hi > walls[1] && walls[1] > lo {
        hi = walls[1];
    }
    Grid::new(lo, hi, bins)
}
