//! One point of a sweep by every method: only what the sweep reports (the target degree's
//! moments and its PDF curves, from which the tails are taken), nothing else.

use std::time::Instant;

use crate::base::run::RunControl;
use crate::grid::Domain;
use crate::model::{BoundModel, Model};
use crate::observe::{ObservableDensity, ObservableMap};
use crate::solve::{
    common_grid, printable, Method, MethodName, Problem, QuantityMoments, Solution, SolveError,
};

use super::frontier::{Frontier, ReferenceRms};
use super::{PointFailure, PointRefusal, PointSolution, PointStats, SolverFigures, SweepSpec};

/// A point's data before the tail thresholds are known.
pub(super) struct Raw {
    pub(super) values: Vec<f64>,
    pub(super) wall_ms: f64,
    /// One entry per method; none when the point was refused.
    pub(super) methods: Vec<RawMethod>,
    /// Why no method solved the point, when it has no stationary density.
    pub(super) refusal: Option<PointRefusal>,
}

impl Raw {
    /// A point refused before any work: no method's data.
    pub(super) fn refused(values: Vec<f64>, refusal: PointRefusal) -> Raw {
        Raw {
            values,
            wall_ms: 0.0,
            methods: Vec::new(),
            refusal: Some(refusal),
        }
    }

    /// What the point knows of its reference values under method number `k` (see
    /// [`super::thresholds`]); none for a refused point.
    pub(super) fn reference(&self, k: usize) -> ReferenceRms {
        self.methods
            .get(k)
            .map_or(ReferenceRms::Known(None), |m| m.reference.clone())
    }
}

/// One method's data at a point.
pub(super) struct RawMethod {
    pub(super) method: MethodName,
    pub(super) wall_ms: f64,
    pub(super) outcome: Result<PointCurves, PointFailure>,
    /// √E\[g²\] per quantity under this method's reference solution (the reported one, or
    /// EPC's degree-2 solution), when the point computed it (see [`super::thresholds`]).
    pub(super) reference: ReferenceRms,
}

/// A solved point's figures and, per quantity, its moments and PDF curve (the tails are
/// taken from the curves once the thresholds are known).
pub(super) struct PointCurves {
    pub(super) solution: PointSolution,
    pub(super) curves: Vec<QuantityCurve>,
}

/// A quantity's PDF curve at one point.
pub(super) struct QuantityCurve {
    pub(super) x: Vec<f64>,
    pub(super) p: Vec<f64>,
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// The point `values` (number `index` of the sweep's points) of `spec` solved by every
/// method in `settled`, under `run`. The first method's EPC reference values are computed
/// when the point is at the `frontier`.
pub(super) fn solve_point(
    model: &Model,
    spec: &SweepSpec,
    (index, values): (usize, Vec<f64>),
    settled: &[(MethodName, Method)],
    domain: Option<Domain>,
    frontier: &Frontier,
    run: &RunControl,
) -> Raw {
    let start = Instant::now();
    let bound = model.bind(&spec.overrides_at(&values));
    // One problem (one reading of the model) for every method at the point.
    let problem = bound
        .as_ref()
        .map(|b| Problem::new(b).map(|p| p.with_grid_domain(domain)));
    let methods = settled
        .iter()
        .enumerate()
        .map(|(k, (name, method))| {
            let t = Instant::now();
            let (outcome, reference) = match (&problem, method) {
                (Err(e), _) => (
                    Err(PointFailure::Bind((*e).clone())),
                    ReferenceRms::Known(None),
                ),
                (Ok(Err(e)), method) => {
                    (Err(failure(e.clone(), *method)), ReferenceRms::Known(None))
                }
                (Ok(Ok(problem)), Method::Epc { degree }) => {
                    by_epc(problem, *degree, (k == 0).then_some((frontier, index)))
                }
                (Ok(Ok(problem)), method) => {
                    let (outcome, rms) = by_method(problem, *method, run);
                    (outcome, ReferenceRms::Known(rms))
                }
            };
            if k == 0 && reference == ReferenceRms::Known(None) {
                frontier.passed(index);
            }
            RawMethod {
                method: *name,
                wall_ms: ms(t),
                outcome,
                reference,
            }
        })
        .collect();
    Raw {
        values,
        wall_ms: ms(start),
        methods,
        refusal: None,
    }
}

/// √E\[g²\] of every quantity, when all are finite and positive.
pub(super) fn rms_of(moments: &[QuantityMoments], count: usize) -> Option<Vec<f64>> {
    let rms: Vec<f64> = moments
        .iter()
        .map(|s| s.moments.mean.hypot(s.std_dev()))
        .collect();
    (rms.len() == count && rms.iter().all(|v| v.is_finite() && *v > 0.0)).then_some(rms)
}

/// The degrees of a point's EPC ladder: 2, then the target degree.
fn ladder(degree: usize) -> Vec<usize> {
    if degree == 2 {
        vec![2]
    } else {
        vec![2, degree]
    }
}

/// Every degree of the point's EPC ladder, each solution or its failure.
fn epc_ladder(problem: &Problem, degree: usize) -> Vec<Result<Solution, PointFailure>> {
    let degrees = ladder(degree);
    problem
        .solve_epc_degrees(&degrees)
        .into_iter()
        .zip(&degrees)
        .map(|(r, &degree)| {
            r.map_err(|error| PointFailure::Method {
                method: Method::Epc { degree },
                error: Box::new(error.into()),
            })
        })
        .collect()
}

/// √E\[g²\] per quantity under the degree-2 EPC solution at a point (the reference the tail
/// thresholds are set from), when the point succeeded (its target degree converged and its
/// statistics are finite) and the values are finite and positive. The ladder is solved
/// exactly as [`by_epc`] solves it, so the degree-2 solution is bit for bit the one a point
/// reports beside its target degree.
pub(super) fn epc_reference_rms(bound: &BoundModel, degree: usize) -> Option<Vec<f64>> {
    let problem = Problem::new(bound).ok()?;
    let solved = epc_ladder(&problem, degree);
    let first = solved.first()?.as_ref().ok()?;
    let rms = rms_of(&first.all_moments(), problem.quantities().len());
    epc_curves(&problem, solved).ok()?;
    rms
}

/// EPC at `degree`, continued from degree 2, and the reference values of the degree-2
/// solution when `reference` (the frontier and this point's index) wants them.
fn by_epc(
    problem: &Problem,
    degree: usize,
    reference: Option<(&Frontier, usize)>,
) -> (Result<PointCurves, PointFailure>, ReferenceRms) {
    let solved = epc_ladder(problem, degree);
    let rms = match (solved.first(), reference) {
        (Some(Ok(first)), Some((frontier, index))) if frontier.wants(index) => {
            ReferenceRms::Known(rms_of(&first.all_moments(), problem.quantities().len()))
        }
        (Some(Ok(_)), _) => ReferenceRms::Unknown,
        (_, _) => ReferenceRms::Known(None),
    };
    let curves = epc_curves(problem, solved);
    // Only a point that succeeded sets the thresholds: a degree-2 solution whose target
    // degree failed would set them from a point the sweep reports as failed.
    let rms = if curves.is_ok() {
        rms
    } else {
        ReferenceRms::Known(None)
    };
    (curves, rms)
}

/// The target degree of a point's EPC ladder. Reported: its moments, and its PDF curves on
/// the grid common to both degrees (the union of the windows where each density is at least
/// 1e−8 of its peak, as the main job's `pdf_*.csv` tabulates both): the curves and hence the
/// tails are those of the study at the point, without the degree-2 curves and moments the
/// study also computes and the sweep never reports.
fn epc_curves(
    problem: &Problem<'_>,
    solved: Vec<Result<Solution, PointFailure>>,
) -> Result<PointCurves, PointFailure> {
    // A failure at degree 2 is the reason the target degree has no solution either.
    let mut solutions = Vec::with_capacity(solved.len());
    for r in solved {
        solutions.push(r?);
    }
    let last = solutions.last().expect("a ladder has at least one degree");
    let moments = last.all_moments();
    let mut collected = Collected::default();
    for (q, st) in problem.quantities().iter().zip(&moments) {
        // Each solution maps the quantity from its own states.
        let densities: Vec<(
            &dyn crate::density::JointDensity,
            &ObservableMap,
            ObservableDensity,
        )> = solutions
            .iter()
            .map(|s| {
                let map = s
                    .quantities()
                    .iter()
                    .find(|own| own.name == q.name)
                    .map_or(&q.map, |own| &own.map);
                (s.joint(), map, ObservableDensity::new(s.joint(), map))
            })
            .collect();
        let windows: Vec<_> = densities.iter().map(|(j, m, d)| (*j, *m, d)).collect();
        let x = common_grid(&windows);
        if x.is_empty() {
            return Err(PointFailure::NoCurve {
                quantity: q.name.clone(),
            });
        }
        let (_, _, target) = densities.last().expect("one density per degree");
        let p = printable(target.pdf(&x));
        collected.push(st, x, p)?;
    }
    Ok(collected.finish(last.figures()))
}

/// Any other method through the front door (the grid on the problem's box when given): the
/// solution's moments and its marginals on the report grid. Under `run`, whose flag stops a
/// grid between two of its solves (the sweep then returns `Cancelled`, not this point).
pub(super) fn by_method(
    problem: &Problem,
    method: Method,
    run: &RunControl,
) -> (Result<PointCurves, PointFailure>, Option<Vec<f64>>) {
    let solution = match problem.solve_with(method, run) {
        Ok(s) => s,
        Err(e) => return (Err(failure(e, method)), None),
    };
    let moments = solution.all_moments();
    let curves = curves_of(&solution, &moments);
    // Only a point that succeeded sets the thresholds.
    let rms = curves
        .is_ok()
        .then(|| rms_of(&moments, solution.quantities().len()))
        .flatten();
    (curves, rms)
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
    Ok(collected.finish(solution.figures()))
}

/// A front-door failure as the stage that failed.
fn failure(e: SolveError, method: Method) -> PointFailure {
    match e {
        SolveError::Fpk(e) => PointFailure::Derive(e),
        SolveError::Zhuravlev(e) => PointFailure::Zhuravlev(e),
        error => PointFailure::Method {
            method,
            error: Box::new(error),
        },
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
