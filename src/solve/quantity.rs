//! The quantities a solution knows by name: the states, then the observables.

use crate::model::{BoundModel, Model, Observable};
use crate::observe::ObservableMap;
use crate::symbolic::{Expr, Symbol};

/// A quantity whose PDF and moments a solution reports: a state or an observable.
#[derive(Clone, Debug, PartialEq)]
pub struct Quantity {
    /// Its name (`z`, `y`, …).
    pub name: String,
    /// How it is computed from the states.
    pub map: ObservableMap,
    /// Whether it is a state (as opposed to a declared observable).
    pub is_state: bool,
}

/// The states (as themselves), then the observables, in declaration order: the one list every
/// report (study, job, sweep) is ordered by.
///
/// ```
/// use fpsolve::model::parse_model;
/// use fpsolve::solve::quantities;
/// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n", None)?;
/// let names: Vec<String> = quantities(&model.bind(&[])?).into_iter().map(|q| q.name).collect();
/// assert_eq!(names, ["z", "v", "y"]);
/// # Ok::<(), fpsolve::Error>(())
/// ```
pub fn quantities(model: &BoundModel) -> Vec<Quantity> {
    listed(model.states(), model.observables())
}

/// [`quantities`] of a model whose parameters are not bound yet (the maps do not depend on
/// them: observables are expressions of the states alone).
pub(crate) fn quantities_of(model: &Model) -> Vec<Quantity> {
    listed(model.states(), model.observables())
}

fn listed(states: &[Symbol; 2], observables: &[Observable]) -> Vec<Quantity> {
    let mut out: Vec<Quantity> = states
        .iter()
        .map(|s| Quantity {
            name: s.to_string(),
            map: ObservableMap::classify(&Expr::Sym(s.clone()), states),
            is_state: true,
        })
        .collect();
    out.extend(observables.iter().map(|o| Quantity {
        name: o.name.to_string(),
        map: ObservableMap::classify(&o.expr, states),
        is_state: false,
    }));
    out
}

/// The quantities of a model solved through its Zhuravlev transform `transformed`, by the
/// original model's names: its states (the transform's first two observables, `y`, `ydot`),
/// then its `observables` own observables, each a map of the transformed states.
pub(crate) fn through(transformed: &BoundModel, observables: usize) -> Vec<Quantity> {
    let states = transformed.states();
    let listed = transformed.observables();
    debug_assert_eq!(listed.len(), 2 + observables);
    listed
        .iter()
        .enumerate()
        .map(|(k, o)| Quantity {
            name: o.name.to_string(),
            map: ObservableMap::classify(&o.expr, states),
            is_state: k < 2,
        })
        .collect()
}

/// What reports and figures show: the observables, or the states when the model declares none.
pub(crate) fn reported(quantities: &[Quantity]) -> Vec<&Quantity> {
    let observables: Vec<&Quantity> = quantities.iter().filter(|q| !q.is_state).collect();
    if observables.is_empty() {
        quantities.iter().collect()
    } else {
        observables
    }
}
