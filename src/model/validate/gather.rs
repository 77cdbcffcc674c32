//! The statements that describe the dynamics (drift, noise, correlation, diffusion, impact,
//! domain, observables, delta), each checked by its own function in file order, and what they
//! say gathered into one [`Gathered`] with the spans later diagnostics point at.

use std::collections::BTreeMap;

use super::super::ast::{Binding, DomainLimit, ExprNode, Ident, Span, Statement, StatementKind};
use super::super::{
    Correlation, DeltaTreatment, Domain, DomainBound, ImpactLaw, Interpretation, NoiseSource,
    Observable, Periodic,
};
use super::error::{fail, DeltaMisuse, Result, SemanticError};
use super::scope::Context;
use super::Validator;
use crate::symbolic::{Expr, Symbol};

/// What the statements say, in file order. Each statement's check reads what earlier ones
/// gathered (a second drift of a state, a third impact), so the first mistake in the file is
/// the one reported.
#[derive(Default)]
pub(super) struct Gathered {
    /// Each state's drift and the span of its state name.
    pub(super) drift: [Option<(Expr, Span)>; 2],
    /// Each state's noise coefficients by source and the span of its state name.
    pub(super) diffusion: [Option<(BTreeMap<usize, Expr>, Span)>; 2],
    /// Each correlation and the span of its statement.
    pub(super) correlations: Vec<(Correlation, Span)>,
    pub(super) noises: Vec<NoiseSource>,
    pub(super) interpretation: Interpretation,
    /// Each impact law and the span of its statement.
    pub(super) impacts: Vec<(ImpactLaw, Span)>,
    /// The domain, the span of its statement and its state's name.
    pub(super) domain: Option<(Domain, Span, Ident)>,
    /// The periodic state, the span of its statement and its state's name.
    pub(super) periodic: Option<(Periodic, Span, Ident)>,
    pub(super) observables: Vec<Observable>,
    pub(super) delta: DeltaTreatment,
    /// Where each bound value was written, for the diagnostics of binding (see `Origin`).
    pub(super) spans: ValueSpans,
}

/// The spans of the values binding evaluates, one field per field of `Origin`.
#[derive(Default)]
pub(super) struct ValueSpans {
    pub(super) intensities: Vec<Span>,
    pub(super) correlations: Vec<Span>,
    pub(super) barriers: Vec<Span>,
    pub(super) maps: Vec<Span>,
    pub(super) domain_bounds: [Option<Span>; 2],
    pub(super) period: Option<Span>,
    pub(super) drifts: [Option<Span>; 2],
    pub(super) diffusions: [Option<Span>; 2],
}

impl Validator<'_> {
    /// Checks every statement of the dynamics in file order and gathers what they say;
    /// `states` names the state pair (for messages about an impact's state).
    pub(super) fn gather(&self, states: &[Symbol; 2]) -> Result<Gathered> {
        let mut g = Gathered::default();
        for st in &self.ast.statements {
            match &st.kind {
                StatementKind::Model { .. } | StatementKind::Param(_) | StatementKind::State(_) => {
                }
                StatementKind::Drift { state, expr } => self.drift(&mut g, state, expr)?,
                StatementKind::Noise { name, intensity } => self.noise(&mut g, name, intensity)?,
                StatementKind::Correlate { a, b, coefficient } => {
                    self.correlate(&mut g, st, a, b, coefficient)?;
                }
                StatementKind::Diffusion { state, expr } => self.diffusion(&mut g, state, expr)?,
                StatementKind::Interpretation(i) => g.interpretation = *i,
                StatementKind::Impact {
                    state,
                    at,
                    other,
                    map,
                } => self.impact(&mut g, st, states, [state, other], at, map)?,
                StatementKind::Domain {
                    state,
                    lower,
                    upper,
                } => self.domain(&mut g, st, state, [lower, upper])?,
                StatementKind::Periodic { state, period } => {
                    self.periodic(&mut g, st, state, period)?;
                }
                StatementKind::Observe(bindings) => self.observe(&mut g, bindings)?,
                StatementKind::Delta(spec) => g.delta = self.delta(spec)?,
                // Lowered after every observable is known (`Validator::safe_set`).
                StatementKind::Safe(_) => {}
                // Lowered after the states are known (`Validator::initial`).
                StatementKind::Initial(_) => {}
            }
        }
        Ok(g)
    }

    /// `drift state: expr`: once per state, a function of the states with deltas only where
    /// a drift may hold them.
    fn drift(&self, g: &mut Gathered, state: &Ident, expr: &ExprNode) -> Result<()> {
        let i = self.state_index(state, None)?;
        if let Some((_, first)) = &g.drift[i] {
            return self.duplicate(&state.name, "drift", "drift", *first, state.span);
        }
        let e = self.scope.lower(expr, Context::StateFunction("a drift"))?;
        self.check_drift_deltas(expr, i)?;
        g.spans.drifts[i] = Some(expr.span);
        g.drift[i] = Some((e, state.span));
        Ok(())
    }

    /// `noise name: intensity S`: a constant intensity.
    fn noise(&self, g: &mut Gathered, name: &Ident, intensity: &ExprNode) -> Result<()> {
        let e = self
            .scope
            .lower(intensity, Context::Constant("a noise intensity"))?;
        self.forbid_delta(
            intensity,
            DeltaMisuse::InConstant {
                context: "a noise intensity",
            },
        )?;
        g.spans.intensities.push(intensity.span);
        g.noises.push(NoiseSource {
            name: Symbol::from(name.name.as_str()),
            intensity: e,
        });
        Ok(())
    }

    /// `correlate a, b: coefficient`: two distinct sources, paired once, a constant
    /// coefficient.
    fn correlate(
        &self,
        g: &mut Gathered,
        st: &Statement,
        a: &Ident,
        b: &Ident,
        coefficient: &ExprNode,
    ) -> Result<()> {
        let c = self.correlation(a, b, coefficient, st.span, &g.correlations)?;
        self.forbid_delta(
            coefficient,
            DeltaMisuse::InConstant {
                context: "a correlation coefficient",
            },
        )?;
        g.spans.correlations.push(coefficient.span);
        g.correlations.push((c, st.span));
        Ok(())
    }

    /// `diffusion state: expr`: once per state, linear in the noise sources.
    fn diffusion(&self, g: &mut Gathered, state: &Ident, expr: &ExprNode) -> Result<()> {
        let i = self.state_index(state, Some("diffusion"))?;
        if let Some((_, first)) = &g.diffusion[i] {
            return self.duplicate(&state.name, "diffusion", "diffusion", *first, state.span);
        }
        let map = self
            .scope
            .noise_coefficients(expr, &state.name)
            .map_err(|mut l| {
                if let SemanticError::NoiseFreeTerm { state: s } = &mut l.error {
                    s.clone_from(&state.name);
                }
                l
            })?;
        self.forbid_delta(expr, DeltaMisuse::InDiffusion)?;
        g.spans.diffusions[i] = Some(expr.span);
        g.diffusion[i] = Some((map, state.span));
        Ok(())
    }

    /// `impact state at x_b, other -> map`: at most two, of one state, each jumping the
    /// other state.
    fn impact(
        &self,
        g: &mut Gathered,
        st: &Statement,
        states: &[Symbol; 2],
        [state, other]: [&Ident; 2],
        at: &ExprNode,
        map: &ExprNode,
    ) -> Result<()> {
        if let [(_, first), (_, second)] = g.impacts.as_slice() {
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
        if let Some((first, _)) = g.impacts.first() {
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
        g.spans.barriers.push(at.span);
        g.spans.maps.push(map.span);
        g.impacts.push((law, st.span));
        Ok(())
    }

    /// `domain state: lower < state < upper`: constant bounds, each optional. Whether it
    /// agrees with the impacts is checked once all statements are read.
    fn domain(
        &self,
        g: &mut Gathered,
        st: &Statement,
        state: &Ident,
        [lower, upper]: [&Option<DomainLimit>; 2],
    ) -> Result<()> {
        let s = self.state_index(state, Some("domain"))?;
        let d = Domain {
            state: s,
            lower: self.domain_bound(g, lower, 0)?,
            upper: self.domain_bound(g, upper, 1)?,
        };
        g.domain = Some((d, st.span, state.clone()));
        Ok(())
    }

    /// `domain state periodic period`: a constant period; its value is checked when the
    /// model is bound, and that the coefficients repeat with it.
    fn periodic(
        &self,
        g: &mut Gathered,
        st: &Statement,
        state: &Ident,
        period: &ExprNode,
    ) -> Result<()> {
        let s = self.state_index(state, Some("domain"))?;
        let at = self.scope.lower(period, Context::Constant("a period"))?;
        self.forbid_delta(
            period,
            DeltaMisuse::InConstant {
                context: "a period",
            },
        )?;
        g.spans.period = Some(period.span);
        g.periodic = Some((
            Periodic {
                state: s,
                period: at,
            },
            st.span,
            state.clone(),
        ));
        Ok(())
    }

    /// Bound `k` (0: lower, 1: upper) of a domain, when written.
    fn domain_bound(
        &self,
        g: &mut Gathered,
        limit: &Option<DomainLimit>,
        k: usize,
    ) -> Result<Option<DomainBound>> {
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
        g.spans.domain_bounds[k] = Some(limit.at.span);
        Ok(Some(DomainBound {
            at,
            strict: limit.strict,
        }))
    }

    /// `observe name = expr, …`: functions of the states, each with a density.
    fn observe(&self, g: &mut Gathered, bindings: &[Binding]) -> Result<()> {
        for b in bindings {
            g.observables.push(Observable {
                name: Symbol::from(b.name.name.as_str()),
                expr: self
                    .scope
                    .lower(&b.value, Context::StateFunction("an observable"))?,
            });
            self.observable_has_density(b, &g.observables[g.observables.len() - 1])?;
        }
        Ok(())
    }
}
