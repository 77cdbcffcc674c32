//! A study: one bound model, EPC at several degrees, and the PDFs of its states and
//! observables on common grids — what `fpsolve solve` and the main job report. Built on the
//! front door ([`crate::solve::Problem`]): each degree is a [`Solution`] or the reason there is
//! none.

use std::time::Instant;

use serde::Serialize;

use crate::epc::{EpcError, EpcSolution};
use crate::mc::{Grid, ParamValue};
use crate::model::{BindError, BoundModel, Model, Override};
use crate::observe::{JointDensity, ObservableDensity};
use crate::solve::{
    common_grid, printable, Problem, Quantity, QuantityMoments, Solution, SolveError,
};

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
}

/// The outcome at one degree.
#[derive(Debug)]
pub struct DegreeResult {
    /// The degree n.
    pub degree: usize,
    /// The solution, or why there is none.
    pub outcome: Result<Solution, EpcError>,
    /// Moments of each state, then each observable (empty when the degree failed).
    pub stats: Vec<QuantityMoments>,
    /// Time of the degree's solve (closure, assembly, solver, normalisation), in milliseconds.
    pub wall_ms: f64,
}

impl DegreeResult {
    /// The EPC solution, if the degree converged.
    pub fn epc(&self) -> Option<&EpcSolution> {
        self.outcome.as_ref().ok().and_then(Solution::epc)
    }
}

/// One degree's PDF column on a curve's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct DegreeColumn {
    /// The degree n.
    pub degree: usize,
    /// The PDF on the grid (NaN where it is infinite).
    pub pdf: Vec<f64>,
    /// The PDF averaged over each bin of [`PdfCurves::bins`] (4-point Gauss–Legendre per bin),
    /// from the same prepared density as `pdf`; empty without bins.
    pub bin_means: Vec<f64>,
}

/// The histogram bins a study also averages each curve over (for comparing with Monte Carlo),
/// chosen from the quantity and its curve's grid; `None` for no bins.
pub type BinChoice<'a> = dyn Fn(&Quantity, &[f64]) -> Option<Grid> + Sync + 'a;

/// The PDF of one quantity on a grid, one column per converged degree.
#[derive(Clone, Debug, PartialEq)]
pub struct PdfCurves {
    /// The quantity's name.
    pub name: String,
    /// The grid.
    pub x: Vec<f64>,
    /// One column per converged degree, in the order asked.
    pub columns: Vec<DegreeColumn>,
    /// The bins the columns' `bin_means` average over, if any were asked for.
    pub bins: Option<Grid>,
}

/// The PDF of a quantity at one degree, or why that degree has none.
#[derive(Debug)]
pub struct DegreePdf<'a> {
    /// The degree n.
    pub degree: usize,
    /// The PDF at the points asked, or the degree's failure.
    pub pdf: Result<Vec<f64>, &'a EpcError>,
}

/// A finished study.
#[derive(Debug)]
pub struct Study {
    /// The bound model.
    pub model: BoundModel,
    /// One result per degree asked, in order.
    pub degrees: Vec<DegreeResult>,
    /// PDFs of the states, then of the observables.
    pub curves: Vec<PdfCurves>,
    /// The states, then the observables, with how each is computed.
    pub quantities: Vec<Quantity>,
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
/// assert!(study.degrees[0].outcome.is_ok());
/// assert!(study.degrees[1].outcome.is_err()); // an odd degree fails alone, visibly
/// let y = study.curves.iter().find(|c| c.name == "y").unwrap();
/// assert_eq!(y.x[0], 0.0); // |z| has no mass below 0: its grid starts at the barrier
/// let at = study.pdf_at("y", &[0.5])?;
/// assert!(at[0].pdf.is_ok() && at[1].pdf.is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct StudyRunner<'a> {
    model: &'a BoundModel,
    degrees: Vec<usize>,
    bins: Option<&'a BinChoice<'a>>,
}

impl<'a> StudyRunner<'a> {
    /// A study of `model` at degrees 2 and 4.
    pub fn new(model: &'a BoundModel) -> StudyRunner<'a> {
        StudyRunner {
            model,
            degrees: vec![2, 4],
            bins: None,
        }
    }

    /// Also averages every curve over histogram bins chosen by `choose` from the quantity and
    /// its curve's grid ([`DegreeColumn::bin_means`]), with the density prepared once for both.
    pub fn bins(mut self, choose: &'a BinChoice<'a>) -> Self {
        self.bins = Some(choose);
        self
    }

    /// The EPC degrees, solved in order with continuation.
    pub fn degrees(mut self, degrees: &[usize]) -> Self {
        self.degrees = degrees.to_vec();
        self
    }

    /// Derives the FPK operator and solves EPC at each degree (each degree continued from the
    /// previous one), then computes the PDFs of the states and the observables on grids
    /// reaching 1e−8 of their peaks.
    ///
    /// # Errors
    /// [`StudyError::NoDegree`], or [`StudyError::Solve`] when the operator cannot be derived;
    /// a degree that fails is kept in [`Study::degrees`].
    pub fn run(self) -> Result<Study, StudyError> {
        if self.degrees.is_empty() {
            return Err(StudyError::NoDegree);
        }
        let start = Instant::now();
        let problem = Problem::new(self.model)?;
        let quantities = problem.quantities().to_vec();
        let degrees: Vec<DegreeResult> = problem
            .solve_epc_degrees(&self.degrees)
            .into_iter()
            .zip(&self.degrees)
            .map(|(outcome, &degree)| {
                let wall_ms = outcome
                    .as_ref()
                    .ok()
                    .and_then(Solution::epc)
                    .map_or(0.0, |s| {
                        let r = &s.solve;
                        r.closure_ms + r.assembly_ms + r.solve_ms + r.normalise_ms
                    });
                let stats = outcome
                    .as_ref()
                    .map_or_else(|_| Vec::new(), Solution::all_moments);
                DegreeResult {
                    degree,
                    outcome,
                    stats,
                    wall_ms,
                }
            })
            .collect();
        let solved: Vec<(usize, &Solution)> = degrees
            .iter()
            .filter_map(|r| r.outcome.as_ref().ok().map(|s| (r.degree, s)))
            .collect();
        let curves = quantities
            .iter()
            .map(|q| curves(q, &solved, self.bins))
            .collect();
        Ok(Study {
            model: self.model.clone(),
            degrees,
            curves,
            quantities,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
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
        let mut out = Vec::with_capacity(self.degrees.len());
        for d in &self.degrees {
            let pdf = match &d.outcome {
                Ok(sol) => Ok(sol.pdf(name, x)?),
                Err(e) => Err(e),
            };
            out.push(DegreePdf {
                degree: d.degree,
                pdf,
            });
        }
        Ok(out)
    }

    /// Whether every degree converged.
    pub fn all_converged(&self) -> bool {
        self.degrees.iter().all(|d| d.outcome.is_ok())
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points (exact for cubics): enough for a bin
/// average of a density sampled by a histogram of ≥ 50 bins.
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// The density averaged over each bin of `grid`.
fn bin_means(density: &ObservableDensity, grid: &Grid) -> Vec<f64> {
    let (lo, w) = (grid.lo, grid.width());
    let nodes: Vec<f64> = (0..grid.bins)
        .flat_map(|b| {
            let c = lo + (b as f64 + 0.5) * w;
            GL4.iter().map(move |(t, _)| c + 0.5 * w * t)
        })
        .collect();
    density
        .pdf(&nodes)
        .chunks(GL4.len())
        .map(|c| c.iter().zip(&GL4).map(|(v, (_, wt))| v * wt).sum::<f64>() / 2.0)
        .collect()
}

fn curves(q: &Quantity, solved: &[(usize, &Solution)], bins: Option<&BinChoice>) -> PdfCurves {
    // Each degree's observable density is prepared once, scanned for its window, then
    // evaluated on the common grid (the union of the windows).
    let densities: Vec<(usize, &dyn JointDensity, ObservableDensity)> = solved
        .iter()
        .map(|&(degree, sol)| {
            (
                degree,
                sol.joint(),
                ObservableDensity::new(sol.joint(), &q.map),
            )
        })
        .collect();
    let windows: Vec<(&dyn JointDensity, &ObservableDensity)> =
        densities.iter().map(|(_, j, d)| (*j, d)).collect();
    let x = common_grid(q, &windows);
    let bins = bins.and_then(|choose| choose(q, &x));
    let columns = if x.is_empty() && bins.is_none() {
        Vec::new()
    } else {
        densities
            .iter()
            .map(|(degree, _, density)| DegreeColumn {
                degree: *degree,
                pdf: if x.is_empty() {
                    Vec::new()
                } else {
                    printable(density.pdf(&x))
                },
                bin_means: bins
                    .as_ref()
                    .map_or_else(Vec::new, |g| bin_means(density, g)),
            })
            .collect()
    };
    PdfCurves {
        name: q.name.clone(),
        x,
        columns,
        bins,
    }
}

/// One degree in a study's summary.
#[derive(Debug, Serialize)]
pub struct DegreeSummary<'a> {
    /// The degree n.
    pub degree: usize,
    /// Whether EPC converged at this degree.
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
    /// One entry per degree asked.
    pub degrees: Vec<DegreeSummary<'a>>,
    /// Whether every degree converged.
    pub all_converged: bool,
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
            degrees: self
                .degrees
                .iter()
                .map(|d| DegreeSummary {
                    degree: d.degree,
                    converged: d.outcome.is_ok(),
                    error: d.outcome.as_ref().err().map(|e| e.to_string()),
                    solve_ms: d.wall_ms,
                    stats: &d.stats,
                    solution: d.epc(),
                })
                .collect(),
            all_converged: self.all_converged(),
            wall_ms: self.wall_ms,
        }
    }
}
