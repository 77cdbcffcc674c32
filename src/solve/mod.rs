//! The front door: a bound model and a method in, a solution that knows every state and
//! observable by name out.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = fpsolve::model::load_model("models/vibro_duffing.sde".as_ref())?;
//! let bound = model.bind(&["mu=0.5".parse()?])?;
//! let solution = fpsolve::solve(&bound, fpsolve::Method::Epc { degree: 4 })?;
//! let p_y = solution.pdf("y", &[0.5, 1.0])?; // any state or observable, by name
//! let (x, p) = solution.marginal("y")?; // on the grid the reports use
//! let m = solution.moments("y")?; // mean, variance, kurtosis, E[y^k] up to k = 4
//! # assert!(p_y.iter().all(|p| *p > 0.0) && x.len() == p.len() && m.moments.variance > 0.0);
//! # assert!(matches!(solution.pdf("w", &[0.0]), Err(fpsolve::solve::SolveError::UnknownQuantity { .. })));
//! # Ok(())
//! # }
//! ```
//!
//! The same words fit every runner of the crate: a problem, a builder for its settings,
//! `run()` (or `solve()`), a report. [`Problem`] here; [`crate::epc::Epc`] for EPC alone,
//! [`crate::mc::Simulation`] for Monte Carlo, [`crate::study::StudyRunner`] for several EPC
//! degrees with their PDF curves, [`crate::sweep::Sweep`] for a parameter sweep.

mod figures;
mod grid;
mod name;
mod not_applicable;
mod quantity;
mod registry;
mod solution;
mod tail;

use std::borrow::Cow;
use std::sync::Arc;

use crate::base::cancel::Cancelled;
use crate::base::run::RunControl;
use crate::dynamics::Dynamics;
use crate::epc::{Epc, EpcError};
use crate::fpk::{FpkError, FpkOperator};
use crate::grid::{GridError, GridSolver};
use crate::model::BoundModel;
use crate::transform::{zhuravlev_bound, Zhuravlev, ZhuravlevError};

pub use figures::{EpcFigures, EpcNormalisation, Figure, SolverFigures};
pub(crate) use grid::{common_grid, printable};
pub use name::{MethodName, MethodNameError, MethodSet};
pub use not_applicable::NotApplicable;
pub use quantity::{quantities, Quantity};
pub(crate) use quantity::{quantities_of, reported, through};
pub use registry::StationaryMethod;
pub use solution::{Density, MomentErrors, Polynomial, QuantityMoments, Solution};
pub(crate) use tail::{tail_probability, two_sided_tail_probability};

/// How to solve for the stationary density. More methods are to come, so a `match` on it
/// needs a wildcard arm. It serialises as its settings alone (`{"degree": 4}`,
/// `{"cells": [200, 400]}`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum Method {
    /// Exponential-polynomial closure at this (even) degree, continued from degree 2.
    Epc {
        /// The degree n of the polynomial Q in p = C·exp(Q).
        degree: usize,
    },
    /// The finite-volume stationary FPK solver ([`crate::grid`]) on `cells` = \[n_x, n_v\]
    /// cells, impacts located exactly (the δ terms of the drift are not used), with its
    /// discretisation-error estimate from a coarser solve.
    Grid {
        /// Cells per axis (even, at least 8); [`crate::grid::DEFAULT_CELLS`] reaches
        /// L1 < 1e−3 on the paper's cases.
        cells: [usize; 2],
    },
    /// EPC with the exact impact condition ([`crate::epc_impact`]) at this (even) degree,
    /// on the domain of the model's original coordinates, continued from degree 2.
    EpcImpact {
        /// The degree n of the polynomial Q in p = C·exp(Q).
        degree: usize,
    },
}

impl Method {
    /// The method's name, without its settings.
    ///
    /// ```
    /// use fpsolve::solve::{Method, MethodName};
    /// assert_eq!(Method::Grid { cells: [40, 80] }.name(), MethodName::Grid);
    /// ```
    pub fn name(self) -> MethodName {
        match self {
            Method::Epc { .. } => MethodName::Epc,
            Method::Grid { .. } => MethodName::Grid,
            Method::EpcImpact { .. } => MethodName::EpcImpact,
        }
    }

    /// The degree of a ladder method, `None` for the grid.
    ///
    /// ```
    /// use fpsolve::solve::Method;
    /// assert_eq!(Method::EpcImpact { degree: 4 }.degree(), Some(4));
    /// assert_eq!(Method::Grid { cells: [40, 80] }.degree(), None);
    /// ```
    pub fn degree(self) -> Option<usize> {
        match self {
            Method::Epc { degree } | Method::EpcImpact { degree } => Some(degree),
            Method::Grid { .. } => None,
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let title = self.name().method().title();
        match self {
            Method::Epc { degree } | Method::EpcImpact { degree } => {
                write!(f, "{title} n = {degree}")
            }
            Method::Grid { cells } => write!(f, "{title} {}×{}", cells[0], cells[1]),
        }
    }
}

/// Why there is no solution, or no answer to a question asked of one. Non-exhaustive: a new
/// method adds its variant here, and code outside the crate (the Python binding) matches
/// with a fallback, so that it needs no new arm.
#[derive(Clone, Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SolveError {
    /// The FPK operator could not be derived.
    #[error(transparent)]
    Fpk(#[from] FpkError),
    /// EPC did not give a density.
    #[error(transparent)]
    Epc(#[from] EpcError),
    /// The grid solver did not give a density (or does not apply to the model).
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The model has one reflecting barrier in its own coordinates, and its Zhuravlev
    /// transform, which EPC solves, cannot be derived.
    #[error(
        "EPC solves a reflecting barrier through the Zhuravlev transform, which fails here: {0}"
    )]
    Zhuravlev(#[from] ZhuravlevError),
    /// EPC with the exact impact condition did not give a density (or does not apply).
    #[error(transparent)]
    EpcImpact(#[from] crate::epc_impact::EpcImpactError),
    /// A method asked to solve with another method's settings
    /// ([`StationaryMethod::solve`]).
    #[error("{method} cannot solve with the settings of {settings}")]
    OtherSettings {
        /// The method asked.
        method: MethodName,
        /// The settings given.
        settings: Method,
    },
    /// The run's flag was set ([`RunControl`]) before the method finished: nothing of the
    /// solve is returned.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// The method cannot represent the model (a periodic state under EPC): refused before
    /// any work, as its [`StationaryMethod::applies`] says.
    #[error(transparent)]
    NotApplicable(#[from] NotApplicable),
    /// A name that is neither a state nor an observable of the model.
    #[error("`{name}` is neither a state nor an observable of the model (it has: {})", known.join(", "))]
    UnknownQuantity {
        /// The name asked for.
        name: String,
        /// The states, then the observables.
        known: Vec<String>,
    },
}

/// A bound model with its FPK operator and its quantities, ready to be solved by any method.
///
/// A model in its own coordinates with one reflecting barrier (`impact y = 0: ydot -> -r*ydot`,
/// `domain y >= 0`) is solved by EPC through its Zhuravlev transform
/// ([`crate::transform::zhuravlev_bound`], the paper's Eqs. 5–10), and its solution answers the
/// original quantities by name (`y`, `ydot`, the original observables); the grid solver
/// solves the model as it stands.
///
/// ```
/// use fpsolve::model::parse_model;
/// use fpsolve::solve::{Method, Problem};
/// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
/// let bound = model.bind(&[])?;
/// let problem = Problem::new(&bound)?;
/// let solution = problem.solve(Method::Epc { degree: 2 })?;
/// assert!((solution.moments("v")?.moments.variance - 1.0).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Problem<'a> {
    /// Borrowed ([`Problem::new`]) or owned ([`Problem::owning`]).
    model: Cow<'a, BoundModel>,
    /// The model read once, for every method ([`Problem::dynamics`]).
    dynamics: Dynamics,
    /// The operator EPC solves: of the Zhuravlev transform when there is one.
    fpk: FpkOperator,
    /// The quantities of EPC's solutions (maps of the transformed states when transformed).
    quantities: Arc<[Quantity]>,
    /// The quantities of the model as it stands (what the grid solver's solutions know).
    own_quantities: Arc<[Quantity]>,
    /// The transform EPC solves, or why a reflecting barrier has none.
    zhuravlev: Option<Result<Zhuravlev<BoundModel>, ZhuravlevError>>,
    /// The grid solver's box, when given (`--domain`); sized from the density otherwise.
    grid_domain: Option<crate::grid::Domain>,
    /// The grid solver's L1 tolerance, when asked (`--tol`): it then chooses its cells.
    grid_tolerance: Option<f64>,
}

impl Problem<'static> {
    /// [`Problem::new`] of a model it keeps: for a caller that derives the problem where it
    /// checks its input and uses it later (the command line checks a job before it touches
    /// the output directory and hands the same problem to [`Job::problem`](crate::job::Job::problem)).
    ///
    /// # Errors
    /// As [`Problem::new`].
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = fpsolve::solve::Problem::owning(bound.clone())?;
    /// assert_eq!(problem.model(), &bound);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn owning(model: BoundModel) -> Result<Problem<'static>, SolveError> {
        Problem::derive(Cow::Owned(model))
    }
}

/// A refusal of the Zhuravlev transform that EPC solves, said in the terms of the model as
/// written when the model itself is refused for a reason (its law `v -> -1.2*v`, its states
/// and parameters, rather than the transform's `v_ -> 1.2*v_`): the user wrote that model.
/// Only computed on failure, so a solvable model pays nothing for it.
fn in_own_terms(dynamics: &Dynamics, error: FpkError) -> FpkError {
    match error {
        FpkError::Inadmissible(_) => match dynamics.admissible() {
            Err(own) => FpkError::Inadmissible(own),
            Ok(()) => error,
        },
        other => other,
    }
}

impl<'a> Problem<'a> {
    /// Derives the FPK operator of `model` (of its Zhuravlev transform for a model with one
    /// reflecting barrier in its own coordinates) and lists its quantities.
    ///
    /// # Errors
    /// [`SolveError::Fpk`] when the operator cannot be derived.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = fpsolve::solve::Problem::new(&bound)?;
    /// // EPC solves the paper's Eq. 10 in z, v and answers for y and ydot.
    /// assert_eq!(problem.fpk().states[0].as_ref(), "z");
    /// assert!(problem.zhuravlev().is_some());
    /// let names: Vec<&str> = problem.quantities().iter().map(|q| q.name.as_str()).collect();
    /// assert_eq!(names, ["y", "ydot"]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new(model: &'a BoundModel) -> Result<Problem<'a>, SolveError> {
        Problem::derive(Cow::Borrowed(model))
    }

    fn derive(bound: Cow<'a, BoundModel>) -> Result<Problem<'a>, SolveError> {
        let model = bound.as_ref();
        let dynamics = Dynamics::read(model);
        let own: Arc<[Quantity]> = quantities(model).into();
        let reflecting = matches!(model.impacts(), [law] if law.side.is_some());
        let zhuravlev = reflecting.then(|| zhuravlev_bound(model));
        let (fpk, quantities) = match &zhuravlev {
            // The transform is another model: EPC's operator is read from it.
            Some(Ok(t)) => (
                FpkOperator::derive(&t.model).map_err(|e| in_own_terms(&dynamics, e))?,
                through(&t.model, model.observables().len()).into(),
            ),
            _ => (FpkOperator::of(&dynamics)?, own.clone()),
        };
        Ok(Problem {
            model: bound,
            dynamics,
            fpk,
            quantities,
            own_quantities: own,
            zhuravlev,
            grid_domain: None,
            grid_tolerance: None,
        })
    }

    /// The grid solver's box ([`GridSolver::domain`]) instead of one sized from the density;
    /// `None` sizes it. Checked against the model's walls by [`GridSolver::check`].
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let d = fpsolve::grid::Domain { x: [-12.0, 12.0], v: [-12.0, 12.0] };
    /// let problem = fpsolve::solve::Problem::new(&bound)?.with_grid_domain(Some(d));
    /// assert_eq!(problem.grid_domain(), Some(d));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_grid_domain(mut self, domain: Option<crate::grid::Domain>) -> Problem<'a> {
        self.grid_domain = domain;
        self
    }

    /// The grid solver's box, when one was given ([`Problem::with_grid_domain`]).
    pub fn grid_domain(&self) -> Option<crate::grid::Domain> {
        self.grid_domain
    }

    /// The grid solver's L1 tolerance ([`GridSolver::tolerance`]): it then chooses and
    /// refines its own cells, and the cells of [`Method::Grid`] are not used; `None` solves
    /// on those cells. Checked by [`GridSolver::check`] (0 < tol ≤ 0.5).
    ///
    /// ```
    /// use fpsolve::solve::{Density, Method, Problem};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = Problem::new(&bound)?.with_grid_tolerance(Some(1e-2));
    /// assert_eq!(problem.grid_tolerance(), Some(1e-2));
    /// let sol = problem.solve(Method::Grid { cells: [200, 400] })?;
    /// let Density::Grid(g) = sol.density() else { unreachable!() };
    /// assert!(g.report.tolerance.as_ref().unwrap().reached);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_grid_tolerance(mut self, tol: Option<f64>) -> Problem<'a> {
        self.grid_tolerance = tol;
        self
    }

    /// The grid solver's L1 tolerance, when one was asked ([`Problem::with_grid_tolerance`]).
    pub fn grid_tolerance(&self) -> Option<f64> {
        self.grid_tolerance
    }

    /// How quantity `name` (a state or an observable) changes in time and where its level
    /// sets lie, in the coordinates `method`'s density is in (EPC of a model with a wall
    /// solves its Zhuravlev form, whose observables carry the original states): what
    /// [`crate::observe::crossing_rate`] integrates.
    ///
    /// # Errors
    /// [`crate::observe::CrossingError`] for a quantity driven by noise (no finite rate) or
    /// one whose level sets are not c ± a state.
    ///
    /// ```
    /// use fpsolve::solve::{MethodName, Problem};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = Problem::new(&bound)?;
    /// assert_eq!(problem.level_rate(MethodName::Grid, "z")?.quantity(), "z");
    /// assert!(problem.level_rate(MethodName::Grid, "v").is_err()); // noise-driven
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn level_rate(
        &self,
        method: MethodName,
        name: &str,
    ) -> Result<crate::observe::LevelRate, crate::observe::CrossingError> {
        let model = method.method().density_model(self);
        match model.states().iter().position(|s| s.as_ref() == name) {
            Some(i) => crate::observe::LevelRate::of_state(model, i),
            None => crate::observe::LevelRate::of_observable(model, name),
        }
    }

    /// The grid solver of this problem's model, with its box and tolerance when given.
    pub(crate) fn grid_solver(&self) -> GridSolver<'_> {
        let solver = GridSolver::reading(&self.dynamics);
        let solver = match self.grid_domain {
            Some(d) => solver.domain(d),
            None => solver,
        };
        match self.grid_tolerance {
            Some(tol) => solver.tolerance(tol),
            None => solver,
        }
    }

    /// The states, then the observables, of the model as it stands: what a solution of a
    /// method that solves the model in its own coordinates knows (the grid, EPC-impact).
    pub(crate) fn own_quantities(&self) -> Arc<[Quantity]> {
        self.own_quantities.clone()
    }

    /// The bound model.
    pub fn model(&self) -> &BoundModel {
        &self.model
    }

    /// The model read once: what every method of this problem reads it through.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let problem = fpsolve::solve::Problem::new(&bound)?;
    /// assert_eq!(problem.dynamics().model(), &bound);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    /// The FPK operator EPC solves: the model's, or its Zhuravlev transform's (see
    /// [`Problem::zhuravlev`]).
    pub fn fpk(&self) -> &FpkOperator {
        &self.fpk
    }

    /// The Zhuravlev transform EPC solves instead of the model (one reflecting barrier in the
    /// model's own coordinates), `None` when EPC solves the model as it stands.
    pub fn zhuravlev(&self) -> Option<&Zhuravlev<BoundModel>> {
        self.zhuravlev.as_ref().and_then(|t| t.as_ref().ok())
    }

    /// The states, then the observables, as EPC's solutions know them: by the model's names,
    /// as maps of the states EPC solves for (z, v under the Zhuravlev transform). Each
    /// [`Solution`] carries its own list; use that one with its density.
    pub fn quantities(&self) -> &[Quantity] {
        &self.quantities
    }

    /// Solves by `method`.
    ///
    /// # Errors
    /// [`SolveError::Epc`] when EPC does not converge or cannot normalise;
    /// [`SolveError::Grid`] when the grid solver refuses the model or fails.
    pub fn solve(&self, method: Method) -> Result<Solution, SolveError> {
        self.solve_with(method, &RunControl::new())
    }

    /// [`Problem::solve`] under `run`: the method checks its flag between its units of work
    /// and reports its progress there (see [`StationaryMethod::solve`]).
    ///
    /// # Errors
    /// As [`Problem::solve`]; [`SolveError::Cancelled`] when `run`'s flag was set.
    ///
    /// ```
    /// use fpsolve::base::{cancel::Cancel, run::RunControl};
    /// use fpsolve::solve::{Method, Problem, SolveError};
    /// let bound = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\n\
    ///     drift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?.bind(&[])?;
    /// let problem = Problem::new(&bound)?;
    /// let cancel = Cancel::new();
    /// let run = RunControl::new().cancelled_by(cancel.clone());
    /// assert!(problem.solve_with(Method::Grid { cells: [40, 40] }, &run).is_ok());
    /// cancel.cancel();
    /// let err = problem.solve_with(Method::Grid { cells: [40, 40] }, &run).unwrap_err();
    /// assert!(matches!(err, SolveError::Cancelled(_)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn solve_with(&self, method: Method, run: &RunControl) -> Result<Solution, SolveError> {
        method.name().method().solve(self, method, run)
    }

    /// [`SolveError::NotApplicable`] when the model has a periodic state, which `method` (an
    /// exponential polynomial) does not represent: what its `applies` says.
    fn refuse_periodic(&self, method: MethodName) -> Result<(), SolveError> {
        match method.method().applies(self)? {
            Err(e @ NotApplicable::PeriodicState { .. }) => Err(SolveError::NotApplicable(e)),
            _ => Ok(()),
        }
    }

    /// Solves by EPC at `degree` (through the Zhuravlev transform when there is one).
    pub(crate) fn solve_epc(&self, degree: usize) -> Result<Solution, SolveError> {
        self.refuse_periodic(MethodName::Epc)?;
        if let Some(Err(e)) = &self.zhuravlev {
            return Err(SolveError::Zhuravlev(e.clone()));
        }
        Ok(self.solution(self.epc().degree(degree).solve()?))
    }

    /// Solves by the grid solver on `cells` (on the cells it chooses when a tolerance was
    /// asked), the model as it stands.
    pub(crate) fn solve_grid(
        &self,
        cells: [usize; 2],
        run: &RunControl,
    ) -> Result<Solution, SolveError> {
        let solver = self.grid_solver().run_control(run.clone());
        let solver = match self.grid_tolerance {
            Some(_) => solver,
            None => solver.cells(cells[0], cells[1]),
        };
        let grid = solver.solve().map_err(|e| match e {
            GridError::Cancelled(c) => SolveError::Cancelled(c),
            e => SolveError::Grid(e),
        })?;
        Ok(Solution::new(
            Density::Grid(Box::new(grid)),
            self.own_quantities(),
        ))
    }

    /// Solves by EPC with the exact impact condition at `degree`, the model as it stands.
    pub(crate) fn solve_epc_impact(&self, degree: usize) -> Result<Solution, SolveError> {
        self.refuse_periodic(MethodName::EpcImpact)?;
        let sol = crate::epc_impact::EpcImpact::reading(&self.dynamics).solve(degree)?;
        Ok(Solution::new(
            Density::EpcImpact(Box::new(sol)),
            self.own_quantities(),
        ))
    }

    /// Solves by EPC at each degree asked, continuing through every lower even degree, one
    /// result per degree in the order given (see [`Epc::solve_degrees`]).
    pub fn solve_epc_degrees(&self, degrees: &[usize]) -> Vec<Result<Solution, EpcError>> {
        self.epc()
            .solve_degrees(degrees)
            .into_iter()
            .map(|r| r.map(|s| self.solution(s)))
            .collect()
    }

    /// Solves by EPC with the exact impact condition at each degree asked, continuing through
    /// every lower even degree, one result per degree in the order given (see
    /// [`crate::epc_impact::EpcImpact::solve_degrees`]). The model is solved as written, in
    /// its own coordinates.
    pub fn solve_epc_impact_degrees(&self, degrees: &[usize]) -> Vec<Result<Solution, SolveError>> {
        crate::epc_impact::EpcImpact::reading(&self.dynamics)
            .solve_degrees(degrees)
            .into_iter()
            .map(|r| {
                r.map(|s| Solution::new(Density::EpcImpact(Box::new(s)), self.own_quantities()))
                    .map_err(SolveError::from)
            })
            .collect()
    }

    fn epc(&self) -> Epc<'_> {
        Epc::new(&self.fpk)
    }

    fn solution(&self, sol: crate::epc::EpcSolution) -> Solution {
        let solution = Solution::new(Density::Epc(Box::new(sol)), self.quantities.clone());
        match self.zhuravlev() {
            Some(t) => solution.over([t.position.to_string(), t.velocity.to_string()]),
            None => solution,
        }
    }
}

/// Solves `model` by `method`: [`Problem::new`] then [`Problem::solve`].
///
/// # Errors
/// As [`Problem::new`] and [`Problem::solve`].
///
/// ```
/// use fpsolve::model::parse_model;
/// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
/// let solution = fpsolve::solve(&model.bind(&[])?, fpsolve::Method::Epc { degree: 2 })?;
/// assert_eq!(solution.method(), fpsolve::Method::Epc { degree: 2 });
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn solve(model: &BoundModel, method: Method) -> Result<Solution, SolveError> {
    Problem::new(model)?.solve(method)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::load_model;
    use crate::study::StudyRunner;

    fn vibro() -> BoundModel {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
        load_model(&path).unwrap().bind(&[]).unwrap()
    }

    /// erfc(x) = (2/√π)∫_x^∞ e^{−t²} dt by Simpson's rule (h = 2e−4, error ~1e−15).
    fn erfc(x: f64) -> f64 {
        let (n, b) = (200_000, x + 40.0);
        let h = (b - x) / n as f64;
        let f = |t: f64| (-t * t).exp();
        let inner: f64 = (1..n)
            .map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * f(x + i as f64 * h))
            .sum();
        (f(x) + f(b) + inner) * h / 3.0 * 2.0 / std::f64::consts::PI.sqrt()
    }

    /// The one tail routine, on its report grid, against erfc: P(z > a) for z ~ N(0, 5) and
    /// P(y > a) for y = |z| (a support edge at 0): relative error below 1e−6 out to 4σ
    /// (measured 5.1e−5 at 5σ); below every value the answer is 1, never more.
    #[test]
    fn tail_probabilities_are_erfc_for_a_gaussian() {
        let text = "model m\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
                    noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
        let bound = crate::model::parse_model(text, None)
            .unwrap()
            .bind(&[])
            .unwrap();
        let solution = solve(&bound, Method::Epc { degree: 2 }).unwrap();
        let sd = 5.0_f64.sqrt();
        for (name, share) in [("z", 0.5), ("y", 1.0)] {
            for k in [0.0, 0.3, 1.0, 1.7, 2.0, 3.0, 4.0, 5.0] {
                let exact = share * erfc(k / 2.0_f64.sqrt());
                let got = solution.tail_probability(name, k * sd).unwrap().unwrap();
                assert!(
                    ((got - exact) / exact).abs() < if k < 4.5 { 1e-6 } else { 1e-4 },
                    "{name}, k = {k}: {got:e} vs {exact:e}"
                );
                let below = solution.tail_probability(name, -k * sd).unwrap().unwrap();
                let exact = if name == "y" { 1.0 } else { 1.0 - exact };
                assert!(
                    (below - exact).abs() < 1e-6 && below <= 1.0,
                    "{name}, k = -{k}: {below:e} vs {exact:e}"
                );
            }
        }
    }

    /// The grid solver answers through the same door: by name, with the same moments and
    /// PDFs as the exact density of the linear oscillator (Var z = πK/(ck), Var v = πK/c).
    #[test]
    fn a_grid_solution_answers_by_name_too() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
        let bound = load_model(&path).unwrap().bind(&[]).unwrap();
        let (c, k, pk) = (
            bound.param("c").unwrap(),
            bound.param("k").unwrap(),
            std::f64::consts::PI * bound.param("K").unwrap(),
        );
        let solution = solve(
            &bound,
            Method::Grid {
                cells: crate::grid::DEFAULT_CELLS,
            },
        )
        .unwrap();
        assert_eq!(
            solution.method(),
            Method::Grid {
                cells: crate::grid::DEFAULT_CELLS
            }
        );
        assert!(solution.epc().is_none());
        let var_v = solution.moments("v").unwrap().moments.variance;
        // At the default cells, measured: Var v 7.0e−4 and p_z(0) 1.7e−3 relative (the peak
        // value of a cell-average density is second order).
        assert!((var_v / (pk / c) - 1.0).abs() < 2e-3, "{var_v}");
        let var_z = pk / (c * k);
        let p0 = solution.pdf("z", &[0.0]).unwrap()[0];
        let exact = 1.0 / (2.0 * std::f64::consts::PI * var_z).sqrt();
        assert!((p0 / exact - 1.0).abs() < 3e-3, "{p0} vs {exact}");
        assert!(matches!(
            solution.pdf("w", &[0.0]),
            Err(SolveError::UnknownQuantity { .. })
        ));
    }

    #[test]
    fn the_solution_is_what_the_study_reports() {
        let bound = vibro();
        let solution = solve(&bound, Method::Epc { degree: 4 }).unwrap();
        let study = StudyRunner::new(&bound).degrees(&[4]).run().unwrap();
        // One degree: the study's common grid is this solution's own report grid.
        for q in solution.quantities() {
            let (x, p) = solution.marginal(&q.name).unwrap();
            let curve = study.curves.iter().find(|c| c.name == q.name).unwrap();
            assert_eq!(x, curve.x, "{}", q.name);
            let same = p
                .iter()
                .zip(&curve.columns[0].pdf)
                .all(|(a, b)| a == b || (a.is_nan() && b.is_nan()));
            assert!(same, "{}", q.name);
            assert_eq!(
                solution.moments(&q.name).unwrap(),
                *study.runs[0]
                    .stats
                    .iter()
                    .find(|s| s.name == q.name)
                    .unwrap()
            );
        }
        assert_eq!(solution.all_moments(), study.runs[0].stats);
    }

    /// Issue 11, item 4: the paper's Eqs. 1–2 as written are solved by EPC through their
    /// Zhuravlev transform and answer y and ẏ exactly as the Zhuravlev-form model does.
    #[test]
    fn epc_of_eqs_1_2_is_epc_of_their_zhuravlev_form() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        let original = load_model(&dir.join("vibro_impact_duffing.sde")).unwrap();
        let paper = load_model(&dir.join("vibro_duffing.sde")).unwrap();
        for set in [vec![], vec![("mu", 1.0), ("eps", -0.1)]] {
            let o: Vec<crate::model::Override> = set
                .iter()
                .map(|(n, v)| crate::model::Override::number(n, *v))
                .collect();
            let (a, b) = (original.bind(&o).unwrap(), paper.bind(&o).unwrap());
            let problem = Problem::new(&a).unwrap();
            assert!(problem.zhuravlev().is_some());
            let names: Vec<(&str, bool)> = problem
                .quantities()
                .iter()
                .map(|q| (q.name.as_str(), q.is_state))
                .collect();
            assert_eq!(names, [("y", true), ("ydot", true)]);
            let sa = problem.solve(Method::Epc { degree: 4 }).unwrap();
            let sb = solve(&b, Method::Epc { degree: 4 }).unwrap();
            let ys: Vec<f64> = (0..60).map(|i| 0.07 * i as f64).collect();
            let vs: Vec<f64> = (0..60).map(|i| -6.0 + 0.2 * i as f64).collect();
            for (name, xs) in [("y", &ys), ("ydot", &vs)] {
                let (pa, pb) = (sa.pdf(name, xs).unwrap(), sb.pdf(name, xs).unwrap());
                for (x, (p, q)) in xs.iter().zip(pa.iter().zip(&pb)) {
                    assert!(
                        (p - q).abs() <= 1e-10 * q.abs().max(1e-300),
                        "{set:?} p_{name}({x}): {p:e} vs {q:e}"
                    );
                }
                assert!(pa.iter().any(|p| *p > 0.1), "{name}");
                let (ma, mb) = (sa.moments(name).unwrap(), sb.moments(name).unwrap());
                assert!((ma.moments.mean - mb.moments.mean).abs() < 1e-10, "{name}");
            }
            // y lives above the barrier: no mass below it.
            assert_eq!(sa.pdf("y", &[-0.5]).unwrap()[0], 0.0);
            assert!(
                sa.pdf("z", &[0.0]).is_err(),
                "the solution answers the original names"
            );
        }
    }

    /// The grid solver solves the model as it stands, and answers the same names.
    #[test]
    fn the_grid_solves_eqs_1_2_as_written() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/vibro_impact_duffing.sde");
        let bound = load_model(&path).unwrap().bind(&[]).unwrap();
        let problem = Problem::new(&bound).unwrap();
        let grid = problem.solve(Method::Grid { cells: [40, 80] }).unwrap();
        let names: Vec<&str> = grid.quantities().iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["y", "ydot"]);
        let Density::Grid(g) = grid.density() else {
            panic!("a grid density")
        };
        assert!(g.report.domain.x[0] >= 0.0, "{:?}", g.report.domain);
        let epc = problem.solve(Method::Epc { degree: 2 }).unwrap();
        // Gaussian closure vs the grid: the same mean displacement to a few percent.
        let (mg, me) = (
            grid.moments("y").unwrap().moments.mean,
            epc.moments("y").unwrap().moments.mean,
        );
        assert!((mg / me - 1.0).abs() < 0.1, "{mg} vs {me}");
    }

    #[test]
    fn unknown_names_are_typed_errors() {
        let solution = solve(&vibro(), Method::Epc { degree: 2 }).unwrap();
        let err = solution.marginal("w").unwrap_err();
        let SolveError::UnknownQuantity { name, known } = err else {
            panic!("expected UnknownQuantity, got {err:?}");
        };
        assert_eq!(name, "w");
        assert_eq!(known, ["z", "v", "y", "ydot"]);
    }

    #[test]
    fn a_failed_degree_is_a_result_the_caller_sees() {
        let bound = vibro();
        let study = StudyRunner::new(&bound).degrees(&[2, 5]).run().unwrap();
        let at = study.pdf_at("y", &[0.5]).unwrap();
        assert_eq!(at.len(), 2);
        assert!(at[0].pdf.is_ok());
        assert!(matches!(
            at[1].pdf,
            Err(SolveError::Epc(EpcError::OddDegree { degree: 5 }))
        ));
        assert!(matches!(
            solve(&bound, Method::Epc { degree: 5 }),
            Err(SolveError::Epc(EpcError::OddDegree { degree: 5 }))
        ));
    }
}
