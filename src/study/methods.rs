//! Which methods a study runs: whether each applies to the model (a typed reason when it does
//! not), and the solver behind each ladder method (a method solved at a ladder of degrees).

use serde::Serialize;

use crate::dynamics::ImpactForm;
use crate::epc::EpcError;
use crate::grid::{GridError, GridSolver, Unsupported};
use crate::observe::ObservableMap;
use crate::solve::{MethodName, MethodSet, Problem, Solution, SolveError};
use crate::symbolic::Expr;

/// Why a method does not apply to a model: found before any work. As JSON, a `reason` tag
/// beside the variant's fields.
///
/// ```
/// use fpsolve::solve::{MethodName, Problem};
/// use fpsolve::study::{applies, NotApplicable};
/// let bound = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: -x + y\n\
///     drift y: -y\nnoise xi: intensity 1\ndiffusion y: xi\n", None)?.bind(&[])?;
/// let problem = Problem::new(&bound)?;
/// assert!(applies(&problem, MethodName::Epc)?.is_ok());
/// assert!(matches!(applies(&problem, MethodName::Grid)?, Err(NotApplicable::Grid { .. })));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum NotApplicable {
    /// EPC (δ-term form) cannot represent the model's impact law.
    #[error("{message}")]
    ImpactLaw {
        /// The law, printed.
        law: String,
        /// Why, in words (what EPC represents, what handles this law).
        message: String,
    },
    /// The grid solver does not handle the model.
    #[error("the grid solver cannot solve model `{model}`: {unsupported}")]
    Grid {
        /// The model's name.
        model: String,
        /// What it does not handle.
        unsupported: Unsupported,
    },
    /// Not computed unless the grid is named: its PDFs of these observables (neither a state
    /// nor ± a state on each quadrant) go through level-set quadrature of its
    /// piecewise-bilinear density, which takes minutes where everything else takes a second.
    /// The grid still runs: its states' PDFs and every moment are reported.
    #[error(
        "its PDFs of {} are not computed by default: they take minutes (level-set quadrature \
         of a piecewise-bilinear density); its states' PDFs and the moments are reported; name \
         the grid with --method to compute them",
        observables.iter().map(|o| format!("`{o}`")).collect::<Vec<_>>().join(", ")
    )]
    SlowObservables {
        /// The observables.
        observables: Vec<String>,
    },
    /// Not computed even when the grid is named: its PDFs of these observables, which have
    /// `min`, `max`, `abs` or `sgn` of the states (kinks or jumps the level-set quadrature of
    /// a piecewise-bilinear density resolves only by splitting panels without end: `max(z, 0)`
    /// ran past 150 s). The grid still runs: its states' PDFs and every moment are reported.
    #[error(
        "its PDFs of {} are not computed: they have min, max, abs or sgn of the states, which          the level-set quadrature of its piecewise-bilinear density does not resolve in          reasonable time; its states' PDFs and the moments are reported; epc and Monte Carlo          give these PDFs",
        observables.iter().map(|o| format!("`{o}`")).collect::<Vec<_>>().join(", ")
    )]
    NonSmoothObservables {
        /// The observables.
        observables: Vec<String>,
    },
    /// EPC with the exact impact condition does not handle the model.
    #[error("EPC with the exact impact condition cannot solve model `{model}`: {unsupported}")]
    EpcImpact {
        /// The model's name.
        model: String,
        /// What it does not handle.
        unsupported: crate::epc_impact::Unsupported,
    },
}

/// A method of the set asked for that was not run because it does not apply to the model,
/// and why (only methods the user did not name are skipped; a named one is refused).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Skipped {
    /// The method.
    pub method: MethodName,
    /// Why it does not apply.
    #[serde(flatten)]
    pub why: NotApplicable,
}

/// The methods named by the user that do not apply to the model: every one of them, each
/// with its reason, so that one message says all that stands in the way.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}", refusal(.methods))]
pub struct Refused {
    /// The methods, in the order named, with why each does not apply (at least one).
    pub methods: Vec<Skipped>,
}

fn refusal(methods: &[Skipped]) -> String {
    match methods {
        [one] => format!("--method {}: {}", one.method, one.why),
        _ => {
            let names: Vec<&str> = methods.iter().map(|s| s.method.as_str()).collect();
            format!(
                "--method: {} of the methods named do not apply ({}): {}",
                methods.len(),
                names.join(", "),
                reasons(methods)
            )
        }
    }
}

/// The methods a study runs, and those of the set asked for that it skips.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodPlan {
    /// The methods to run, in the order [`MethodName::ALL`] lists them.
    pub run: Vec<MethodName>,
    /// Methods left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// Methods that run but leave out some of their PDFs by default, with the reason (the
    /// grid's PDFs of observables that take minutes): the study computes the rest.
    pub skipped_curves: Vec<Skipped>,
}

/// Why no plan: a named method does not apply, nothing applies, or the model cannot be
/// prepared at all.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A method the user named does not apply.
    #[error(transparent)]
    Refused(#[from] Refused),
    /// None of the methods of the set applies.
    #[error("no method of `{asked}` applies to the model: {}", reasons(skipped))]
    NothingApplies {
        /// The set asked for.
        asked: MethodSet,
        /// Why each does not apply.
        skipped: Vec<Skipped>,
    },
    /// The model cannot be prepared for a method (a coefficient that does not compile, …).
    #[error(transparent)]
    Solve(#[from] SolveError),
}

fn reasons(skipped: &[Skipped]) -> String {
    let r: Vec<String> = skipped
        .iter()
        .map(|s| format!("{}: {}", s.method, s.why))
        .collect();
    r.join("; ")
}

impl MethodPlan {
    /// The plan for `asked`: with `required` (the user named the methods) every method must
    /// apply (the refusal names all that do not); otherwise those that do not are skipped
    /// with their reason, and at least one must apply. Unless named, the grid runs without
    /// its PDFs of observables that take minutes ([`MethodPlan::skipped_curves`]).
    ///
    /// # Errors
    /// [`PlanError::Refused`], [`PlanError::NothingApplies`], or [`PlanError::Solve`] when a
    /// method cannot even check the model.
    ///
    /// ```
    /// use fpsolve::solve::{MethodName, Problem};
    /// use fpsolve::study::{MethodPlan, PlanError};
    /// let bound = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: -x + y\n\
    ///     drift y: -y\nnoise xi: intensity 1\ndiffusion y: xi\n", None)?.bind(&[])?;
    /// let problem = Problem::new(&bound)?;
    /// let plan = MethodPlan::new(&problem, &"epc,grid".parse()?, false)?;
    /// assert_eq!(plan.run, [MethodName::Epc]);
    /// assert_eq!(plan.skipped[0].method, MethodName::Grid);
    /// let named = MethodPlan::new(&problem, &"epc,grid".parse()?, true);
    /// assert!(matches!(named, Err(PlanError::Refused(_))));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new(
        problem: &Problem,
        asked: &MethodSet,
        required: bool,
    ) -> Result<MethodPlan, PlanError> {
        let mut plan = MethodPlan {
            run: Vec::new(),
            skipped: Vec::new(),
            skipped_curves: Vec::new(),
        };
        for &method in asked.names() {
            match applies(problem, method)? {
                Ok(()) => {
                    plan.run.push(method);
                    if let Err(why) = default_cost(problem, method, required) {
                        plan.skipped_curves.push(Skipped { method, why });
                    }
                }
                Err(why) => plan.skipped.push(Skipped { method, why }),
            }
        }
        if required && !plan.skipped.is_empty() {
            return Err(Refused {
                methods: plan.skipped,
            }
            .into());
        }
        if plan.run.is_empty() {
            return Err(PlanError::NothingApplies {
                asked: asked.clone(),
                skipped: plan.skipped,
            });
        }
        Ok(plan)
    }
}

/// What a method that applies leaves out: the grid's PDFs of observables that need level-set
/// quadrature unless it is named, and of non-smooth ones always.
fn default_cost(
    problem: &Problem,
    method: MethodName,
    required: bool,
) -> Result<(), NotApplicable> {
    if method != MethodName::Grid {
        return Ok(());
    }
    let general: Vec<(&str, &Expr)> = problem
        .quantities()
        .iter()
        .filter(|q| !q.is_state)
        .filter_map(|q| match &q.map {
            ObservableMap::General { expr, .. } => Some((q.name.as_str(), expr)),
            _ => None,
        })
        .collect();
    let rough: Vec<String> = general
        .iter()
        .filter(|(_, expr)| expr.has_kink())
        .map(|(name, _)| name.to_string())
        .collect();
    if !rough.is_empty() {
        return Err(NotApplicable::NonSmoothObservables { observables: rough });
    }
    if required || general.is_empty() {
        Ok(())
    } else {
        Err(NotApplicable::SlowObservables {
            observables: general.iter().map(|(n, _)| n.to_string()).collect(),
        })
    }
}

/// Whether `method` applies to the problem's model (the outer `Result` is a model that cannot
/// even be checked).
///
/// # Errors
/// [`SolveError::Grid`] when the grid solver cannot read the model for another reason than
/// not handling it (a coefficient that does not compile).
pub fn applies(
    problem: &Problem,
    method: MethodName,
) -> Result<Result<(), NotApplicable>, SolveError> {
    if let Some(Err(why)) = ladder(method) {
        return Ok(Err(why));
    }
    match method {
        MethodName::Epc => Ok(match &problem.fpk().impact {
            Some(ImpactForm::Unsupported { law, reason }) => Err(NotApplicable::ImpactLaw {
                law: law.clone(),
                message: EpcError::UnsupportedImpact {
                    law: law.clone(),
                    reason: reason.clone(),
                }
                .to_string(),
            }),
            _ => Ok(()),
        }),
        MethodName::EpcImpact => Ok(
            match crate::epc_impact::EpcImpact::new(problem.model()).check() {
                Ok(()) => Ok(()),
                Err(crate::epc_impact::EpcImpactError::Unsupported { model, reason }) => {
                    Err(NotApplicable::EpcImpact {
                        model,
                        unsupported: reason,
                    })
                }
                Err(e) => return Err(e.into()),
            },
        ),
        MethodName::Grid => match GridSolver::new(problem.model()).check() {
            Ok(()) => Ok(Ok(())),
            Err(GridError::Unsupported { model, reason }) => Ok(Err(NotApplicable::Grid {
                model,
                unsupported: reason,
            })),
            Err(e) => Err(e.into()),
        },
    }
}

/// How a ladder method solves its degrees: one result per degree asked, in order.
pub(crate) type LadderSolver = fn(&Problem, &[usize]) -> Vec<Result<Solution, SolveError>>;

/// The solver of a ladder method, or why there is none (`None`: the method is not solved at
/// degrees): the one place where a ladder method's name meets its solver.
pub(crate) fn ladder(method: MethodName) -> Option<Result<LadderSolver, NotApplicable>> {
    match method {
        MethodName::Epc => Some(Ok(|problem, degrees| {
            problem
                .solve_epc_degrees(degrees)
                .into_iter()
                .map(|r| r.map_err(SolveError::Epc))
                .collect()
        })),
        MethodName::EpcImpact => Some(Ok(|problem, degrees| {
            problem.solve_epc_impact_degrees(degrees)
        })),
        MethodName::Grid => None,
    }
}
