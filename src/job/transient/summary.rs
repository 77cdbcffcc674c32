//! `summary.json` of a transient: where it came from, the methods, the start, the grid's
//! report and Monte Carlo's settings, and at each output the grid's masses, Monte Carlo's
//! moments with their standard errors, and the grid's distance to Monte Carlo in its
//! standard errors.

use serde::Serialize;

use super::TransientRun;
use crate::grid::TransientHistory;
use crate::mc::McTransientHistory;
use crate::model::{BoundModel, InitialState, Provenance};
use crate::report::UndefinedField;

/// The start as `summary.json` writes it.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum InitialJson {
    Rest,
    Point {
        at: [f64; 2],
    },
    Gaussian {
        mean: [f64; 2],
        covariance: [[f64; 2]; 2],
    },
}

impl From<InitialState> for InitialJson {
    fn from(s: InitialState) -> Self {
        match s {
            InitialState::Rest => InitialJson::Rest,
            InitialState::Point(at) => InitialJson::Point { at },
            InitialState::Gaussian { mean, covariance } => {
                InitialJson::Gaussian { mean, covariance }
            }
        }
    }
}

#[derive(Serialize)]
struct Output<'a> {
    t: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    grid: Option<GridOutput<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mc: Option<McOutput>,
    /// (grid − MC)/MC's standard error of each state's mean, variance and kurtosis (null
    /// where the standard error is 0, as at a point start).
    #[serde(skip_serializing_if = "Option::is_none")]
    grid_vs_mc_in_se: Option<Vec<Distance>>,
}

#[derive(Serialize)]
struct GridOutput<'a> {
    mass: f64,
    negative_mass: f64,
    edge_mass: f64,
    /// The estimated errors of the output's numbers (from the run on half the cells).
    #[serde(skip_serializing_if = "Option::is_none")]
    estimate: Option<&'a crate::grid::SnapshotErrors>,
}

#[derive(Serialize)]
struct McOutput {
    blown_up: u64,
    /// Each state's moments with standard errors and time-step bias.
    moments: Vec<crate::mc::McStateMoments>,
    /// The fraction of each state's trajectories outside the histogram's bins.
    outside_bins: Vec<f64>,
}

#[derive(Serialize)]
struct Distance {
    state: String,
    mean: Option<f64>,
    variance: Option<f64>,
    kurtosis: Option<f64>,
    /// The largest |grid − MC|/se over the bins where MC's se is positive.
    pdf_worst: Option<f64>,
}

#[derive(Serialize)]
struct McSummary<'a> {
    settings: &'a crate::mc::McTransientSettings,
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    method: String,
    initial: InitialJson,
    times: usize,
    /// The run's settings and what it did (cells, box, tolerance, steps, factorisations).
    #[serde(skip_serializing_if = "Option::is_none")]
    grid: Option<&'a crate::grid::TransientReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mc: Option<McSummary<'a>>,
    /// The period map's residual and counts, when a period was given (outputs' `t` are
    /// then phases).
    #[serde(skip_serializing_if = "Option::is_none")]
    periodic: Option<&'a crate::grid::PeriodicReport>,
    /// Monte Carlo's periodic state, when a period was given: the periods discarded (the
    /// pilot's choice) and recorded at each phase.
    #[serde(skip_serializing_if = "Option::is_none")]
    mc_periodic: Option<&'a crate::mc::McPeriodicReport>,
    outputs: Vec<Output<'a>>,
}

/// (a − b)/se, `None` where se is 0 or anything is not finite.
fn in_se(a: f64, b: f64, se: f64) -> Option<f64> {
    let d = (a - b) / se;
    (se > 0.0 && d.is_finite()).then_some(d)
}

/// Grid against MC at output `k`, per state.
fn distances(
    states: &[String],
    g: &TransientHistory,
    m: &McTransientHistory,
    k: usize,
) -> Vec<Distance> {
    let (gs, ms) = (&g.snapshots[k], &m.snapshots[k]);
    states
        .iter()
        .enumerate()
        .map(|(a, q)| {
            let (gm, mm) = (&gs.moments[a], &ms.moments[a]);
            let pdf_worst = ms.densities.as_ref().and_then(|d| {
                let d = &d[a];
                let worst = gs.marginals[a]
                    .density
                    .iter()
                    .zip(d.density.iter().zip(&d.stderr))
                    .filter_map(|(g, (m, se))| in_se(*g, *m, *se))
                    .map(f64::abs)
                    .fold(f64::NAN, f64::max);
                worst.is_finite().then_some(worst)
            });
            Distance {
                state: q.clone(),
                mean: in_se(gm.mean, mm.mean.value, mm.mean.stderr),
                variance: in_se(gm.variance, mm.variance.value, mm.variance.stderr),
                kurtosis: in_se(gm.kurtosis, mm.kurtosis.value, mm.kurtosis.stderr),
                pdf_worst,
            }
        })
        .collect()
}

impl TransientRun {
    /// `summary.json`'s text (pretty-printed, a final newline, `provenance` first) and the
    /// numbers that have no finite value: each is written as null and listed under
    /// `undefined` (the kurtosis of a point start, whose variance is 0), never a lost run.
    ///
    /// ```
    /// use fpsolve::grid::Domain;
    /// use fpsolve::job::transient::TransientSettings;
    /// use fpsolve::report::Provenance;
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let mut s = TransientSettings::new(vec![0.0, 0.5]);
    /// (s.cells, s.domain) = ([32, 32], Some(Domain { x: [-8.0, 8.0], v: [-8.0, 8.0] }));
    /// let run = s.check(&bound)?.run(&bound)?;
    /// let (text, undefined) = run.summary_json(&bound, Provenance::now_bound(&bound))?;
    /// assert!(text.starts_with("{\n  \"provenance\"") && undefined.is_empty());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// serde's, should a number fail to serialise.
    pub fn summary_json(
        &self,
        bound: &BoundModel,
        provenance: Provenance,
    ) -> Result<(String, Vec<UndefinedField>), serde_json::Error> {
        crate::report::json_flagging_undefined(&self.summary(bound, provenance))
    }

    fn summary(&self, bound: &BoundModel, provenance: Provenance) -> Summary<'_> {
        let states: Vec<String> = bound.states().iter().map(|s| s.to_string()).collect();
        let outputs = self
            .times()
            .iter()
            .enumerate()
            .map(|(k, &t)| Output {
                t,
                grid: self.grid.as_ref().map(|g| {
                    let s = &g.snapshots[k];
                    GridOutput {
                        mass: s.mass,
                        negative_mass: s.negative_mass,
                        edge_mass: s.edge_mass,
                        estimate: s.estimate.as_ref(),
                    }
                }),
                mc: self.mc.as_ref().map(|m| {
                    let s = &m.snapshots[k];
                    McOutput {
                        blown_up: s.blown_up,
                        moments: s.moments.to_vec(),
                        outside_bins: s
                            .densities
                            .as_ref()
                            .map(|d| d.iter().map(|d| d.outside).collect())
                            .unwrap_or_default(),
                    }
                }),
                grid_vs_mc_in_se: match (&self.grid, &self.mc) {
                    (Some(g), Some(m)) => Some(distances(&states, g, m, k)),
                    _ => None,
                },
            })
            .collect();
        Summary {
            provenance,
            method: self.settings.methods.to_string(),
            initial: self.settings.initial.into(),
            times: self.settings.times.len(),
            grid: self.grid.as_ref().map(|g| &g.report),
            mc: self.mc.as_ref().map(|m| McSummary {
                settings: &m.settings,
            }),
            periodic: self.periodic.as_ref(),
            mc_periodic: self.mc_periodic.as_ref(),
            outputs,
        }
    }
}
