//! Why a method does not apply to a model, found before any work: the typed refusal every
//! method's [`applies`](super::StationaryMethod::applies) gives.

use serde::Serialize;

use crate::grid::Unsupported;

/// Why a method does not apply to a model: found before any work. As JSON, a `reason` tag
/// beside the variant's fields.
///
/// ```
/// use fpsolve::solve::{MethodName, NotApplicable, Problem};
/// let bound = fpsolve::model::parse_model("model m\nstate x, y\ndrift x: y\n\
///     drift y: -y - x - 0.1*y*abs(y)*delta(x)\nnoise xi: intensity 1\ndiffusion y: xi\n", None)?.bind(&[])?;
/// let problem = Problem::new(&bound)?;
/// assert!(MethodName::Epc.method().applies(&problem)?.is_ok());
/// assert!(matches!(MethodName::Grid.method().applies(&problem)?, Err(NotApplicable::Grid { .. })));
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
    /// The model has a periodic state (`domain theta periodic 2*pi`), which the method does
    /// not represent.
    #[error("{method} does not apply to model `{model}`: `{state}` is periodic, and {why}")]
    PeriodicState {
        /// The method, in words.
        method: String,
        /// The model's name.
        model: String,
        /// The periodic state.
        state: String,
        /// Why the method cannot represent it, and what can.
        why: String,
    },
    /// The grid solver does not handle the model.
    #[error("the grid solver cannot solve model `{model}`: {unsupported}")]
    Grid {
        /// The model's name.
        model: String,
        /// What it does not handle.
        unsupported: Unsupported,
    },
    /// Not computed unless the grid is named: its PDFs of these observables, which have `sgn`
    /// of the states (a jump across a curve of the plane). Maps with kinks (`abs`, `min`,
    /// `max`) and smooth maps are computed, by level-set quadrature cut at the pieces of its
    /// piecewise-bilinear density and at the kinks, and checked against exact answers; a
    /// jump has no such check yet. The grid still runs: its states' PDFs and every moment are
    /// reported.
    #[error(
        "its PDFs of {} are not computed by default: they have sgn of the states (a jump), on \
         which its level-set quadrature is not checked; its states' PDFs and the moments are \
         reported; name the grid with --method to compute them",
        observables.iter().map(|o| format!("`{o}`")).collect::<Vec<_>>().join(", ")
    )]
    JumpingObservables {
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

impl NotApplicable {
    /// [`NotApplicable::PeriodicState`] for `method`, an exponential polynomial of the
    /// states (EPC, EPC-impact), when `model` has a periodic state; `None` without one.
    pub(crate) fn exponential_of_angle(
        method: &str,
        model: &crate::model::BoundModel,
    ) -> Option<NotApplicable> {
        model.periodic().map(|p| NotApplicable::PeriodicState {
            method: method.to_string(),
            model: model.name().to_string(),
            state: model.states()[p.state].to_string(),
            why: "an exponential polynomial in it is not periodic: the grid solves this model \
                  (`--method grid`)"
                .to_string(),
        })
    }
}
