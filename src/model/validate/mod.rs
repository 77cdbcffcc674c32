//! [`ModelAst`] → validated [`Model`]: names resolved, expressions lowered to [`Expr`], the
//! noise matrix extracted, and every mistake reported as a typed [`SemanticError`] at the
//! span where it was made.
//!
//! One job per file: the error catalogue (`error`), name resolution and lowering (`scope`),
//! noise linearity (`noise`), where deltas may stand (`delta`), checks of single statements
//! (`statements`); parameter cycles are found by [`super::dependency`], shared with binding.

mod delta;
mod error;
mod noise;
mod scope;
mod statements;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use super::ast::{Binding, ExprNode, Ident, ModelAst, Span, StatementKind};
use super::{
    Correlation, DeltaTreatment, Domain, DomainBound, ImpactLaw, Interpretation, Model,
    NoiseSource, Observable, Origin,
};
use crate::symbolic::{Expr, Symbol};
pub(crate) use error::Located;
use error::{fail, Result};
pub use error::{DeltaMisuse, SemanticError, MAX_PARAMETER_CHAIN};
pub(crate) use scope::lower_free;
use scope::{line_of, Context, Scope};

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

    fn run(mut self) -> Result<Model> {
        let (name, description) = self.model_line()?;
        self.once_only()?;
        self.declare_all()?;
        let states = self.state_pair()?;
        let params = self.lower_params()?;

        let mut drift: [Option<(Expr, Span)>; 2] = [None, None];
        let mut diffusion: [Option<(BTreeMap<usize, Expr>, Span)>; 2] = [None, None];
        let mut correlations: Vec<(Correlation, Span)> = Vec::new();
        let mut noises = Vec::new();
        let mut interpretation = Interpretation::default();
        let mut impacts: Vec<(ImpactLaw, Span)> = Vec::new();
        let mut domain: Option<(Domain, Span, Ident)> = None;
        let mut domain_bounds = [None, None];
        let mut observables = Vec::new();
        let mut delta = DeltaTreatment::default();
        let mut intensity_spans = Vec::new();
        let mut correlation_spans = Vec::new();
        let mut barrier_spans = Vec::new();
        let mut map_spans = Vec::new();
        let mut drift_spans = [None, None];
        let mut diffusion_spans = [None, None];

        for st in &self.ast.statements {
            match &st.kind {
                StatementKind::Model { .. } | StatementKind::Param(_) | StatementKind::State(_) => {
                }
                StatementKind::Drift { state, expr } => {
                    let i = self.state_index(state, None)?;
                    if let Some((_, first)) = &drift[i] {
                        return self.duplicate(&state.name, "drift", "drift", *first, state.span);
                    }
                    let e = self.scope.lower(expr, Context::StateFunction("a drift"))?;
                    self.check_drift_deltas(expr, i)?;
                    drift_spans[i] = Some(expr.span);
                    drift[i] = Some((e, state.span));
                }
                StatementKind::Noise { name, intensity } => {
                    let e = self
                        .scope
                        .lower(intensity, Context::Constant("a noise intensity"))?;
                    self.forbid_delta(
                        intensity,
                        DeltaMisuse::InConstant {
                            context: "a noise intensity",
                        },
                    )?;
                    intensity_spans.push(intensity.span);
                    noises.push(NoiseSource {
                        name: Symbol::from(name.name.as_str()),
                        intensity: e,
                    });
                }
                StatementKind::Correlate { a, b, coefficient } => {
                    let c = self.correlation(a, b, coefficient, st.span, &correlations)?;
                    self.forbid_delta(
                        coefficient,
                        DeltaMisuse::InConstant {
                            context: "a correlation coefficient",
                        },
                    )?;
                    correlation_spans.push(coefficient.span);
                    correlations.push((c, st.span));
                }
                StatementKind::Diffusion { state, expr } => {
                    let i = self.state_index(state, Some("diffusion"))?;
                    if let Some((_, first)) = &diffusion[i] {
                        return self.duplicate(
                            &state.name,
                            "diffusion",
                            "diffusion",
                            *first,
                            state.span,
                        );
                    }
                    let map =
                        self.scope
                            .noise_coefficients(expr, &state.name)
                            .map_err(|mut l| {
                                if let SemanticError::NoiseFreeTerm { state: s } = &mut l.error {
                                    s.clone_from(&state.name);
                                }
                                l
                            })?;
                    self.forbid_delta(expr, DeltaMisuse::InDiffusion)?;
                    diffusion_spans[i] = Some(expr.span);
                    diffusion[i] = Some((map, state.span));
                }
                StatementKind::Interpretation(i) => interpretation = *i,
                StatementKind::Impact {
                    state,
                    at,
                    other,
                    map,
                } => {
                    if let [(_, first), (_, second)] = impacts.as_slice() {
                        return fail(
                            SemanticError::TooManyImpacts {
                                previous_lines: (self.line(*first), self.line(*second)),
                            },
                            st.keyword,
                        );
                    }
                    let s = self.state_index(state, Some("impact"))?;
                    let o = self.state_index(other, Some("impact"))?;
                    if s == o {
                        return fail(
                            SemanticError::ImpactOnItself {
                                state: state.name.clone(),
                            },
                            other.span,
                        );
                    }
                    let law = ImpactLaw {
                        state: s,
                        at: self
                            .scope
                            .lower(at, Context::Constant("a barrier position"))?,
                        other: o,
                        map: self
                            .scope
                            .lower(map, Context::StateFunction("an impact map"))?,
                    };
                    self.forbid_delta(
                        at,
                        DeltaMisuse::InConstant {
                            context: "a barrier position",
                        },
                    )?;
                    self.forbid_delta(map, DeltaMisuse::InImpactMap)?;
                    if let Some((first, _)) = impacts.first() {
                        if first.state != s {
                            return fail(
                                SemanticError::ImpactsOnDifferentStates {
                                    first: states[first.state].to_string(),
                                    second: state.name.clone(),
                                },
                                state.span,
                            );
                        }
                    }
                    barrier_spans.push(at.span);
                    map_spans.push(map.span);
                    impacts.push((law, st.span));
                }
                StatementKind::Domain {
                    state,
                    lower,
                    upper,
                } => {
                    let s = self.state_index(state, Some("domain"))?;
                    let mut bound = |limit: &Option<super::ast::DomainLimit>,
                                     k: usize|
                     -> Result<Option<DomainBound>> {
                        let Some(limit) = limit else {
                            return Ok(None);
                        };
                        let at = self
                            .scope
                            .lower(&limit.at, Context::Constant("a domain bound"))?;
                        self.forbid_delta(
                            &limit.at,
                            DeltaMisuse::InConstant {
                                context: "a domain bound",
                            },
                        )?;
                        domain_bounds[k] = Some(limit.at.span);
                        Ok(Some(DomainBound {
                            at,
                            strict: limit.strict,
                        }))
                    };
                    let d = Domain {
                        state: s,
                        lower: bound(lower, 0)?,
                        upper: bound(upper, 1)?,
                    };
                    domain = Some((d, st.span, state.clone()));
                }
                StatementKind::Observe(bindings) => {
                    for b in bindings {
                        observables.push(Observable {
                            name: Symbol::from(b.name.name.as_str()),
                            expr: self
                                .scope
                                .lower(&b.value, Context::StateFunction("an observable"))?,
                        });
                        self.observable_has_density(b, &observables[observables.len() - 1])?;
                    }
                }
                StatementKind::Delta(spec) => delta = self.delta(spec)?,
            }
        }

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
        let noise_matrix = self.noise_matrix(diffusion)?;
        if let Some((d, span, name)) = &domain {
            match impacts.first() {
                None => {
                    return fail(
                        SemanticError::DomainWithoutImpact {
                            state: name.name.clone(),
                        },
                        *span,
                    )
                }
                Some((law, _)) if law.state != d.state => {
                    return fail(
                        SemanticError::DomainOnOtherState {
                            domain_state: name.name.clone(),
                            impact_state: states[law.state].to_string(),
                        },
                        name.span,
                    )
                }
                Some(_) => {}
            }
        }
        let domain_span = domain.as_ref().map(|(_, span, _)| *span);
        self.check_parameter_graph(&params)?;

        let [d0, d1]: [Expr; 2] = drift_exprs
            .try_into()
            .expect("one drift per state was checked above");
        Ok(Model {
            name,
            description,
            params,
            states,
            drift: [d0, d1],
            noises,
            correlations: correlations.into_iter().map(|(c, _)| c).collect(),
            noise_matrix,
            interpretation,
            impacts: impacts.into_iter().map(|(law, _)| law).collect(),
            domain: domain.map(|(d, ..)| d),
            observables,
            delta,
            origin: Some(std::sync::Arc::new(Origin {
                source: self.source.to_string(),
                path: self.path.map(str::to_string),
                params: self.params.iter().map(|b| b.value.span).collect(),
                intensities: intensity_spans,
                correlations: correlation_spans,
                barriers: barrier_spans,
                maps: map_spans,
                domain: domain_span,
                domain_bounds,
                drifts: drift_spans,
                diffusions: diffusion_spans,
            })),
        })
    }
}
