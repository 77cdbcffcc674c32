//! EPC with the exact impact condition ([`crate::epc_impact`]) as a [`StationaryMethod`].

use super::StationaryMethod;
use crate::base::run::RunControl;
use crate::epc_impact::{EpcImpact, EpcImpactError};
use crate::solve::{Method, MethodName, NotApplicable, Problem, Solution, SolveError};

/// EPC with the exact impact condition: a ladder of even degrees on the domain of the
/// model's own coordinates.
pub(super) struct ExactImpact;

impl StationaryMethod for ExactImpact {
    fn name(&self) -> MethodName {
        MethodName::EpcImpact
    }

    fn title(&self) -> &'static str {
        "EPC-impact"
    }

    fn has_degrees(&self) -> bool {
        true
    }

    fn settle(&self, degree: usize, _cells: [usize; 2]) -> Method {
        Method::EpcImpact { degree }
    }

    fn applies(&self, problem: &Problem) -> Result<Result<(), NotApplicable>, SolveError> {
        let method = "EPC with the exact impact condition";
        if let Some(refused) = NotApplicable::exponential_of_angle(method, problem.model()) {
            return Ok(Err(refused));
        }
        match EpcImpact::reading(problem.dynamics()).check() {
            Ok(()) => Ok(Ok(())),
            Err(EpcImpactError::Unsupported { model, reason }) => {
                Ok(Err(NotApplicable::EpcImpact {
                    model,
                    unsupported: reason,
                }))
            }
            Err(e) => Err(e.into()),
        }
    }

    fn solve(
        &self,
        problem: &Problem,
        method: Method,
        run: &RunControl,
    ) -> Result<Solution, SolveError> {
        match method {
            Method::EpcImpact { degree } => {
                super::one_unit(run, || problem.solve_epc_impact(degree))
            }
            other => Err(SolveError::OtherSettings {
                method: self.name(),
                settings: other,
            }),
        }
    }

    fn solve_degrees(
        &self,
        problem: &Problem,
        degrees: &[usize],
        run: &RunControl,
    ) -> Option<Vec<Result<Solution, SolveError>>> {
        Some(super::one_ladder(run, degrees, || {
            problem.solve_epc_impact_degrees(degrees)
        }))
    }

    /// As EPC's (its FPK residual includes the impact condition's), and the quadrature's
    /// change of ‖R‖ on a rule twice as fine.
    fn figure_names(&self) -> &'static [&'static str] {
        &[
            "iterations",
            "residual",
            "residual_threshold",
            "fpk_residual",
            "quadrature_change",
            "normalisation",
        ]
    }

    fn zero_reason(&self) -> &'static str {
        "beyond its ridge"
    }
}
