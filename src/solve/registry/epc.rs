//! EPC (the exponential-polynomial closure of the FPK equation as the model gives it) as a
//! [`StationaryMethod`].

use super::StationaryMethod;
use crate::base::run::RunControl;
use crate::dynamics::ImpactForm;
use crate::epc::EpcError;
use crate::solve::{Method, MethodName, NotApplicable, Problem, Solution, SolveError};

/// EPC: a ladder of even degrees, the Zhuravlev transform for a reflecting barrier in the
/// model's own coordinates.
pub(super) struct Closure;

impl StationaryMethod for Closure {
    fn name(&self) -> MethodName {
        MethodName::Epc
    }

    /// The Zhuravlev form of a model with a wall ([`Problem::zhuravlev`]), EPC's own model
    /// otherwise.
    fn density_model<'p>(&self, problem: &'p Problem) -> &'p crate::model::BoundModel {
        match problem.zhuravlev() {
            Some(t) => &t.model,
            None => problem.model(),
        }
    }

    fn title(&self) -> &'static str {
        "EPC"
    }

    fn has_degrees(&self) -> bool {
        true
    }

    fn settle(&self, degree: usize, _cells: [usize; 2]) -> Method {
        Method::Epc { degree }
    }

    fn applies(&self, problem: &Problem) -> Result<Result<(), NotApplicable>, SolveError> {
        if let Some(refused) = NotApplicable::exponential_of_angle("EPC", problem.model()) {
            return Ok(Err(refused));
        }
        Ok(match &problem.fpk().impact {
            Some(ImpactForm::Unsupported { law, reason }) => Err(NotApplicable::ImpactLaw {
                law: law.clone(),
                message: EpcError::UnsupportedImpact {
                    law: law.clone(),
                    reason: reason.clone(),
                }
                .to_string(),
            }),
            _ => Ok(()),
        })
    }

    fn solve(
        &self,
        problem: &Problem,
        method: Method,
        run: &RunControl,
    ) -> Result<Solution, SolveError> {
        match method {
            Method::Epc { degree } => super::one_unit(run, || problem.solve_epc(degree)),
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
            problem
                .solve_epc_degrees(degrees)
                .into_iter()
                .map(|r| r.map_err(SolveError::Epc))
                .collect()
        }))
    }

    fn figure_names(&self) -> &'static [&'static str] {
        &[
            "iterations",
            "residual",
            "residual_threshold",
            "fpk_residual",
            "normalisation",
        ]
    }

    fn zero_reason(&self) -> &'static str {
        "beyond its ridge"
    }
}
