//! The reliability outputs from every stationary method that ran, of the main job and of
//! `fpsolve reliability` (whose grid study is its own stationary solve):
//! - `crossings_<q>.csv`: Rice's mean up-crossing rate ν⁺(u) of each reported state and
//!   observable that has one, on the levels of its PDF curve (`pdf_<q>.csv`'s first column),
//!   one column per method and degree, the grid's followed by its error bound (empty where
//!   the rate is below [`TAIL_LEVEL`] of its peak: the estimate is not trusted there), and
//!   with figures its figure `crossings_<q>.png/.svg` (linear and log panels);
//! - at each wall, the impact statistics (rate, mean impact speed, mean dissipated power) in
//!   `summary.json` under `impacts`, from the methods whose density is in the model's own
//!   coordinates (the grid, EPC with the exact impact condition), the grid's with their
//!   errors, and the flux-weighted impact-speed PDFs in `impact_speeds_<state>_<side>.csv`.
//!
//! A quantity without a finite rate (a velocity driven by white noise) or whose level sets the
//! rate formula does not cover is listed under `no_crossings` with the reason.
//!
//! With a Monte Carlo run (run by the job, or read with `--mc-from` when its levels and speed
//! grid are these), its numbers go beside the others: in a crossing table the columns `mc`
//! (up-crossings counted between sample points per unit time per trajectory, through the
//! impacts in between; at a wall's level one per impact, as Rice's flux there), `mc_se` (its
//! batch-means standard error) and `mc_bias` (its stated bias: the sample spacing's, from
//! counting on every other sample point, plus the time-step bias from the 2·dt run when the
//! run estimated one); at a wall a row `mc` in `impacts` with standard errors and time-step
//! biases instead of error bounds, and the columns `mc`, `mc_se` of the impact-speed table
//! (a histogram whose bins are centred on the table's speeds).

mod figure;

use std::path::PathBuf;

use rayon::prelude::*;
use serde::Serialize;

use super::Unwritten;
use crate::grid::TAIL_LEVEL;
use crate::mc::{CrossingRates, Grid, McConfig, McResult};
use crate::model::BarrierSide;
use crate::observe::LevelRate;
use crate::observe::{
    crossing_rate, crossings_csv, crossings_file_name, impact_statistics, CrossingCurve,
    CrossingError, ImpactStatistics,
};
use crate::report::{short_number, OutputDir, PdfTable, ReportError};
use crate::solve::Problem;
use crate::study::Study;

/// Points of an impact-speed PDF, from 0 to the density's velocity extent.
const SPEED_POINTS: usize = 201;

/// What the reliability outputs add to `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ReliabilitySummary {
    /// The crossing tables written, one per quantity.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub crossings: Vec<CrossingFile>,
    /// The quantities reported without a crossing table, and why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub no_crossings: Vec<NoCrossings>,
    /// The impact statistics at every wall, by every method whose density is in the model's
    /// coordinates.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub impacts: Vec<WallImpacts>,
}

/// One quantity's crossing table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossingFile {
    /// The state or observable.
    pub quantity: String,
    /// The file's name.
    pub file: String,
}

/// A quantity without a crossing table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoCrossings {
    /// The state or observable.
    pub quantity: String,
    /// Why it has none.
    pub why: String,
}

/// The impact statistics at one wall by one method (per unit mass, in the model's
/// coordinates); the errors are the method's discretisation estimate plus the integrals'
/// accuracy, absent for a method without an estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WallImpacts {
    /// The method (and degree), as the tables' columns name it.
    pub method: String,
    /// The state that meets the wall.
    pub state: String,
    /// The wall's position.
    pub at: f64,
    /// The side of the wall the state lives on.
    pub side: BarrierSide,
    /// The impact law as written.
    pub law: String,
    /// Impacts per unit time.
    pub rate: f64,
    /// The mean impact speed, flux-weighted.
    pub mean_speed: f64,
    /// The mean power the impacts dissipate.
    pub mean_power: f64,
    /// Bound on the error of `rate`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rate_error: Option<f64>,
    /// Bound on the error of `mean_speed`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_speed_error: Option<f64>,
    /// Bound on the error of `mean_power`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_power_error: Option<f64>,
    /// The relative accuracy of the quadrature over the method's density alone (0 for Monte
    /// Carlo, which has none), `quadrature_accuracy` in `summary.json`: not an error bound
    /// of the numbers (EPC and EPC-impact state none; the grid's are the `*_error` fields,
    /// Monte Carlo's `stderr` and `time_step_bias`).
    #[serde(rename = "quadrature_accuracy")]
    pub accuracy: f64,
    /// Monte Carlo's batch-means standard errors of `rate`, `mean_speed`, `mean_power`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stderr: Option<[f64; 3]>,
    /// Monte Carlo's time-step biases (S_dt − S, from the 2·dt run) of `rate`, `mean_speed`,
    /// `mean_power`, when the run estimated them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_step_bias: Option<[f64; 3]>,
    /// For a method that states no error (EPC, EPC-impact: an approximation), its `rate`,
    /// `mean_speed` and `mean_power` minus the grid's at the same wall, when the grid ran:
    /// the one measure of its error the run has; `no_error_bound` in `summary.json` says so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub minus_grid: Option<[f64; 3]>,
    /// Why the row has no error bound (a method that states none), `None` for the grid's and
    /// Monte Carlo's rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_error_bound: Option<&'static str>,
    /// The file holding the impact-speed PDF.
    pub speed_pdf_file: String,
}

/// Why a method's impact row has no error bound.
const NO_ERROR_BOUND: &str = "an approximation that states no error (the closure's); its \
     distance from the grid's numbers is `minus_grid` when the grid ran";

/// What writing the reliability outputs gave.
pub(crate) struct Written {
    pub(crate) files: Vec<PathBuf>,
    pub(crate) unwritten: Vec<Unwritten>,
    pub(crate) summary: ReliabilitySummary,
}

/// The crossing tables and impact statistics of one study, computed and not yet written
/// (see the module documentation): what [`ReliabilityTables::write`] writes and
/// [`ReliabilityTables::summary`] lists, so that a front end without files (Python) reports
/// the same numbers.
#[derive(Clone, Debug)]
pub(crate) struct ReliabilityTables {
    crossings: Vec<CrossingTable>,
    no_crossings: Vec<NoCrossings>,
    walls: Vec<WallTable>,
}

/// One quantity's crossing table: its CSV text, and the curves and Monte Carlo's counts it
/// holds (for the figure).
#[derive(Clone, Debug)]
pub(crate) struct CrossingTable {
    /// The state or observable.
    pub(crate) quantity: String,
    /// `crossings_<q>.csv`'s text.
    pub(crate) text: String,
    /// Each method's curve, by its column's label.
    curves: Vec<(String, CrossingCurve)>,
    /// Monte Carlo's counts, when they are on the table's levels.
    mc: Option<CrossingRates>,
}

/// One wall's impact statistics: the rows of `summary.json` and the impact-speed table.
#[derive(Clone, Debug)]
struct WallTable {
    file: String,
    table: PdfTable,
    rows: Vec<WallImpacts>,
}

impl ReliabilityTables {
    /// The crossing tables of `names` and the impact statistics of every wall from
    /// `study`'s solutions of `problem`, with Monte Carlo's counts beside them when `mc` has
    /// them.
    pub(crate) fn of(
        problem: &Problem,
        study: &Study,
        names: &[String],
        mc: Option<&McResult>,
    ) -> ReliabilityTables {
        let mut tables = ReliabilityTables {
            crossings: Vec::new(),
            no_crossings: Vec::new(),
            walls: Vec::new(),
        };
        for name in names {
            match crossing_curves(problem, study, name) {
                Ok(Some(curves)) => {
                    let refs: Vec<(&str, &CrossingCurve)> =
                        curves.iter().map(|(l, c)| (l.as_str(), c)).collect();
                    let text = match crossings_csv(&refs) {
                        Ok(text) => text,
                        Err(e) => {
                            tables.no_crossings.push(NoCrossings {
                                quantity: name.clone(),
                                why: e.to_string(),
                            });
                            continue;
                        }
                    };
                    let rates = mc
                        .and_then(|m| m.crossings.iter().find(|c| &c.quantity == name))
                        .filter(|r| curves[0].1.levels.len() == r.levels.len());
                    let text = match rates {
                        Some(rates) => with_mc_columns(&text, rates),
                        None => text,
                    };
                    tables.crossings.push(CrossingTable {
                        quantity: name.clone(),
                        text,
                        curves,
                        mc: rates.cloned(),
                    });
                }
                Ok(None) => {}
                Err(e) => tables.no_crossings.push(NoCrossings {
                    quantity: name.clone(),
                    why: e.to_string(),
                }),
            }
        }
        tables.walls = impacts(problem, study, mc);
        tables
    }

    /// The crossing tables.
    pub(crate) fn crossings(&self) -> &[CrossingTable] {
        &self.crossings
    }

    /// What `summary.json` lists: every crossing table, the quantities without one, every
    /// wall's statistics.
    pub(crate) fn summary(&self) -> ReliabilitySummary {
        ReliabilitySummary {
            crossings: self
                .crossings
                .iter()
                .map(|c| CrossingFile {
                    quantity: c.quantity.clone(),
                    file: crossings_file_name(&c.quantity),
                })
                .collect(),
            no_crossings: self.no_crossings.clone(),
            impacts: self.walls.iter().flat_map(|w| w.rows.clone()).collect(),
        }
    }

    /// Writes the tables into `out`, and with a `caption` (the model's name, a subtitle)
    /// the crossing figures `crossings_<q>.png/.svg` ([`figure::crossing_figure`]); a table
    /// or figure that cannot be written is listed with why, and a crossing table not written
    /// is not listed in the summary.
    pub(crate) fn write(&self, out: &OutputDir, caption: Option<(&str, &str)>) -> Written {
        let mut written = Written {
            files: Vec::new(),
            unwritten: Vec::new(),
            summary: ReliabilitySummary {
                no_crossings: self.no_crossings.clone(),
                ..ReliabilitySummary::default()
            },
        };
        for table in &self.crossings {
            let file = crossings_file_name(&table.quantity);
            match out.write_atomic(&file, table.text.as_bytes()) {
                Ok(path) => {
                    written.files.push(path);
                    written.summary.crossings.push(CrossingFile {
                        quantity: table.quantity.clone(),
                        file,
                    });
                }
                Err(e) => written.unwritten.push(Unwritten {
                    file,
                    error: e.to_string(),
                }),
            }
        }
        if let Some((model, subtitle)) = caption {
            // The figures side by side, listed in the tables' order.
            let drawn: Vec<_> = self
                .crossings
                .par_iter()
                .map(|t| {
                    let stem = format!("crossings_{}", t.quantity);
                    let figure = figure::crossing_figure(model, subtitle, t);
                    (stem.clone(), figure.write(out, &stem))
                })
                .collect();
            for (stem, result) in drawn {
                match result {
                    Ok(f) => written.files.extend([f.png, f.svg]),
                    Err(e) => written.unwritten.push(Unwritten {
                        file: format!("{stem}.png/.svg"),
                        error: match e {
                            ReportError::Figure { source, .. } => source.to_string(),
                            e => e.to_string(),
                        },
                    }),
                }
            }
        }
        for wall in &self.walls {
            match wall.table.write_csv(out, &wall.file) {
                Ok(path) => written.files.push(path),
                Err(e) => written.unwritten.push(Unwritten {
                    file: wall.file.clone(),
                    error: e.to_string(),
                }),
            }
            written.summary.impacts.extend(wall.rows.iter().cloned());
        }
        written
    }
}

/// Writes the crossing tables of `names` and the impact statistics of every wall (see the
/// module documentation) from `study`'s solutions of `problem`, with the crossing figures
/// when `figures`.
pub(super) fn write(
    problem: &Problem,
    study: &Study,
    names: &[String],
    mc: Option<&McResult>,
    figures: bool,
    out: &OutputDir,
) -> Written {
    let model = problem.model();
    let subtitle = model
        .params()
        .iter()
        .map(|(p, v)| format!("{p} = {}", short_number(*v)))
        .collect::<Vec<_>>()
        .join(", ");
    ReliabilityTables::of(problem, study, names, mc)
        .write(out, figures.then_some((model.name(), subtitle.as_str())))
}

/// The levels of the crossing tables Monte Carlo can count beside the other methods: each of
/// `names` whose curve the study has and whose rate is finite in the model's coordinates,
/// but a periodic state.
pub(super) fn mc_levels(
    problem: &Problem,
    study: &Study,
    names: &[String],
) -> Vec<(String, Vec<f64>)> {
    let model = problem.model();
    // A periodic state's crossings are not counted by Monte Carlo (its recorded values jump
    // at the seam).
    let periodic = model
        .periodic()
        .map(|p| model.states()[p.state].to_string());
    names
        .iter()
        .filter(|name| periodic.as_ref() != Some(*name))
        .filter_map(|name| {
            let curve = study.curves.iter().find(|c| &c.name == name)?;
            let rate = match model.states().iter().position(|s| s.as_ref() == name) {
                Some(i) => LevelRate::of_state(model, i),
                None => LevelRate::of_observable(model, name),
            };
            let ascending = curve.x.windows(2).all(|w| w[0] < w[1]);
            (rate.is_ok() && ascending && !curve.x.is_empty())
                .then(|| (name.clone(), curve.x.clone()))
        })
        .collect()
}

/// The speeds of the impact-speed tables: from 0 to the velocity extent of the first density
/// in the model's coordinates, in [`SPEED_POINTS`] points; `None` without one.
fn speed_points(problem: &Problem, study: &Study) -> Option<Vec<f64>> {
    let model = problem.model();
    let density = study.runs.iter().find_map(|run| {
        let solution = run.solution()?;
        std::ptr::eq(run.name().method().density_model(problem), model).then(|| solution.joint())
    })?;
    let top = density.extent()[1][1].max(-density.extent()[1][0]);
    Some(
        (0..SPEED_POINTS)
            .map(|k| top * k as f64 / (SPEED_POINTS - 1) as f64)
            .collect(),
    )
}

/// Monte Carlo's impact-speed grid for a model with a wall: bins centred on the speed
/// tables' points (from the study's density, else from 0 to the largest speed of the
/// velocity's histogram grid in `config`), `None` without a wall or a range.
pub(super) fn mc_speed_grid(problem: &Problem, study: &Study, config: &McConfig) -> Option<Grid> {
    let model = problem.model();
    let wall = model.impacts().iter().find(|i| i.side.is_some())?;
    let top = match speed_points(problem, study) {
        Some(x) => *x.last()?,
        None => {
            let v = model.states()[wall.other].to_string();
            let (_, g) = config.grids.iter().find(|(n, _)| n == &v)?;
            g.hi.max(-g.lo)
        }
    };
    let half = 0.5 * top / (SPEED_POINTS - 1) as f64;
    Grid::new(-half, top + half, SPEED_POINTS).ok()
}

/// `text` (a crossing table) with Monte Carlo's columns `mc`, `mc_se`, `mc_bias` added, when
/// its levels are the table's; else `text` as it is.
fn with_mc_columns(text: &str, rates: &CrossingRates) -> String {
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() != rates.levels.len() + 1 {
        return text.to_string();
    }
    let mut out = format!("{},mc,mc_se,mc_bias\n", lines[0]);
    for (k, line) in lines[1..].iter().enumerate() {
        let bias =
            rates.spacing_bias[k].value + rates.time_step_bias.as_ref().map_or(0.0, |b| b[k].value);
        let r = rates.rate[k];
        out.push_str(&format!("{line},{},{},{}\n", r.value, r.stderr, bias));
    }
    out
}

/// The crossing curves of `name` by each method that solved, by their columns' labels;
/// `None` when no method solved or the quantity has no curve.
fn crossing_curves(
    problem: &Problem,
    study: &Study,
    name: &str,
) -> Result<Option<Vec<(String, CrossingCurve)>>, CrossingError> {
    let Some(levels) = study
        .curves
        .iter()
        .find(|c| c.name == name)
        .map(|c| c.x.as_slice())
    else {
        return Ok(None);
    };
    let mut curves: Vec<(String, CrossingCurve)> = Vec::new();
    for run in &study.runs {
        let Some(solution) = run.solution() else {
            continue;
        };
        let method = run.name().method();
        let rate = problem.level_rate(run.name(), name)?;
        let curve = crossing_rate(solution.joint(), &rate, levels)?;
        let derive = |d: &dyn crate::density::JointDensity| {
            crossing_rate(d, &rate, levels)
                .map_or_else(|_| vec![f64::NAN; levels.len()], |c| c.rate)
        };
        let curve = match method.estimate_derived(solution, &curve.rate, &derive) {
            Some(errors) => {
                // As for the PDF's tails, the estimate is trusted only where the rate is at
                // least TAIL_LEVEL of its peak (below, the half-resolution solve's far tail
                // is no guide): no bound there rather than one that may not hold.
                let peak = curve.rate.iter().cloned().fold(0.0, f64::max);
                let errors = envelope(&errors, &curve.rate)
                    .into_iter()
                    .zip(&curve.rate)
                    .map(|(e, &r)| if r >= TAIL_LEVEL * peak { e } else { f64::NAN })
                    .collect();
                curve.with_discretisation(errors)
            }
            None => curve,
        };
        curves.push((run.source().label(), curve));
    }
    Ok((!curves.is_empty()).then_some(curves))
}

/// Levels on each side over which [`envelope`] takes its maximum, as a fraction of the
/// levels of a curve.
const ENVELOPE_FRACTION: f64 = 1.0 / 40.0;

/// A curve's pointwise error estimates made robust where they vanish by accident: the
/// estimate is a difference between two resolutions, which crosses zero wherever the two
/// solutions' errors cross each other, though neither error is zero there (on the linear
/// oscillator at 100×200 cells, the estimate at u = 6 was 5e−6 for an error of 3.4e−5, with
/// 10 % of the rate on either side). Each level gets the largest relative estimate
/// (estimate / rate) within ±[`ENVELOPE_FRACTION`] of the levels around it, times its rate.
fn envelope(errors: &[f64], rate: &[f64]) -> Vec<f64> {
    let n = rate.len();
    let half = ((n as f64 * ENVELOPE_FRACTION).ceil() as usize).max(1);
    let relative: Vec<f64> = errors
        .iter()
        .zip(rate)
        .map(|(e, r)| if *r > 0.0 { e / r } else { f64::NAN })
        .collect();
    (0..n)
        .map(|i| {
            let window = &relative[i.saturating_sub(half)..(i + half + 1).min(n)];
            // NaN (a zero rate, or an estimate without a value) wins: no bound.
            let worst = window
                .iter()
                .try_fold(0.0f64, |m, &r| r.is_finite().then(|| m.max(r)))
                .unwrap_or(f64::NAN);
            (worst * rate[i]).max(errors[i])
        })
        .collect()
}

/// The impact statistics at every wall, by every method whose density is in the model's own
/// coordinates.
fn impacts(problem: &Problem, study: &Study, mc: Option<&McResult>) -> Vec<WallTable> {
    let model = problem.model();
    let mut tables = Vec::new();
    for impact in model.impacts() {
        let Some(side) = impact.side else {
            // A pass-through law (the Zhuravlev form's): its state is not the user's position.
            continue;
        };
        let state = model.states()[impact.state].to_string();
        let side_name = match side {
            BarrierSide::Above => "lower",
            BarrierSide::Below => "upper",
        };
        let file = format!("impact_speeds_{state}_{side_name}.csv");
        let mut table = PdfTable {
            variable: "speed".into(),
            x: Vec::new(),
            columns: Vec::new(),
        };
        let mut rows = Vec::new();
        for run in &study.runs {
            let Some(solution) = run.solution() else {
                continue;
            };
            let method = run.name().method();
            if !std::ptr::eq(method.density_model(problem), model) {
                continue;
            }
            let density = solution.joint();
            if table.x.is_empty() {
                let top = density.extent()[1][1].max(-density.extent()[1][0]);
                table.x = (0..SPEED_POINTS)
                    .map(|k| top * k as f64 / (SPEED_POINTS - 1) as f64)
                    .collect();
            }
            let Ok(stats) = impact_statistics(density, model, impact, &table.x) else {
                continue;
            };
            let scalars = |s: &ImpactStatistics| vec![s.rate, s.mean_speed, s.mean_power];
            let derive = |d: &dyn crate::density::JointDensity| {
                impact_statistics(d, model, impact, &[])
                    .map_or_else(|_| vec![f64::NAN; 3], |s| scalars(&s))
            };
            let errors = method
                .estimate_derived(solution, &scalars(&stats), &derive)
                .map(|e| {
                    e.iter()
                        .zip(scalars(&stats))
                        .map(|(e, v)| e + stats.accuracy * v.abs())
                        .collect::<Vec<f64>>()
                });
            let label = run.source().label();
            table.columns.push((label.clone(), stats.speed_pdf.clone()));
            rows.push(WallImpacts {
                method: label,
                state: state.clone(),
                at: stats.at,
                side,
                law: stats.law.clone(),
                rate: stats.rate,
                mean_speed: stats.mean_speed,
                mean_power: stats.mean_power,
                rate_error: errors.as_ref().map(|e| e[0]),
                mean_speed_error: errors.as_ref().map(|e| e[1]),
                mean_power_error: errors.as_ref().map(|e| e[2]),
                accuracy: stats.accuracy,
                stderr: None,
                time_step_bias: None,
                minus_grid: None,
                no_error_bound: errors.is_none().then_some(NO_ERROR_BOUND),
                speed_pdf_file: file.clone(),
            });
        }
        if let Some(grid) = rows.iter().find(|r| r.method == "grid").cloned() {
            for r in rows.iter_mut().filter(|r| r.no_error_bound.is_some()) {
                r.minus_grid = Some([
                    r.rate - grid.rate,
                    r.mean_speed - grid.mean_speed,
                    r.mean_power - grid.mean_power,
                ]);
            }
        }
        let above = side == BarrierSide::Above;
        let walls = mc
            .and_then(|m| m.impacts.as_ref())
            .map(|i| i.walls.as_slice());
        if let Some(w) = walls
            .unwrap_or(&[])
            .iter()
            .find(|w| w.state == state && w.at == impact.at && w.above == above)
        {
            if let Some(d) = &w.speeds {
                // The bins are centred on k·width: the tables' speeds when the grid was made
                // from them (`mc_speed_grid`).
                let w = d.grid.width();
                if table.x.is_empty() {
                    table.x = (0..d.density.len()).map(|k| k as f64 * w).collect();
                }
                let on_points = table.x.len() == d.density.len()
                    && table
                        .x
                        .iter()
                        .enumerate()
                        .all(|(k, x)| (x - k as f64 * w).abs() <= 1e-9 * w * (k + 1) as f64);
                if on_points {
                    table.columns.push(("mc".into(), d.density.clone()));
                    table.columns.push(("mc_se".into(), d.stderr.clone()));
                }
            }
            rows.push(WallImpacts {
                method: "mc".into(),
                state: state.clone(),
                at: w.at,
                side,
                law: impact.map.to_string(),
                rate: w.rate.value,
                mean_speed: w.mean_speed.value,
                mean_power: w.mean_power.value,
                rate_error: None,
                mean_speed_error: None,
                mean_power_error: None,
                accuracy: 0.0,
                stderr: Some([w.rate.stderr, w.mean_speed.stderr, w.mean_power.stderr]),
                time_step_bias: w
                    .time_step_bias
                    .map(|b| [b[0].value, b[1].value, b[2].value]),
                minus_grid: None,
                no_error_bound: None,
                speed_pdf_file: file.clone(),
            });
        }
        if !rows.is_empty() {
            tables.push(WallTable { file, table, rows });
        }
    }
    tables
}
