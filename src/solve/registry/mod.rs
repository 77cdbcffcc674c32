//! The stationary methods behind one trait, and the registry that maps each name to its
//! method: the study, the sweep, the job and the command line ask a method through
//! [`StationaryMethod`], never by matching on its name.
//!
//! Adding a method: its solver in its own stage folder (beside `epc/`, `grid/`), one file
//! here implementing [`StationaryMethod`], one [`MethodName`] variant with its spelling, one
//! line in [`MethodName::method`], and its settings as a [`Method`] variant.

mod epc;
mod epc_impact;
mod grid;

use super::{Method, MethodName, NotApplicable, Problem, Solution, SolveError};
use crate::base::run::RunControl;

/// A method that solves for the stationary density: what it is called, whether it applies
/// to a model (a typed refusal before any work), and its solve, once or at a ladder of
/// degrees.
///
/// ```
/// use fpsolve::base::run::RunControl;
/// use fpsolve::solve::{MethodName, Problem};
/// let bound = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\n\
///     drift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?.bind(&[])?;
/// let problem = Problem::new(&bound)?;
/// for name in MethodName::ALL {
///     let method = name.method();
///     assert_eq!(method.name(), name);
///     if method.applies(&problem)?.is_ok() {
///         let solution = method.solve(&problem, method.settle(2, [40, 40]), &RunControl::new())?;
///         assert!(solution.moments("v")?.moments.variance > 0.9);
///     }
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub trait StationaryMethod: Sync {
    /// Its name.
    fn name(&self) -> MethodName;

    /// How tables and legends title it (`EPC`, `grid`).
    fn title(&self) -> &'static str;

    /// Whether it is solved at a ladder of degrees (`--degree`), each continued from the one
    /// below.
    fn has_degrees(&self) -> bool;

    /// The method with a run's settings: `degree` for a ladder method, `cells` for the grid.
    fn settle(&self, degree: usize, cells: [usize; 2]) -> Method;

    /// Whether it applies to the problem's model, decided before any work (the inner
    /// `Err`); the outer `Err` is a model it cannot even check (a coefficient that does not
    /// compile).
    ///
    /// # Errors
    /// A [`SolveError`] when the model cannot be checked.
    fn applies(&self, problem: &Problem) -> Result<Result<(), NotApplicable>, SolveError>;

    /// What it leaves out of a run that applies (PDFs that take minutes), unless `named`
    /// by the user; `Ok` when it leaves out nothing.
    ///
    /// # Errors
    /// The [`NotApplicable`] reason for the PDFs left out.
    fn leaves_out(&self, _problem: &Problem, _named: bool) -> Result<(), NotApplicable> {
        Ok(())
    }

    /// Solves once with `method`'s settings (a [`Method`] of this name), under `run`: the
    /// method checks `run`'s flag between its units of work and stops there with
    /// [`SolveError::Cancelled`], and reports each unit done (the grid: each solve on a mesh,
    /// a tolerance's refinements included; EPC: its solve, which takes milliseconds, is one
    /// unit, checked before it starts).
    ///
    /// # Errors
    /// The method's failure, as a [`SolveError`]; [`SolveError::Cancelled`].
    fn solve(
        &self,
        problem: &Problem,
        method: Method,
        run: &RunControl,
    ) -> Result<Solution, SolveError>;

    /// Solves at each degree asked, continuing through every lower even degree, one result
    /// per degree in the order given, under `run` (checked before the ladder starts: a
    /// ladder is one unit of work, reported when done); `None` for a method without
    /// degrees. A cancelled ladder gives [`SolveError::Cancelled`] at every degree.
    fn solve_degrees(
        &self,
        _problem: &Problem,
        _degrees: &[usize],
        _run: &RunControl,
    ) -> Option<Vec<Result<Solution, SolveError>>> {
        None
    }

    /// Its own estimated L1 error of `solution`'s marginals, when it can serve as the
    /// reference other methods are judged against; `None` when it cannot.
    fn error_estimate(&self, _solution: &Solution) -> Option<f64> {
        None
    }

    /// The model whose states its density is over: the problem's own, or for EPC of a
    /// model with a wall its Zhuravlev form (whose observables carry the original states).
    fn density_model<'p>(&self, problem: &'p Problem) -> &'p crate::model::BoundModel {
        problem.model()
    }

    /// Its own estimate of the discretisation error (absolute) of each number `derive`
    /// takes from `solution`'s joint density (a crossing-rate curve, impact statistics),
    /// given their `values` on `solution` (already computed by the caller):
    /// the grid's from its half-resolution solve; `None` for a method without an estimate
    /// (EPC's closure error has none).
    fn estimate_derived(
        &self,
        _solution: &Solution,
        _values: &[f64],
        _derive: &dyn Fn(&dyn crate::density::JointDensity) -> Vec<f64>,
    ) -> Option<Vec<f64>> {
        None
    }

    /// The names of its own figures of a solution, the columns `sweep.csv` gives them
    /// ([`SolverFigures::values`](crate::solve::SolverFigures::values) in this order).
    fn figure_names(&self) -> &'static [&'static str];

    /// Why its density is exactly 0 where another's is not (EPC is cut beyond its ridge,
    /// the grid ends at its domain).
    fn zero_reason(&self) -> &'static str;
}

/// A solve that is one unit of work (EPC's: milliseconds): `run`'s flag checked before it
/// starts, its start and end reported.
fn one_unit(
    run: &RunControl,
    solve: impl FnOnce() -> Result<Solution, SolveError>,
) -> Result<Solution, SolveError> {
    run.check()?;
    run.report(0, 1);
    let solved = solve();
    run.report(1, 1);
    solved
}

/// [`one_unit`] for a ladder of `degrees`: a cancelled ladder is cancelled at every degree.
fn one_ladder(
    run: &RunControl,
    degrees: &[usize],
    solve: impl FnOnce() -> Vec<Result<Solution, SolveError>>,
) -> Vec<Result<Solution, SolveError>> {
    if let Err(c) = run.check() {
        return degrees.iter().map(|_| Err(c.into())).collect();
    }
    run.report(0, 1);
    let solved = solve();
    run.report(1, 1);
    solved
}

impl MethodName {
    /// The method of this name: the registry, the one place a name meets its method.
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// assert_eq!(MethodName::Grid.method().title(), "grid");
    /// assert!(MethodName::Epc.method().has_degrees());
    /// ```
    pub fn method(self) -> &'static dyn StationaryMethod {
        match self {
            MethodName::Epc => &epc::Closure,
            MethodName::EpcImpact => &epc_impact::ExactImpact,
            MethodName::Grid => &grid::FiniteVolumes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each method's figures of a solution have one value per name it gives the sweep.
    #[test]
    fn figures_match_their_names() {
        let text = "model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\n\
                    diffusion v: xi\nimpact z = -3: v -> -0.8*v\ndomain z >= -3\n";
        let bound = crate::model::parse_model(text, None)
            .unwrap()
            .bind(&[])
            .unwrap();
        let problem = Problem::new(&bound).unwrap();
        let mut solved = 0;
        for name in MethodName::ALL {
            let method = name.method();
            if method.applies(&problem).unwrap().is_err() {
                continue;
            }
            let solution = method
                .solve(&problem, method.settle(2, [32, 48]), &RunControl::new())
                .unwrap();
            assert_eq!(
                solution.figures().values().len(),
                method.figure_names().len(),
                "{name}"
            );
            solved += 1;
        }
        assert_eq!(
            solved,
            MethodName::ALL.len(),
            "every method applies to this model"
        );
    }

    #[test]
    fn every_name_has_its_own_method() {
        for name in MethodName::ALL {
            let method = name.method();
            assert_eq!(method.name(), name);
            assert_eq!(method.settle(4, [40, 80]).name(), name);
            assert_eq!(
                method.has_degrees(),
                method.settle(4, [40, 80]).degree() == Some(4)
            );
        }
    }
}
