//! A study: one bound model, the methods asked for (EPC at several degrees, the grid solver,
//! …) and the PDFs of its states and observables on common grids — what `fpsolve solve` and
//! the main job report. It sits above the front door ([`crate::solve::Problem`]: each degree
//! of a ladder method, and the grid, is a [`Solution`] or the reason there is none) and the
//! observables, and below the job and the sweep, which add Monte Carlo and the files.

#![warn(missing_docs)]

mod bin_means;
mod curves;
mod methods;
mod run;
mod warning;

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use serde::Serialize;

use crate::base::run::RunControl;
use crate::base::timeline;
use crate::epc::EpcSolution;
use crate::grid::GridReport;
use crate::mc::ParamValue;
use crate::model::{BindError, BoundModel, Model, Override};
use crate::solve::{Method, MethodName, Problem, Quantity, QuantityMoments, Solution, SolveError};

pub use curves::{BinChoice, MethodColumn, PdfCurves, Source};
pub use methods::{MethodPlan, PlanError, Refused, Skipped};
pub use run::Run;
pub use warning::{StudyWarning, MEAN_VELOCITY_MARGIN, MEAN_VELOCITY_RELATIVE};

/// Why a study could not run at all (a failing degree is not this: it is kept in the study).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The parameters could not be bound.
    #[error(transparent)]
    Bind(#[from] BindError),
    /// The FPK operator could not be derived.
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// No degree was asked for.
    #[error("no EPC degree was asked for")]
    NoDegree,
    /// No method was asked for.
    #[error("no method was asked for")]
    NoMethod,
}

/// The PDF of a quantity at one degree, or why that degree has none.
#[derive(Debug)]
pub struct DegreePdf<'a> {
    /// The degree n.
    pub degree: usize,
    /// The PDF at the points asked, or the degree's failure.
    pub pdf: Result<Vec<f64>, &'a SolveError>,
}

/// A finished study.
#[derive(Debug)]
pub struct Study {
    /// The bound model.
    pub model: BoundModel,
    /// One run per degree asked of each ladder method, in the order the methods were asked
    /// (EPC first), then one run of each method without degrees (the grid).
    pub runs: Vec<Run>,
    /// PDFs of the states, then of the observables (those asked by
    /// [`StudyRunner::curves_of`]).
    pub curves: Vec<PdfCurves>,
    /// The states, then the observables, with how each is computed.
    pub quantities: Vec<Quantity>,
    /// What the reader must know beyond each method's report (a non-smooth Zhuravlev
    /// transform under EPC, a mean velocity that is not 0); those that
    /// [flag](StudyWarning::flags) the run make it exit 1.
    pub warnings: Vec<StudyWarning>,
    /// Total wall time in milliseconds.
    pub wall_ms: f64,
}

/// A study to run: a bound model and the EPC degrees (the builder of [`Study`]).
///
/// ```
/// use fpsolve::model::parse_model;
/// use fpsolve::study::StudyRunner;
/// let text = "model linear
/// param c = 0.1, k = 1
/// state z, v
/// drift z: v
/// drift v: -c*v - k*z
/// noise xi: intensity 1
/// diffusion v: xi
/// observe y = abs(z)
/// ";
/// let bound = parse_model(text, None)?.bind(&[])?;
/// let study = StudyRunner::new(&bound).degrees(&[2, 3]).run()?;
/// assert!(study.runs[0].outcome.is_ok());
/// assert!(study.runs[1].outcome.is_err()); // an odd degree fails alone, visibly
/// let y = study.curves.iter().find(|c| c.name == "y").unwrap();
/// assert_eq!(y.x[0], 0.0); // |z| has no mass below 0: its grid starts at the barrier
/// let at = study.pdf_at("y", &[0.5])?;
/// assert!(at[0].pdf.is_ok() && at[1].pdf.is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct StudyRunner<'a> {
    model: &'a BoundModel,
    /// The model's problem when the caller derived it already ([`StudyRunner::of`]).
    problem: Option<&'a Problem<'a>>,
    degrees: Vec<usize>,
    methods: Vec<MethodName>,
    cells: [usize; 2],
    bins: Option<&'a BinChoice<'a>>,
    curves_of: Option<Vec<String>>,
    left_out: Vec<(MethodName, String)>,
    run: RunControl,
    /// Methods solved so far (a ladder counts once), for `run`'s progress.
    solved: AtomicU64,
}

impl<'a> StudyRunner<'a> {
    /// A study of `model` by EPC at degrees 2 and 4.
    pub fn new(model: &'a BoundModel) -> StudyRunner<'a> {
        StudyRunner {
            model,
            problem: None,
            degrees: vec![2, 4],
            methods: vec![MethodName::Epc],
            cells: crate::grid::DEFAULT_CELLS,
            bins: None,
            curves_of: None,
            left_out: Vec::new(),
            run: RunControl::new(),
            solved: AtomicU64::new(0),
        }
    }

    /// A study of the model of `problem` (as [`StudyRunner::new`]), solving that problem
    /// rather than deriving it again from the model (a third of a millisecond for
    /// vibro_duffing: a caller that checked the model with it saves that).
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = fpsolve::solve::Problem::new(&bound)?;
    /// let study = fpsolve::study::StudyRunner::of(&problem).degrees(&[2]).run()?;
    /// assert_eq!(study.runs[0].stats.len(), problem.quantities().len());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn of(problem: &'a Problem<'a>) -> StudyRunner<'a> {
        StudyRunner {
            problem: Some(problem),
            ..StudyRunner::new(problem.model())
        }
    }

    /// Computes the PDF curves of these quantities only (default: every state and
    /// observable); the moments are computed for all of them either way.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let study = fpsolve::study::StudyRunner::new(&bound)
    ///     .degrees(&[2])
    ///     .curves_of(&["y".to_string()])
    ///     .run()?;
    /// assert_eq!(study.curves.len(), 1);
    /// assert_eq!(study.runs[0].stats.len(), 4);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn curves_of(mut self, names: &[String]) -> Self {
        self.curves_of = Some(names.to_vec());
        self
    }

    /// Leaves `method`'s column out of the curves of these quantities (the grid's PDFs of
    /// observables that need level-set quadrature take minutes: what
    /// [`StationaryMethod::leaves_out`](crate::solve::StationaryMethod::leaves_out) says);
    /// its moments of them, and its columns of every other quantity, are computed as usual.
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// use fpsolve::study::{Source, StudyRunner};
    /// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\n\
    ///             diffusion v: xi\nobserve E = v^2/2 + z^2/2\n";
    /// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// let study = StudyRunner::new(&bound)
    ///     .degrees(&[2])
    ///     .methods(&[MethodName::Epc, MethodName::Grid])
    ///     .cells([40, 60])
    ///     .without_curves_of(MethodName::Grid, &["E".to_string()])
    ///     .run()?;
    /// let curve = |name: &str| study.curves.iter().find(|c| c.name == name).unwrap();
    /// let grid = Source { method: MethodName::Grid, degree: None };
    /// assert!(curve("E").column(grid).is_none());
    /// assert!(curve("z").column(grid).is_some());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn without_curves_of(mut self, method: MethodName, names: &[String]) -> Self {
        self.left_out
            .extend(names.iter().map(|n| (method, n.clone())));
        self
    }

    /// Also averages every curve over histogram bins chosen by `choose` from the quantity and
    /// its curve's grid ([`MethodColumn::bin_means`]), with the density prepared once for both.
    pub fn bins(mut self, choose: &'a BinChoice<'a>) -> Self {
        self.bins = Some(choose);
        self
    }

    /// The degrees of every ladder method, solved in order with continuation.
    pub fn degrees(mut self, degrees: &[usize]) -> Self {
        self.degrees = degrees.to_vec();
        self
    }

    /// The methods (default: EPC alone); ladder methods are solved at [`Self::degrees`].
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// use fpsolve::study::StudyRunner;
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let study = StudyRunner::new(&bound)
    ///     .degrees(&[2])
    ///     .methods(&[MethodName::Epc, MethodName::Grid])
    ///     .cells([40, 60])
    ///     .run()?;
    /// let grid = study.run_of(MethodName::Grid).unwrap();
    /// assert_eq!(grid.solution().unwrap().grid().unwrap().report.cells, [40, 60]);
    /// let z = &study.curves[0];
    /// assert!(z.column(grid.source()).is_some() && z.columns.len() == 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn methods(mut self, methods: &[MethodName]) -> Self {
        self.methods = methods.to_vec();
        self
    }

    /// Runs under `run`: each method checks its flag between its units of work (a method
    /// stopped by it keeps [`SolveError::Cancelled`] as its outcome, beside the methods that
    /// finished), and the study reports each method solved (a ladder counts once) as a unit
    /// of progress, of the methods asked.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// use std::sync::{Arc, Mutex};
    /// use fpsolve::base::run::RunControl;
    /// use fpsolve::solve::MethodName;
    /// let seen = Arc::new(Mutex::new(Vec::new()));
    /// let run = RunControl::new().reporting({
    ///     let seen = seen.clone();
    ///     move |done, total| seen.lock().unwrap().push((done, total))
    /// });
    /// fpsolve::study::StudyRunner::new(&bound)
    ///     .degrees(&[2])
    ///     .methods(&[MethodName::Epc, MethodName::Grid])
    ///     .cells([40, 60])
    ///     .run_control(run)
    ///     .run()?;
    /// let mut seen = seen.lock().unwrap().clone();
    /// seen.sort();
    /// assert_eq!(seen, [(1, 2), (2, 2)]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run_control(mut self, run: RunControl) -> Self {
        self.run = run;
        self
    }

    /// A method solved: one unit of the study's progress.
    fn solved_one(&self) {
        let done = self.solved.fetch_add(1, Ordering::Relaxed) + 1;
        self.run.report(done, self.methods.len() as u64);
    }

    /// Cells of the grid solver (position, velocity); default [`crate::grid::DEFAULT_CELLS`].
    pub fn cells(mut self, cells: [usize; 2]) -> Self {
        self.cells = cells;
        self
    }

    /// Derives the FPK operator and solves each ladder method at each degree (each degree
    /// continued from the previous one) and the grid, the grid beside the ladders on another
    /// thread; then computes the PDFs of the states and the observables on grids reaching
    /// 1e−8 of their peaks.
    ///
    /// # Errors
    /// [`StudyError::NoMethod`], [`StudyError::NoDegree`] (a ladder method without degrees),
    /// or [`StudyError::Solve`] when the operator cannot be derived; a degree (or a grid solve)
    /// that fails is kept in the study.
    pub fn run(self) -> Result<Study, StudyError> {
        if self.methods.is_empty() {
            return Err(StudyError::NoMethod);
        }
        let ladders: Vec<MethodName> = self
            .methods
            .iter()
            .copied()
            .filter(|m| m.method().has_degrees())
            .collect();
        if !ladders.is_empty() && self.degrees.is_empty() {
            return Err(StudyError::NoDegree);
        }
        let start = Instant::now();
        timeline::mark("study: start");
        let derived;
        let problem = match self.problem {
            Some(p) => p,
            None => {
                derived = Problem::new(self.model)?;
                &derived
            }
        };
        let quantities = problem.quantities().to_vec();
        let others: Vec<MethodName> = self
            .methods
            .iter()
            .copied()
            .filter(|m| !m.method().has_degrees())
            .collect();
        // The observables' quadrature tables, built on a worker while the ladder solves (an
        // EPC ladder is mostly sequential, so a core is free).
        rayon::spawn(|| {
            crate::observe::prepare();
            timeline::mark("study: tables ready");
        });
        let ladders = || {
            ladders
                .iter()
                .flat_map(|&method| self.ladder(problem, method))
                .collect::<Vec<Run>>()
        };
        // The ladders on this thread, which is running now: handed to the pool (as the
        // other methods' partner in a join) they could wait for a worker to wake, or for the
        // one awake to build the tables first, a millisecond or more of a job that takes ten.
        let (mut runs, others) = if others.is_empty() {
            (ladders(), Vec::new())
        } else {
            rayon::join(ladders, || {
                others
                    .iter()
                    .map(|&m| self.once(problem, m))
                    .collect::<Vec<Run>>()
            })
        };
        let ladder_runs = runs.len();
        runs.extend(others);
        timeline::mark("study: ladder solved");
        let solved: Vec<(Source, &Solution)> = runs
            .iter()
            .filter_map(|r| r.solution().map(|s| (r.source(), s)))
            .collect();
        let wanted = |q: &&Quantity| self.curves_of.as_ref().is_none_or(|n| n.contains(&q.name));
        // The degrees' moments and the quantities' curves are independent of each other and
        // each computed by itself, in the same order: side by side they keep both cores busy
        // (an EPC-only ladder is sequential) and give the same numbers as one after another.
        let (stats, curves) = rayon::join(
            || {
                let stats = runs[..ladder_runs]
                    .par_iter()
                    .map(|r| r.solution().map_or_else(Vec::new, Solution::all_moments))
                    .collect::<Vec<_>>();
                timeline::mark("study: moments done");
                stats
            },
            || {
                let wanted: Vec<&Quantity> = quantities.iter().filter(wanted).collect();
                let curves = wanted
                    .par_iter()
                    .map(|q| {
                        let of_q: Vec<(Source, &Solution)> = solved
                            .iter()
                            .filter(|(source, _)| {
                                !self.left_out.contains(&(source.method, q.name.clone()))
                            })
                            .copied()
                            .collect();
                        curves::curves(q, &of_q, self.bins)
                    })
                    .collect::<Vec<_>>();
                timeline::mark("study: curves done");
                curves
            },
        );
        drop(solved);
        timeline::mark("study: done");
        for (r, s) in runs.iter_mut().zip(stats) {
            r.stats = s;
        }
        let warnings = self.warnings(problem, &runs);
        Ok(Study {
            model: self.model.clone(),
            runs,
            curves,
            quantities,
            warnings,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The study's [`StudyWarning`]s: EPC's non-smooth transform (when EPC ran), then each
    /// solution's mean velocity.
    fn warnings(&self, problem: &Problem, runs: &[Run]) -> Vec<StudyWarning> {
        let mut out = Vec::new();
        if self.methods.contains(&MethodName::Epc) {
            out.extend(warning::non_smooth_transform(problem));
        }
        for r in runs {
            if let Some(s) = r.solution() {
                out.extend(warning::mean_velocity(
                    self.model,
                    r.name(),
                    r.degree(),
                    s,
                    &r.stats,
                ));
            }
        }
        out
    }

    fn ladder(&self, problem: &Problem, method: MethodName) -> Vec<Run> {
        let solved = method
            .method()
            .solve_degrees(problem, &self.degrees, &self.run.silent());
        self.solved_one();
        solved
            .unwrap_or_default()
            .into_iter()
            .zip(&self.degrees)
            .map(|(outcome, &degree)| {
                let wall_ms = outcome.as_ref().map_or(0.0, Solution::solve_ms);
                Run {
                    method: method.method().settle(degree, self.cells),
                    outcome,
                    // Filled in by `run`, beside the curves.
                    stats: Vec::new(),
                    wall_ms,
                }
            })
            .collect()
    }

    /// A method without degrees, solved once with the runner's settings, with its moments.
    fn once(&self, problem: &Problem, name: MethodName) -> Run {
        let t = Instant::now();
        let method = name.method().settle(0, self.cells);
        let outcome = problem.solve_with(method, &self.run.silent());
        self.solved_one();
        let stats = outcome
            .as_ref()
            .map_or_else(|_| Vec::new(), Solution::all_moments);
        Run {
            method,
            outcome,
            stats,
            wall_ms: t.elapsed().as_secs_f64() * 1e3,
        }
    }
}

impl Study {
    /// Binds `model` with `overrides` and runs [`StudyRunner`] at `degrees`.
    ///
    /// # Errors
    /// [`StudyError::Bind`], or as [`StudyRunner::run`].
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// use fpsolve::study::Study;
    /// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let study = Study::run(&model, &["k=1".parse()?], &[2]);
    /// assert!(study.is_err()); // the model has no parameter k
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run(
        model: &Model,
        overrides: &[Override],
        degrees: &[usize],
    ) -> Result<Study, StudyError> {
        let bound = model.bind(overrides)?;
        StudyRunner::new(&bound).degrees(degrees).run()
    }

    /// The PDF of quantity `name` at the points `x`, one entry per degree asked: the PDF, or
    /// the degree's failure.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`] when there is no such quantity.
    pub fn pdf_at(&self, name: &str, x: &[f64]) -> Result<Vec<DegreePdf<'_>>, SolveError> {
        if !self.quantities.iter().any(|q| q.name == name) {
            return Err(SolveError::UnknownQuantity {
                name: name.to_string(),
                known: self.quantities.iter().map(|q| q.name.clone()).collect(),
            });
        }
        let mut out = Vec::new();
        for (r, degree) in self.ladder() {
            let pdf = match &r.outcome {
                Ok(sol) => Ok(sol.pdf(name, x)?),
                Err(e) => Err(e),
            };
            out.push(DegreePdf { degree, pdf });
        }
        Ok(out)
    }

    /// The runs of ladder methods, each with its degree, in order.
    pub fn ladder(&self) -> impl Iterator<Item = (&Run, usize)> {
        self.runs.iter().filter_map(|r| r.degree().map(|d| (r, d)))
    }

    /// The first run of `method`, if it ran.
    pub fn run_of(&self, method: MethodName) -> Option<&Run> {
        self.runs.iter().find(|r| r.name() == method)
    }

    /// The methods run, in the order [`MethodName::ALL`] lists them.
    pub fn methods(&self) -> Vec<MethodName> {
        MethodName::ALL
            .into_iter()
            .filter(|&m| self.run_of(m).is_some())
            .collect()
    }

    /// Whether every degree converged.
    pub fn all_converged(&self) -> bool {
        self.ladder().all(|(r, _)| r.outcome.is_ok())
    }
}

/// One degree in a study's summary.
#[derive(Debug, Serialize)]
pub struct DegreeSummary<'a> {
    /// The method.
    pub method: MethodName,
    /// The degree n.
    pub degree: usize,
    /// Whether the method converged at this degree.
    pub converged: bool,
    /// Why not, if it did not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Solve time (closure, assembly, solver, normalisation) in milliseconds.
    pub solve_ms: f64,
    /// Moments of each state and observable.
    pub stats: &'a [QuantityMoments],
    /// The solution: coefficients with exponents, weights' σ, iterations, residual,
    /// normalisation, moments of the states.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solution: Option<&'a EpcSolution>,
    /// The EPC-impact solution (method `epc-impact`): coefficients with exponents, domain,
    /// window, iterations, residual, quadrature check, normalisation, moments of the states.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub impact_solution: Option<&'a crate::epc_impact::EpcImpactSolution>,
}

/// A method without degrees (the grid) in a study's summary.
#[derive(Debug, Serialize)]
pub struct RunSummary<'a> {
    /// The settings it solved with (the grid's `cells`, position and velocity: those a
    /// tolerance chose when one was asked; those asked when it did not solve).
    #[serde(flatten)]
    pub settings: Method,
    /// Whether it solved.
    pub solved: bool,
    /// Why not, if it did not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// How it solved: cells, domain, clipped negative mass, discretisation-error estimate,
    /// timings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<&'a GridReport>,
    /// Time of the solve and of the moments, in milliseconds.
    pub wall_ms: f64,
    /// Moments of each state and observable.
    pub stats: &'a [QuantityMoments],
}

/// What `summary.json` holds.
#[derive(Debug, Serialize)]
pub struct StudySummary<'a> {
    /// The model's name.
    pub model: &'a str,
    /// Parameter values used.
    pub parameters: Vec<ParamValue>,
    /// How δ terms were integrated.
    pub delta_treatment: crate::model::DeltaTreatment,
    /// Itô or Stratonovich.
    pub interpretation: crate::model::Interpretation,
    /// The methods run, in the order [`MethodName::ALL`] lists them.
    pub methods: Vec<MethodName>,
    /// One entry per degree asked of each ladder method.
    pub degrees: Vec<DegreeSummary<'a>>,
    /// Each method without degrees that was run, under its name (`grid`): its outcome and
    /// report.
    #[serde(flatten)]
    pub once: std::collections::BTreeMap<&'static str, RunSummary<'a>>,
    /// Whether every degree converged.
    pub all_converged: bool,
    /// The study's warnings, each with its kind under `warning` (`non-smooth-transform`,
    /// `mean-velocity`); absent when there are none.
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    pub warnings: &'a [StudyWarning],
    /// Total wall time of the study in milliseconds.
    pub wall_ms: f64,
}

impl Study {
    /// The study as the data of `summary.json`.
    pub fn summary(&self) -> StudySummary<'_> {
        StudySummary {
            model: self.model.name(),
            parameters: self
                .model
                .params()
                .iter()
                .map(|(n, v)| ParamValue {
                    name: n.to_string(),
                    value: *v,
                })
                .collect(),
            delta_treatment: self.model.delta_treatment(),
            interpretation: self.model.interpretation(),
            methods: self.methods(),
            degrees: self
                .ladder()
                .map(|(r, degree)| DegreeSummary {
                    method: r.name(),
                    degree,
                    converged: r.outcome.is_ok(),
                    error: r.outcome.as_ref().err().map(|e| e.to_string()),
                    solve_ms: r.wall_ms,
                    stats: &r.stats,
                    solution: r.epc(),
                    impact_solution: r.solution().and_then(Solution::epc_impact),
                })
                .collect(),
            once: self
                .runs
                .iter()
                .filter(|r| r.degree().is_none())
                .map(|r| {
                    let summary = RunSummary {
                        // The cells solved on: a tolerance chooses its own.
                        settings: r.solution().map_or(r.method, Solution::method),
                        solved: r.outcome.is_ok(),
                        error: r.outcome.as_ref().err().map(|e| e.to_string()),
                        report: r.solution().and_then(Solution::grid).map(|g| &g.report),
                        wall_ms: r.wall_ms,
                        stats: &r.stats,
                    };
                    (r.name().as_str(), summary)
                })
                .collect(),
            all_converged: self.all_converged(),
            warnings: &self.warnings,
            wall_ms: self.wall_ms,
        }
    }
}
