//! The short table the command line prints after a job.

use std::fmt::Write;

use super::{Comparison, JobReport, LogRatio, Reference};
use crate::base::number_text::fixed_or_scientific;
use crate::solve::{MethodName, QuantityMoments};
use crate::study::{DegreeResult, Source, Study};

impl std::fmt::Display for JobReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&table(self))
    }
}

fn table(report: &JobReport) -> String {
    let study = &report.study;
    let mut s = String::new();
    let params: Vec<String> = study
        .model
        .params()
        .iter()
        .map(|(n, v)| format!("{n} = {v:.6}"))
        .collect();
    let _ = writeln!(s, "{}: {}", study.model.name(), params.join(", "));
    if !study.degrees.is_empty() {
        // Two quality figures: the Galerkin residual says the projected equations were
        // solved; the FPK residual ∫|F|·p says how far the density is from solving the FPK
        // equation itself.
        let _ = writeln!(
            s,
            "{:>6} {:>6} {:>10} {:>10} {:>10}  normalisation",
            "degree", "iters", "galerkin", "fpk resid", "solve ms"
        );
    }
    let mut method = MethodName::Epc;
    for d in &study.degrees {
        if d.method != method {
            method = d.method;
            let _ = writeln!(s, "{method}:");
        }
        degree_row(&mut s, d);
    }
    if let Some(g) = &study.grid {
        match (&g.outcome, g.report()) {
            (Ok(_), Some(r)) => {
                let _ = writeln!(s, "{r}");
            }
            (Err(e), _) => {
                let _ = writeln!(s, "grid {}x{}: failed: {e}", g.cells[0], g.cells[1]);
            }
            (Ok(_), None) => {
                let _ = writeln!(s, "grid: not a grid solution");
            }
        }
    }
    for skipped in &report.skipped {
        let _ = writeln!(s, "{}: not run: {}", skipped.method, skipped.why);
    }
    for skipped in &report.skipped_curves {
        let _ = writeln!(s, "{}: {}", skipped.method, skipped.why);
    }
    let _ = writeln!(
        s,
        "{:>8} {:>6} {:>12} {:>12} {:>10}",
        "quantity", "degree", "mean", "std dev", "kurtosis"
    );
    for d in &study.degrees {
        let key = match d.method {
            MethodName::Epc => d.degree.to_string(),
            _ => format!("i{}", d.degree),
        };
        stats_rows(&mut s, &key, &d.stats);
    }
    if let Some(g) = &study.grid {
        stats_rows(&mut s, "grid", &g.stats);
    }
    for note in super::defect_notes(study) {
        let _ = writeln!(s, "warning: {note}");
    }
    for w in &study.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    if let Some(mc) = &report.mc {
        // The same table `fpsolve simulate` prints, then the run's wall time or origin.
        let _ = write!(s, "{mc}");
        match &report.mc_from {
            Some(dir) => {
                let _ = writeln!(s, "Monte Carlo read from {}", dir.display());
            }
            None => {
                let _ = writeln!(s, "Monte Carlo wall time: {:.1} s", report.mc_wall_s);
            }
        }
        distances(&mut s, study, report, Reference::Mc);
    }
    distances(&mut s, study, report, Reference::Grid);
    for d in &report.disagreements {
        let _ = writeln!(s, "error: {d}");
    }
    s
}

fn degree_row(s: &mut String, d: &DegreeResult) {
    match d.outcome.as_ref().map(|s| s.epc()) {
        Ok(Some(sol)) => {
            let norm = match &sol.normalisation.kind {
                crate::epc::NormalisationKind::Plane { .. } => "plane".to_string(),
                crate::epc::NormalisationKind::InsideRidge { depth, .. } => {
                    format!(
                        "inside ridge, {} e-folds below the mode",
                        crate::epc::EFolds(*depth)
                    )
                }
            };
            let _ = writeln!(
                s,
                "{:>6} {:>6} {:>10.2e} {:>10.2e} {:>10.1}  {}",
                d.degree,
                sol.solve.iterations,
                sol.solve.residual,
                sol.fpk_residual,
                d.wall_ms,
                norm
            );
        }
        Ok(None) => match d.outcome.as_ref().ok().and_then(|s| s.epc_impact()) {
            // EPC with the exact impact condition: its FPK residual includes the impact
            // condition's; the quadrature check (‖R‖ on a rule twice as fine) under its name.
            Some(sol) => {
                let r = &sol.report;
                let fpk = r
                    .fpk_residual
                    .map_or_else(|| "n/a".to_string(), |v| format!("{v:.2e}"));
                let _ = writeln!(
                    s,
                    "{:>6} {:>6} {:>10.2e} {:>10} {:>10.1}  {}; quadrature check {:.1e}",
                    d.degree,
                    r.iterations,
                    r.residual,
                    fpk,
                    d.wall_ms,
                    r.normalisation,
                    r.quadrature_change
                );
            }
            None => {
                let _ = writeln!(s, "{:>6}  not an EPC solution", d.degree);
            }
        },
        Err(e) => {
            let _ = writeln!(s, "{:>6}  failed: {e}", d.degree);
        }
    }
}

fn stats_rows(s: &mut String, key: &str, stats: &[QuantityMoments]) {
    for st in stats {
        let _ = writeln!(
            s,
            "{:>8} {:>6} {} {} {}{}",
            st.name,
            key,
            fixed_or_scientific(st.moments.mean, 5, 12),
            fixed_or_scientific(st.std_dev(), 5, 12),
            fixed_or_scientific(st.moments.kurtosis, 4, 10),
            if st.note().is_some() {
                "   (see warning)"
            } else {
                ""
            }
        );
    }
}

/// One line per method, degree and quantity compared with `reference`; a degree that failed
/// says so in place of its distances, nothing is dropped.
fn distances(s: &mut String, study: &Study, report: &JobReport, reference: Reference) {
    let of: Vec<&Comparison> = report
        .comparisons
        .iter()
        .filter(|c| c.reference == reference)
        .collect();
    if of.is_empty() {
        return;
    }
    for d in study.degrees.iter().filter(|d| d.outcome.is_err()) {
        let _ = writeln!(
            s,
            "{} vs {reference}: no distances, the degree failed",
            d.source()
        );
    }
    if let Some(Err(_)) = study.grid.as_ref().map(|g| &g.outcome) {
        if reference != Reference::Grid {
            let _ = writeln!(
                s,
                "grid vs {reference}: no distances, the grid solve failed"
            );
        }
    }
    for c in of {
        let _ = writeln!(
            s,
            "{} vs {reference}, {} on [{:.4}, {:.4}]: L1 = {:.4}, max|log10 ratio| = {} ({reference} > 1e-3 peak), {} (> 1e-5 peak)",
            c.source,
            c.quantity,
            c.range[0],
            c.range[1],
            c.l1,
            ratio(&c.ratio_1e3, c.source),
            ratio(&c.ratio_1e5, c.source)
        );
    }
}

/// A worst log-ratio, saying where the method's density is 0 and why (EPC is cut beyond its
/// ridge, the grid ends at its domain).
fn ratio(r: &LogRatio, source: Source) -> String {
    if source.method == MethodName::Epc {
        return r.to_string(); // "(EPC is 0 in k of n bins: beyond its ridge)"
    }
    let mut s = match r.max_abs_log10 {
        Some(m) => format!("{m:.3}"),
        None => "undefined".into(),
    };
    if r.bins_epc_zero > 0 {
        let why = source.method.method().zero_reason();
        let _ = write!(
            s,
            " ({source} is 0 in {} of {} bins: {why})",
            r.bins_epc_zero, r.bins
        );
    }
    s
}
