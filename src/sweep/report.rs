//! A finished sweep as files: `sweep.csv` (through the report stage's CSV writer),
//! `sweep.json` and line figures.

use std::path::PathBuf;

use crate::report::{write_json, Cell, Curve, LineFigure, OutputDir, ReportError, TextTable};

use super::{PointOutcome, PointSolution, PointStats, SweepResult, TAIL_MULTIPLES};

impl SweepResult {
    /// The points that converged.
    pub fn converged(&self) -> usize {
        self.points
            .iter()
            .filter(|p| matches!(p.outcome, PointOutcome::Converged(_)))
            .count()
    }

    /// The sweep as CSV text: one row per point with the swept parameters, `status`
    /// (`converged` or `failed`), `stage` and `message` of a failure, the solver's
    /// iterations, residual, residual threshold, FPK residual and normalisation, then per
    /// quantity `<g>_mean`, `<g>_std_dev`, `<g>_kurtosis` and `<g>_p_gt_<k>rms` = P(|g| > k·rms)
    /// for k = 2, 3, 4 (the thresholds are in `sweep.json`). A failed point has empty
    /// statistic fields.
    pub fn to_csv(&self) -> String {
        self.table().to_csv()
    }

    /// The rows of [`to_csv`](Self::to_csv).
    fn table(&self) -> TextTable {
        let mut header: Vec<String> = self.parameters.clone();
        header.extend(
            [
                "status",
                "stage",
                "message",
                "iterations",
                "residual",
                "residual_threshold",
                "fpk_residual",
                "normalisation",
            ]
            .map(String::from),
        );
        for q in &self.quantities {
            header.extend(["mean", "std_dev", "kurtosis"].map(|s| format!("{q}_{s}")));
            if self.tail_thresholds.iter().any(|t| &t.name == q) {
                header.extend(TAIL_MULTIPLES.iter().map(|k| format!("{q}_p_gt_{k}rms")));
            }
        }
        let mut rows = Vec::with_capacity(self.points.len());
        for point in &self.points {
            let mut row: Vec<Cell> = point.values.iter().map(|&v| Cell::Number(v)).collect();
            match &point.outcome {
                PointOutcome::Converged(s) => {
                    row.extend([
                        Cell::Word("converged".into()),
                        Cell::Empty,
                        Cell::Empty,
                        Cell::Word(s.iterations.to_string()),
                        Cell::Number(s.residual),
                        Cell::Number(s.residual_threshold),
                        Cell::Number(s.fpk_residual),
                        Cell::Word(s.normalisation.clone()),
                    ]);
                    for q in &self.quantities {
                        let st = s.stats.iter().find(|st| &st.name == q);
                        row.extend(
                            [
                                st.map(|s| s.moments.mean),
                                st.map(|s| s.moments.std_dev()),
                                st.map(|s| s.moments.kurtosis),
                            ]
                            .map(|v| v.map_or(Cell::Empty, Cell::Number)),
                        );
                        if self.tail_thresholds.iter().any(|t| &t.name == q) {
                            for k in 0..TAIL_MULTIPLES.len() {
                                let v = st.and_then(|s| s.tail.get(k).copied().flatten());
                                row.push(v.map_or(Cell::Empty, Cell::Number));
                            }
                        }
                    }
                }
                PointOutcome::Failed(failure) => {
                    row.extend([
                        Cell::Word("failed".into()),
                        Cell::Word(failure.stage().into()),
                        Cell::Text(failure.to_string()),
                    ]);
                }
            }
            rows.push(row);
        }
        TextTable { header, rows }
    }

    /// The line figures: mean, standard deviation and kurtosis of the figure quantities
    /// against the first swept parameter (one series per quantity and value of the second
    /// parameter), and per figure quantity log10 P(|g| > a) for each threshold. Figures
    /// without any finite value (every point failed) are left out. Returned with their file
    /// stems.
    pub fn figures(&self) -> Vec<(String, LineFigure)> {
        let mut out = Vec::new();
        let x_label = self.parameters.first().cloned().unwrap_or_default();
        let groups = self.series_groups();
        let stat = |s: &PointStats, which: usize| match which {
            0 => s.moments.mean,
            1 => s.moments.std_dev(),
            _ => s.moments.kurtosis,
        };
        for (which, (stem, label)) in [
            ("mean", "mean"),
            ("std_dev", "standard deviation"),
            ("kurtosis", "kurtosis"),
        ]
        .into_iter()
        .enumerate()
        {
            let mut series = Vec::new();
            for q in &self.figure_quantities {
                for (group_label, indices) in &groups {
                    let (x, y) = self.column(indices, |sol| {
                        sol.stats
                            .iter()
                            .find(|s| &s.name == q)
                            .map_or(f64::NAN, |s| stat(s, which))
                    });
                    series.push(Curve {
                        label: join_label(q, group_label),
                        x,
                        y,
                    });
                }
            }
            out.push((
                format!("sweep_{stem}"),
                LineFigure {
                    title: format!("{}: {label} (EPC n = {})", self.model, self.degree),
                    x_label: x_label.clone(),
                    y_label: label.to_string(),
                    series,
                },
            ));
        }
        for q in &self.figure_quantities {
            let Some(t) = self.tail_thresholds.iter().find(|t| &t.name == q) else {
                continue;
            };
            let mut series = Vec::new();
            for (k, a) in t.thresholds.iter().enumerate() {
                for (group_label, indices) in &groups {
                    let (x, y) = self.column(indices, |sol| {
                        sol.stats
                            .iter()
                            .find(|s| &s.name == q)
                            .and_then(|s| s.tail.get(k).copied().flatten())
                            .map_or(f64::NAN, |p| if p > 0.0 { p.log10() } else { f64::NAN })
                    });
                    series.push(Curve {
                        label: join_label(&format!("a = {}", short(*a)), group_label),
                        x,
                        y,
                    });
                }
            }
            out.push((
                format!("sweep_tail_{q}"),
                LineFigure {
                    title: format!(
                        "{}: P(|{q}| > a), a = 2, 3, 4 × rms at {} (EPC n = {})",
                        self.model,
                        self.threshold_label(),
                        self.degree
                    ),
                    x_label: x_label.clone(),
                    y_label: format!("log10 P(|{q}| > a)"),
                    series,
                },
            ));
        }
        out.retain(|(_, f)| f.series.iter().any(|s| s.y.iter().any(|v| v.is_finite())));
        out
    }

    /// The reference point of the tail thresholds as `p1 = v1, p2 = v2`.
    fn threshold_label(&self) -> String {
        let Some(point) = self.threshold_point.and_then(|i| self.points.get(i)) else {
            return "no point".to_string();
        };
        self.parameters
            .iter()
            .zip(&point.values)
            .map(|(n, v)| format!("{n} = {}", short(*v)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Point indices of each series: one per value of the second swept parameter (in the
    /// order given), or a single unlabelled series.
    fn series_groups(&self) -> Vec<(String, Vec<usize>)> {
        let Some(second) = self.parameters.get(1) else {
            return vec![(String::new(), (0..self.points.len()).collect())];
        };
        let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
        for (i, p) in self.points.iter().enumerate() {
            let v = p.values[1];
            match groups.iter_mut().find(|(g, _)| *g == v) {
                Some((_, idx)) => idx.push(i),
                None => groups.push((v, vec![i])),
            }
        }
        groups
            .into_iter()
            .map(|(v, idx)| (format!("{second} = {}", short(v)), idx))
            .collect()
    }

    /// The first swept parameter and a statistic at the given points (NaN where a point
    /// failed, leaving a gap in the line).
    fn column(
        &self,
        indices: &[usize],
        value: impl Fn(&PointSolution) -> f64,
    ) -> (Vec<f64>, Vec<f64>) {
        indices
            .iter()
            .map(|&i| {
                let p = &self.points[i];
                let y = match &p.outcome {
                    PointOutcome::Converged(sol) => value(sol),
                    PointOutcome::Failed(_) => f64::NAN,
                };
                (p.values[0], if y.is_finite() { y } else { f64::NAN })
            })
            .unzip()
    }

    /// Writes `sweep.csv`, `sweep.json` and the figures of [`figures`](Self::figures)
    /// (PNG and SVG) into `out`; returns the files written.
    ///
    /// # Errors
    /// The first [`ReportError`] met; files written before it stay.
    pub fn write(&self, out: &OutputDir) -> Result<Vec<PathBuf>, ReportError> {
        let mut files = vec![
            self.table().write_csv(out, "sweep.csv")?,
            write_json(out, "sweep.json", self)?,
        ];
        for (stem, figure) in self.figures() {
            let written = figure.write(out, &stem)?;
            files.push(written.png);
            files.push(written.svg);
        }
        Ok(files)
    }
}

fn join_label(a: &str, b: &str) -> String {
    if b.is_empty() {
        a.to_string()
    } else {
        format!("{a}, {b}")
    }
}

/// A number for a legend: at most four significant digits, no trailing zeros.
fn short(v: f64) -> String {
    let rounded: f64 = format!("{v:.3e}").parse().unwrap_or(v);
    format!("{rounded}")
}
