//! The figures of a first-passage run, drawn with the report stage's two-panel figures
//! (linear and log scale): `reliability` (the grid's R(t) with its estimated error as a thin
//! band, Monte Carlo's with its 95 % Wilson band) and `first_passage_pdf` (the grid's
//! first-passage-time density, Monte Carlo's histogram on the output times with its
//! standard errors). A figure that cannot be drawn is reported with why, never raised: the
//! numbers are written all the same, and drawing reads them without changing any.

use std::path::PathBuf;

use crate::grid::PassageSolution;
use crate::job::Unwritten;
use crate::mc::McPassageResult;
use crate::report::{count_text, short_number, Band, Curve, OutputDir, PanelFigure, Points};
use crate::report::{PdfFigure, ReportError};

/// The figures a first-passage run wrote, and those it could not draw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassageFigures {
    /// The files written (PNG and SVG of each figure drawn).
    pub files: Vec<PathBuf>,
    /// The figures not written, each with why.
    pub unwritten: Vec<Unwritten>,
}

/// What the figures say about the run: the model's name for the titles, a line of settings
/// for the subtitles.
pub(super) struct Caption {
    pub(super) title: String,
    pub(super) subtitle: String,
}

/// Draws and writes both figures into `dir`.
pub(super) fn write(
    dir: &OutputDir,
    caption: &Caption,
    grid: Option<&PassageSolution>,
    mc: Option<&McPassageResult>,
) -> PassageFigures {
    let mut out = PassageFigures::default();
    let nothing = grid.is_none_or(|g| g.times.is_empty()) && mc.is_none_or(|m| m.times.is_empty());
    for (stem, figure) in [
        (
            "reliability",
            Figure::Panels(reliability(caption, grid, mc)),
        ),
        ("first_passage_pdf", Figure::Pdf(density(caption, grid, mc))),
    ] {
        let written = if nothing {
            Err("no output times to draw".to_string())
        } else {
            // The figure's own error: `file` names it, and the staging path it would
            // have been written to means nothing once the run is in place.
            figure.write(dir, stem).map_err(|e| match e {
                ReportError::Figure { source, .. } => source.to_string(),
                e => e.to_string(),
            })
        };
        match written {
            Ok(files) => out.files.extend(files),
            Err(error) => out.unwritten.push(Unwritten {
                file: format!("{stem}.png/.svg"),
                error,
            }),
        }
    }
    out
}

/// One of the two kinds of figure drawn.
enum Figure {
    Panels(PanelFigure),
    Pdf(PdfFigure),
}

impl Figure {
    fn write(&self, dir: &OutputDir, stem: &str) -> Result<[PathBuf; 2], ReportError> {
        let files = match self {
            Figure::Panels(f) => f.write(dir, stem)?,
            Figure::Pdf(f) => f.write(dir, stem)?,
        };
        Ok([files.png, files.svg])
    }
}

/// The legend text of the grid's curves.
fn grid_label(g: &PassageSolution) -> String {
    let [nx, nv] = g.report.cells;
    format!("grid {nx}×{nv}")
}

/// The legend text of Monte Carlo's curves.
fn mc_label(m: &McPassageResult) -> String {
    format!(
        "Monte Carlo, {} paths, dt {}",
        count_text(m.paths),
        short_number(m.dt)
    )
}

/// R(t): the grid's line with its estimated error as a band, Monte Carlo's line with its
/// Wilson 95 % band, each band in its line's colour.
fn reliability(
    caption: &Caption,
    grid: Option<&PassageSolution>,
    mc: Option<&McPassageResult>,
) -> PanelFigure {
    let (mut curves, mut bands) = (Vec::new(), Vec::new());
    if let Some(g) = grid {
        if let Some(e) = &g.errors {
            let cells = g
                .report
                .estimate_cells
                .map_or(String::new(), |[x, v]| format!(", from {x}×{v}"));
            bands.push(Band {
                label: format!("grid ± estimated error{cells}"),
                x: g.times.clone(),
                lo: g
                    .reliability
                    .iter()
                    .zip(&e.reliability)
                    .map(|(r, e)| r - e)
                    .collect(),
                hi: g
                    .reliability
                    .iter()
                    .zip(&e.reliability)
                    .map(|(r, e)| r + e)
                    .collect(),
                colour_of: curves.len(),
            });
        }
        curves.push(Curve {
            label: grid_label(g),
            x: g.times.clone(),
            y: g.reliability.clone(),
        });
    }
    if let Some(m) = mc {
        bands.push(Band {
            label: "Monte Carlo, 95 % (Wilson)".into(),
            x: m.times.clone(),
            lo: m.reliability_lo.clone(),
            hi: m.reliability_hi.clone(),
            colour_of: curves.len(),
        });
        curves.push(Curve {
            label: mc_label(m),
            x: m.times.clone(),
            y: m.reliability.clone(),
        });
    }
    PanelFigure {
        title: format!("{}: reliability R(t) = P(T > t)", caption.title),
        subtitle: caption.subtitle.clone(),
        x_label: "t".into(),
        y_label: "R(t)".into(),
        curves,
        bands,
        points: None,
        y_bound: Some(1.0),
    }
}

/// The first-passage-time density: the grid's line at the output times, Monte Carlo's
/// histogram at the centres of the bins between them with its standard errors.
fn density(
    caption: &Caption,
    grid: Option<&PassageSolution>,
    mc: Option<&McPassageResult>,
) -> PdfFigure {
    let curves = grid
        .map(|g| Curve {
            label: grid_label(g),
            x: g.times.clone(),
            y: g.pdf.clone(),
        })
        .into_iter()
        .collect();
    let points = mc.filter(|m| !m.pdf_binned.is_empty()).map(|m| Points {
        label: format!("{} (± 1 standard error)", mc_label(m)),
        x: m.times.windows(2).map(|w| (w[0] + w[1]) / 2.0).collect(),
        y: m.pdf_binned.clone(),
        stderr: m.pdf_binned_stderr.clone(),
    });
    PdfFigure {
        title: format!("{}: first-passage-time density", caption.title),
        subtitle: caption.subtitle.clone(),
        variable_label: "t".into(),
        curves,
        points,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::{PassageBias, PassageEstimate};

    /// A Monte Carlo result on the times 0, 1, 2 with the given R(t) and density.
    fn mc(reliability: Vec<f64>, pdf: Vec<f64>) -> McPassageResult {
        let e = PassageEstimate {
            value: 1.0,
            stderr: 0.0,
        };
        McPassageResult {
            paths: 256,
            dt: 0.01,
            horizon: 2.0,
            seed: 1,
            censored: 0,
            censored_fraction: 0.0,
            blowups: 0,
            mean: None,
            variance: None,
            mean_lower_bound: e,
            bias: PassageBias {
                value: 0.0,
                stderr: 0.0,
                paths: 128,
            },
            times: vec![0.0, 1.0, 2.0],
            reliability_lo: reliability.clone(),
            reliability_hi: reliability.clone(),
            reliability,
            pdf_binned_stderr: vec![0.0; pdf.len()],
            pdf_binned: pdf,
        }
    }

    #[test]
    fn a_figure_with_nothing_to_draw_is_listed_not_raised() {
        let path = std::env::temp_dir().join(format!("fpsolve_passage_fig_{}", std::process::id()));
        let dir = OutputDir::create(&path).unwrap();
        let caption = Caption {
            title: "m".into(),
            subtitle: String::new(),
        };
        // Every path blew up: R and the density are NaN throughout.
        let nan = mc(vec![f64::NAN; 3], vec![f64::NAN; 2]);
        let written = write(&dir, &caption, None, Some(&nan));
        assert!(written.files.is_empty());
        let files: Vec<&str> = written.unwritten.iter().map(|u| u.file.as_str()).collect();
        assert_eq!(
            files,
            ["reliability.png/.svg", "first_passage_pdf.png/.svg"]
        );
        assert!(
            written.unwritten[0].error.contains("nothing to draw"),
            "{:?}",
            written.unwritten
        );
        // Every path censored: R = 1 is drawn; a density of 0 has nothing for the log panel.
        let censored = mc(vec![1.0; 3], vec![0.0; 2]);
        let written = write(&dir, &caption, None, Some(&censored));
        assert_eq!(written.files.len(), 2);
        assert!(written.files[0].ends_with("reliability.png"));
        assert_eq!(written.unwritten.len(), 1);
        assert_eq!(
            written.unwritten[0].error,
            "no positive density value to draw on a log scale"
        );
        std::fs::remove_dir_all(&path).unwrap();
    }
}
