//! [`ModelAst`] → validated [`Model`]: names resolved, expressions lowered to [`Expr`], the
//! noise matrix extracted, and every mistake reported as a typed [`SemanticError`] at the
//! span where it was made. It is the model stage's step between parsing (the syntax tree)
//! and binding (parameter values), so a model that reaches the methods says what it means.
//!
//! One job per file: the error catalogue (`error`), name resolution and lowering (`scope`),
//! noise linearity (`noise`), where deltas may stand (`delta`), checks of single statements
//! (`statements`), the statements of the dynamics gathered in file order (`gather`); parameter cycles are found by [`super::dependency`], shared with binding.

mod delta;
mod error;
mod gather;
mod initial;
mod noise;
mod safe;
mod scope;
mod statements;
#[cfg(test)]
mod tests;

use super::ast::{Binding, ExprNode, Ident, ModelAst, SafeSpec, Span, StatementKind};
use super::{Domain, ImpactLaw, Model, Origin};
use crate::symbolic::{Expr, Symbol};
pub(crate) use error::Located;
use error::{fail, Result};
pub use error::{DeltaMisuse, SemanticError, MAX_PARAMETER_CHAIN};
pub(crate) use scope::lower_free;
use scope::{line_of, Scope};

/// Lowers a `--safe` value (`spec`, parsed from `text`) against the names of the model
/// file `ast` (read from `source`); errors point into `text`.
pub(crate) fn validate_safe(
    ast: &ModelAst,
    source: &str,
    spec: &SafeSpec,
    text: &str,
    observables: &[super::Observable],
) -> Result<super::SafeSet> {
    let mut v = Validator::new(ast, source);
    v.declare_all()?;
    v.safe_set(spec, text, observables)
}

/// Lowers an `--initial` value (`spec`, parsed from `text`) against the states of the model
/// file `ast` (`source`).
pub(crate) fn validate_initial(
    ast: &ModelAst,
    source: &str,
    spec: &super::ast::InitialAst,
    text: &str,
) -> Result<super::InitialSpec> {
    let mut v = Validator::new(ast, source);
    v.declare_all()?;
    let states = v.state_pair()?;
    v.initial(spec, &states, text)
}

/// Validates a parsed model file and builds the [`Model`]; `path` is what error messages
/// about its bound values will show.
pub(crate) fn validate(ast: &ModelAst, source: &str, path: Option<&str>) -> Result<Model> {
    let mut v = Validator::new(ast, source);
    v.path = path;
    v.run()
}

struct Validator<'a> {
    ast: &'a ModelAst,
    source: &'a str,
    path: Option<&'a str>,
    scope: Scope<'a>,
    params: Vec<&'a Binding>,
    states: Vec<&'a Ident>,
    noises: Vec<(&'a Ident, &'a ExprNode)>,
    observables: Vec<&'a Binding>,
}

impl<'a> Validator<'a> {
    fn new(ast: &'a ModelAst, source: &'a str) -> Validator<'a> {
        Validator {
            ast,
            source,
            path: None,
            scope: Scope::empty(),
            params: Vec::new(),
            states: Vec::new(),
            noises: Vec::new(),
            observables: Vec::new(),
        }
    }

    fn line(&self, span: Span) -> usize {
        line_of(self.source, span.start)
    }

    /// The model line, the declarations, then every statement of the dynamics in file order,
    /// then the checks that need all of them: each state has a drift, the noise matrix, the
    /// domain against the impacts, the parameter graph.
    fn run(mut self) -> Result<Model> {
        let (name, description) = self.model_line()?;
        self.once_only()?;
        self.declare_all()?;
        let states = self.state_pair()?;
        let params = self.lower_params()?;
        let g = self.gather(&states)?;
        let drift = self.drifts(g.drift, &states)?;
        let noise_matrix = self.noise_matrix(g.diffusion)?;
        self.domain_agrees(g.domain.as_ref(), &g.impacts, &states)?;
        if let (Some((_, span, name)), Some(_)) = (&g.periodic, g.impacts.first()) {
            return fail(
                SemanticError::PeriodicWithImpact {
                    state: name.name.clone(),
                },
                *span,
            );
        }
        self.check_parameter_graph(&params)?;
        let safe = match self.ast.statements.iter().find_map(|st| match &st.kind {
            StatementKind::Safe(spec) => Some(spec),
            _ => None,
        }) {
            Some(spec) => Some(self.safe_set(spec, self.source, &g.observables)?),
            None => None,
        };

        let initial = match self.ast.statements.iter().find_map(|st| match &st.kind {
            StatementKind::Initial(spec) => Some(spec),
            _ => None,
        }) {
            Some(spec) => Some(self.initial(spec, &states, self.source)?),
            None => None,
        };

        let spans = g.spans;
        let domain_span = g
            .domain
            .as_ref()
            .map(|(_, span, _)| *span)
            .or(g.periodic.as_ref().map(|(_, span, _)| *span));
        Ok(Model {
            name,
            description,
            params,
            states,
            drift,
            noises: g.noises,
            correlations: g.correlations.into_iter().map(|(c, _)| c).collect(),
            noise_matrix,
            interpretation: g.interpretation,
            impacts: g.impacts.into_iter().map(|(law, _)| law).collect(),
            domain: g.domain.map(|(d, ..)| d),
            periodic: g.periodic.map(|(p, ..)| p),
            observables: g.observables,
            delta: g.delta,
            safe,
            initial,
            origin: Some(std::sync::Arc::new(Origin {
                source: self.source.to_string(),
                path: self.path.map(str::to_string),
                params: self.params.iter().map(|b| b.value.span).collect(),
                intensities: spans.intensities,
                correlations: spans.correlations,
                barriers: spans.barriers,
                maps: spans.maps,
                domain: domain_span,
                domain_bounds: spans.domain_bounds,
                period: spans.period,
                drifts: spans.drifts,
                diffusions: spans.diffusions,
            })),
        })
    }

    /// Each state's drift, or [`SemanticError::MissingDrift`] at the first state without one.
    fn drifts(&self, drift: [Option<(Expr, Span)>; 2], states: &[Symbol; 2]) -> Result<[Expr; 2]> {
        let mut drift_exprs = Vec::with_capacity(2);
        for (i, d) in drift.into_iter().enumerate() {
            match d {
                Some((e, _)) => drift_exprs.push(e),
                None => {
                    return fail(
                        SemanticError::MissingDrift {
                            state: states[i].to_string(),
                        },
                        self.states[i].span,
                    )
                }
            }
        }
        Ok(drift_exprs
            .try_into()
            .expect("one drift per state was checked above"))
    }

    /// A domain bounds the state the impacts act on, so it needs an impact of that state.
    fn domain_agrees(
        &self,
        domain: Option<&(Domain, Span, Ident)>,
        impacts: &[(ImpactLaw, Span)],
        states: &[Symbol; 2],
    ) -> Result<()> {
        let Some((d, span, name)) = domain else {
            return Ok(());
        };
        match impacts.first() {
            None => fail(
                SemanticError::DomainWithoutImpact {
                    state: name.name.clone(),
                },
                *span,
            ),
            Some((law, _)) if law.state != d.state => fail(
                SemanticError::DomainOnOtherState {
                    domain_state: name.name.clone(),
                    impact_state: states[law.state].to_string(),
                },
                name.span,
            ),
            Some(_) => Ok(()),
        }
    }
}
