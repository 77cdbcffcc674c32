//! Monte Carlo simulation of a bound model: the reference the EPC solution is checked against.
//!
//! Trajectories start from the stationary Gaussian of the drift linearised at the origin
//! (folded onto the barrier's side) and are integrated with a scheme matching the model (see
//! [`SchemeKind`]), impacts handled as events, and after a burn-in each trajectory's states
//! and observables are sampled at a fixed spacing into streaming histograms on fixed grids.
//! Trajectories run in statistics batches of [`McConfig::lanes`] (structure-of-arrays, one
//! random stream per trajectory); batches run in parallel and are reduced in batch order, so
//! a seed gives bit-identical results whatever the number of threads, and a run split into
//! [`Shard`]s merges ([`merge_shards`]) to exactly the unsplit result.
//!
//! ```
//! use fpsolve::mc::{reference, McConfig, Simulation};
//! // A linear oscillator z'' + c z' + k z = ξ: Var z = S/(2ck).
//! let model = reference::linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
//! let config = McConfig { trajectories: 256, samples: 200, seed: 1, ..McConfig::default() };
//! let result = Simulation::new(&model, &config).unwrap().run().unwrap();
//! let var = result.quantity("z").unwrap().variance;
//! assert!((var.value - 1.0).abs() < 5.0 * var.stderr + 0.02);
//! ```

// Lane loops index several structure-of-arrays columns in lockstep; iterator zips of four
// or five slices would hide that.
#![allow(clippy::needless_range_loop)]

mod ensemble;
mod error;
mod eval;
mod histogram;
mod impact;
pub mod reference;
mod rng;
mod scheme;
mod shard;

pub use ensemble::{
    BlowUp, ImpactStats, LastState, McResult, ParamValue, QuantitySpec, RunSettings,
};
pub use error::McError;
pub use histogram::{Estimate, Grid, QuantityStats};
pub use rng::Increments;
pub use scheme::{SchemeChoice, SchemeKind};
pub use shard::{merge_shards, Shard, ShardOutput};

use serde::{Deserialize, Serialize};

use crate::model::BoundModel;
use ensemble::{finalize_run, run_batches};
use scheme::Plan;

/// How long to run each trajectory before recording.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BurnIn {
    /// A multiple of the slowest decay time 1/λ of the drift linearised at the origin.
    DecayTimes(f64),
    /// A fixed time.
    Time(f64),
}

/// Settings of a Monte Carlo run. Start from [`McConfig::default`] and change fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct McConfig {
    /// Time step (default 0.01).
    pub dt: f64,
    /// Time between recorded samples, a whole number of steps (default 0.1).
    pub spacing: f64,
    /// Number of trajectories, rounded up to whole statistics batches (default 4096). Error
    /// bars come from the spread over batches: at least two are required, ~30 or more give
    /// trustworthy ones.
    pub trajectories: u64,
    /// Samples recorded per trajectory (default 1000).
    pub samples: u64,
    /// Burn-in before the first sample (default: 10 decay times).
    pub burn_in: BurnIn,
    /// Seed of all random streams (default 0).
    pub seed: u64,
    /// Trajectories per statistics batch, run together structure-of-arrays (default 128, the
    /// compiled tape's block length).
    pub lanes: usize,
    /// Bins of the grids chosen automatically (default 100).
    pub bins: usize,
    /// Histogram grids by quantity name; the others are chosen from a short pilot run
    /// (mean ± 6 standard deviations, cut at 0 for quantities the pilot never saw negative).
    pub grids: Vec<(String, Grid)>,
    /// Distribution of the noise increments (default three-point, see [`Increments`]).
    pub increments: Increments,
    /// Scheme selection (default automatic).
    pub scheme: SchemeChoice,
}

impl Default for McConfig {
    fn default() -> McConfig {
        McConfig {
            dt: 0.01,
            spacing: 0.1,
            trajectories: 4096,
            samples: 1000,
            burn_in: BurnIn::DecayTimes(10.0),
            seed: 0,
            lanes: 128,
            bins: 100,
            grids: Vec::new(),
            increments: Increments::default(),
            scheme: SchemeChoice::default(),
        }
    }
}

/// Samples per trajectory of the pilot run that chooses the automatic grids.
const PILOT_SAMPLES: u64 = 500;
/// Statistics batches of the pilot run.
const PILOT_BATCHES: u64 = 2;
/// Mixed into the seed so the pilot's trajectories are not the run's first ones.
const PILOT_SALT: u64 = 0x5049_4C4F_545F_5255;
/// Half-width of an automatic grid, in pilot standard deviations.
const GRID_HALF_WIDTH_SDS: f64 = 6.0;

/// A model compiled for simulation with its run settings resolved: ready to run whole or
/// in shards.
pub struct Simulation {
    plan: Plan,
    settings: RunSettings,
}

fn bad(name: &'static str, reason: String) -> McError {
    McError::BadSetting { name, reason }
}

impl Simulation {
    /// Compiles `model`, checks `config`, fixes the burn-in and the histogram grids (running
    /// the pilot if some grid is not given).
    pub fn new(model: &BoundModel, config: &McConfig) -> Result<Simulation, McError> {
        // No stationary law to sample: refused before any step (issue 9, item 13).
        crate::physics::check(model)?;
        let dt = config.dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(bad("dt", format!("must be a positive number, got {dt}")));
        }
        let ratio = config.spacing / dt;
        let steps_per_sample = ratio.round();
        if !(steps_per_sample >= 1.0 && (ratio - steps_per_sample).abs() <= 1e-6 * ratio) {
            return Err(bad(
                "spacing",
                format!(
                    "must be a positive whole number of steps dt = {dt}, got {}",
                    config.spacing
                ),
            ));
        }
        if config.lanes == 0 || config.lanes > 1 << 16 {
            return Err(bad(
                "lanes",
                format!("must lie in 1..=65536, got {}", config.lanes),
            ));
        }
        let batches = config.trajectories.div_ceil(config.lanes as u64);
        if batches < 2 {
            return Err(bad(
                "trajectories",
                format!(
                    "need at least two statistics batches of {} for error bars, got {}",
                    config.lanes, config.trajectories
                ),
            ));
        }
        if config.samples == 0 {
            return Err(bad("samples", "must be at least 1".into()));
        }
        if config.bins == 0 {
            return Err(bad("bins", "must be at least 1".into()));
        }
        let plan = Plan::new(model, config.scheme)?;
        let burn_in = match config.burn_in {
            BurnIn::Time(t) if t.is_finite() && t >= 0.0 => t,
            BurnIn::DecayTimes(k) if k.is_finite() && k >= 0.0 => {
                let rate = plan.slowest_decay_rate();
                if !(rate.is_finite() && rate > 0.0) {
                    return Err(McError::NoDecay { rate });
                }
                k / rate
            }
            other => {
                return Err(bad(
                    "burn_in",
                    format!("must be finite and ≥ 0, got {other:?}"),
                ))
            }
        };
        let mut names: Vec<(String, bool)> =
            model.states.iter().map(|s| (s.to_string(), true)).collect();
        names.extend(
            model
                .observables
                .iter()
                .map(|o| (o.name.to_string(), false)),
        );
        for (g, _) in &config.grids {
            if !names.iter().any(|(n, _)| n == g) {
                return Err(McError::UnknownQuantity { name: g.clone() });
            }
        }
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
            steps_per_sample: steps_per_sample as u64,
            burn_in_steps: (burn_in / dt).ceil() as u64,
            samples_per_trajectory: config.samples,
            lanes: config.lanes,
            batches,
            seed: config.seed,
            has_barrier: model.impact.is_some(),
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
                })
                .collect(),
        };
        let given = |n: &str| config.grids.iter().any(|(g, _)| g == n);
        if settings.quantities.iter().any(|q| !given(&q.name)) {
            let pilot = RunSettings {
                seed: config.seed ^ PILOT_SALT,
                batches: PILOT_BATCHES,
                samples_per_trajectory: config.samples.min(PILOT_SAMPLES),
                ..settings.clone()
            };
            let summaries = run_batches(&plan, &pilot, 0..PILOT_BATCHES);
            let refs: Vec<_> = summaries.iter().collect();
            let res = finalize_run(&pilot, &refs).map_err(|_| McError::NoPilotRange {
                name: settings.quantities[0].name.clone(),
            })?;
            for (spec, stats) in settings.quantities.iter_mut().zip(&res.quantities) {
                if !given(&spec.name) {
                    spec.grid = auto_grid(stats, config.bins)?;
                }
            }
        }
        Ok(Simulation { plan, settings })
    }

    /// The resolved settings (scheme, burn-in, grids, …).
    pub fn settings(&self) -> &RunSettings {
        &self.settings
    }

    /// Runs the whole simulation. Trajectories that blow up are listed in the result and left
    /// out; if all do, that is an error.
    pub fn run(&self) -> Result<McResult, McError> {
        let summaries = run_batches(&self.plan, &self.settings, 0..self.settings.batches);
        let refs: Vec<_> = summaries.iter().collect();
        finalize_run(&self.settings, &refs)
    }

    /// Runs one shard of the simulation; see [`merge_shards`].
    pub fn run_shard(&self, shard: Shard) -> Result<ShardOutput, McError> {
        if shard.count == 0 || shard.index >= shard.count || shard.count > self.settings.batches {
            return Err(bad(
                "shard",
                format!(
                    "shard {} of {} does not fit a run of {} statistics batches",
                    shard.index, shard.count, self.settings.batches
                ),
            ));
        }
        let range = shard.batch_range(self.settings.batches);
        Ok(ShardOutput {
            settings: self.settings.clone(),
            shard,
            batches: run_batches(&self.plan, &self.settings, range),
        })
    }
}

/// A grid covering mean ± 6 sd of the pilot samples, one-sided where the pilot saw only
/// values of one sign (|z|, energies).
fn auto_grid(stats: &QuantityStats, bins: usize) -> Result<Grid, McError> {
    let (m, var) = (stats.mean.value, stats.variance.value);
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
    Grid::new(lo, hi, bins)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::reference::{duffing, linear_oscillator, vibro_impact, VibroImpact};

    fn small(trajectories: u64) -> McConfig {
        McConfig {
            trajectories,
            lanes: 16,
            samples: 100,
            ..McConfig::default()
        }
    }

    #[test]
    fn blown_up_trajectories_are_reported_and_left_out() {
        // A softening spring, k z − z³: trajectories that cross |z| = 1 run off to infinity.
        let model = duffing(0.5, 1.0, -1.0, 0.12).bind(&[]).unwrap();
        let config = McConfig {
            grids: vec![
                ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
                ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ],
            ..small(64)
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let res = sim.run().unwrap();
        let total = sim.settings().trajectories();
        let lost = res.blowups.len() as u64;
        assert!(lost > 0 && lost < total, "{lost} of {total} blew up");
        assert_eq!(res.trajectories, total - lost);
        let mut seen = std::collections::HashSet::new();
        for b in &res.blowups {
            assert!(b.trajectory < total && seen.insert(b.trajectory));
            assert_eq!(b.params.len(), 4);
            if let Some(last) = &b.last_finite {
                assert!(last.step < b.step && last.state.iter().all(|s| s.is_finite()));
            }
        }
        let z = res.quantity("z").unwrap();
        assert!(z.mean.value.is_finite() && z.variance.value.is_finite());
        assert_eq!(z.samples, res.trajectories * 100);
        assert_eq!(z.invalid, 0);
    }

    #[test]
    fn a_run_where_every_trajectory_blows_up_is_an_error() {
        // Strong noise over a low barrier: every trajectory escapes to infinity.
        let model = duffing(0.5, 1.0, -1.0, 5.0).bind(&[]).unwrap();
        let config = McConfig {
            grids: vec![
                ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
                ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ],
            ..small(32)
        };
        let sim = Simulation::new(&model, &config).unwrap();
        assert_eq!(sim.run(), Err(McError::AllBlewUp { blowups: 32 }));
    }

    #[test]
    fn schemes_are_chosen_from_the_model_form() {
        let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&lin, &small(32)).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::MechanicalStrang);
        let general = McConfig {
            scheme: SchemeChoice::General,
            ..small(32)
        };
        let sim = Simulation::new(&lin, &general).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::Heun);
        // Noise in the x-equation: not mechanical.
        let mut m = linear_oscillator(0.5, 1.0, 1.0);
        m.noise_matrix[0] = vec![crate::symbolic::Expr::num(0.1)];
        let sim = Simulation::new(&m.bind(&[]).unwrap(), &small(32)).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::Heun);
        m.interpretation = crate::model::Interpretation::Ito;
        let sim = Simulation::new(&m.bind(&[]).unwrap(), &small(32)).unwrap();
        assert_eq!(sim.settings().scheme, SchemeKind::EulerMaruyama);
    }

    #[test]
    fn burn_in_is_ten_decay_times_of_the_linearisation() {
        // z'' + 0.4 z' + z: eigenvalues −0.2 ± i·0.98, decay time 5.
        let lin = linear_oscillator(0.4, 1.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&lin, &small(32)).unwrap();
        assert_eq!(sim.settings().burn_in_steps, 5000);
        // Overdamped z'' + 5 z' + 4 z: eigenvalues −1 and −4, the slow one decides.
        let od = linear_oscillator(5.0, 4.0, 1.0).bind(&[]).unwrap();
        let sim = Simulation::new(&od, &small(32)).unwrap();
        assert_eq!(sim.settings().burn_in_steps, 1000);
        // No damping: no stationary law at all, refused before the burn-in is estimated.
        let free = linear_oscillator(0.0, 1.0, 1.0).bind(&[]).unwrap();
        assert!(matches!(
            Simulation::new(&free, &small(32)),
            Err(McError::Inadmissible(
                crate::physics::Inadmissible::NoDamping { .. }
            ))
        ));
    }

    #[test]
    fn automatic_grids_cover_the_pilot_and_fold_at_zero() {
        let p = VibroImpact {
            c: 0.5,
            k: 1.0,
            mu: 1.0,
            eps: 0.0,
            r: 0.9,
            big_k: 0.1,
        };
        let m = vibro_impact(p).bind(&[]).unwrap();
        let sim = Simulation::new(&m, &small(32)).unwrap();
        let q = &sim.settings().quantities;
        let names: Vec<&str> = q.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["z", "v", "y", "ydot"]);
        assert_eq!(q[2].grid.lo, 0.0, "y = |z| is never negative");
        assert!(q[0].grid.lo < -0.5 && q[0].grid.hi > 0.5);
        assert_eq!(q[0].grid.bins, 100);
    }

    #[test]
    fn bad_settings_are_errors() {
        let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
        let bad = |c: McConfig| Simulation::new(&lin, &c).err().unwrap();
        assert!(matches!(
            bad(McConfig {
                dt: 0.0,
                ..small(32)
            }),
            McError::BadSetting { name: "dt", .. }
        ));
        assert!(matches!(
            bad(McConfig {
                spacing: 0.015,
                ..small(32)
            }),
            McError::BadSetting {
                name: "spacing",
                ..
            }
        ));
        assert!(matches!(
            bad(small(16)),
            McError::BadSetting {
                name: "trajectories",
                ..
            }
        ));
        let unknown = McConfig {
            grids: vec![("w".into(), Grid::new(0.0, 1.0, 2).unwrap())],
            ..small(32)
        };
        assert!(matches!(bad(unknown), McError::UnknownQuantity { .. }));
    }

    #[test]
    fn a_delta_term_without_an_impact_law_is_an_error() {
        let p = VibroImpact {
            c: 0.5,
            k: 1.0,
            mu: 1.0,
            eps: 0.0,
            r: 0.9,
            big_k: 0.1,
        };
        let mut m = vibro_impact(p);
        m.impact = None;
        assert!(matches!(
            Simulation::new(&m.bind(&[]).unwrap(), &small(32)),
            Err(McError::DeltaWithoutImpact { .. })
        ));
    }

    /// `v' = −c v − k z + ξ₀ + σ v ξ₁` (independent sources of intensities s₀, s₁): the
    /// stationary E[v²] is s₀/(2c − s₁σ²) read as Itô and s₀/(2c − 2s₁σ²) read as
    /// Stratonovich (Wong–Zakai adds ½s₁σ²·v to the drift).
    fn velocity_noise(interpretation: crate::model::Interpretation, seed: u64) -> McResult {
        use crate::model::NoiseSource;
        use crate::symbolic::Expr;
        let mut m = linear_oscillator(0.5, 1.0, 1.0);
        m.noises.push(NoiseSource {
            name: "xi1".into(),
            intensity: Expr::num(1.0),
        });
        m.noise_matrix = [
            vec![Expr::num(0.0), Expr::num(0.0)],
            vec![Expr::num(1.0), Expr::num(0.5) * Expr::sym("v")],
        ];
        m.interpretation = interpretation;
        let config = McConfig {
            dt: 0.005,
            spacing: 0.5,
            trajectories: 512,
            lanes: 16,
            samples: 200,
            seed,
            grids: vec![
                ("z".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
                ("v".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
            ],
            ..McConfig::default()
        };
        Simulation::new(&m.bind(&[]).unwrap(), &config)
            .unwrap()
            .run()
            .unwrap()
    }

    #[test]
    fn ito_and_stratonovich_readings_reach_their_own_exact_variances() {
        use crate::model::Interpretation;
        for (interp, exact, kind) in [
            (
                Interpretation::Ito,
                1.0 / (1.0 - 0.25),
                SchemeKind::EulerMaruyama,
            ),
            (
                Interpretation::Stratonovich,
                1.0 / (1.0 - 0.5),
                SchemeKind::Heun,
            ),
        ] {
            let res = velocity_noise(interp, 4);
            assert_eq!(res.settings.scheme, kind);
            let var = res.quantity("v").unwrap().variance;
            eprintln!("{interp:?}: {} ± {} (exact {exact})", var.value, var.stderr);
            assert!(
                (var.value - exact).abs() < 4.5 * var.stderr,
                "{interp:?}: {} ± {} vs {exact}",
                var.value,
                var.stderr
            );
        }
    }

    #[test]
    fn fully_correlated_sources_have_a_singular_square_root() {
        let l = scheme::psd_sqrt(&[vec![4.0, 2.0], vec![2.0, 1.0]]).unwrap();
        assert_eq!(l, vec![2.0, 0.0, 1.0, 0.0]);
        assert!(matches!(
            scheme::psd_sqrt(&[vec![1.0, 2.0], vec![2.0, 1.0]]),
            Err(McError::IntensityNotPsd { .. })
        ));
    }
}
