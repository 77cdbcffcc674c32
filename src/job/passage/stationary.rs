//! The stationary statistics a reliability run reports beside the first passage: the mean
//! up-crossing rates ν⁺(u) of the states and observables (`crossings_<q>.csv`, their
//! figures) and the impact statistics at every wall, computed and written by the main job's
//! code (`job::reliability`) from a grid study of the model on the run's cells (and box,
//! when given), with Monte Carlo's counts beside them when Monte Carlo runs.
//!
//! The first passage's own stationary solve (the safe set's mass) is not reused: it is made
//! on a box moved to the safe set's ends, without the curves and the error estimate of every
//! derived number that the stationary grid study gives. The study costs a stationary solve
//! and one on half the cells (the error estimate), run beside the first passage's solves: at
//! 200×400 cells, one after the other on a loaded 2-core machine, 0.44–0.55 s against
//! 0.5–1.2 s for the mean times alone (case 1, the linear and the Duffing oscillator), as
//! much again for a run of the mean times only, a few per cent beside R(t) to a few mean
//! times (tens of seconds).
//!
//! The stationary Monte Carlo is the stationary kernel of `fpsolve simulate` with its
//! defaults (4096 trajectories of 1000 samples, the whole number of steps nearest 0.1 apart,
//! after a burn-in of 10 decay times) at the run's dt and seed, counting crossings on the
//! tables' levels and recording the impacts; its failure leaves the grid's numbers standing,
//! with why.

use std::time::Instant;

use serde::Serialize;

use crate::job::reliability::{mc_levels, mc_speed_grid, ReliabilityTables};
use crate::job::{simulate, Quiet, ReliabilitySummary};
use crate::mc::{McConfig, McResult};
use crate::model::BoundModel;
use crate::solve::{quantities, MethodName, MethodSet, NotApplicable, Problem};
use crate::study::{MethodPlan, StudyRunner};

/// How the stationary statistics of a reliability run were computed, or why they were not.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum StationaryReport {
    /// Computed by a grid study (and Monte Carlo when it ran).
    Computed {
        /// The grid's cells.
        cells: [usize; 2],
        /// The grid study's wall time, ms.
        grid_ms: f64,
        /// The stationary Monte Carlo, when it ran.
        #[serde(skip_serializing_if = "Option::is_none")]
        mc: Option<StationaryMc>,
    },
    /// Not computed.
    NotComputed {
        /// Why (a model without a stationary density, the grid not run, its solve failed).
        why: String,
    },
}

/// The stationary Monte Carlo's settings and cost, or why it gave no result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StationaryMc {
    /// Trajectories run (whole statistics batches).
    pub trajectories: u64,
    /// Samples per trajectory.
    pub samples: u64,
    /// Time step.
    pub dt: f64,
    /// Seed.
    pub seed: u64,
    /// Wall time, ms.
    pub wall_ms: f64,
    /// Why the run gave no result, or why its result is not to be trusted (its verdict).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The stationary statistics of a reliability run: the crossing tables and the walls'
/// impact statistics, with how they were computed.
#[derive(Clone, Debug)]
pub struct StationaryStatistics {
    tables: Option<ReliabilityTables>,
    /// How they were computed, or why not.
    pub report: StationaryReport,
}

impl StationaryStatistics {
    /// Not computed, for `why`.
    pub(super) fn not_computed(why: impl Into<String>) -> StationaryStatistics {
        StationaryStatistics {
            tables: None,
            report: StationaryReport::NotComputed { why: why.into() },
        }
    }

    /// The grid study on `cells` (and `problem`'s box), then, with `mc` (dt, seed), the
    /// stationary Monte Carlo on the tables' levels.
    pub(super) fn solve(
        bound: &BoundModel,
        domain: Option<crate::grid::Domain>,
        cells: [usize; 2],
        mc: Option<(f64, u64)>,
    ) -> StationaryStatistics {
        let started = Instant::now();
        let problem = match Problem::new(bound) {
            Ok(p) => p.with_grid_domain(domain),
            Err(e) => return StationaryStatistics::not_computed(e.to_string()),
        };
        if let Err(e) = problem.dynamics().admissible() {
            return StationaryStatistics::not_computed(format!("no stationary density: {e}"));
        }
        let grid = MethodSet::new(vec![MethodName::Grid]).expect("one method");
        let plan = match MethodPlan::new(&problem, &grid, true) {
            Ok(plan) => plan,
            Err(e) => return StationaryStatistics::not_computed(e.to_string()),
        };
        let names: Vec<String> = quantities(bound).into_iter().map(|q| q.name).collect();
        // As the main job: the grid's PDFs of observables that take minutes are left out.
        let without: Vec<String> = plan
            .skipped_curves
            .iter()
            .flat_map(|s| match &s.why {
                NotApplicable::JumpingObservables { observables } => observables.clone(),
                _ => Vec::new(),
            })
            .collect();
        let study = match StudyRunner::of(&problem)
            .curves_of(&names)
            .methods(&[MethodName::Grid])
            .cells(cells)
            .without_curves_of(MethodName::Grid, &without)
            .run()
        {
            Ok(study) => study,
            Err(e) => return StationaryStatistics::not_computed(e.to_string()),
        };
        if let Some(Err(e)) = study.run_of(MethodName::Grid).map(|r| r.outcome.as_ref()) {
            return StationaryStatistics::not_computed(format!("the stationary grid solve: {e}"));
        }
        let grid_ms = started.elapsed().as_secs_f64() * 1e3;
        let (result, mc_report) = match mc {
            None => (None, None),
            Some((dt, seed)) => {
                // The whole number of steps nearest the default sample spacing, at least one.
                let spacing = dt * (McConfig::default().spacing / dt).round().max(1.0);
                let mut config = McConfig {
                    dt,
                    spacing,
                    seed,
                    levels: mc_levels(&problem, &study, &names),
                    ..McConfig::default()
                };
                config.impact_speeds = mc_speed_grid(&problem, &study, &config);
                let started = Instant::now();
                let run = simulate(problem.dynamics(), &config, &Quiet);
                let (result, error): (Option<McResult>, Option<String>) = match run {
                    Ok(r) => {
                        let verdict = r.verdict().err().map(|e| e.to_string());
                        (Some(r), verdict)
                    }
                    Err(e) => (None, Some(e.to_string())),
                };
                let report = StationaryMc {
                    trajectories: result.as_ref().map_or(config.trajectories, |r| {
                        r.settings.batches * r.settings.lanes as u64
                    }),
                    samples: config.samples,
                    dt,
                    seed,
                    wall_ms: started.elapsed().as_secs_f64() * 1e3,
                    error,
                };
                (result, Some(report))
            }
        };
        StationaryStatistics {
            tables: Some(ReliabilityTables::of(
                &problem,
                &study,
                &names,
                result.as_ref(),
            )),
            report: StationaryReport::Computed {
                cells,
                grid_ms,
                mc: mc_report,
            },
        }
    }

    /// What `summary.json` lists: the crossing tables, the quantities without one and why,
    /// the impact statistics at every wall (empty when not computed).
    pub fn summary(&self) -> ReliabilitySummary {
        self.tables
            .as_ref()
            .map(ReliabilityTables::summary)
            .unwrap_or_default()
    }

    /// Each crossing table's quantity and `crossings_<q>.csv`'s text.
    pub fn crossing_tables(&self) -> Vec<(&str, &str)> {
        self.tables.as_ref().map_or(Vec::new(), |t| {
            t.crossings()
                .iter()
                .map(|c| (c.quantity.as_str(), c.text.as_str()))
                .collect()
        })
    }

    /// The tables the command line writes.
    pub(super) fn tables(&self) -> Option<&ReliabilityTables> {
        self.tables.as_ref()
    }
}
