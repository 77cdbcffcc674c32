//! A job's per-quantity files: `pdf_<name>.csv` (one column per method and degree),
//! `mc_<name>.csv` (the histogram beside every method's bin averages), the figures, and the
//! distances between methods and to Monte Carlo computed on the same bins.

use std::path::PathBuf;

use rayon::prelude::*;

use super::compare::{against_grid, compare, Comparison, Reference};
use super::{mc_columns, Unwritten};
use crate::mc::McResult;
use crate::report::{
    count_text, short_number, Curve, OutputDir, PdfFigure, PdfTable, Points, ReportError,
};
use crate::study::{Source, Study};

/// What writing the per-quantity files gave.
pub(super) struct Written {
    pub(super) files: Vec<PathBuf>,
    pub(super) unwritten: Vec<Unwritten>,
    pub(super) comparisons: Vec<Comparison>,
}

/// Records a written file, or which file could not be written and why.
fn keep(
    file: String,
    written: Result<Vec<PathBuf>, ReportError>,
    files: &mut Vec<PathBuf>,
    unwritten: &mut Vec<Unwritten>,
) {
    match written {
        Ok(p) => files.extend(p),
        Err(e) => unwritten.push(Unwritten {
            file,
            error: e.to_string(),
        }),
    }
}

/// Writes the files of the quantities `names` and computes the comparisons: every method
/// against Monte Carlo (when there is a result), every other method against the grid.
pub(super) fn write(
    study: &Study,
    names: &[String],
    mc: Option<&McResult>,
    figures: bool,
    out: &OutputDir,
) -> Written {
    // Quantities in parallel (the figures are most of the work), their files, failures and
    // comparisons gathered in the order of `names`, as written one after another.
    let parts: Vec<QuantityFiles> = names
        .par_iter()
        .map(|name| write_quantity(study, name, mc, figures, out))
        .collect();
    let mut written = Written {
        files: Vec::new(),
        unwritten: Vec::new(),
        comparisons: Vec::new(),
    };
    let mut to_grid = Vec::new();
    for part in parts {
        written.files.extend(part.files);
        written.unwritten.extend(part.unwritten);
        written.comparisons.extend(part.to_mc);
        to_grid.extend(part.to_grid);
    }
    // Monte Carlo first (as before the grid), then the grid as the reference.
    written.comparisons.extend(to_grid);
    written
}

/// One quantity's files, failures and comparisons.
struct QuantityFiles {
    files: Vec<PathBuf>,
    unwritten: Vec<Unwritten>,
    to_mc: Vec<Comparison>,
    to_grid: Vec<Comparison>,
}

/// Writes the files of quantity `name` (see [`write`]).
fn write_quantity(
    study: &Study,
    name: &str,
    mc: Option<&McResult>,
    figures: bool,
    out: &OutputDir,
) -> QuantityFiles {
    let mut files = Vec::new();
    // A file that cannot be written does not cost the others: it is recorded in the summary.
    let mut unwritten: Vec<Unwritten> = Vec::new();
    let mut to_mc = Vec::new();
    let mut to_grid = Vec::new();
    let curve = study
        .curves
        .iter()
        .find(|c| c.name == name)
        .expect("a curve per quantity");
    let mc_q = mc.and_then(|m| m.quantity(name));
    // Every method on its common grid, whatever the histogram's range.
    if !curve.x.is_empty() {
        let table = PdfTable {
            variable: name.to_string(),
            x: curve.x.clone(),
            columns: curve
                .columns
                .iter()
                .map(|c| (c.source.label(), c.pdf.clone()))
                .collect(),
        };
        let file = format!("pdf_{name}.csv");
        let written = table.write_csv(out, &file).map(|p| vec![p]);
        keep(file, written, &mut files, &mut unwritten);
    }
    to_grid.extend(against_grid(curve));
    // The histogram beside each method's bin averages, on the histogram's bins.
    if let Some(q) = mc_q {
        // A failed degree has no column here; it is flagged with the study's other
        // failures. The bins are the histogram's own (set from the curve above).
        let mut columns = mc_columns(q);
        for c in curve
            .columns
            .iter()
            .filter(|c| c.bin_means.len() == q.grid.bins)
        {
            to_mc.push(compare(
                name,
                c.source,
                Reference::Mc,
                &c.bin_means,
                &q.density,
                &q.grid,
            ));
            columns.push((
                format!("{}_bin_mean", c.source.label()),
                c.bin_means.clone(),
            ));
        }
        let table = PdfTable {
            variable: name.to_string(),
            x: q.grid.centers(),
            columns,
        };
        let file = format!("mc_{name}.csv");
        let written = table.write_csv(out, &file).map(|p| vec![p]);
        keep(file, written, &mut files, &mut unwritten);
    }
    if figures && !curve.x.is_empty() {
        let figure = PdfFigure {
            title: format!("{}: PDF of {name}", study.model.name()),
            subtitle: study
                .model
                .params()
                .iter()
                .map(|(p, v)| format!("{p} = {}", short_number(*v)))
                .collect::<Vec<_>>()
                .join(", "),
            variable_label: name.to_string(),
            curves: curve
                .columns
                .iter()
                .map(|c| Curve {
                    label: legend(study, c.source),
                    x: curve.x.clone(),
                    y: c.pdf.clone(),
                })
                .collect(),
            points: mc_q.map(|q| Points {
                label: format!("Monte Carlo, {} samples", count_text(q.samples)),
                x: q.grid.centers(),
                y: q.density.clone(),
                stderr: q.stderr.clone(),
            }),
        };
        let written = figure
            .write(out, &format!("pdf_{name}"))
            .map(|w| vec![w.png, w.svg]);
        keep(
            format!("pdf_{name}.png/.svg"),
            written,
            &mut files,
            &mut unwritten,
        );
    }
    QuantityFiles {
        files,
        unwritten,
        to_mc,
        to_grid,
    }
}

/// The legend text of a curve: the method with its settings (`EPC n = 4`, `grid 200×400`),
/// and for an EPC degree whether its density is normalised inside a ridge.
fn legend(study: &Study, source: Source) -> String {
    let run = study.runs.iter().find(|r| r.source() == source);
    let Some(solution) = run.and_then(|r| r.solution()) else {
        return source.to_string();
    };
    let label = solution.method().to_string();
    let ridge = solution.epc().and_then(|s| match &s.normalisation.kind {
        crate::epc::NormalisationKind::InsideRidge { depth, .. } => Some(*depth),
        crate::epc::NormalisationKind::Plane { .. } => None,
    });
    match ridge {
        Some(depth) => format!(
            "{label} (inside ridge, {} e-folds)",
            crate::epc::EFolds(depth)
        ),
        None => label,
    }
}
