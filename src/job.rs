//! The jobs the command line runs, as library functions: a study (EPC at several degrees,
//! PDFs of states or observables), optionally a Monte Carlo reference on the same grids, the
//! EPC-vs-MC distances, and the files: `pdf_<name>.csv`, `summary.json`, figures. A
//! finished job's [`JobReport`] prints as the table the command line shows.

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use crate::mc::{merge_shards, Grid, McConfig, McError, McResult, Shard, Simulation};
use crate::model::{Model, Override};
use crate::report::{
    write_json_flagging_undefined, Curve, OutputDir, PdfFigure, PdfTable, Points, ReportError,
    UndefinedField,
};
use crate::solve::{reported, Quantity};
use crate::study::{Study, StudyError, StudyRunner, StudySummary};

/// What a job reports PDFs of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The model's observables (the states when it declares none): the main job.
    Observables,
    /// The states' marginals: `fpsolve solve`.
    States,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct JobSpec {
    /// EPC degrees, solved in order with continuation.
    pub degrees: Vec<usize>,
    /// Parameter overrides.
    pub overrides: Vec<Override>,
    /// States or observables.
    pub target: Target,
    /// Monte Carlo settings, if a Monte Carlo reference is wanted. Its grids are set by the
    /// job to the EPC grids.
    pub mc: Option<McConfig>,
    /// Bins of each Monte Carlo histogram.
    pub mc_bins: usize,
    /// Whether to render figures.
    pub figures: bool,
}

/// Hears about a job's progress (a progress bar in the command line; nothing in tests).
pub trait Progress: Sync {
    /// A new stage begins.
    fn stage(&self, _message: &str) {}
    /// Monte Carlo progress: `done` of `total` parts finished.
    fn advance(&self, _done: u64, _total: u64) {}
}

/// Progress that goes nowhere.
pub struct Quiet;
impl Progress for Quiet {}

/// Why a job failed as a whole.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The study could not run.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// The Monte Carlo run failed.
    #[error("Monte Carlo: {0}")]
    Mc(#[from] McError),
    /// A file could not be written.
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// The distance between one EPC degree and Monte Carlo for one quantity, on the histogram's
/// bins: the EPC density is averaged over each bin (as the histogram is), never taken at the
/// bin centre.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The quantity.
    pub quantity: String,
    /// The EPC degree.
    pub degree: usize,
    /// The histogram's range [lo, hi]: the distances say nothing about values outside it.
    pub range: [f64; 2],
    /// L1 = Σ_bins |p̄_EPC − p_MC|·width, with p̄_EPC the EPC density's bin average.
    pub l1: f64,
    /// The worst log-ratio where p_MC > 1e−3 of its peak.
    pub ratio_1e3: LogRatio,
    /// The worst log-ratio where p_MC > 1e−5 of its peak.
    pub ratio_1e5: LogRatio,
}

/// max |log10(p̄_EPC / p_MC)| over the bins where the histogram exceeds a level, and the bins
/// there where the EPC density is exactly 0 (cut beyond its ridge), where the ratio has no
/// finite value and is not counted in the maximum.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogRatio {
    /// The maximum over the bins where p̄_EPC > 0 (`None` if there is no such bin).
    pub max_abs_log10: Option<f64>,
    /// Bins above the level (where the histogram is positive).
    pub bins: usize,
    /// Bins above the level where p̄_EPC = 0.
    pub bins_epc_zero: usize,
}

impl std::fmt::Display for LogRatio {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.max_abs_log10 {
            Some(m) => write!(f, "{m:.3}")?,
            None => f.write_str("undefined")?,
        }
        if self.bins_epc_zero > 0 {
            write!(
                f,
                " (EPC is 0 in {} of {} bins: beyond its ridge)",
                self.bins_epc_zero, self.bins
            )?;
        }
        Ok(())
    }
}

/// What `summary.json` holds.
#[derive(Serialize)]
struct Summary<'a> {
    #[serde(flatten)]
    study: StudySummary<'a>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo: Option<&'a McResult>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_error: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_wall_s: Option<f64>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    epc_vs_mc: Vec<Comparison>,
    #[serde(skip_serializing_if = "<[Unwritten]>::is_empty")]
    unwritten: &'a [Unwritten],
}

/// A result file that could not be written, and why (the run's other files are kept).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Unwritten {
    /// The file's name.
    pub file: String,
    /// Why it could not be written.
    pub error: String,
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

/// A finished job.
#[derive(Debug)]
pub struct JobReport {
    /// The study.
    pub study: Study,
    /// The Monte Carlo result, if one was run.
    pub mc: Option<McResult>,
    /// Why the Monte Carlo run asked for gave no result (the EPC results are still written).
    pub mc_error: Option<String>,
    /// Its wall time in seconds.
    pub mc_wall_s: f64,
    /// EPC-vs-MC distances (empty without Monte Carlo).
    pub comparisons: Vec<Comparison>,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Numbers of `summary.json` that have no finite value (written there as `null` and listed
    /// under `undefined`).
    pub undefined: Vec<UndefinedField>,
    /// Result files that could not be written (listed in `summary.json` under `unwritten`).
    pub unwritten: Vec<Unwritten>,
}

/// A job to run: a model and a [`JobSpec`] (the builder; [`Job::run`] writes the files and
/// gives the [`JobReport`]), the shape of every runner of the crate.
///
/// ```
/// use fpsolve::job::{Job, JobSpec, Target};
/// use fpsolve::report::OutputDir;
/// let model = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\nobserve y = abs(z)\n", None)?;
/// let spec = JobSpec {
///     degrees: vec![2],
///     overrides: vec![],
///     target: Target::Observables,
///     mc: None,
///     mc_bins: 100,
///     figures: false,
/// };
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-job-{}", std::process::id()));
/// let report = Job::new(&model, &spec).run(&OutputDir::create(&tmp)?)?;
/// assert!(report.study.all_converged() && tmp.join("pdf_y.csv").is_file());
/// assert!(report.to_string().contains("degree")); // the table the command line prints
/// # std::fs::remove_dir_all(&tmp)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Job<'a> {
    model: &'a Model,
    spec: &'a JobSpec,
    progress: &'a dyn Progress,
}

impl<'a> Job<'a> {
    /// A job of `model` as `spec` says, reporting progress nowhere.
    pub fn new(model: &'a Model, spec: &'a JobSpec) -> Job<'a> {
        Job {
            model,
            spec,
            progress: &Quiet,
        }
    }

    /// Where progress goes (a progress bar in the command line).
    pub fn progress(mut self, progress: &'a dyn Progress) -> Self {
        self.progress = progress;
        self
    }

    /// Runs the job and writes its files into `out`.
    ///
    /// # Errors
    /// A [`JobError`] when the study cannot run or `summary.json` cannot be written; a
    /// degree, a Monte Carlo run or another file that fails is recorded in the report.
    pub fn run(&self, out: &OutputDir) -> Result<JobReport, JobError> {
        run(self.model, self.spec, out, self.progress)
    }
}

fn run(
    model: &Model,
    spec: &JobSpec,
    out: &OutputDir,
    progress: &dyn Progress,
) -> Result<JobReport, JobError> {
    progress.stage("solving EPC");
    let bound = model.bind(&spec.overrides).map_err(StudyError::from)?;
    // With Monte Carlo, each curve is also averaged over the bins its histogram will have (the
    // user's `--grid`, or the curve's range in `mc_bins` bins), from the same prepared density.
    let choose = |q: &Quantity, x: &[f64]| -> Option<Grid> {
        let config = spec.mc.as_ref()?;
        if let Some((_, grid)) = config.grids.iter().find(|(n, _)| n == &q.name) {
            return Some(*grid);
        }
        (x.len() >= 2)
            .then(|| Grid::new(x[0], x[x.len() - 1], spec.mc_bins).ok())
            .flatten()
    };
    let study = StudyRunner::new(&bound)
        .degrees(&spec.degrees)
        .bins(&choose)
        .run()?;
    let names: Vec<String> = match spec.target {
        Target::States => study
            .quantities
            .iter()
            .filter(|q| q.is_state)
            .map(|q| q.name.clone())
            .collect(),
        Target::Observables => reported(&study.quantities)
            .into_iter()
            .map(|q| q.name.clone())
            .collect(),
    };

    let mut mc = None;
    let mut mc_error = None;
    let mut mc_wall_s = 0.0;
    if let Some(config) = &spec.mc {
        progress.stage("Monte Carlo");
        let mut config = config.clone();
        for c in &study.curves {
            if let Some(grid) = &c.bins {
                if !config.grids.iter().any(|(n, _)| n == &c.name) {
                    config.grids.push((c.name.clone(), *grid));
                }
            }
        }
        let t = Instant::now();
        // A Monte Carlo failure does not cost the EPC results: it is recorded beside them.
        match simulate(&study, &config, progress) {
            Ok(result) => mc = Some(result),
            Err(e) => mc_error = Some(e.to_string()),
        }
        mc_wall_s = t.elapsed().as_secs_f64();
    }

    progress.stage("writing results");
    let mut files = Vec::new();
    // A file that cannot be written does not cost the others: it is recorded in the summary.
    let mut unwritten: Vec<Unwritten> = Vec::new();
    let mut comparisons = Vec::new();
    for name in &names {
        let curve = study
            .curves
            .iter()
            .find(|c| &c.name == name)
            .expect("a curve per quantity");
        let mc_q = mc.as_ref().and_then(|m| m.quantity(name));
        // The EPC curves on their own grid, whatever the histogram's range.
        if !curve.x.is_empty() {
            let table = PdfTable {
                variable: name.clone(),
                x: curve.x.clone(),
                columns: curve
                    .columns
                    .iter()
                    .map(|c| (format!("epc_n{}", c.degree), c.pdf.clone()))
                    .collect(),
            };
            let file = format!("pdf_{name}.csv");
            let written = table.write_csv(out, &file).map(|p| vec![p]);
            keep(file, written, &mut files, &mut unwritten);
        }
        // The histogram beside each degree's bin averages, on the histogram's bins.
        if let Some(q) = mc_q {
            // A failed degree has no column here; it is flagged with the study's other
            // failures. The bins are the histogram's own (set from the curve above).
            let mut columns = mc_columns(q);
            for c in curve
                .columns
                .iter()
                .filter(|c| c.bin_means.len() == q.grid.bins)
            {
                comparisons.push(compare(name, c.degree, &c.bin_means, q));
                columns.push((format!("epc_n{}_bin_mean", c.degree), c.bin_means.clone()));
            }
            let table = PdfTable {
                variable: name.clone(),
                x: q.grid.centers(),
                columns,
            };
            let file = format!("mc_{name}.csv");
            let written = table.write_csv(out, &file).map(|p| vec![p]);
            keep(file, written, &mut files, &mut unwritten);
        }
        if spec.figures && !curve.x.is_empty() {
            let figure = PdfFigure {
                title: format!("{}: PDF of {name}", study.model.name()),
                variable_label: name.clone(),
                curves: curve
                    .columns
                    .iter()
                    .map(|c| Curve {
                        label: epc_label(&study, c.degree),
                        x: curve.x.clone(),
                        y: c.pdf.clone(),
                    })
                    .collect(),
                points: mc_q.map(|q| Points {
                    label: "Monte Carlo".into(),
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
    }
    let summary = Summary {
        study: study.summary(),
        monte_carlo: mc.as_ref(),
        monte_carlo_error: mc_error.as_deref(),
        monte_carlo_wall_s: mc.as_ref().map(|_| mc_wall_s),
        epc_vs_mc: comparisons.clone(),
        unwritten: &unwritten,
    };
    let (path, undefined) = write_json_flagging_undefined(out, "summary.json", &summary)?;
    files.push(path);
    Ok(JobReport {
        study,
        mc,
        mc_error,
        mc_wall_s,
        comparisons,
        files,
        undefined,
        unwritten,
    })
}

/// What a finished job flags, one line each: degrees that did not converge and numbers that
/// have no finite value. Empty when everything asked for was computed and is defined.
pub fn flags(report: &JobReport) -> Vec<String> {
    let mut out: Vec<String> = report
        .study
        .degrees
        .iter()
        .filter_map(|d| {
            d.outcome
                .as_ref()
                .err()
                .map(|e| format!("degree {}: {e}", d.degree))
        })
        .collect();
    if let Some(e) = &report.mc_error {
        out.push(format!("Monte Carlo: {e}"));
    }
    out.extend(defect_notes(&report.study));
    for u in &report.unwritten {
        out.push(format!("{} was not written: {}", u.file, u.error));
    }
    if let Some(Err(e)) = report.mc.as_ref().map(|m| m.verdict()) {
        out.push(format!("Monte Carlo: {e}"));
    }
    match report.undefined.as_slice() {
        [] => {}
        [u] => out.push(format!(
            "summary.json: {} is {} (written as null)",
            u.field, u.value
        )),
        [u, rest @ ..] => out.push(format!(
            "summary.json: {} is {} and {} more numbers have no finite value (written as null, \
             listed under `undefined`)",
            u.field,
            u.value,
            rest.len()
        )),
    }
    out
}

/// What is wrong with each defective observable (one with no finite value on part of the
/// plane), once per observable: its undefined mass is a property of the map, the same at every
/// degree up to the solution's accuracy.
fn defect_notes(study: &Study) -> Vec<String> {
    let mut seen: Vec<&str> = Vec::new();
    let mut notes = Vec::new();
    for st in study.degrees.iter().flat_map(|d| &d.stats) {
        if let Some(note) = st.note() {
            if !seen.contains(&st.name.as_str()) {
                seen.push(&st.name);
                notes.push(note);
            }
        }
    }
    notes
}

/// The legend text of a degree's curve, saying when the density is normalised inside a ridge.
fn epc_label(study: &Study, degree: usize) -> String {
    let ridge = study
        .degrees
        .iter()
        .find(|d| d.degree == degree)
        .and_then(|d| d.epc())
        .and_then(|s| match &s.normalisation.kind {
            crate::epc::NormalisationKind::InsideRidge { depth, .. } => Some(*depth),
            crate::epc::NormalisationKind::Plane { .. } => None,
        });
    match ridge {
        Some(depth) => format!("EPC n = {degree} (inside ridge, {depth:.1} e-folds)"),
        None => format!("EPC n = {degree}"),
    }
}

/// Runs the Monte Carlo in consecutive shards so that progress can be shown; merging the
/// shards gives exactly the unsplit result (the statistics batches are the unit of both).
fn simulate(
    study: &Study,
    config: &McConfig,
    progress: &dyn Progress,
) -> Result<McResult, McError> {
    let sim = Simulation::new(&study.model, config)?;
    let batches = sim.settings().batches;
    let threads = rayon::current_num_threads() as u64;
    // Enough batches per part to keep every thread busy, at most 50 parts.
    let parts = (batches / (2 * threads).max(1)).clamp(1, 50);
    let mut outputs = Vec::with_capacity(parts as usize);
    for k in 0..parts {
        outputs.push(sim.run_shard(Shard::new(k, parts)?)?);
        progress.advance(k + 1, parts);
    }
    merge_shards(&outputs)
}

/// L1 distance and the worst log-ratios between EPC bin averages and a histogram.
fn compare(
    name: &str,
    degree: usize,
    epc_bins: &[f64],
    mc: &crate::mc::QuantityHistogram,
) -> Comparison {
    let width = mc.grid.width();
    let l1 = epc_bins
        .iter()
        .zip(&mc.density)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        * width;
    let peak = mc.density.iter().copied().fold(0.0, f64::max);
    let worst = |level: f64| {
        let mut r = LogRatio {
            max_abs_log10: None,
            bins: 0,
            bins_epc_zero: 0,
        };
        for (e, m) in epc_bins.iter().zip(&mc.density) {
            if !(*m > level * peak && *m > 0.0) {
                continue;
            }
            r.bins += 1;
            if *e > 0.0 {
                let v = (e / m).log10().abs();
                r.max_abs_log10 = Some(r.max_abs_log10.map_or(v, |w: f64| w.max(v)));
            } else {
                r.bins_epc_zero += 1;
            }
        }
        r
    };
    let [lo, hi] = [mc.grid.lo, mc.grid.hi];
    Comparison {
        quantity: name.to_string(),
        degree,
        range: [lo, hi],
        l1,
        ratio_1e3: worst(1e-3),
        ratio_1e5: worst(1e-5),
    }
}

/// The short table the command line prints after a job.
impl std::fmt::Display for JobReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&table(self))
    }
}

fn table(report: &JobReport) -> String {
    use std::fmt::Write;
    let study = &report.study;
    let mut s = String::new();
    let params: Vec<String> = study
        .model
        .params()
        .iter()
        .map(|(n, v)| format!("{n} = {v:.6}"))
        .collect();
    let _ = writeln!(s, "{}: {}", study.model.name(), params.join(", "));
    // Two quality figures: the Galerkin residual says the projected equations were solved;
    // the FPK residual ∫|F|·p says how far the density is from solving the FPK equation itself.
    let _ = writeln!(
        s,
        "{:>6} {:>6} {:>10} {:>10} {:>10}  normalisation",
        "degree", "iters", "galerkin", "fpk resid", "solve ms"
    );
    for d in &study.degrees {
        match d.outcome.as_ref().map(|s| s.epc()) {
            Ok(Some(sol)) => {
                let norm = match &sol.normalisation.kind {
                    crate::epc::NormalisationKind::Plane { .. } => "plane".to_string(),
                    crate::epc::NormalisationKind::InsideRidge { depth, .. } => {
                        format!("inside ridge, {depth:.1} e-folds below the mode")
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
            Ok(None) => {
                let _ = writeln!(s, "{:>6}  not an EPC solution", d.degree);
            }
            Err(e) => {
                let _ = writeln!(s, "{:>6}  failed: {e}", d.degree);
            }
        }
    }
    let _ = writeln!(
        s,
        "{:>8} {:>6} {:>12} {:>12} {:>10}",
        "quantity", "degree", "mean", "std dev", "kurtosis"
    );
    for d in &study.degrees {
        for st in &d.stats {
            let _ = writeln!(
                s,
                "{:>8} {:>6} {:>12.5} {:>12.5} {:>10.4}{}",
                st.name,
                d.degree,
                st.moments.mean,
                st.std_dev(),
                st.moments.kurtosis,
                if st.note().is_some() {
                    "   (see warning)"
                } else {
                    ""
                }
            );
        }
    }
    for note in defect_notes(study) {
        let _ = writeln!(s, "warning: {note}");
    }
    if let Some(mc) = &report.mc {
        // The same table `fpsolve simulate` prints, then the run's wall time.
        let _ = write!(s, "{mc}");
        let _ = writeln!(s, "Monte Carlo wall time: {:.1} s", report.mc_wall_s);
        for c in &report.comparisons {
            let _ = writeln!(
                s,
                "EPC n = {} vs MC, {} on [{:.4}, {:.4}]: L1 = {:.4}, max|log10 ratio| = {} (MC > 1e-3 peak), {} (> 1e-5 peak)",
                c.degree,
                c.quantity,
                c.range[0],
                c.range[1],
                c.l1,
                c.ratio_1e3,
                c.ratio_1e5
            );
        }
    }
    s
}

/// Writes a Monte Carlo result alone (`fpsolve simulate`, `fpsolve merge`):
/// `mc_<quantity>.csv` (bin centre, `mc`, `mc_stderr`, and `mc_bias`, `mc_bias_stderr` when
/// the time-step bias was estimated) per state and observable, and `mc_summary.json` (the
/// whole [`McResult`]: verdicts and warnings included). A merged set of shards writes exactly what the unsplit run writes.
pub fn write_mc(result: &McResult, out: &OutputDir) -> Result<Vec<PathBuf>, ReportError> {
    let mut files = Vec::new();
    for q in &result.quantities {
        let table = PdfTable {
            variable: q.name.clone(),
            x: q.grid.centers(),
            columns: mc_columns(q),
        };
        files.push(table.write_csv(out, &format!("mc_{}.csv", q.name))?);
    }
    files.push(write_json_flagging_undefined(out, "mc_summary.json", result)?.0);
    Ok(files)
}

/// A histogram's columns: `mc`, `mc_stderr`, and the time-step bias estimate of each bin
/// beside its statistical error (`mc_bias`, `mc_bias_stderr`) when one was made.
fn mc_columns(q: &crate::mc::QuantityHistogram) -> Vec<(String, Vec<f64>)> {
    let mut columns = vec![
        ("mc".into(), q.density.clone()),
        ("mc_stderr".into(), q.stderr.clone()),
    ];
    if let Some(b) = &q.time_step_bias {
        // A bin whose bias has no finite estimate (too few samples in it) is a missing cell,
        // not a number.
        let defined = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .map(|x| if x.is_finite() { *x } else { f64::NAN })
                .collect()
        };
        columns.push(("mc_bias".into(), defined(&b.density)));
        columns.push(("mc_bias_stderr".into(), defined(&b.density_stderr)));
    }
    columns
}
