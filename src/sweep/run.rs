//! Solving every point of a sweep by every method asked, in parallel.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::cancel::{Cancel, Cancelled};
use crate::grid::Cells;
use crate::model::{BoundModel, Model};
use crate::solve::{
    quantities_of, reported, tail_probability, Density, Method, MethodName, MethodSet, Problem,
    QuantityMoments, Solution, SolveError,
};
use crate::study::{Study, StudyError, StudyRunner};

use super::method::{applies, settle};
use super::{
    EpcFigures, MethodOutcome, MethodRefusal, PointFailure, PointOutcome, PointSolution,
    PointStats, SolverFigures, SweepError, SweepPoint, SweepResult, SweepSpec, TailThresholds,
    TAIL_MULTIPLES,
};

/// A sweep to run: a model, the points, the methods and their settings (the builder;
/// [`Sweep::run`] gives the report).
pub struct Sweep<'a> {
    model: &'a Model,
    spec: &'a SweepSpec,
    methods: MethodSet,
    degree: usize,
    cells: Cells,
    progress: &'a (dyn Fn(u64, u64) + Sync),
}

/// A point's data before the tail thresholds are known.
struct Raw {
    values: Vec<f64>,
    wall_ms: f64,
    methods: Vec<RawMethod>,
}

/// One method's data at a point.
struct RawMethod {
    method: MethodName,
    wall_ms: f64,
    outcome: Result<PointCurves, PointFailure>,
    /// √E\[g²\] per quantity under the reference solution (EPC: degree 2), when it has one.
    rms: Option<Vec<f64>>,
}

/// A solved point's figures and, per quantity, its moments and PDF curve (the tails are
/// taken from the curves once the thresholds are known).
struct PointCurves {
    solution: PointSolution,
    curves: Vec<QuantityCurve>,
}

/// A quantity's PDF curve at one point.
struct QuantityCurve {
    x: Vec<f64>,
    p: Vec<f64>,
}

impl<'a> Sweep<'a> {
    /// A sweep of `model` over the points of `spec`, by EPC at degree 4.
    pub fn new(model: &'a Model, spec: &'a SweepSpec) -> Sweep<'a> {
        Sweep {
            model,
            spec,
            methods: MethodSet::new(vec![MethodName::Epc]).expect("one method is a set"),
            degree: 4,
            cells: Cells::default(),
            progress: &|_, _| {},
        }
    }

    /// The methods each point is solved by (default: `epc`).
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// use fpsolve::grid::Cells;
    /// use fpsolve::sweep::{Sweep, SweepSpec};
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()])?;
    /// let result = Sweep::new(&model, &spec)
    ///     .methods("epc,grid".parse()?)
    ///     .degree(2)
    ///     .cells(Cells([80, 80]))
    ///     .run();
    /// // Var v = S/(2c) = 1/c, exactly by EPC, to the grid's accuracy by the grid.
    /// for point in &result.points {
    ///     let exact = 1.0 / point.values[0];
    ///     let epc = point.solution(MethodName::Epc).unwrap().stats_of("v").unwrap();
    ///     let grid = point.solution(MethodName::Grid).unwrap().stats_of("v").unwrap();
    ///     assert!((epc.moments.variance / exact - 1.0).abs() < 1e-6);
    ///     assert!((grid.moments.variance / exact - 1.0).abs() < 1e-2); // measured 8.0e−3 at c = 0.5
    /// }
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn methods(mut self, methods: MethodSet) -> Self {
        self.methods = methods;
        self
    }

    /// The EPC degree every point is solved at (continued from degree 2 within the point).
    pub fn degree(mut self, degree: usize) -> Self {
        self.degree = degree;
        self
    }

    /// The grid solver's cells (default [`crate::grid::DEFAULT_CELLS`]).
    pub fn cells(mut self, cells: Cells) -> Self {
        self.cells = cells;
        self
    }

    /// Calls `progress(done, total)` as each point finishes (from the worker threads, in
    /// completion order), e.g. for a progress bar.
    ///
    /// ```
    /// use std::sync::atomic::{AtomicU64, Ordering};
    /// use fpsolve::sweep::{Sweep, SweepSpec};
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()]).unwrap();
    /// let seen = AtomicU64::new(0);
    /// let count = |_, total| {
    ///     assert_eq!(total, 2);
    ///     seen.fetch_add(1, Ordering::Relaxed);
    /// };
    /// let result = Sweep::new(&model, &spec).degree(2).progress(&count).run();
    /// assert_eq!((result.converged(), seen.into_inner()), (2, 2));
    /// ```
    pub fn progress(mut self, progress: &'a (dyn Fn(u64, u64) + Sync)) -> Self {
        self.progress = progress;
        self
    }

    /// Checks, in milliseconds and before any work, that every method applies to the model:
    /// that it is built in, that its settings are valid, and that the model has the form it
    /// needs (EPC: an impact law it represents; grid: the mechanical form). The model is
    /// bound at the first point whose parameters bind; what depends on the values (a point
    /// without a stationary density) is not checked here but recorded at that point.
    ///
    /// # Errors
    /// [`SweepError::Method`] naming the method and why.
    ///
    /// ```
    /// use fpsolve::sweep::{Sweep, SweepError, SweepSpec};
    /// // x' = −c·x + y: not the mechanical form x' = v the grid solver needs.
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate x, y\ndrift x: -c*x + y\ndrift y: -y\nnoise xi: intensity 1\ndiffusion x: xi\n", None)?;
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()])?;
    /// assert!(Sweep::new(&model, &spec).check().is_ok()); // EPC applies
    /// let err = Sweep::new(&model, &spec).methods("epc,grid".parse()?).check().unwrap_err();
    /// assert!(matches!(err, SweepError::Method { method: fpsolve::solve::MethodName::Grid, .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn check(&self) -> Result<(), SweepError> {
        let refused = |method: MethodName, reason: MethodRefusal| SweepError::Method {
            method,
            model: self.model.name().to_string(),
            reason: Box::new(reason),
        };
        let mut settled = Vec::new();
        for &name in self.methods.names() {
            settled.push((name, settle(name, self.degree, self.cells)));
        }
        let bound = self
            .spec
            .points()
            .into_iter()
            .find_map(|values| self.model.bind(&self.spec.overrides_at(&values)).ok());
        if let Some(bound) = bound {
            for (name, method) in settled {
                applies(&bound, name, method).map_err(|r| refused(name, r))?;
            }
        }
        Ok(())
    }

    /// Solves every point by every method (EPC at the degree, continued from degree 2 within
    /// the point), all points in parallel, and collects the statistics of each state and
    /// observable. A method that fails at a point — bind error (e.g. a negative intensity),
    /// FPK error, EPC failure at degree 2 or at `degree`, grid failure — is kept as
    /// [`PointOutcome::Failed`] with its stage and message; the other methods and points are
    /// unaffected.
    ///
    /// Tail probabilities P(|g| > a) use thresholds a = 2, 3, 4 × √E\[g²\] at the first
    /// point the first method solved (for EPC its degree-2 solution), fixed for the whole
    /// sweep and every method. √E\[g²\] is σ for a zero-mean quantity and makes the
    /// thresholds of |z| those of z. The probabilities are integrals of the quantity's PDF
    /// curve (Eqs. 23–28) beyond ±a, normalised by the curve's mass.
    ///
    /// Every point's EPC result is the same as a [`Study::run`] at its values, and its
    /// other methods' results the same as [`crate::solve()`] at its values, whatever the
    /// number of threads.
    pub fn run(&self) -> SweepResult {
        self.run_cancellable(&Cancel::new())
            .expect("a sweep whose flag nobody holds is never cancelled")
    }

    /// [`Sweep::run`] that stops when `cancel` is set: no point starts after it is set, and
    /// the points in flight finish (each takes milliseconds to a second). A cancelled sweep
    /// returns [`Cancelled`] and nothing else.
    ///
    /// ```
    /// use fpsolve::cancel::{Cancel, Cancelled};
    /// use fpsolve::sweep::{Sweep, SweepSpec};
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()]).unwrap();
    /// let cancel = Cancel::new();
    /// assert!(Sweep::new(&model, &spec).degree(2).run_cancellable(&cancel).is_ok());
    /// cancel.cancel();
    /// assert_eq!(Sweep::new(&model, &spec).degree(2).run_cancellable(&cancel).err(), Some(Cancelled));
    /// ```
    pub fn run_cancellable(&self, cancel: &Cancel) -> Result<SweepResult, Cancelled> {
        let start = Instant::now();
        let (model, spec, progress) = (self.model, self.spec, self.progress);
        let total = spec.len() as u64;
        let done = AtomicU64::new(0);
        let settled: Vec<(MethodName, Method)> = self
            .methods
            .names()
            .iter()
            .map(|&name| (name, settle(name, self.degree, self.cells)))
            .collect();
        let raw: Vec<Raw> = spec
            .points()
            .into_par_iter()
            .map(|values| {
                if cancel.is_cancelled() {
                    return Err(Cancelled);
                }
                let point = solve_point(model, spec, values, &settled);
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(k, total);
                Ok(point)
            })
            .collect::<Result<_, _>>()?;
        if cancel.is_cancelled() {
            return Err(Cancelled);
        }
        let listed = quantities_of(model);
        let quantities: Vec<String> = listed.iter().map(|q| q.name.clone()).collect();
        let figure_quantities = reported(&listed)
            .into_iter()
            .map(|q| q.name.clone())
            .collect();
        let threshold_method = self.methods.names()[0];
        let reference = |r: &Raw| r.methods[0].rms.clone();
        let threshold_point = raw.iter().position(|r| reference(r).is_some());
        let tail_thresholds: Vec<TailThresholds> = threshold_point
            .and_then(|i| reference(&raw[i]))
            .map(|rms| {
                quantities
                    .iter()
                    .zip(rms)
                    .map(|(name, rms)| TailThresholds {
                        name: name.clone(),
                        rms,
                        thresholds: TAIL_MULTIPLES.iter().map(|k| k * rms).collect(),
                    })
                    .collect()
            })
            .unwrap_or_default();
        let points = raw
            .into_iter()
            .map(|r| SweepPoint {
                values: r.values,
                wall_ms: r.wall_ms,
                outcomes: r
                    .methods
                    .into_iter()
                    .map(|m| MethodOutcome {
                        method: m.method,
                        wall_ms: m.wall_ms,
                        outcome: with_tails(m.outcome, &tail_thresholds),
                    })
                    .collect(),
            })
            .collect();
        Ok(SweepResult {
            model: model.name().to_string(),
            methods: self.methods.clone(),
            degree: self.degree,
            cells: self
                .methods
                .contains(MethodName::Grid)
                .then_some(self.cells.0),
            parameters: spec.swept.iter().map(|s| s.name.clone()).collect(),
            fixed: spec
                .fixed
                .iter()
                .map(|o| format!("{}={}", o.name, o.value))
                .collect(),
            quantities,
            figure_quantities,
            threshold_method,
            threshold_point,
            tail_thresholds,
            points,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }
}

/// The outcome with P(|g| > a) at the sweep's thresholds, from each quantity's curve.
fn with_tails(
    outcome: Result<PointCurves, PointFailure>,
    thresholds: &[TailThresholds],
) -> PointOutcome {
    match outcome {
        Ok(PointCurves {
            mut solution,
            curves,
        }) => {
            for (stats, curve) in solution.stats.iter_mut().zip(&curves) {
                if let Some(t) = thresholds.iter().find(|t| t.name == stats.name) {
                    stats.tail = t
                        .thresholds
                        .iter()
                        .map(|&a| tail_probability(&curve.x, &curve.p, a))
                        .collect();
                }
            }
            PointOutcome::Converged(solution)
        }
        Err(failure) => PointOutcome::Failed(failure),
    }
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

fn solve_point(
    model: &Model,
    spec: &SweepSpec,
    values: Vec<f64>,
    settled: &[(MethodName, Method)],
) -> Raw {
    let start = Instant::now();
    let bound = model.bind(&spec.overrides_at(&values));
    let methods = settled
        .iter()
        .map(|(name, method)| {
            let t = Instant::now();
            let (outcome, rms) = match (&bound, method) {
                (Err(e), _) => (Err(PointFailure::Bind(e.clone())), None),
                (Ok(bound), Method::Epc { degree }) => by_epc(bound, *degree),
                (Ok(bound), method) => by_method(bound, *method),
            };
            RawMethod {
                method: *name,
                wall_ms: ms(t),
                outcome,
                rms,
            }
        })
        .collect();
    Raw {
        values,
        wall_ms: ms(start),
        methods,
    }
}

/// √E\[g²\] of every quantity, when all are finite and positive.
fn rms_of(moments: &[QuantityMoments], count: usize) -> Option<Vec<f64>> {
    let rms: Vec<f64> = moments
        .iter()
        .map(|s| s.moments.mean.hypot(s.std_dev()))
        .collect();
    (rms.len() == count && rms.iter().all(|v| v.is_finite() && *v > 0.0)).then_some(rms)
}

/// EPC at `degree`, continued from degree 2, through the study (whose degree-2 solution sets
/// the tail thresholds and whose common grid of both degrees carries the curves).
fn by_epc(
    bound: &BoundModel,
    degree: usize,
) -> (Result<PointCurves, PointFailure>, Option<Vec<f64>>) {
    let degrees: Vec<usize> = if degree == 2 {
        vec![2]
    } else {
        vec![2, degree]
    };
    let study = StudyRunner::new(bound)
        .degrees(&degrees)
        .run()
        .map_err(|e| match e {
            StudyError::Bind(e) => PointFailure::Bind(e),
            StudyError::Solve(SolveError::Fpk(e)) => PointFailure::Derive(e),
            StudyError::Solve(e) => failure(e, Method::Epc { degree }),
            // A model EPC cannot represent (when `check` was not called first).
            StudyError::NotApplicable { why, .. } => {
                PointFailure::Refused(MethodRefusal::NotApplicable(why))
            }
            // The study is always given EPC and its degrees.
            e @ (StudyError::NoDegree | StudyError::NoMethod) => {
                unreachable!("a sweep point's study failed before EPC: {e}")
            }
        });
    match study {
        Err(e) => (Err(e), None),
        Ok(study) => {
            let rms2 = study.degrees[0]
                .outcome
                .is_ok()
                .then(|| rms_of(&study.degrees[0].stats, study.quantities.len()))
                .flatten();
            (solved(&study), rms2)
        }
    }
}

/// The target degree's data (the last degree of the study), or why there is none.
fn solved(study: &Study) -> Result<PointCurves, PointFailure> {
    // A failure at degree 2 is the reason the target degree has no solution either.
    if let Some((degree, error)) = study
        .degrees
        .iter()
        .find_map(|d| d.outcome.as_ref().err().map(|e| (d.degree, e)))
    {
        return Err(failure(error.clone(), Method::Epc { degree }));
    }
    let last = study
        .degrees
        .last()
        .expect("a study has at least one degree");
    let sol = last.epc().expect("an EPC study solves by EPC");
    let mut collected = Collected::default();
    for q in &study.quantities {
        let st = last.stats.iter().find(|s| s.name == q.name);
        let curve = study.curves.iter().find(|c| c.name == q.name);
        let column = curve.and_then(|c| {
            c.columns
                .iter()
                .find(|c| c.source.degree == Some(last.degree))
        });
        let (Some(st), Some(curve), Some(column)) = (st, curve, column) else {
            return Err(PointFailure::NoCurve {
                quantity: q.name.clone(),
            });
        };
        collected.push(st, curve.x.clone(), column.pdf.clone())?;
    }
    Ok(collected.finish(SolverFigures::Epc(EpcFigures::of(sol))))
}

/// Any other method through the front door: the solution's moments and its marginals on the
/// report grid.
fn by_method(
    bound: &BoundModel,
    method: Method,
) -> (Result<PointCurves, PointFailure>, Option<Vec<f64>>) {
    let solution = match Problem::new(bound).and_then(|p| p.solve(method)) {
        Ok(s) => s,
        Err(e) => return (Err(failure(e, method)), None),
    };
    let moments = solution.all_moments();
    let rms = rms_of(&moments, solution.quantities().len());
    (curves_of(&solution, &moments), rms)
}

fn curves_of(
    solution: &Solution,
    moments: &[QuantityMoments],
) -> Result<PointCurves, PointFailure> {
    let mut collected = Collected::default();
    for (q, st) in solution.quantities().iter().zip(moments) {
        let (x, p) = solution
            .marginal(&q.name)
            .expect("a quantity of the solution");
        if x.is_empty() {
            return Err(PointFailure::NoCurve {
                quantity: q.name.clone(),
            });
        }
        collected.push(st, x, p)?;
    }
    let solver = match solution.density() {
        Density::Epc(s) => SolverFigures::Epc(EpcFigures::of(s)),
        Density::Grid(g) => SolverFigures::Grid(g.report.clone()),
        Density::EpcImpact(s) => SolverFigures::EpcImpact(s.report.clone()),
    };
    Ok(collected.finish(solver))
}

/// A front-door failure as the stage that failed.
fn failure(e: SolveError, method: Method) -> PointFailure {
    match (e, method) {
        (SolveError::Fpk(e), _) => PointFailure::Derive(e),
        (SolveError::Epc(error), Method::Epc { degree }) => PointFailure::Solve { degree, error },
        (SolveError::Grid(e), _) => PointFailure::Grid(e),
        (SolveError::EpcImpact(error), Method::EpcImpact { degree }) => {
            PointFailure::EpcImpact { degree, error }
        }
        (SolveError::Zhuravlev(e), _) => PointFailure::Zhuravlev(e),
        (
            e
            @ (SolveError::Epc(_) | SolveError::EpcImpact(_) | SolveError::UnknownQuantity { .. }),
            _,
        ) => unreachable!("{method} failed where it cannot: {e}"),
    }
}

/// Statistics and curves of the quantities, each checked to be finite.
#[derive(Default)]
struct Collected {
    stats: Vec<PointStats>,
    curves: Vec<QuantityCurve>,
}

impl Collected {
    fn push(&mut self, st: &QuantityMoments, x: Vec<f64>, p: Vec<f64>) -> Result<(), PointFailure> {
        let m = &st.moments;
        if [m.mean, st.std_dev(), m.kurtosis]
            .iter()
            .any(|v| !v.is_finite())
        {
            return Err(PointFailure::NotFinite {
                quantity: st.name.clone(),
                mean: m.mean,
                std_dev: st.std_dev(),
                kurtosis: m.kurtosis,
            });
        }
        self.stats.push(PointStats {
            name: st.name.clone(),
            moments: st.moments,
            tail: Vec::new(),
        });
        self.curves.push(QuantityCurve { x, p });
        Ok(())
    }

    fn finish(self, solver: SolverFigures) -> PointCurves {
        PointCurves {
            solution: PointSolution {
                solver,
                stats: self.stats,
            },
            curves: self.curves,
        }
    }
}
