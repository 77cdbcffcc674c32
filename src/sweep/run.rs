//! Solving every point of a sweep by every method asked, in parallel.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::base::cancel::{Cancel, Cancelled};
use crate::base::run::RunControl;
use crate::grid::{Cells, Domain, GridSolver};
use crate::model::Model;
use crate::solve::{
    quantities_of, reported, two_sided_tail_probability, Method, MethodName, MethodSet, Problem,
};

use super::admission;
use super::frontier::{Frontier, ReferenceRms};
use super::method::{applies, settle};
use super::point::{solve_point, PointCurves, Raw};
use super::thresholds::{self, Reference};
use super::{
    MethodOutcome, MethodRefusal, PointFailure, PointOutcome, SweepError, SweepPoint, SweepResult,
    SweepSpec, TailThresholds, TAIL_MULTIPLES,
};

/// The method whose solution set the tail thresholds, and its reference point.
pub(super) type ThresholdSource = (MethodName, Reference);

/// A sweep to run: a model, the points, the methods and their settings (the builder;
/// [`Sweep::run`] gives the report).
pub struct Sweep<'a> {
    pub(super) model: &'a Model,
    pub(super) spec: &'a SweepSpec,
    methods: MethodSet,
    degree: usize,
    cells: Cells,
    domain: Option<Domain>,
    progress: &'a (dyn Fn(u64, u64) + Sync),
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
            domain: None,
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

    /// The grid solver's box at every point ([`GridSolver::domain`], `--domain`) instead of
    /// one sized from each point's density; checked by [`Sweep::check`] at every point that
    /// binds (a wall that moves with a parameter must stay an end of the box).
    ///
    /// ```
    /// use fpsolve::grid::{Cells, Domain};
    /// use fpsolve::solve::MethodName;
    /// use fpsolve::sweep::{Sweep, SweepSpec};
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()])?;
    /// let d = Domain { x: [-9.0, 9.0], v: [-9.0, 9.0] };
    /// let sweep = Sweep::new(&model, &spec).methods("grid".parse()?).cells(Cells([40, 40])).grid_domain(d);
    /// sweep.check()?;
    /// for point in &sweep.run().points {
    ///     assert_eq!(point.solution(MethodName::Grid).unwrap().grid().unwrap().domain, d);
    /// }
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn grid_domain(mut self, domain: Domain) -> Self {
        self.domain = Some(domain);
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
    /// // δ-term impact damping without an impact law: EPC solves it, the grid refuses it.
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate x, y\ndrift x: y\ndrift y: -c*y - x - 0.1*y*abs(y)*delta(x)\nnoise xi: intensity 1\ndiffusion y: xi\n", None)?;
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()])?;
    /// assert!(Sweep::new(&model, &spec).check().is_ok()); // EPC applies
    /// let err = Sweep::new(&model, &spec).methods("epc,grid".parse()?).check().unwrap_err();
    /// assert!(matches!(err, SweepError::Method { method: fpsolve::solve::MethodName::Grid, .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn check(&self) -> Result<(), SweepError> {
        if self.model.time_dependent() {
            return Err(SweepError::TimeDependent {
                model: self.model.name().to_string(),
            });
        }
        let refused = |method: MethodName, reason: MethodRefusal| SweepError::Method {
            method,
            model: self.model.name().to_string(),
            reason: Box::new(reason),
        };
        let mut settled = Vec::new();
        for &name in self.methods.names() {
            settled.push((name, settle(name, self.degree, self.cells)));
        }
        // The structure is checked at the first point with a stationary density: at a point
        // without one no operator is derived, and nothing could be checked.
        let bound = self.spec.points().into_iter().find_map(|values| {
            let bound = self.model.bind(&self.spec.overrides_at(&values)).ok()?;
            Problem::new(&bound).ok()?;
            Some(bound)
        });
        if let Some(bound) = bound {
            for (name, method) in settled {
                applies(&bound, name, method).map_err(|r| refused(name, r))?;
            }
        }
        if let Some(d) = self.domain {
            self.check_domain(d)
                .map_err(|r| refused(MethodName::Grid, r))?;
        }
        Ok(())
    }

    /// Solves every point by every method (EPC at the degree, continued from degree 2 within
    /// the point), all points in parallel, and collects the statistics of each state and
    /// observable. Before any point is solved, every point is checked for a stationary
    /// density as a single run is ([`crate::dynamics::check`]); a point without one (a
    /// softening spring's escaping regime, no noise, …) is not solved but kept as
    /// [`PointOutcome::Refused`] for every method, with the typed reason. A method that
    /// fails at a point — bind error (e.g. a negative intensity), FPK error, EPC failure at
    /// degree 2 or at `degree`, grid failure — is kept as [`PointOutcome::Failed`] with its
    /// stage and message; the other methods and points are unaffected.
    ///
    /// Tail probabilities P(|g| > a) use thresholds a = 2, 3, 4 × √E\[g²\] at the first
    /// point, in the sweep's order, that the first method solved (converged at the target
    /// degree; for EPC the values are those of its degree-2 solution) — or, when the first
    /// method solved no point, the next method in the order asked that solved one — fixed
    /// for the whole sweep and every method; [`SweepResult::threshold_method`] and
    /// [`SweepResult::threshold_point`] name them, and when no method solved any point there
    /// are no thresholds. √E\[g²\] is σ for a zero-mean quantity and makes the
    /// thresholds of |z| those of z. The probabilities are integrals of the quantity's PDF
    /// curve (Eqs. 23–28) beyond ±a, normalised by the curve's mass.
    ///
    /// Every point's EPC result is the same as a [`Study::run`](crate::study::Study::run) at its values, and its
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
    /// use fpsolve::base::cancel::{Cancel, Cancelled};
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
        let total = self.spec.len();
        let (raw, reference) = self.solve_range(0..total, cancel)?;
        Ok(self.assemble(raw, reference, start))
    }

    /// Solves the points of `range` (indices into [`SweepSpec::points`]) in parallel and
    /// finds the reference point of the tail thresholds among all the sweep's points, in
    /// order (see [`super::thresholds`]): the same whatever the range, so that shards agree.
    pub(super) fn solve_range(
        &self,
        range: Range<usize>,
        cancel: &Cancel,
    ) -> Result<(Vec<Raw>, Option<ThresholdSource>), Cancelled> {
        let (model, spec, progress) = (self.model, self.spec, self.progress);
        let total = range.len() as u64;
        let done = AtomicU64::new(0);
        let settled = self.settled();
        let all = spec.points();
        // Every point of the sweep is checked before any is solved (the walk below may need
        // points outside the range): a point without a stationary density is never handed
        // to a solver.
        let refusals = admission::refusals(model, spec, &all);
        let frontier = Frontier::at(&range);
        let run = RunControl::new().cancelled_by(cancel.clone());
        let solve = || {
            range
                .clone()
                .into_par_iter()
                .map(|i| {
                    if cancel.is_cancelled() {
                        return Err(Cancelled);
                    }
                    let point = match &refusals[i] {
                        Some(refusal) => {
                            frontier.passed(i);
                            Raw::refused(all[i].clone(), refusal.clone())
                        }
                        None => solve_point(
                            model,
                            spec,
                            (i, all[i].clone()),
                            &settled,
                            self.domain,
                            &frontier,
                            &run,
                        ),
                    };
                    let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(k, total);
                    Ok(point)
                })
                .collect::<Result<Vec<Raw>, Cancelled>>()
        };
        let walk = |k: usize, indices: Range<usize>, known: &dyn Fn(usize) -> ReferenceRms| {
            let known = |i: usize| match refusals[i] {
                Some(_) => ReferenceRms::Known(None),
                None => known(i),
            };
            let method = settled[k].1;
            thresholds::reference(
                model,
                spec,
                &all,
                indices,
                (method, self.domain),
                known,
                cancel,
            )
        };
        // The points before this range (a shard's) are walked on one core while the others
        // solve; then the range's own points, from what they computed (see
        // [`super::thresholds`]), and any after it.
        let (raw, before) = rayon::join(solve, || {
            walk(0, 0..range.start, &|_| ReferenceRms::Unknown)
        });
        let raw = raw?;
        let (solved, first) = (&raw, range.start);
        let known = |k: usize| {
            move |i: usize| match i.checked_sub(first).and_then(|j| solved.get(j)) {
                Some(point) => point.reference(k),
                None => ReferenceRms::Unknown,
            }
        };
        let mut reference = before
            .or_else(|| walk(0, range.start..all.len(), &known(0)))
            .map(|r| (settled[0].0, r));
        // A method that solved no point sets no thresholds: the next method, in the order
        // asked, that solved one does.
        for (k, &(name, _)) in settled.iter().enumerate().skip(1) {
            if reference.is_some() {
                break;
            }
            reference = walk(k, 0..range.start, &|_| ReferenceRms::Unknown)
                .or_else(|| walk(k, range.start..all.len(), &known(k)))
                .map(|r| (name, r));
        }
        if cancel.is_cancelled() {
            return Err(Cancelled);
        }
        Ok((raw, reference))
    }

    /// The box `d` at every point that binds with a stationary density: a box, fitting the
    /// model's walls there (they may move with a parameter).
    fn check_domain(&self, d: Domain) -> Result<(), MethodRefusal> {
        for values in self.spec.points() {
            let Ok(bound) = self.model.bind(&self.spec.overrides_at(&values)) else {
                continue;
            };
            let dynamics = crate::dynamics::Dynamics::read(&bound);
            if dynamics.admissible().is_err() {
                continue;
            }
            GridSolver::reading(&dynamics)
                .domain(d)
                .check()
                .map_err(|error| MethodRefusal::Domain {
                    at: self
                        .spec
                        .swept
                        .iter()
                        .zip(&values)
                        .map(|(s, v)| format!("{}={v}", s.name))
                        .collect::<Vec<_>>()
                        .join(","),
                    error,
                })?;
        }
        Ok(())
    }

    /// Each method with the sweep's settings.
    fn settled(&self) -> Vec<(MethodName, Method)> {
        self.methods
            .names()
            .iter()
            .map(|&name| (name, settle(name, self.degree, self.cells)))
            .collect()
    }

    /// The points of `raw` (consecutive, from the sweep's start or a shard's) with their
    /// tails at the thresholds of `reference`, as a result.
    pub(super) fn assemble(
        &self,
        raw: Vec<Raw>,
        reference: Option<ThresholdSource>,
        start: Instant,
    ) -> SweepResult {
        let (model, spec) = (self.model, self.spec);
        let listed = quantities_of(model);
        let quantities: Vec<String> = listed.iter().map(|q| q.name.clone()).collect();
        let figure_quantities = reported(&listed)
            .into_iter()
            .map(|q| q.name.clone())
            .collect();
        let threshold_method = reference
            .as_ref()
            .map_or(self.methods.names()[0], |(method, _)| *method);
        let threshold_point = reference.as_ref().map(|(_, r)| r.point);
        let tail_thresholds: Vec<TailThresholds> = reference
            .map(|(_, r)| {
                quantities
                    .iter()
                    .zip(r.rms)
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
                outcomes: match r.refusal {
                    // Refused before any work: every method has the same reason.
                    Some(refusal) => self
                        .methods
                        .names()
                        .iter()
                        .map(|&method| MethodOutcome {
                            method,
                            wall_ms: 0.0,
                            outcome: PointOutcome::Refused(refusal.clone()),
                        })
                        .collect(),
                    None => r
                        .methods
                        .into_iter()
                        .map(|m| MethodOutcome {
                            method: m.method,
                            wall_ms: m.wall_ms,
                            outcome: with_tails(m.outcome, &tail_thresholds),
                        })
                        .collect(),
                },
            })
            .collect();
        SweepResult {
            provenance: Some(crate::report::Provenance::now(Some(model))),
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
        }
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
                        .map(|&a| two_sided_tail_probability(&curve.x, &curve.p, a))
                        .collect();
                }
            }
            PointOutcome::Converged(solution)
        }
        Err(failure) => PointOutcome::Failed(failure),
    }
}
