//! Which methods a study runs: those of the set asked for that apply to the model, and a
//! typed reason for each that does not.

use serde::Serialize;

use crate::solve::{MethodName, MethodSet, NotApplicable, Problem, SolveError};

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
    /// let bound = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: y\n\
    ///     drift y: -y - x - 0.1*y*abs(y)*delta(x)\nnoise xi: intensity 1\ndiffusion y: xi\n", None)?.bind(&[])?;
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
            match method.method().applies(problem)? {
                Ok(()) => {
                    plan.run.push(method);
                    if let Err(why) = method.method().leaves_out(problem, required) {
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
