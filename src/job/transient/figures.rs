//! The figures of a transient, drawn with the report stage's helpers: σ(t) of each
//! state (the grid's line, Monte Carlo's points with their 95 % band) and the marginal PDFs
//! at a few chosen times (linear and log panels, Monte Carlo's histogram with 95 % bars).

use crate::grid::TransientHistory;
use crate::mc::McTransientHistory;
use crate::model::BoundModel;
use crate::report::{Curve, LineFigure, OutputDir, PdfFigure, Points, ReportError};

/// The normal quantile of a two-sided 95 % interval.
const Z95: f64 = 1.96;

/// The fractions of the last output time whose nearest outputs get PDF figures (t = 5, 20,
/// 80 of a run to 80).
const PDF_FRACTIONS: [f64; 3] = [1.0 / 16.0, 0.25, 1.0];

/// Writes the figures; returns how many files.
pub(super) fn write(
    dir: &OutputDir,
    model: &BoundModel,
    grid: &Option<TransientHistory>,
    mc: &Option<McTransientHistory>,
) -> Result<usize, ReportError> {
    let states: Vec<String> = model.states().iter().map(|s| s.to_string()).collect();
    let times: Vec<f64> = match (grid, mc) {
        (Some(g), _) => g.snapshots.iter().map(|s| s.t).collect(),
        (None, Some(m)) => m.snapshots.iter().map(|s| s.t).collect(),
        (None, None) => return Ok(0),
    };
    let mut series = Vec::new();
    for (a, q) in states.iter().enumerate() {
        if let Some(g) = grid {
            series.push(Curve {
                label: format!("grid σ({q})"),
                x: times.clone(),
                y: g.snapshots
                    .iter()
                    .map(|s| s.moments[a].variance.sqrt())
                    .collect(),
            });
        }
        if let Some(m) = mc {
            // σ = √var, its standard error se(var)/(2σ) (the delta method).
            let sd: Vec<(f64, f64)> = m
                .snapshots
                .iter()
                .map(|s| {
                    let v = s.moments[a].variance;
                    let sd = v.value.max(0.0).sqrt();
                    let se = if sd > 0.0 { v.stderr / (2.0 * sd) } else { 0.0 };
                    (sd, se)
                })
                .collect();
            let line = |label: String, f: &dyn Fn(&(f64, f64)) -> f64| Curve {
                label,
                x: times.clone(),
                y: sd.iter().map(f).collect(),
            };
            series.push(line(format!("MC σ({q})"), &|p| p.0));
            series.push(line(format!("MC σ({q}) − 95 %"), &|p| p.0 - Z95 * p.1));
            series.push(line(format!("MC σ({q}) + 95 %"), &|p| p.0 + Z95 * p.1));
        }
    }
    let mut files = 0;
    LineFigure {
        title: format!("{}: standard deviation against time", model.name()),
        x_label: "t".into(),
        y_label: "σ".into(),
        series,
    }
    .write(dir, "sigma_vs_t")?;
    files += 2;
    let last = times.last().copied().unwrap_or(0.0);
    let mut chosen: Vec<usize> = PDF_FRACTIONS
        .iter()
        .filter_map(|f| nearest(&times, f * last))
        .collect();
    chosen.dedup();
    for k in chosen {
        for (a, q) in states.iter().enumerate() {
            let curves = grid
                .iter()
                .map(|g| {
                    let m = &g.snapshots[k].marginals[a];
                    Curve {
                        label: "grid".into(),
                        x: m.centres.clone(),
                        y: m.density.clone(),
                    }
                })
                .collect();
            let points = mc
                .as_ref()
                .and_then(|m| m.snapshots[k].densities.as_ref())
                .map(|d| {
                    let d = &d[a];
                    Points {
                        label: format!("Monte Carlo (95 %, {} paths)", total(mc)),
                        x: d.grid.centers(),
                        y: d.density.clone(),
                        stderr: d.stderr.iter().map(|s| Z95 * s).collect(),
                    }
                });
            let t = times[k];
            PdfFigure {
                title: format!("{}: PDF of {q} at t = {t}", model.name()),
                subtitle: String::new(),
                variable_label: q.clone(),
                curves,
                points,
            }
            .write(dir, &format!("pdf_{q}_at_t{t}"))?;
            files += 2;
        }
    }
    Ok(files)
}

/// The index of the positive output time nearest `t`.
fn nearest(times: &[f64], t: f64) -> Option<usize> {
    times
        .iter()
        .enumerate()
        .filter(|(_, s)| **s > 0.0)
        .min_by(|a, b| (a.1 - t).abs().total_cmp(&(b.1 - t).abs()))
        .map(|(k, _)| k)
}

fn total(mc: &Option<McTransientHistory>) -> u64 {
    mc.as_ref().map_or(0, |m| m.settings.trajectories)
}
