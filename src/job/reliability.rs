//! The main job's reliability outputs from every stationary method that ran:
//! - `crossings_<q>.csv`: Rice's mean up-crossing rate ν⁺(u) of each reported state and
//!   observable that has one, on the levels of its PDF curve (`pdf_<q>.csv`'s first column),
//!   one column per method and degree, the grid's followed by its error bound (empty where
//!   the rate is below [`TAIL_LEVEL`] of its peak: the estimate is not trusted there);
//! - at each wall, the impact statistics (rate, mean impact speed, mean dissipated power) in
//!   `summary.json` under `impacts`, from the methods whose density is in the model's own
//!   coordinates (the grid, EPC with the exact impact condition), the grid's with their
//!   errors, and the flux-weighted impact-speed PDFs in `impact_speeds_<state>_<side>.csv`.
//!
//! A quantity without a finite rate (a velocity driven by white noise) or whose level sets the
//! rate formula does not cover is listed under `no_crossings` with the reason.

use std::path::PathBuf;

use serde::Serialize;

use super::Unwritten;
use crate::grid::TAIL_LEVEL;
use crate::model::BarrierSide;
use crate::observe::{
    crossing_rate, crossings_csv, crossings_file_name, impact_statistics, CrossingCurve,
    CrossingError, ImpactStatistics,
};
use crate::report::{OutputDir, PdfTable};
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
    /// The relative accuracy of the integrals alone.
    pub accuracy: f64,
    /// The file holding the impact-speed PDF.
    pub speed_pdf_file: String,
}

/// What writing the reliability outputs gave.
pub(super) struct Written {
    pub(super) files: Vec<PathBuf>,
    pub(super) unwritten: Vec<Unwritten>,
    pub(super) summary: ReliabilitySummary,
}

/// Writes the crossing tables of `names` and the impact statistics of every wall (see the
/// module documentation) from `study`'s solutions of `problem`.
pub(super) fn write(
    problem: &Problem,
    study: &Study,
    names: &[String],
    out: &OutputDir,
) -> Written {
    let mut written = Written {
        files: Vec::new(),
        unwritten: Vec::new(),
        summary: ReliabilitySummary::default(),
    };
    for name in names {
        match crossing_text(problem, study, name) {
            Ok(Some(text)) => {
                let file = crossings_file_name(name);
                match out.write_atomic(&file, text.as_bytes()) {
                    Ok(path) => {
                        written.files.push(path);
                        written.summary.crossings.push(CrossingFile {
                            quantity: name.clone(),
                            file,
                        });
                    }
                    Err(e) => written.unwritten.push(Unwritten {
                        file,
                        error: e.to_string(),
                    }),
                }
            }
            Ok(None) => {}
            Err(e) => written.summary.no_crossings.push(NoCrossings {
                quantity: name.clone(),
                why: e.to_string(),
            }),
        }
    }
    impacts(problem, study, out, &mut written);
    written
}

/// The crossing table of `name`, `None` when no method solved or the quantity has no curve.
fn crossing_text(
    problem: &Problem,
    study: &Study,
    name: &str,
) -> Result<Option<String>, CrossingError> {
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
    if curves.is_empty() {
        return Ok(None);
    }
    let refs: Vec<(&str, &CrossingCurve)> = curves.iter().map(|(l, c)| (l.as_str(), c)).collect();
    crossings_csv(&refs).map(Some)
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
/// coordinates, into `written`.
fn impacts(problem: &Problem, study: &Study, out: &OutputDir, written: &mut Written) {
    let model = problem.model();
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
                speed_pdf_file: file.clone(),
            });
        }
        if rows.is_empty() {
            continue;
        }
        match table.write_csv(out, &file) {
            Ok(path) => written.files.push(path),
            Err(e) => written.unwritten.push(Unwritten {
                file,
                error: e.to_string(),
            }),
        }
        written.summary.impacts.extend(rows);
    }
}
