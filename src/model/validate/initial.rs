//! The `initial` line: each state given exactly once, the values constant expressions, the
//! covariance four entries (checked symmetric positive definite here when they are plain
//! numbers, else when the model is bound).

use super::super::ast::{Binding, InitialAst, Span};
use super::super::initial::covariance_problem;
use super::super::InitialSpec;
use super::error::{fail, DeltaMisuse, Result, SemanticError};
use super::scope::Context;
use super::Validator;
use crate::symbolic::{Expr, Symbol};

const CONTEXT: &str = "an initial state";

impl Validator<'_> {
    /// Lowers `spec`, written in `text` (the model file, or the `--initial` value its spans
    /// point into), against the states.
    pub(super) fn initial(
        &self,
        spec: &InitialAst,
        states: &[Symbol; 2],
        text: &str,
    ) -> Result<InitialSpec> {
        Ok(match spec {
            InitialAst::Rest => InitialSpec::Rest,
            InitialAst::Point(values) => InitialSpec::Point(self.per_state(values, states)?),
            InitialAst::Gaussian {
                mean,
                covariance,
                span,
            } => {
                let mean = self.per_state(mean, states)?;
                if covariance.len() != 4 {
                    return fail(
                        SemanticError::InitialCovariance {
                            reason: format!(
                                "{} entries given; it needs 4, row by row: xx, xv, vx, vv",
                                covariance.len()
                            ),
                        },
                        *span,
                    );
                }
                let mut c = Vec::with_capacity(4);
                for e in covariance {
                    c.push(self.constant(e)?);
                }
                let numbers: Vec<f64> = c.iter().filter_map(|e| e.eval(&|_| None).ok()).collect();
                if let [xx, xv, vx, vv] = numbers[..] {
                    if let Some(reason) = covariance_problem([[xx, xv], [vx, vv]]) {
                        return fail(SemanticError::InitialCovariance { reason }, *span);
                    }
                }
                let [xx, xv, vx, vv]: [Expr; 4] =
                    c.try_into().expect("four entries, checked above");
                InitialSpec::Gaussian {
                    mean,
                    covariance: [[xx, xv], [vx, vv]],
                    text: text[span.start..span.end].to_string(),
                }
            }
        })
    }

    fn constant(&self, e: &super::super::ast::ExprNode) -> Result<Expr> {
        let lowered = self.scope.lower(e, Context::Constant(CONTEXT))?;
        self.forbid_delta(e, DeltaMisuse::InConstant { context: CONTEXT })?;
        Ok(lowered)
    }

    /// One value per state, in the `state` line's order.
    fn per_state(&self, values: &[Binding], states: &[Symbol; 2]) -> Result<[Expr; 2]> {
        let mut out: [Option<Expr>; 2] = [None, None];
        let mut counts = [0usize; 2];
        let mut last = Span::new(0, 0);
        for b in values {
            let Some(i) = states.iter().position(|s| **s == *b.name.name) else {
                return fail(
                    SemanticError::InitialNotAState {
                        name: b.name.name.clone(),
                        first: states[0].to_string(),
                        second: states[1].to_string(),
                    },
                    b.name.span,
                );
            };
            counts[i] += 1;
            if counts[i] > 1 {
                return fail(
                    SemanticError::InitialStateCount {
                        state: states[i].to_string(),
                        count: counts[i],
                    },
                    b.name.span,
                );
            }
            out[i] = Some(self.constant(&b.value)?);
            last = b.value.span;
        }
        match out {
            [Some(x), Some(v)] => Ok([x, v]),
            _ => {
                let i = usize::from(out[0].is_some());
                let span = values.first().map_or(last, |f| f.name.span.to(last));
                fail(
                    SemanticError::InitialStateCount {
                        state: states[i].to_string(),
                        count: 0,
                    },
                    span,
                )
            }
        }
    }
}
