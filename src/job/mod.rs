//! The jobs the command line runs, as library functions: a study (EPC at several degrees,
//! the grid solver, …; PDFs of states or observables), optionally a Monte Carlo reference on
//! the same grids (run, or read from a finished run's directory), the distances of every
//! method to Monte Carlo and to the grid, and the files: `pdf_<name>.csv`, `mc_<name>.csv`,
//! `summary.json`, figures. It is the top of the pipeline, just under the CLI: it runs the
//! study and Monte Carlo and hands their results to the report stage, and a finished job's
//! [`JobReport`] prints as the table the command line shows.

#![warn(missing_docs)]

mod compare;
mod files;
mod mc_from;
pub mod passage;
mod reliability;
mod table;
pub mod transient;

use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::mc::{merge_shards, Grid, McConfig, McError, McResult, Shard, Simulation};
use crate::model::{Model, Override};
use crate::report::{
    count_text, short_number, write_json_flagging_undefined, OutputDir, PdfFigure, PdfTable,
    Points, Provenance, ReportError, UndefinedField,
};
use crate::solve::{quantities, MethodName, MethodSet, NotApplicable, Problem, Quantity};
use crate::study::{MethodPlan, PlanError, Skipped, Study, StudyError, StudyRunner, StudySummary};

pub use compare::{Comparison, Disagreement, LogRatio, Reference, DISAGREEMENT_L1};
pub use mc_from::{McFrom, McFromError};
pub use reliability::{CrossingFile, NoCrossings, ReliabilitySummary, WallImpacts};

/// What a job reports PDFs of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The states and the model's observables (the states are always reported, so that
    /// every method is compared on them too): the main job.
    Observables,
    /// The states' marginals: `fpsolve solve`.
    States,
}

/// What to run. [`JobSpec::default`] is EPC at degrees 2 and 4 on the observables, without
/// Monte Carlo or figures.
#[derive(Clone, Debug)]
pub struct JobSpec {
    /// Degrees of every ladder method (EPC, EPC-impact), solved in order with continuation.
    pub degrees: Vec<usize>,
    /// Parameter overrides.
    pub overrides: Vec<Override>,
    /// States or observables.
    pub target: Target,
    /// The methods.
    pub methods: MethodSet,
    /// Whether the user named the methods: then each must apply to the model (else the job
    /// is refused); otherwise one that does not apply is skipped, with its reason reported.
    pub methods_named: bool,
    /// Cells of the grid solver (position, velocity).
    pub cells: [usize; 2],
    /// Monte Carlo settings, if a Monte Carlo reference is to be run. Its grids are set by
    /// the job to the curves' grids.
    pub mc: Option<McConfig>,
    /// A finished Monte Carlo run to compare with instead of running one: its histogram
    /// grids are the comparison bins.
    pub mc_from: Option<Box<McFrom>>,
    /// Bins of each Monte Carlo histogram, and of the comparisons between methods.
    pub mc_bins: usize,
    /// Whether to render figures.
    pub figures: bool,
}

impl Default for JobSpec {
    fn default() -> JobSpec {
        JobSpec {
            degrees: vec![2, 4],
            overrides: Vec::new(),
            target: Target::Observables,
            methods: MethodSet::new(vec![MethodName::Epc]).expect("one method"),
            methods_named: false,
            cells: crate::grid::DEFAULT_CELLS,
            mc: None,
            mc_from: None,
            mc_bins: 100,
            figures: false,
        }
    }
}

/// The main job's methods when none are named: EPC and the grid, and EPC-impact too where
/// EPC cannot use the model's impact law (two walls, a reflecting law it has no δ-term form
/// for), so that the job runs every method that applies (a [`MethodPlan`] then skips those
/// that do not, with their reasons).
///
/// # Errors
/// [`crate::solve::SolveError`] when EPC cannot even check the model.
///
/// ```
/// use fpsolve::job::default_methods;
/// use fpsolve::solve::Problem;
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_strip.sde");
/// let strip = fpsolve::model::load_model(&path)?.bind(&[])?;
/// assert_eq!(default_methods(&Problem::new(&strip)?)?.to_string(), "epc,epc-impact,grid");
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// let linear = fpsolve::model::load_model(&path)?.bind(&[])?;
/// assert_eq!(default_methods(&Problem::new(&linear)?)?.to_string(), "epc,grid");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn default_methods(problem: &Problem) -> Result<MethodSet, crate::solve::SolveError> {
    let names = match MethodName::Epc.method().applies(problem)? {
        Err(NotApplicable::ImpactLaw { .. }) => {
            vec![MethodName::Epc, MethodName::EpcImpact, MethodName::Grid]
        }
        Ok(()) | Err(_) => vec![MethodName::Epc, MethodName::Grid],
    };
    Ok(MethodSet::new(names).expect("distinct methods"))
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
    /// The methods asked for cannot run on the model.
    #[error(transparent)]
    Methods(#[from] PlanError),
    /// The Monte Carlo run failed.
    #[error("Monte Carlo: {0}")]
    Mc(#[from] McError),
    /// The Monte Carlo run to compare with is not of this model, or not readable.
    #[error("--mc-from: {0}")]
    McFrom(#[from] McFromError),
    /// Both a Monte Carlo run and a finished one to read were asked for.
    #[error("a Monte Carlo run and --mc-from were both asked for; give one")]
    TwoMonteCarlo,
    /// A file could not be written.
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// What `summary.json` holds.
#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    #[serde(flatten)]
    study: StudySummary<'a>,
    #[serde(skip_serializing_if = "<[Skipped]>::is_empty")]
    skipped_methods: &'a [Skipped],
    #[serde(skip_serializing_if = "<[Skipped]>::is_empty")]
    skipped_curves: &'a [Skipped],
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo: Option<&'a McResult>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_from: Option<&'a std::path::Path>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_error: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_wall_s: Option<f64>,
    /// Every distance between two methods, one entry per method, degree, reference and
    /// quantity (each entry names its `method` and `reference`): Monte Carlo's first, then
    /// the grid's, methods in the order [`MethodName::ALL`] lists them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    comparisons: Vec<&'a Comparison>,
    #[serde(skip_serializing_if = "<[Disagreement]>::is_empty")]
    disagreements: &'a [Disagreement],
    #[serde(flatten)]
    reliability: &'a ReliabilitySummary,
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

/// A finished job.
#[derive(Debug)]
pub struct JobReport {
    /// The study.
    pub study: Study,
    /// Methods of the set asked for that were not run because they do not apply to the
    /// model (only when the user did not name the methods).
    pub skipped: Vec<Skipped>,
    /// Methods that ran but left out some of their PDFs, and why (the grid's PDFs of
    /// observables that take minutes, unless the grid was named).
    pub skipped_curves: Vec<Skipped>,
    /// The Monte Carlo result, if one was run or read.
    pub mc: Option<McResult>,
    /// The directory it was read from, with `--mc-from`.
    pub mc_from: Option<PathBuf>,
    /// Why the Monte Carlo run asked for gave no result (the other results are still
    /// written).
    pub mc_error: Option<String>,
    /// Its wall time in seconds (0 for a run read from a directory).
    pub mc_wall_s: f64,
    /// Distances of every method (every degree) to Monte Carlo and to the grid, per
    /// quantity reported.
    pub comparisons: Vec<Comparison>,
    /// The comparisons whose two methods both claim success yet are further apart than
    /// their errors allow (listed in `summary.json` under `disagreements`; the run is flagged).
    pub disagreements: Vec<Disagreement>,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Numbers of `summary.json` that have no finite value (written there as `null` and listed
    /// under `undefined`).
    pub undefined: Vec<UndefinedField>,
    /// Result files that could not be written (listed in `summary.json` under `unwritten`).
    pub unwritten: Vec<Unwritten>,
    /// The crossing tables and impact statistics written (`summary.json`'s `crossings`,
    /// `no_crossings` and `impacts`).
    pub reliability: ReliabilitySummary,
}

/// A job to run: a model and a [`JobSpec`] (the builder; [`Job::run`] writes the files and
/// gives the [`JobReport`]), the shape of every runner of the crate.
///
/// ```
/// use fpsolve::job::{Job, JobSpec, Reference};
/// use fpsolve::report::OutputDir;
/// let model = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\nobserve y = abs(z)\n", None)?;
/// let spec = JobSpec {
///     degrees: vec![2],
///     methods: "epc,grid".parse()?,
///     cells: [40, 60],
///     ..JobSpec::default()
/// };
/// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-job-{}", std::process::id()));
/// let report = Job::new(&model, &spec).run(&OutputDir::create(&tmp)?)?;
/// assert!(report.study.all_converged() && tmp.join("pdf_y.csv").is_file());
/// // EPC n = 2 is exact here: it agrees with the grid to the grid's accuracy.
/// let c = &report.comparisons[0];
/// assert!(c.reference == Reference::Grid && c.l1 < 2e-2);
/// assert!(report.to_string().contains("degree")); // the table the command line prints
/// # std::fs::remove_dir_all(&tmp)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Job<'a> {
    model: &'a Model,
    spec: &'a JobSpec,
    progress: &'a dyn Progress,
    prepared: Option<&'a Problem<'a>>,
}

impl<'a> Job<'a> {
    /// A job of `model` as `spec` says, reporting progress nowhere.
    pub fn new(model: &'a Model, spec: &'a JobSpec) -> Job<'a> {
        Job {
            model,
            spec,
            progress: &Quiet,
            prepared: None,
        }
    }

    /// The model's [`Problem`] as the caller already derived it (of the model bound with the
    /// spec's overrides), used instead of deriving it again (a few tenths of a millisecond of
    /// symbolic work). A problem of another binding is not used: the job derives its own.
    ///
    /// ```
    /// use fpsolve::job::{Job, JobSpec};
    /// use fpsolve::report::OutputDir;
    /// use fpsolve::solve::Problem;
    /// let model = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let spec = JobSpec { degrees: vec![2], methods: "epc".parse()?, ..JobSpec::default() };
    /// let problem = Problem::owning(model.bind(&spec.overrides)?)?;
    /// # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-job-problem-{}", std::process::id()));
    /// let report = Job::new(&model, &spec).problem(&problem).run(&OutputDir::create(&tmp)?)?;
    /// assert!(report.study.all_converged());
    /// # std::fs::remove_dir_all(&tmp)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn problem(mut self, problem: &'a Problem<'a>) -> Self {
        self.prepared = Some(problem);
        self
    }

    /// Where progress goes (a progress bar in the command line).
    pub fn progress(mut self, progress: &'a dyn Progress) -> Self {
        self.progress = progress;
        self
    }

    /// Runs the job and writes its files into `out`.
    ///
    /// # Errors
    /// A [`JobError`] when the study cannot run, a method named does not apply, the Monte
    /// Carlo reference to read is not of this model, or `summary.json` cannot be written; a
    /// degree, a grid solve, a Monte Carlo run or another file that fails is recorded in the
    /// report.
    pub fn run(&self, out: &OutputDir) -> Result<JobReport, JobError> {
        run(self.model, self.spec, self.prepared, out, self.progress)
    }
}

fn run(
    model: &Model,
    spec: &JobSpec,
    prepared: Option<&Problem>,
    out: &OutputDir,
    progress: &dyn Progress,
) -> Result<JobReport, JobError> {
    progress.stage("solving");
    let bound = model.bind(&spec.overrides).map_err(StudyError::from)?;
    if spec.mc.is_some() && spec.mc_from.is_some() {
        return Err(JobError::TwoMonteCarlo);
    }
    if let Some(from) = &spec.mc_from {
        from.check(&bound)?;
    }
    let derived;
    let problem = match prepared {
        Some(p) if p.model() == &bound => p,
        _ => {
            derived = Problem::new(&bound).map_err(StudyError::from)?;
            &derived
        }
    };
    let plan = MethodPlan::new(problem, &spec.methods, spec.methods_named)?;
    // Each curve is also averaged over the bins the comparisons use, from the same prepared
    // density: the Monte Carlo histogram's (the user's `--grid`, the run read, or the
    // curve's range in `mc_bins` bins); without Monte Carlo, the curve's range when there is
    // a grid solution to compare the other methods with.
    let compared = plan.run.contains(&MethodName::Grid) && plan.run.len() > 1;
    let choose = |q: &Quantity, x: &[f64]| -> Option<Grid> {
        if let Some(from) = &spec.mc_from {
            return from.result.quantity(&q.name).map(|h| h.grid);
        }
        if let Some((_, grid)) = spec
            .mc
            .as_ref()
            .and_then(|c| c.grids.iter().find(|(n, _)| n == &q.name))
        {
            return Some(*grid);
        }
        (x.len() >= 2 && (spec.mc.is_some() || compared))
            .then(|| Grid::new(x[0], x[x.len() - 1], spec.mc_bins).ok())
            .flatten()
    };
    let all = quantities(&bound);
    let names: Vec<String> = match spec.target {
        Target::States => all
            .iter()
            .filter(|q| q.is_state)
            .map(|q| q.name.clone())
            .collect(),
        Target::Observables => all.iter().map(|q| q.name.clone()).collect(),
    };
    let without_grid: Vec<String> = plan
        .skipped_curves
        .iter()
        .filter(|s| s.method == MethodName::Grid)
        .flat_map(|s| match &s.why {
            NotApplicable::JumpingObservables { observables } => observables.clone(),
            _ => Vec::new(),
        })
        .collect();
    // The curves of the quantities reported; with a Monte Carlo run, of every quantity: their
    // ranges are the histograms' grids (no pilot run needed).
    let curves_of = if spec.mc.is_some() {
        all.iter().map(|q| q.name.clone()).collect()
    } else {
        names.clone()
    };
    let study = StudyRunner::of(problem)
        .curves_of(&curves_of)
        .degrees(&spec.degrees)
        .methods(&plan.run)
        .cells(spec.cells)
        .without_curves_of(MethodName::Grid, &without_grid)
        .bins(&choose)
        .run()?;
    let mut mc = spec.mc_from.as_ref().map(|f| f.result.clone());
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
        // The crossing tables' levels and the impact-speed table's points, so that Monte
        // Carlo's columns sit beside the other methods'.
        for (name, levels) in reliability::mc_levels(problem, &study, &names) {
            if !config.levels.iter().any(|(n, _)| n == &name) {
                config.levels.push((name, levels));
            }
        }
        if config.impact_speeds.is_none() {
            config.impact_speeds = reliability::mc_speed_grid(problem, &study, &config);
        }
        let t = Instant::now();
        // A Monte Carlo failure does not cost the other results: it is recorded beside them.
        match simulate(problem.dynamics(), &config, progress) {
            Ok(result) => mc = Some(result),
            Err(e) => mc_error = Some(e.to_string()),
        }
        mc_wall_s = t.elapsed().as_secs_f64();
    }

    progress.stage("writing results");
    crate::base::timeline::mark("job: writing");
    let written = files::write(&study, &names, mc.as_ref(), spec.figures, out);
    let comparisons = written.comparisons;
    let mut files = written.files;
    let mut unwritten = written.unwritten;
    crate::base::timeline::mark("job: crossings and impacts");
    let reliability = reliability::write(problem, &study, &names, mc.as_ref(), spec.figures, out);
    files.extend(reliability.files);
    unwritten.extend(reliability.unwritten);
    let reliability = reliability.summary;
    let disagreements = compare::disagreements(&comparisons, |c| match c.reference {
        Reference::Grid => study
            .run_of(MethodName::Grid)
            .and_then(|r| r.solution())
            .and_then(|s| MethodName::Grid.method().error_estimate(s)),
        Reference::Mc => {
            let result = mc.as_ref().filter(|m| m.verdict().is_ok())?;
            let h = result.quantity(&c.quantity)?;
            Some(h.stderr.iter().sum::<f64>() * h.grid.width())
        }
    });
    let mut listed: Vec<&Comparison> = comparisons.iter().collect();
    listed.sort_by_key(|c| (c.reference, c.source.method));
    let summary = Summary {
        provenance: Provenance::now(Some(model)),
        study: study.summary(),
        skipped_methods: &plan.skipped,
        skipped_curves: &plan.skipped_curves,
        monte_carlo: mc.as_ref(),
        monte_carlo_from: spec.mc_from.as_ref().map(|f| f.dir.as_path()),
        monte_carlo_error: mc_error.as_deref(),
        monte_carlo_wall_s: (mc.is_some() && spec.mc.is_some()).then_some(mc_wall_s),
        comparisons: listed,
        disagreements: &disagreements,
        reliability: &reliability,
        unwritten: &unwritten,
    };
    let (path, undefined) = write_json_flagging_undefined(out, "summary.json", &summary)?;
    files.push(path);
    crate::base::timeline::mark("job: summary written");
    Ok(JobReport {
        study,
        skipped: plan.skipped,
        skipped_curves: plan.skipped_curves,
        mc,
        mc_from: spec.mc_from.as_ref().map(|f| f.dir.clone()),
        mc_error,
        mc_wall_s,
        comparisons,
        disagreements,
        files,
        undefined,
        unwritten,
        reliability,
    })
}

/// What a finished job flags, one line each: degrees that did not converge, methods that
/// disagree beyond their errors and numbers that have no finite value. Empty when everything
/// asked for was computed and is defined.
pub fn flags(report: &JobReport) -> Vec<String> {
    // A failed run: EPC's degrees are "degree n" (the method a job runs first), another
    // ladder's "epc-impact degree n", a method without degrees by its name.
    let mut out: Vec<String> = report
        .study
        .runs
        .iter()
        .filter_map(|r| {
            let e = r.outcome.as_ref().err()?;
            Some(match (r.name(), r.degree()) {
                (MethodName::Epc, Some(d)) => format!("degree {d}: {e}"),
                (m, Some(d)) => format!("{m} degree {d}: {e}"),
                (m, None) => format!("{m}: {e}"),
            })
        })
        .collect();
    if let Some(e) = &report.mc_error {
        out.push(format!("Monte Carlo: {e}"));
    }
    out.extend(tolerance_shortfalls(&report.study));
    out.extend(defect_notes(&report.study));
    let warnings = report.study.warnings.iter();
    out.extend(warnings.filter(|w| w.flags()).map(|w| w.to_string()));
    out.extend(report.disagreements.iter().map(Disagreement::to_string));
    for u in &report.unwritten {
        out.push(format!("{} was not written: {}", u.file, u.error));
    }
    if let Some(Err(e)) = report.mc.as_ref().map(|m| m.verdict()) {
        out.push(format!("Monte Carlo: {e}"));
    }
    // A histogram that misses mass makes every distance to it short by that mass.
    let missing = report.mc.iter().flat_map(|m| &m.warnings);
    for w in missing.filter(|w| w.flags_a_comparison()) {
        out.push(format!("Monte Carlo: {w}"));
    }
    out.extend(undefined_flag("summary.json", &report.undefined));
    out
}

/// One line per grid solve whose L1 tolerance (`--tol`) was not reached: its best solve was
/// written, with the estimate it achieved, and flags the run.
fn tolerance_shortfalls(study: &Study) -> Vec<String> {
    study
        .runs
        .iter()
        .filter_map(|r| r.solution()?.grid()?.report.tolerance.as_ref())
        .filter_map(|t| {
            let why = t.shortfall.as_ref()?;
            Some(format!(
                "grid: the L1 tolerance {:.1e} was not reached (estimate {:.1e}): {why}",
                t.asked, t.achieved
            ))
        })
        .collect()
}

/// The line that flags the numbers of `file` that have no finite value (`None` when there
/// are none).
fn undefined_flag(file: &str, undefined: &[UndefinedField]) -> Option<String> {
    match undefined {
        [] => None,
        [u] => Some(format!(
            "{file}: {} is {} (written as null)",
            u.field, u.value
        )),
        [u, rest @ ..] => Some(format!(
            "{file}: {} is {} and {} more numbers have no finite value (written as null, \
             listed under `undefined`)",
            u.field,
            u.value,
            rest.len()
        )),
    }
}

/// What is wrong with each defective observable (one with no finite value on part of the
/// plane), once per observable: its undefined mass is a property of the map, the same at every
/// degree up to the solution's accuracy.
fn defect_notes(study: &Study) -> Vec<String> {
    let mut seen: Vec<&str> = Vec::new();
    let mut notes = Vec::new();
    for st in study.runs.iter().flat_map(|r| &r.stats) {
        if let Some(note) = st.note() {
            if !seen.contains(&st.name.as_str()) {
                seen.push(&st.name);
                notes.push(note);
            }
        }
    }
    notes
}

/// Runs the Monte Carlo in consecutive shards so that progress can be shown; merging the
/// shards gives exactly the unsplit result (the statistics batches are the unit of both).
fn simulate(
    dynamics: &crate::dynamics::Dynamics,
    config: &McConfig,
    progress: &dyn Progress,
) -> Result<McResult, McError> {
    let sim = Simulation::reading(dynamics, config)?;
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

/// What [`write_mc`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct McFiles {
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Numbers of `mc_summary.json` that have no finite value (written there as `null` and
    /// listed under `undefined`).
    pub undefined: Vec<UndefinedField>,
    /// The figures that could not be drawn, each with why (the numbers are written all the
    /// same; [`McFiles::flags`] lists them).
    pub unwritten: Vec<Unwritten>,
}

impl McFiles {
    /// What the files flag, one line each: the result's verdict failures, the numbers
    /// that have no finite value and the figures not drawn. Empty when the result can be used as it stands.
    pub fn flags(&self, result: &McResult) -> Vec<String> {
        let mut out = mc_flags(result, &self.undefined);
        for u in &self.unwritten {
            out.push(format!("{} was not written: {}", u.file, u.error));
        }
        out
    }
}

/// What a Monte Carlo result flags, one line each: its verdict failures (too many blow-ups,
/// not stationary) and, when `undefined` (from [`crate::report::undefined_fields`]) is not
/// empty, the numbers of `mc_summary.json` that have no finite value. Empty when the result
/// can be used as it stands: what `fpsolve simulate` exits 1 for, and what the Python
/// package warns about.
pub fn mc_flags(result: &McResult, undefined: &[UndefinedField]) -> Vec<String> {
    let mut out = Vec::new();
    if let Err(e) = result.verdict() {
        out.push(e.to_string());
    }
    out.extend(undefined_flag("mc_summary.json", undefined));
    out
}

/// Writes a Monte Carlo result alone (`fpsolve simulate`, `fpsolve merge`):
/// `mc_<quantity>.csv` (bin centre, `mc`, `mc_stderr`, and `mc_bias`, `mc_bias_stderr` when
/// the time-step bias was estimated) and its figure `mc_<quantity>.png/.svg` per state and
/// observable, and `mc_summary.json` (the
/// whole [`McResult`]: verdicts and warnings included, numbers without a finite value written
/// as `null` and listed under `undefined`), with its `provenance`. A merged set of shards
/// writes exactly what the unsplit run writes, but for the provenance (the command, the time).
pub fn write_mc(
    result: &McResult,
    provenance: &Provenance,
    out: &OutputDir,
) -> Result<McFiles, ReportError> {
    let mut files = Vec::new();
    let mut unwritten = Vec::new();
    for q in &result.quantities {
        let table = PdfTable {
            variable: q.name.clone(),
            x: q.grid.centers(),
            columns: mc_columns(q),
        };
        files.push(table.write_csv(out, &format!("mc_{}.csv", q.name))?);
    }
    // The figures side by side (each drawn and written by itself), listed in the quantities'
    // order. A figure that cannot be drawn costs no number: noted, the files still written.
    let figures: Vec<_> = result
        .quantities
        .par_iter()
        .map(|q| mc_figure(result, q).write(out, &format!("mc_{}", q.name)))
        .collect();
    for (q, figure) in result.quantities.iter().zip(figures) {
        match figure {
            Ok(w) => files.extend([w.png, w.svg]),
            Err(e) => unwritten.push(Unwritten {
                file: format!("mc_{}.png/.svg", q.name),
                error: e.to_string(),
            }),
        }
    }
    #[derive(Serialize)]
    struct WithProvenance<'a> {
        provenance: &'a Provenance,
        #[serde(flatten)]
        result: &'a McResult,
    }
    let (summary, undefined) = write_json_flagging_undefined(
        out,
        "mc_summary.json",
        &WithProvenance { provenance, result },
    )?;
    files.push(summary);
    Ok(McFiles {
        files,
        undefined,
        unwritten,
    })
}

/// A histogram drawn as the main job draws Monte Carlo beside the other methods: points with
/// their standard errors, linear and log panels, the model's parameters under the title.
fn mc_figure(result: &McResult, q: &crate::mc::QuantityHistogram) -> PdfFigure {
    PdfFigure {
        title: format!("{}: Monte Carlo PDF of {}", result.settings.model, q.name),
        subtitle: result
            .settings
            .params
            .iter()
            .map(|p| format!("{} = {}", p.name, short_number(p.value)))
            .collect::<Vec<_>>()
            .join(", "),
        variable_label: q.name.clone(),
        curves: Vec::new(),
        points: Some(Points {
            label: format!("Monte Carlo, {} samples", count_text(q.samples)),
            x: q.grid.centers(),
            y: q.density.clone(),
            stderr: q.stderr.clone(),
        }),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_model;

    /// A prepared problem of the model as the spec binds it is used; one of another binding
    /// is not (the job derives its own): each run gives the bits of a job given none.
    #[test]
    fn a_prepared_problem_of_another_binding_is_not_used() {
        let model = parse_model(
            "model m\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
             noise xi: intensity 1\ndiffusion v: xi\n",
            None,
        )
        .unwrap();
        let spec = JobSpec {
            degrees: vec![2],
            methods: "epc".parse().unwrap(),
            overrides: vec!["c=0.3".parse().unwrap()],
            ..JobSpec::default()
        };
        let root =
            std::env::temp_dir().join(format!("fpsolve-job-prepared-{}", std::process::id()));
        let variance = |prepared: Option<&Problem>, tag: &str| {
            let out = OutputDir::create(root.join(tag)).unwrap();
            let job = Job::new(&model, &spec);
            let job = match prepared {
                Some(p) => job.problem(p),
                None => job,
            };
            let report = job.run(&out).unwrap();
            let solution = report.study.runs[0].outcome.as_ref().unwrap();
            solution.moments("v").unwrap().moments.variance
        };
        let fresh = variance(None, "fresh");
        // Var v = πK/c = 1/(2c) for 2πK = 1: the override's c, not the file's.
        assert!((fresh - 1.0 / 0.6).abs() < 1e-8, "{fresh}");
        let same = Problem::owning(model.bind(&spec.overrides).unwrap()).unwrap();
        let other = Problem::owning(model.bind(&[]).unwrap()).unwrap();
        assert_eq!(variance(Some(&same), "same").to_bits(), fresh.to_bits());
        assert_eq!(variance(Some(&other), "other").to_bits(), fresh.to_bits());
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// The job reads its model once for every method it runs (EPC's operator, EPC-impact,
    /// the grid and the Monte Carlo run take the problem's reading); only EPC's Zhuravlev
    /// transform, another model, is read on its own.
    #[test]
    fn a_job_reads_its_model_once() {
        let model = crate::model::parse_model(
            "model read_once_job\nstate z, v\ndrift z: v\ndrift v: -v - z\n\
             noise xi: intensity 2\ndiffusion v: xi\nimpact z = -3: v -> -0.8*v\n\
             domain z >= -3\n",
            None,
        )
        .unwrap();
        let spec = JobSpec {
            degrees: vec![2],
            methods: "epc,epc-impact,grid".parse().unwrap(),
            methods_named: true,
            cells: [32, 48],
            mc: Some(McConfig {
                trajectories: 256,
                ..McConfig::default()
            }),
            ..JobSpec::default()
        };
        let out =
            std::env::temp_dir().join(format!("fpsolve-job-read-once-{}", std::process::id()));
        let problem = Problem::owning(model.bind(&[]).unwrap()).unwrap();
        let report = Job::new(&model, &spec)
            .problem(&problem)
            .run(&OutputDir::create(&out).unwrap())
            .unwrap();
        std::fs::remove_dir_all(&out).unwrap();
        assert_eq!(report.study.runs.len(), 3);
        assert!(report.study.runs.iter().all(|r| r.outcome.is_ok()));
        assert!(report.mc.is_some(), "{:?}", report.mc_error);
        assert_eq!(crate::dynamics::reads_of("read_once_job"), 1);
    }
}
