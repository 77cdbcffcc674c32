//! Checks of single statements: the `model` line, statements that may appear once, name
//! declarations, the state pair, parameters, correlations, the delta treatment and
//! observables that have a density.

use std::collections::HashMap;

use super::super::ast::{Binding, DeltaSpec, ExprNode, Ident, Span, Statement, StatementKind};
use super::super::dependency::{walk, WalkError};
use super::super::{Correlation, DeltaTreatment, Observable, Parameter, TIME};
use super::delta::find_delta;
use super::error::{fail, DeltaMisuse, Result, SemanticError, MAX_PARAMETER_CHAIN};
use super::scope::{closest, Context, Declaration, Kind, Scope};
use super::Validator;
use crate::symbolic::{Func, Symbol};

impl<'a> Validator<'a> {
    /// Refuses an observable whose density does not exist, before any computation: one that
    /// contains `delta(...)` (a distribution, not a value), one that depends on no state (a
    /// constant), and one whose gradient is zero wherever it is defined (its derivatives in
    /// both states vanish once the δ parts, the jumps of `sgn`, are dropped: `sgn(z)`,
    /// `sgn(z)*sgn(v)`), which takes only discrete values.
    ///
    /// An observable undefined on part of the plane (`log(z)`) is not refused: whether it is
    /// cannot in general be decided from the expression (`log(z^2 + 1)` is defined
    /// everywhere), so the probability where it is undefined is computed and reported with its
    /// moments (`undefined_mass`) and its PDF is left defective, never renormalised.
    pub(super) fn observable_has_density(&self, b: &Binding, o: &Observable) -> Result<()> {
        let refuse = |reason: &'static str, span: Span| {
            let text = self
                .source
                .get(b.value.span.start..b.value.span.end)
                .unwrap_or_default()
                .to_string();
            fail(
                SemanticError::ObservableWithoutDensity {
                    name: b.name.name.clone(),
                    text,
                    reason,
                },
                span,
            )
        };
        if let Some(span) = find_delta(&b.value).map(|d| d.span) {
            return refuse(
                "contains `delta(...)`, a distribution, not a value: an observable must be a \
                 function of the states",
                span,
            );
        }
        let expr = crate::symbolic::simplify(&o.expr);
        if !self.states.iter().any(|s| expr.mentions(&s.name)) {
            return refuse(
                "does not depend on the states: it is a constant and has no density",
                b.value.span,
            );
        }
        let flat = self.states.iter().all(|s| {
            crate::symbolic::diff(&expr, &s.name)
                .map(|d| crate::symbolic::simplify(&d.without_deltas()).as_num() == Some(0.0))
                .unwrap_or(false)
        });
        if flat {
            return refuse(
                "takes only discrete values: it has no density (its gradient is zero wherever \
                 it is defined); observe a quantity that varies continuously, e.g. `abs(z)` or \
                 `v*sgn(z)`",
                b.value.span,
            );
        }
        Ok(())
    }

    pub(super) fn duplicate<T>(
        &self,
        name: &str,
        kind: &'static str,
        previous_kind: &'static str,
        first: Span,
        here: Span,
    ) -> Result<T> {
        fail(
            SemanticError::DuplicateDefinition {
                name: name.to_string(),
                kind,
                previous_kind,
                previous_line: self.line(first),
            },
            here,
        )
    }

    /// The `model` line: present, first, once.
    pub(super) fn model_line(&self) -> Result<(String, String)> {
        let mut found: Option<(&Statement, &Ident, &String)> = None;
        for st in &self.ast.statements {
            if let StatementKind::Model { name, description } = &st.kind {
                if let Some((first, ..)) = found {
                    return fail(
                        SemanticError::DuplicateModelLine {
                            previous_line: self.line(first.span),
                        },
                        st.keyword,
                    );
                }
                found = Some((st, name, description));
            }
        }
        let Some((model, name, description)) = found else {
            let span = self
                .ast
                .statements
                .first()
                .map_or(Span::new(0, 0), |s| s.keyword);
            return fail(SemanticError::MissingModelLine, span);
        };
        if let Some(first) = self.ast.statements.first() {
            if !std::ptr::eq(first, model) {
                return fail(SemanticError::ModelNotFirst, model.keyword);
            }
        }
        Ok((name.name.clone(), description.clone()))
    }

    /// `state`, `interpretation`, `domain` and `delta` appear at most once.
    pub(super) fn once_only(&self) -> Result<()> {
        let mut seen: HashMap<&'static str, Span> = HashMap::new();
        for st in &self.ast.statements {
            let keyword = match st.kind {
                StatementKind::State(_) => "state",
                StatementKind::Interpretation(_) => "interpretation",
                StatementKind::Domain { .. } | StatementKind::Periodic { .. } => "domain",
                StatementKind::Delta(_) => "delta",
                StatementKind::Safe(_) => "safe",
                StatementKind::Initial(_) => "initial",
                _ => continue,
            };
            if let Some(first) = seen.get(keyword) {
                return fail(
                    SemanticError::DuplicateStatement {
                        keyword,
                        previous_line: self.line(*first),
                    },
                    st.keyword,
                );
            }
            seen.insert(keyword, st.keyword);
        }
        Ok(())
    }

    /// Enters every declared name in the scope, in file order.
    pub(super) fn declare_all(&mut self) -> Result<()> {
        let ast = self.ast;
        for st in &ast.statements {
            match &st.kind {
                StatementKind::Param(bindings) => {
                    for b in bindings {
                        self.declare(&b.name, Kind::Parameter, self.params.len())?;
                        self.params.push(b);
                    }
                }
                StatementKind::State(names) => {
                    for n in names {
                        self.declare(n, Kind::State, self.states.len())?;
                        self.states.push(n);
                    }
                }
                StatementKind::Noise { name, intensity } => {
                    self.declare(name, Kind::Noise, self.noises.len())?;
                    self.noises.push((name, intensity));
                }
                StatementKind::Observe(bindings) => {
                    for b in bindings {
                        self.declare(&b.name, Kind::Observable, self.observables.len())?;
                        self.observables.push(b);
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    pub(super) fn declare(&mut self, name: &'a Ident, kind: Kind, index: usize) -> Result<()> {
        let reserved = match name.name.as_str() {
            "pi" | "e" => Some("a mathematical constant"),
            TIME => Some("the time"),
            n if Func::from_name(n).is_some() => Some("a function"),
            _ => None,
        };
        if let Some(what) = reserved {
            return fail(
                SemanticError::ReservedName {
                    name: name.name.clone(),
                    what,
                    kind: kind.noun(),
                },
                name.span,
            );
        }
        if let Some(previous) = self.scope.names.get(name.name.as_str()) {
            return self.duplicate(
                &name.name,
                kind.noun(),
                previous.kind.noun(),
                previous.span,
                name.span,
            );
        }
        self.scope.names.insert(
            &name.name,
            Declaration {
                kind,
                index,
                span: name.span,
            },
        );
        self.scope.order.push(&name.name);
        Ok(())
    }

    /// Exactly two states.
    pub(super) fn state_pair(&self) -> Result<[Symbol; 2]> {
        match self.states.as_slice() {
            [a, b] => Ok([Symbol::from(a.name.as_str()), Symbol::from(b.name.as_str())]),
            other => {
                let span = self
                    .ast
                    .statements
                    .iter()
                    .find(|s| matches!(s.kind, StatementKind::State(_)))
                    .or_else(|| self.ast.statements.first())
                    .map_or(Span::new(0, 0), |s| s.span);
                fail(SemanticError::StateCount { found: other.len() }, span)
            }
        }
    }

    pub(super) fn lower_params(&self) -> Result<Vec<Parameter>> {
        self.params
            .iter()
            .map(|b| {
                let default = self
                    .scope
                    .lower(&b.value, Context::Constant("a parameter default"))?;
                self.forbid_delta(
                    &b.value,
                    DeltaMisuse::InConstant {
                        context: "a parameter default",
                    },
                )?;
                Ok(Parameter {
                    name: Symbol::from(b.name.name.as_str()),
                    default,
                })
            })
            .collect()
    }

    pub(super) fn state_index(&self, name: &Ident, context: Option<&'static str>) -> Result<usize> {
        if let Some(i) = self.states.iter().position(|s| s.name == name.name) {
            return Ok(i);
        }
        let suggestion = closest(&name.name, self.states.iter().map(|s| s.name.as_str()));
        let error = match context {
            None => SemanticError::DriftForUnknownState {
                name: name.name.clone(),
                suggestion,
            },
            Some(context) => SemanticError::UnknownState {
                name: name.name.clone(),
                context,
                suggestion,
            },
        };
        fail(error, name.span)
    }

    pub(super) fn noise_index(&self, name: &Ident) -> Result<usize> {
        match self.scope.names.get(name.name.as_str()) {
            Some(Declaration {
                kind: Kind::Noise,
                index,
                ..
            }) => Ok(*index),
            _ => fail(
                SemanticError::UndeclaredNoise {
                    name: name.name.clone(),
                },
                name.span,
            ),
        }
    }

    pub(super) fn correlation(
        &self,
        a: &Ident,
        b: &Ident,
        coefficient: &ExprNode,
        span: Span,
        earlier: &[(Correlation, Span)],
    ) -> Result<Correlation> {
        let ia = self.noise_index(a)?;
        let ib = self.noise_index(b)?;
        if ia == ib {
            return fail(
                SemanticError::SelfCorrelation {
                    name: a.name.clone(),
                },
                a.span.to(b.span),
            );
        }
        if let Some((_, first)) = earlier
            .iter()
            .find(|(c, _)| (c.a, c.b) == (ia, ib) || (c.a, c.b) == (ib, ia))
        {
            return fail(
                SemanticError::DuplicateCorrelation {
                    a: a.name.clone(),
                    b: b.name.clone(),
                    previous_line: self.line(*first),
                },
                span,
            );
        }
        Ok(Correlation {
            a: ia,
            b: ib,
            coefficient: self
                .scope
                .lower(coefficient, Context::Constant("a correlation coefficient"))?,
        })
    }

    pub(super) fn delta(&self, spec: &DeltaSpec) -> Result<DeltaTreatment> {
        let node = match spec {
            DeltaSpec::Exact => return Ok(DeltaTreatment::Exact),
            DeltaSpec::Gaussian(node) => node,
        };
        let bad = |detail: String| fail(SemanticError::BadGaussianWidth { detail }, node.span);
        // Only literal numbers (and pi, e): the width is fixed when the model is read.
        let e = match Scope::empty().lower(node, Context::Constant("a gaussian width")) {
            Ok(e) => e,
            Err(located) => match located.error {
                SemanticError::UnknownIdentifier { name, .. } => {
                    return bad(format!(", not an expression of `{name}`"))
                }
                _ => return Err(located),
            },
        };
        match e.eval(&|_| None) {
            Ok(w) if w.is_finite() && w > 0.0 => Ok(DeltaTreatment::Gaussian { width: w }),
            Ok(w) => bad(format!(", not {}", super::super::number(w))),
            Err(_) => bad(String::new()),
        }
    }

    /// Parameters must not be defined through themselves, and chains must stay short enough
    /// for binding's recursive evaluation. Iterative, so a long chain cannot overflow here.
    pub(super) fn check_parameter_graph(&self, params: &[Parameter]) -> Result<()> {
        let index: HashMap<&str, usize> = params
            .iter()
            .enumerate()
            .map(|(i, p)| (&*p.name, i))
            .collect();
        let edges = |i: usize| -> Vec<std::result::Result<usize, ()>> {
            params[i]
                .default
                .symbols()
                .iter()
                .filter_map(|s| index.get(&**s).copied())
                .map(Ok)
                .collect()
        };
        let finish = |_| Ok(());
        match walk(params.len(), edges, Some(MAX_PARAMETER_CHAIN), finish) {
            Ok(()) | Err(WalkError::Stopped(())) => Ok(()),
            Err(WalkError::Cycle { chain }) => {
                let repeated = *chain.last().expect("a cycle has nodes");
                let names: Vec<&str> = chain.iter().map(|i| &*params[*i].name).collect();
                fail(
                    SemanticError::ParameterCycle {
                        name: params[repeated].name.to_string(),
                        chain: names.join(" -> "),
                    },
                    self.params[repeated].name.span,
                )
            }
            Err(WalkError::TooLong { node }) => fail(
                SemanticError::ParameterChainTooLong {
                    name: params[node].name.to_string(),
                    limit: MAX_PARAMETER_CHAIN,
                },
                self.params[node].name.span,
            ),
        }
    }
}
