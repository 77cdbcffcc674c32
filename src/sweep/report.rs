//! A finished sweep as files: `sweep.csv` (through the report stage's CSV writer),
//! `sweep.json` and line figures.

use std::path::PathBuf;

use crate::report::{
    short_number, write_json, Cell, Curve, FigureError, LineFigure, OutputDir, ReportError,
    TextTable,
};

use crate::solve::{Figure, MethodName};

use super::{PointOutcome, PointSolution, PointStats, SweepResult, TAIL_MULTIPLES};

/// The smallest tail probability a sweep's tail figure draws (`sweep.csv` keeps every value):
/// below it no method is checked (Monte Carlo's 1e9 samples resolve about 1e−8, the grid's
/// tails are checked to 1e−10 of the peak, EPC's tails are its closure's guess), and a
/// figure reaching 1e−44 only squeezes the part where methods can be compared.
const TAIL_FLOOR: f64 = 1e-10;

impl SweepResult {
    /// The points every method solved (for an EPC sweep: the points that converged).
    pub fn converged(&self) -> usize {
        self.points
            .iter()
            .filter(|p| {
                p.outcomes
                    .iter()
                    .all(|o| matches!(o.outcome, PointOutcome::Converged(_)))
            })
            .count()
    }

    /// The points refused before any work (no stationary density): no method solved them.
    pub fn refused(&self) -> usize {
        self.points
            .iter()
            .filter(|p| {
                p.outcomes
                    .iter()
                    .any(|o| matches!(o.outcome, PointOutcome::Refused(_)))
            })
            .count()
    }

    /// The points `method` solved.
    pub fn converged_by(&self, method: MethodName) -> usize {
        self.points
            .iter()
            .filter(|p| p.solution(method).is_some())
            .count()
    }

    /// The sweep as CSV text: one row per point with the swept parameters, then one block of
    /// columns per method: `status` (`converged`, `failed`, or `refused` for a point without a
    /// stationary density, which no method was asked to solve), `stage` and `message` of a
    /// failure or refusal (stage `admissibility`), the method's own figures (EPC: iterations, residual, residual threshold, FPK
    /// residual and normalisation; grid: clipped negative mass and the estimated L1 errors of
    /// the two marginals), then per quantity `<g>_mean`, `<g>_std_dev`, `<g>_kurtosis` and
    /// `<g>_p_gt_<k>rms` = P(|g| > k·rms) for k = 2, 3, 4 (the thresholds are in
    /// `sweep.json`). Every column of a block starts with its method (`epc_status`,
    /// `grid_status`, `epc_y_mean`, `epc_impact_y_mean`), whichever methods were asked, so
    /// that a column's name never depends on the others. A failed method has empty fields
    /// after its message.
    pub fn to_csv(&self) -> String {
        self.table().to_csv()
    }

    /// The prefix of a method's columns: its name with `_` for `-`.
    fn prefix(method: MethodName) -> String {
        format!("{}_", method.as_str().replace('-', "_"))
    }

    /// The rows of [`to_csv`](Self::to_csv).
    fn table(&self) -> TextTable {
        let mut header: Vec<String> = self.parameters.clone();
        let mut widths = Vec::new();
        for &method in self.methods.names() {
            let p = Self::prefix(method);
            let before = header.len();
            let own = method.method().figure_names();
            header.extend(
                ["status", "stage", "message"]
                    .iter()
                    .chain(own)
                    .map(|c| format!("{p}{c}")),
            );
            for q in &self.quantities {
                header.extend(["mean", "std_dev", "kurtosis"].map(|s| format!("{p}{q}_{s}")));
                if self.has_tails(q) {
                    header.extend(TAIL_MULTIPLES.iter().map(|k| format!("{p}{q}_p_gt_{k}rms")));
                }
            }
            widths.push(header.len() - before);
        }
        let mut rows = Vec::with_capacity(self.points.len());
        for point in &self.points {
            let mut row: Vec<Cell> = point.values.iter().map(|&v| Cell::Number(v)).collect();
            for (o, width) in point.outcomes.iter().zip(&widths) {
                let block = match &o.outcome {
                    PointOutcome::Converged(s) => self.converged_cells(s),
                    PointOutcome::Failed(failure) => vec![
                        Cell::Word("failed".into()),
                        Cell::Word(failure.stage().into()),
                        Cell::Text(failure.to_string()),
                    ],
                    PointOutcome::Refused(refusal) => vec![
                        Cell::Word("refused".into()),
                        Cell::Word(refusal.stage().into()),
                        Cell::Text(refusal.to_string()),
                    ],
                };
                let n = block.len();
                row.extend(block);
                row.extend((n..*width).map(|_| Cell::Empty));
            }
            rows.push(row);
        }
        TextTable { header, rows }
    }

    /// A solved method's block of a row.
    fn converged_cells(&self, s: &PointSolution) -> Vec<Cell> {
        let mut row = vec![Cell::Word("converged".into()), Cell::Empty, Cell::Empty];
        row.extend(s.solver.values().into_iter().map(|f| match f {
            Figure::Word(w) => Cell::Word(w),
            Figure::Number(v) => Cell::Number(v),
            Figure::Missing => Cell::Empty,
        }));
        for q in &self.quantities {
            let st = s.stats_of(q);
            row.extend(
                [
                    st.map(|s| s.moments.mean),
                    st.map(|s| s.moments.std_dev()),
                    st.map(|s| s.moments.kurtosis),
                ]
                .map(|v| v.map_or(Cell::Empty, Cell::Number)),
            );
            if self.has_tails(q) {
                for k in 0..TAIL_MULTIPLES.len() {
                    let v = st.and_then(|s| s.tail.get(k).copied().flatten());
                    row.push(v.map_or(Cell::Empty, Cell::Number));
                }
            }
        }
        row
    }

    fn has_tails(&self, q: &str) -> bool {
        self.tail_thresholds.iter().any(|t| t.name == q)
    }

    /// How figures name a method: `EPC n = 4`, `grid 140×280`.
    fn method_label(&self, method: MethodName) -> String {
        let m = method.method();
        match self.cells {
            None if !m.has_degrees() => m.title().to_string(),
            cells => m.settle(self.degree, cells.unwrap_or_default()).to_string(),
        }
    }

    /// The methods in a figure's title: `EPC n = 4`, or `EPC n = 4, grid 140×280`.
    fn methods_label(&self) -> String {
        let labels: Vec<String> = self
            .methods
            .names()
            .iter()
            .map(|&m| self.method_label(m))
            .collect();
        labels.join(", ")
    }

    /// A series' method in its legend: nothing when the sweep has one method (the title says
    /// it).
    fn series_method(&self, method: MethodName) -> String {
        if self.methods.names().len() == 1 {
            String::new()
        } else {
            self.method_label(method)
        }
    }

    /// The line figures: mean, standard deviation and kurtosis of the figure quantities
    /// against the first swept parameter (one series per quantity, method and value of the
    /// second parameter), and per figure quantity log10 P(|g| > a) for each threshold and
    /// method. Figures
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
                for &method in self.methods.names() {
                    for (group_label, indices) in &groups {
                        let (x, y) = self.column(indices, method, |sol| {
                            sol.stats_of(q).map_or(f64::NAN, |s| stat(s, which))
                        });
                        let label = join_label(q, &self.series_method(method));
                        series.push(Curve {
                            label: join_label(&label, group_label),
                            x,
                            y,
                        });
                    }
                }
            }
            out.push((
                format!("sweep_{stem}"),
                LineFigure {
                    title: format!("{}: {label} ({})", self.model, self.methods_label()),
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
                for &method in self.methods.names() {
                    for (group_label, indices) in &groups {
                        let (x, y) = self.column(indices, method, |sol| {
                            sol.stats_of(q)
                                .and_then(|s| s.tail.get(k).copied().flatten())
                                .map_or(f64::NAN, |p| {
                                    if p >= TAIL_FLOOR {
                                        p.log10()
                                    } else {
                                        f64::NAN
                                    }
                                })
                        });
                        let label = join_label(
                            &format!("a = {}", short_number(*a)),
                            &self.series_method(method),
                        );
                        series.push(Curve {
                            label: join_label(&label, group_label),
                            x,
                            y,
                        });
                    }
                }
            }
            out.push((
                format!("sweep_tail_{q}"),
                LineFigure {
                    title: format!(
                        "{}: P(|{q}| > a), a = 2, 3, 4 × rms at {} ({})",
                        self.model,
                        self.threshold_label(),
                        self.methods_label()
                    ),
                    x_label: x_label.clone(),
                    y_label: format!(
                        "log10 P(|{q}| > a), shown down to {}",
                        short_number(TAIL_FLOOR)
                    ),
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
            .map(|(n, v)| format!("{n} = {}", short_number(*v)))
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
            .map(|(v, idx)| (format!("{second} = {}", short_number(v)), idx))
            .collect()
    }

    /// The first swept parameter and a statistic of `method` at the given points (NaN where
    /// the method failed, leaving a gap in the line).
    fn column(
        &self,
        indices: &[usize],
        method: MethodName,
        value: impl Fn(&PointSolution) -> f64,
    ) -> (Vec<f64>, Vec<f64>) {
        indices
            .iter()
            .map(|&i| {
                let p = &self.points[i];
                let y = p.solution(method).map_or(f64::NAN, &value);
                (p.values[0], if y.is_finite() { y } else { f64::NAN })
            })
            .unzip()
    }

    /// Writes `sweep.csv`, `sweep.json` and the figures of [`figures`](Self::figures)
    /// (PNG and SVG) into `out`; returns the files written. A figure whose statistics span
    /// more than the largest floating-point number fits no axis and is left out.
    ///
    /// # Errors
    /// The first [`ReportError`] met; files written before it stay.
    pub fn write(&self, out: &OutputDir) -> Result<Vec<PathBuf>, ReportError> {
        let mut files = vec![
            self.table().write_csv(out, "sweep.csv")?,
            write_json(out, "sweep.json", self)?,
        ];
        for (stem, figure) in self.figures() {
            match figure.write(out, &stem) {
                Ok(written) => {
                    files.push(written.png);
                    files.push(written.svg);
                }
                // Statistics further apart than the largest float (a blown-up point) fit no
                // axis: the figure is left out, its numbers are in sweep.csv and sweep.json.
                Err(ReportError::Figure {
                    source: FigureError::Span { .. },
                    ..
                }) => {}
                Err(e) => return Err(e),
            }
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
