//! A study: one model, one set of parameter values, EPC at several degrees, and the PDFs of
//! its states and observables on common grids — what `fpsolve solve` and the main job report.

use std::time::Instant;

use serde::Serialize;

use crate::epc::{Epc, EpcError, EpcSolution};
use crate::fpk::{FpkError, FpkOperator};
use crate::model::{BindError, BoundModel, Model, Override};
use crate::observe::{moments_of_all, JointDensity, ObservableDensity, ObservableMap};
use crate::symbolic::{DeltaPolicy, Expr, Symbol};

/// Why a study could not run at all (a failing degree is not this: it is kept in the study).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The parameters could not be bound.
    #[error(transparent)]
    Bind(#[from] BindError),
    /// The FPK operator could not be derived.
    #[error(transparent)]
    Fpk(#[from] FpkError),
    /// No degree was asked for.
    #[error("no EPC degree was asked for")]
    NoDegree,
}

/// A quantity whose PDF a study reports: a state or an observable.
#[derive(Clone, Debug)]
pub struct Quantity {
    /// Its name (`z`, `y`, …).
    pub name: String,
    /// How it is computed from the states.
    pub map: ObservableMap,
}

/// Mean, standard deviation, kurtosis and raw moments of a quantity under one EPC solution,
/// taken from the joint density directly (E\[g^k\] = ∬ g^k p, see
/// [`crate::observe::moments`]), not from its PDF curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuantityStats {
    /// The quantity's name.
    pub name: String,
    /// E\[g\].
    pub mean: f64,
    /// √Var\[g\].
    pub std_dev: f64,
    /// E\[(g − mean)⁴\] / Var\[g\]².
    pub kurtosis: f64,
    /// E\[g\], E\[g²\], E\[g³\], E\[g⁴\].
    pub raw_moments: [f64; 4],
    /// P(g has no finite value), e.g. P(z ≤ 0) for `log(z)`: 0 for an observable defined
    /// everywhere. When it is positive the observable's PDF integrates to 1 − this (it is not
    /// renormalised) and the moments above are those of g given that it is defined.
    pub undefined_mass: f64,
    /// How many of the raw moments exist (0 to 4); the others, and the statistics built on
    /// them, are NaN (written as `null` in JSON), never a number the quadrature happened to
    /// give for a divergent integral.
    pub existing_moments: usize,
}

impl QuantityStats {
    /// A warning in words when the quantity is undefined on part of the support (its
    /// `undefined_mass` is positive), for tables and logs; `None` otherwise.
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// use fpsolve::study::Study;
    /// let text = "model m
    /// param c = 0.1
    /// state z, v
    /// drift z: v
    /// drift v: -c*v - z
    /// noise xi: intensity 1
    /// diffusion v: xi
    /// observe l = log(z)
    /// ";
    /// let study = Study::run(&parse_model(text, None).unwrap(), &[], &[2]).unwrap();
    /// let l = study.degrees[0].stats.iter().find(|s| s.name == "l").unwrap();
    /// assert!(l.note().unwrap().contains("no finite value with probability 0.5"));
    /// assert!(study.degrees[0].stats[0].note().is_none()); // z is defined everywhere
    /// ```
    pub fn note(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.undefined_mass > 0.0 {
            parts.push(format!(
                "`{}` has no finite value with probability {:.3}: its PDF integrates to {:.3} \
                 (not renormalised) and its moments are conditional on it being defined",
                self.name,
                self.undefined_mass,
                1.0 - self.undefined_mass
            ));
        }
        if self.existing_moments < 4 {
            let k = self.existing_moments + 1;
            parts.push(format!(
                "E[|{}|^{k}] is not established as finite (its integral diverges, or has a \
                 singularity the quadrature does not resolve): {} undefined",
                self.name,
                match k {
                    1 => "the mean, standard deviation and kurtosis are",
                    2 => "the standard deviation and kurtosis are",
                    _ => "the kurtosis is",
                }
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }
}

/// The outcome at one degree.
#[derive(Debug)]
pub struct DegreeResult {
    /// The degree n.
    pub degree: usize,
    /// The solution, or why there is none.
    pub outcome: Result<EpcSolution, EpcError>,
    /// Statistics of each state, then each observable (empty when the degree failed).
    pub stats: Vec<QuantityStats>,
    /// Time of the degree's solve (closure, assembly, solver, normalisation), in milliseconds.
    pub wall_ms: f64,
}

/// The PDF of one quantity on a grid, one column per converged degree.
#[derive(Clone, Debug, PartialEq)]
pub struct PdfCurves {
    /// The quantity's name.
    pub name: String,
    /// The grid.
    pub x: Vec<f64>,
    /// `(degree, pdf on the grid)` for every converged degree.
    pub columns: Vec<(usize, Vec<f64>)>,
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

/// Grid points per PDF curve.
const GRID_POINTS: usize = 401;
/// The grid reaches where the density is this fraction of its peak.
const TAIL: f64 = 1e-8;

impl Study {
    /// Binds the model, derives its FPK operator and solves EPC at each degree (each degree
    /// continued from the previous one), then computes the PDFs of the states and the
    /// observables on grids reaching 1e−8 of their peaks.
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// use fpsolve::study::Study;
    /// let text = "model linear
    /// param c = 0.1, k = 1
    /// state z, v
    /// drift z: v
    /// drift v: -c*v - k*z
    /// noise xi: intensity 1
    /// diffusion v: xi
    /// observe y = abs(z)
    /// ";
    /// let model = parse_model(text, None).unwrap();
    /// let study = Study::run(&model, &[], &[2]).unwrap();
    /// assert!(study.degrees[0].outcome.is_ok());
    /// let y = study.curves.iter().find(|c| c.name == "y").unwrap();
    /// assert_eq!(y.x[0], 0.0); // |z| has no mass below 0: its grid starts at the barrier
    /// ```
    pub fn run(
        model: &Model,
        overrides: &[Override],
        degrees: &[usize],
    ) -> Result<Study, StudyError> {
        if degrees.is_empty() {
            return Err(StudyError::NoDegree);
        }
        let start = Instant::now();
        let bound = model.bind(overrides)?;
        let fpk = FpkOperator::derive(&bound)?;
        let quantities = quantities(&bound);
        let epc = Epc::new(&fpk, bound.delta_treatment());
        let mut results: Vec<DegreeResult> = epc
            .solve_degrees(degrees)
            .into_iter()
            .zip(degrees)
            .map(|(outcome, &degree)| DegreeResult {
                degree,
                wall_ms: outcome.as_ref().map_or(0.0, |s| {
                    let r = &s.solve;
                    r.closure_ms + r.assembly_ms + r.solve_ms + r.normalise_ms
                }),
                outcome,
                stats: Vec::new(),
            })
            .collect();
        let curves: Vec<PdfCurves> = {
            let solutions: Vec<(usize, &EpcSolution)> = results
                .iter()
                .filter_map(|r| r.outcome.as_ref().ok().map(|s| (r.degree, s)))
                .collect();
            quantities.iter().map(|q| curves(q, &solutions)).collect()
        };
        for r in &mut results {
            if let Ok(sol) = &r.outcome {
                r.stats = stats(sol, &quantities);
            }
        }
        Ok(Study {
            model: bound,
            degrees: results,
            curves,
            quantities,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The PDF of quantity `name` at the points `x`, one column per converged degree (`None`
    /// if there is no such quantity).
    pub fn pdf_at(&self, name: &str, x: &[f64]) -> Option<Vec<(usize, Vec<f64>)>> {
        let q = self.quantities.iter().find(|q| q.name == name)?;
        Some(
            self.degrees
                .iter()
                .filter_map(|d| {
                    let sol = d.outcome.as_ref().ok()?;
                    Some((d.degree, ObservableDensity::new(sol, &q.map).pdf(x)))
                })
                .collect(),
        )
    }

    /// Whether every degree converged.
    pub fn all_converged(&self) -> bool {
        self.degrees.iter().all(|d| d.outcome.is_ok())
    }
}

/// The states (as themselves), then the observables.
fn quantities(model: &BoundModel) -> Vec<Quantity> {
    let states: &[Symbol; 2] = model.states();
    let mut out: Vec<Quantity> = states
        .iter()
        .map(|s| Quantity {
            name: s.to_string(),
            map: ObservableMap::classify(&Expr::Sym(s.clone()), states),
        })
        .collect();
    out.extend(model.observables().iter().map(|o| Quantity {
        name: o.name.to_string(),
        map: ObservableMap::classify(&o.expr, states),
    }));
    out
}

/// The interval of values a quantity can take where the density lives.
fn value_range(sol: &EpcSolution, q: &Quantity) -> [f64; 2] {
    let ext = JointDensity::extent(sol);
    match &q.map {
        ObservableMap::SignedState { state, .. } => {
            let r = ext[*state][0].abs().max(ext[*state][1].abs());
            [-r, r]
        }
        ObservableMap::General { expr, states } => {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            let n = 120;
            for i in 0..=n {
                for j in 0..=n {
                    let x1 = ext[0][0] + (ext[0][1] - ext[0][0]) * i as f64 / n as f64;
                    let x2 = ext[1][0] + (ext[1][1] - ext[1][0]) * j as f64 / n as f64;
                    if sol.pdf(x1, x2) <= 0.0 {
                        continue;
                    }
                    let g = expr
                        .eval_states(states, [x1, x2], DeltaPolicy::Reject)
                        .unwrap_or(f64::NAN);
                    if g.is_finite() {
                        lo = lo.min(g);
                        hi = hi.max(g);
                    }
                }
            }
            [lo, hi]
        }
    }
}

fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// The window of a scanned density where it is at least `TAIL` of its peak, widened by one
/// scan step.
fn window(x: &[f64], p: &[f64]) -> Option<[f64; 2]> {
    // An infinite value (a saddle or degenerate critical value of g) is not a peak to scale by.
    let peak = p
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    if peak <= 0.0 {
        return None;
    }
    let first = p.iter().position(|v| *v >= TAIL * peak)?;
    let last = p.iter().rposition(|v| *v >= TAIL * peak)?;
    let lo = x[first.saturating_sub(1)];
    let hi = x[(last + 1).min(x.len() - 1)];
    Some([lo, hi])
}

fn curves(q: &Quantity, solutions: &[(usize, &EpcSolution)]) -> PdfCurves {
    // Each degree's observable density is prepared once, scanned for its window, then
    // evaluated on the common grid (the union of the windows).
    let densities: Vec<(usize, &EpcSolution, ObservableDensity)> = solutions
        .iter()
        .map(|&(degree, sol)| (degree, sol, ObservableDensity::new(sol, &q.map)))
        .collect();
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (_, sol, density) in &densities {
        let [a, b] = value_range(sol, q);
        let scan = linspace(a, b, 241);
        if let Some([a, b]) = window(&scan, &density.pdf(&scan)) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    // A quantity like |z| has its support edge at 0: start the grid exactly there.
    if non_negative(q) {
        lo = lo.max(0.0);
    }
    if lo >= hi {
        return PdfCurves {
            name: q.name.clone(),
            x: Vec::new(),
            columns: Vec::new(),
        };
    }
    let x = linspace(lo, hi, GRID_POINTS);
    // Where the density of g is infinite (a grid point on a saddle or degenerate critical
    // value, e.g. v² at 0) there is no number to print: the point is left empty (NaN), which
    // the CSV writes as an empty field and the figures as a gap.
    let columns = densities
        .iter()
        .map(|(degree, _, density)| {
            let p = density.pdf(&x);
            let p = p
                .into_iter()
                .map(|v| if v.is_infinite() { f64::NAN } else { v })
                .collect();
            (*degree, p)
        })
        .collect();
    PdfCurves {
        name: q.name.clone(),
        x,
        columns,
    }
}

/// Whether a signed-state quantity only takes values ≥ 0 (like |z|): every quadrant maps
/// its half-line of the state to the non-negative side.
fn non_negative(q: &Quantity) -> bool {
    let ObservableMap::SignedState { state, sign } = &q.map else {
        return false;
    };
    (0..2).all(|a| {
        (0..2).all(|b| {
            let half = if *state == 0 { a } else { b };
            let side = if half == 1 { 1.0 } else { -1.0 };
            sign[a][b] * side > 0.0
        })
    })
}

/// Moments of each quantity from the joint density directly (the density evaluated once for
/// all of them).
fn stats(sol: &EpcSolution, quantities: &[Quantity]) -> Vec<QuantityStats> {
    let maps: Vec<&ObservableMap> = quantities.iter().map(|q| &q.map).collect();
    moments_of_all(sol, &maps)
        .into_iter()
        .zip(quantities)
        .map(|(m, q)| QuantityStats {
            name: q.name.clone(),
            mean: m.moments.mean,
            std_dev: m.moments.std_dev(),
            kurtosis: m.moments.kurtosis,
            raw_moments: m.moments.raw,
            undefined_mass: m.undefined_mass,
            existing_moments: m.existing,
        })
        .collect()
}

/// A parameter and its value, for reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamValue {
    /// The parameter's name.
    pub name: String,
    /// Its value.
    pub value: f64,
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
    /// Mean, standard deviation and kurtosis of each state and observable.
    pub stats: &'a [QuantityStats],
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
                    solution: d.outcome.as_ref().ok(),
                })
                .collect(),
            all_converged: self.all_converged(),
            wall_ms: self.wall_ms,
        }
    }
}
