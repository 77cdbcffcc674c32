//! Solving every point of a sweep, in parallel, through the study.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::epc::{EpcError, NormalisationKind};
use crate::model::Model;
use crate::moments::Moments;
use crate::solve::{quantities_of, reported, tail_probability, SolveError};
use crate::study::{Study, StudyError, StudyRunner};

use super::{SweepSpec, TAIL_MULTIPLES};

/// Statistics of one state or observable at one point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointStats {
    /// The quantity's name.
    pub name: String,
    /// Mean, variance, kurtosis and raw moments (all finite at a converged point).
    #[serde(flatten)]
    pub moments: Moments,
    /// P(|g| > a) for each threshold a of [`SweepResult::tail_thresholds`] (empty when no
    /// threshold could be set); `None` where a lies beyond the tabulated PDF on both sides
    /// (the density there is below about 1e−8 of its peak, so the tail is not resolved).
    /// Accurate to a few per mille while P ≳ 1e−7; smaller values lean on an exponential
    /// continuation of the curve beyond its last point and are good to a few per cent.
    pub tail: Vec<Option<f64>>,
}

/// A point that was solved at the sweep's degree.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointSolution {
    /// Nonlinear-solver iterations at the target degree.
    pub iterations: usize,
    /// Final Galerkin residual ‖R‖ (scaled variables).
    pub residual: f64,
    /// The bound ‖R‖ had to reach.
    pub residual_threshold: f64,
    /// FPK residual indicator ∫|F|·p dx (0 for an exact solution).
    pub fpk_residual: f64,
    /// How the density was normalised: `plane` or `inside_ridge`.
    pub normalisation: String,
    /// Statistics of each state, then each observable.
    pub stats: Vec<PointStats>,
}

/// What happened at one point.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum PointOutcome {
    /// EPC converged at the target degree.
    Converged(PointSolution),
    /// The point could not be solved; the other points are unaffected.
    Failed(PointFailure),
}

/// Why a point has no solution, by the stage that failed. `Display` gives the message of
/// `sweep.csv`; [`PointFailure::stage`] its `stage` column.
#[derive(Clone, Debug, thiserror::Error)]
pub enum PointFailure {
    /// The parameters could not be bound at this point (e.g. a negative intensity).
    #[error(transparent)]
    Bind(crate::model::BindError),
    /// The FPK operator could not be derived.
    #[error(transparent)]
    Derive(crate::fpk::FpkError),
    /// EPC failed at `degree` (degree 2 failing is why the target degree has no solution
    /// either).
    #[error("degree {degree}: {error}")]
    Solve {
        /// The first degree that failed.
        degree: usize,
        /// Why.
        #[source]
        error: EpcError,
    },
    /// No PDF of a quantity could be tabulated (its density has no window above 1e−8 of its
    /// peak).
    #[error("no PDF of `{quantity}` could be tabulated")]
    NoCurve {
        /// The quantity.
        quantity: String,
    },
    /// A statistic of a quantity has no finite value.
    #[error("statistics of `{quantity}` are not finite (mean {mean}, std dev {std_dev}, kurtosis {kurtosis})")]
    NotFinite {
        /// The quantity.
        quantity: String,
        /// Its mean.
        mean: f64,
        /// Its standard deviation.
        std_dev: f64,
        /// Its kurtosis.
        kurtosis: f64,
    },
}

impl PointFailure {
    /// The stage that failed, as `sweep.csv` names it: `bind`, `fpk`, `epc` or `statistics`.
    pub fn stage(&self) -> &'static str {
        match self {
            PointFailure::Bind(_) => "bind",
            PointFailure::Derive(_) => "fpk",
            PointFailure::Solve { .. } => "epc",
            PointFailure::NoCurve { .. } | PointFailure::NotFinite { .. } => "statistics",
        }
    }
}

/// In `sweep.json` a failure is its stage and its message.
impl Serialize for PointFailure {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("PointFailure", 2)?;
        st.serialize_field("stage", self.stage())?;
        st.serialize_field("message", &self.to_string())?;
        st.end()
    }
}

/// One point of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepPoint {
    /// The swept parameters' values, in the order of [`SweepResult::parameters`].
    pub values: Vec<f64>,
    /// The solution's statistics, or why there is none.
    #[serde(flatten)]
    pub outcome: PointOutcome,
    /// Wall time of this point's study in milliseconds.
    pub wall_ms: f64,
}

/// The thresholds a of P(|g| > a) for one quantity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailThresholds {
    /// The quantity's name.
    pub name: String,
    /// √E\[g²\] of the degree-2 solution at the reference point.
    pub rms: f64,
    /// [`TAIL_MULTIPLES`] × `rms`.
    pub thresholds: Vec<f64>,
}

/// A finished sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepResult {
    /// The model's name.
    pub model: String,
    /// The EPC degree every point was solved at.
    pub degree: usize,
    /// The swept parameters' names.
    pub parameters: Vec<String>,
    /// The fixed overrides, as `name=expr`.
    pub fixed: Vec<String>,
    /// The states, then the observables: the order of [`PointSolution::stats`].
    pub quantities: Vec<String>,
    /// The observables (the states when the model declares none): what the figures show.
    pub figure_quantities: Vec<String>,
    /// Index of the point whose degree-2 solution set the tail thresholds (the first point
    /// whose degree 2 converged), if any.
    pub threshold_point: Option<usize>,
    /// Tail thresholds per quantity, fixed for the whole sweep so that curves are comparable.
    pub tail_thresholds: Vec<TailThresholds>,
    /// One entry per point, in the order of [`SweepSpec::points`].
    pub points: Vec<SweepPoint>,
    /// Total wall time in milliseconds.
    pub wall_ms: f64,
}

/// A sweep to run: a model, the points, the degree (the builder; [`Sweep::run`] gives the
/// report).
pub struct Sweep<'a> {
    model: &'a Model,
    spec: &'a SweepSpec,
    degree: usize,
    progress: &'a (dyn Fn(u64, u64) + Sync),
}

/// A point's data before the tail thresholds are known.
struct Raw {
    values: Vec<f64>,
    wall_ms: f64,
    outcome: Result<PointCurves, PointFailure>,
    /// √E\[g²\] per quantity at degree 2, when degree 2 converged.
    rms2: Option<Vec<f64>>,
}

/// A converged point's figures and, per quantity, its moments and PDF curve at the target
/// degree (the tails are taken from the curves once the thresholds are known).
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
    /// A sweep of `model` over the points of `spec`, at degree 4.
    pub fn new(model: &'a Model, spec: &'a SweepSpec) -> Sweep<'a> {
        Sweep {
            model,
            spec,
            degree: 4,
            progress: &|_, _| {},
        }
    }

    /// The EPC degree every point is solved at (continued from degree 2 within the point).
    pub fn degree(mut self, degree: usize) -> Self {
        self.degree = degree;
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

    /// Solves every point by EPC at the degree (continued from degree 2 within the
    /// point), all points in parallel, and collects the statistics of each state and
    /// observable. A point that fails — bind error (e.g. a negative intensity), FPK error,
    /// EPC failure at degree 2 or at `degree` — is kept as [`PointOutcome::Failed`] with its
    /// message; the other points are unaffected.
    ///
    /// Tail probabilities P(|g| > a) use thresholds a = 2, 3, 4 × √E\[g²\] of the degree-2
    /// solution at the first point (the first whose degree 2 converged), fixed for the whole
    /// sweep. √E\[g²\] is σ for a zero-mean quantity and makes the thresholds of |z| those of
    /// z. The probabilities are integrals of the quantity's PDF curve (Eqs. 23–28 via
    /// [`Study`]) beyond ±a, normalised by the curve's mass.
    ///
    /// Every point's result is the same as a [`Study::run`] at its values, whatever the
    /// number of threads.
    pub fn run(&self) -> SweepResult {
        let (model, spec, degree, progress) = (self.model, self.spec, self.degree, self.progress);
        let start = Instant::now();
        let total = spec.len() as u64;
        let done = std::sync::atomic::AtomicU64::new(0);
        let degrees: Vec<usize> = if degree == 2 {
            vec![2]
        } else {
            vec![2, degree]
        };
        let raw: Vec<Raw> = spec
            .points()
            .into_par_iter()
            .map(|values| {
                let point = solve_point(model, spec, values, &degrees);
                let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(k, total);
                point
            })
            .collect();
        let listed = quantities_of(model);
        let quantities: Vec<String> = listed.iter().map(|q| q.name.clone()).collect();
        let figure_quantities = reported(&listed)
            .into_iter()
            .map(|q| q.name.clone())
            .collect();
        let threshold_point = raw.iter().position(|r| r.rms2.is_some());
        let tail_thresholds: Vec<TailThresholds> = threshold_point
            .and_then(|i| raw[i].rms2.as_ref())
            .map(|rms| {
                quantities
                    .iter()
                    .zip(rms)
                    .map(|(name, &rms)| TailThresholds {
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
                outcome: match r.outcome {
                    Ok(PointCurves {
                        mut solution,
                        curves,
                    }) => {
                        for (stats, curve) in solution.stats.iter_mut().zip(&curves) {
                            if let Some(t) = tail_thresholds.iter().find(|t| t.name == stats.name) {
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
                },
            })
            .collect();
        SweepResult {
            model: model.name().to_string(),
            degree,
            parameters: spec.swept.iter().map(|s| s.name.clone()).collect(),
            fixed: spec
                .fixed
                .iter()
                .map(|o| format!("{}={}", o.name, o.value))
                .collect(),
            quantities,
            figure_quantities,
            threshold_point,
            tail_thresholds,
            points,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }
}

fn solve_point(model: &Model, spec: &SweepSpec, values: Vec<f64>, degrees: &[usize]) -> Raw {
    let start = Instant::now();
    let study = model
        .bind(&spec.overrides_at(&values))
        .map_err(PointFailure::Bind)
        .and_then(|bound| {
            StudyRunner::new(&bound)
                .degrees(degrees)
                .run()
                .map_err(|e| match e {
                    StudyError::Bind(e) => PointFailure::Bind(e),
                    StudyError::Solve(SolveError::Fpk(e)) => PointFailure::Derive(e),
                    StudyError::Solve(SolveError::Epc(error)) => PointFailure::Solve {
                        degree: degrees[degrees.len() - 1],
                        error,
                    },
                    // A study of a bound model with degrees fails only in deriving.
                    e @ (StudyError::NoDegree
                    | StudyError::NoMethod
                    | StudyError::NotApplicable { .. }
                    | StudyError::Solve(_)) => {
                        unreachable!("a sweep point's study failed before EPC: {e}")
                    }
                })
        });
    let (outcome, rms2) = match study {
        Err(e) => (Err(e), None),
        Ok(study) => {
            let rms2 = study.degrees[0]
                .outcome
                .is_ok()
                .then(|| {
                    study.degrees[0]
                        .stats
                        .iter()
                        .map(|s| s.moments.mean.hypot(s.std_dev()))
                        .collect::<Vec<f64>>()
                })
                .filter(|r| {
                    r.len() == study.quantities.len() && r.iter().all(|v| v.is_finite() && *v > 0.0)
                });
            (solved(&study), rms2)
        }
    };
    Raw {
        values,
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
        outcome,
        rms2,
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
        return Err(PointFailure::Solve {
            degree,
            error: error.clone(),
        });
    }
    let last = study
        .degrees
        .last()
        .expect("a study has at least one degree");
    let sol = last.epc().expect("an EPC study solves by EPC");
    let mut stats = Vec::with_capacity(study.quantities.len());
    let mut curves = Vec::with_capacity(study.quantities.len());
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
        let m = &st.moments;
        if [m.mean, st.std_dev(), m.kurtosis]
            .iter()
            .any(|v| !v.is_finite())
        {
            return Err(PointFailure::NotFinite {
                quantity: q.name.clone(),
                mean: m.mean,
                std_dev: st.std_dev(),
                kurtosis: m.kurtosis,
            });
        }
        stats.push(PointStats {
            name: q.name.clone(),
            moments: st.moments,
            tail: Vec::new(),
        });
        curves.push(QuantityCurve {
            x: curve.x.clone(),
            p: column.pdf.clone(),
        });
    }
    Ok(PointCurves {
        solution: PointSolution {
            iterations: sol.solve.iterations,
            residual: sol.solve.residual,
            residual_threshold: sol.solve.residual_threshold,
            fpk_residual: sol.fpk_residual,
            normalisation: match sol.normalisation.kind {
                NormalisationKind::Plane { .. } => "plane",
                NormalisationKind::InsideRidge { .. } => "inside_ridge",
            }
            .to_string(),
            stats,
        },
        curves,
    })
}
