//! The `safe` line (and a `--safe` value): the quantity lowered over states, observables
//! and parameters, the observables replaced by their definitions, the bounds constants.

use super::super::ast::{DomainLimit, SafeSpec};
use super::super::{DomainBound, Observable, SafeSet};
use super::error::{fail, DeltaMisuse, Result, SemanticError};
use super::scope::Context;
use super::Validator;

impl Validator<'_> {
    /// Lowers `spec`, written in `text` (the model file, or the `--safe` value its spans
    /// point into), against this model's names.
    pub(super) fn safe_set(
        &self,
        spec: &SafeSpec,
        text: &str,
        observables: &[Observable],
    ) -> Result<SafeSet> {
        let written = |s: super::super::ast::Span| text[s.start..s.end].to_string();
        let quantity = self
            .scope
            .lower(&spec.quantity, Context::SafeQuantity)?
            .map_symbols(&|s| {
                observables
                    .iter()
                    .find(|o| o.name == *s)
                    .map(|o| o.expr.clone())
            });
        self.forbid_delta(
            &spec.quantity,
            DeltaMisuse::InConstant {
                context: "a safe set",
            },
        )?;
        if !self.states.iter().any(|s| quantity.mentions(&s.name)) {
            return fail(
                SemanticError::SafeWithoutState {
                    text: written(spec.quantity.span),
                },
                spec.quantity.span,
            );
        }
        let bound = |limit: &Option<DomainLimit>| -> Result<Option<DomainBound>> {
            let Some(limit) = limit else { return Ok(None) };
            let at = self
                .scope
                .lower(&limit.at, Context::Constant("a safe bound"))?;
            self.forbid_delta(
                &limit.at,
                DeltaMisuse::InConstant {
                    context: "a safe bound",
                },
            )?;
            Ok(Some(DomainBound {
                at,
                strict: limit.strict,
            }))
        };
        let lower = bound(&spec.lower)?;
        let upper = bound(&spec.upper)?;
        let start = spec
            .lower
            .as_ref()
            .map_or(spec.quantity.span, |l| l.at.span);
        let end = spec
            .upper
            .as_ref()
            .map_or(spec.quantity.span, |u| u.at.span);
        Ok(SafeSet {
            quantity,
            lower,
            upper,
            text: written(start.to(end)),
        })
    }
}
