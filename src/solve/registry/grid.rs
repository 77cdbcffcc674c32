//! The finite-volume grid solver ([`crate::grid`]) as a [`StationaryMethod`]: the reference
//! the other methods are compared with when there is no Monte Carlo run.

use super::StationaryMethod;
use crate::base::run::RunControl;
use crate::grid::GridError;
use crate::observe::ObservableMap;
use crate::solve::{Density, Method, MethodName, NotApplicable, Problem, Solution, SolveError};
use crate::symbolic::{Expr, Func};

/// The grid solver: one solve on the cells asked for, with its discretisation-error
/// estimate.
pub(super) struct FiniteVolumes;

impl StationaryMethod for FiniteVolumes {
    fn name(&self) -> MethodName {
        MethodName::Grid
    }

    fn title(&self) -> &'static str {
        "grid"
    }

    fn has_degrees(&self) -> bool {
        false
    }

    fn settle(&self, _degree: usize, cells: [usize; 2]) -> Method {
        Method::Grid { cells }
    }

    fn applies(&self, problem: &Problem) -> Result<Result<(), NotApplicable>, SolveError> {
        match problem.grid_solver().check() {
            Ok(()) => Ok(Ok(())),
            Err(GridError::Unsupported { model, reason }) => Ok(Err(NotApplicable::Grid {
                model,
                unsupported: reason,
            })),
            Err(e) => Err(e.into()),
        }
    }

    /// Its PDFs of observables with a jump (`sgn` of the states), unless named: the level-set
    /// quadrature of its piecewise density is checked on smooth and kinked maps only.
    fn leaves_out(&self, problem: &Problem, named: bool) -> Result<(), NotApplicable> {
        let jumping: Vec<String> = problem
            .quantities()
            .iter()
            .filter(|q| !q.is_state)
            .filter_map(|q| match &q.map {
                ObservableMap::General { expr, .. } if has_jump(expr) => Some(q.name.clone()),
                _ => None,
            })
            .collect();
        if named || jumping.is_empty() {
            Ok(())
        } else {
            Err(NotApplicable::JumpingObservables {
                observables: jumping,
            })
        }
    }

    fn solve(
        &self,
        problem: &Problem,
        method: Method,
        run: &RunControl,
    ) -> Result<Solution, SolveError> {
        match method {
            Method::Grid { cells } => problem.solve_grid(cells, run),
            other => Err(SolveError::OtherSettings {
                method: self.name(),
                settings: other,
            }),
        }
    }

    /// The larger of its position and velocity marginals' estimated L1 errors (0 when the
    /// estimate was not made).
    fn error_estimate(&self, solution: &Solution) -> Option<f64> {
        match solution.density() {
            Density::Grid(g) => Some(
                g.report
                    .discretisation_estimate
                    .map_or(0.0, |e| e.x.max(e.v)),
            ),
            _ => None,
        }
    }

    /// From the half-resolution solve the error estimate made
    /// ([`crate::grid::GridSolution::estimate_of_each`]).
    fn estimate_derived(
        &self,
        solution: &Solution,
        values: &[f64],
        derive: &dyn Fn(&dyn crate::density::JointDensity) -> Vec<f64>,
    ) -> Option<Vec<f64>> {
        match solution.density() {
            Density::Grid(g) => g.estimate_of_each(values, |s| derive(s)),
            _ => None,
        }
    }

    /// Clipped negative mass and the estimated L1 errors of the position and velocity
    /// marginals.
    fn figure_names(&self) -> &'static [&'static str] {
        &["negative_mass", "estimate_x", "estimate_v"]
    }

    fn zero_reason(&self) -> &'static str {
        "outside its domain"
    }
}

/// Whether `expr` has `sgn` of anything: a jump across a curve of the plane.
fn has_jump(expr: &Expr) -> bool {
    let mut found = false;
    expr.walk(&mut |e| found |= matches!(e, Expr::Call(Func::Sgn, _)));
    found
}
