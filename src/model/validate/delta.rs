//! Where `delta(...)` may appear: only as a factor of a drift term, alone in its term, with an
//! argument linear in the other state; everywhere else it is refused with a [`DeltaMisuse`].

use super::super::ast::{ExprKind, ExprNode, ProductOp};
use super::error::{fail, DeltaMisuse, Result, SemanticError};
use super::scope::Context;
use super::Validator;

/// The first `delta(...)` call in `node`, if any.
pub(super) fn find_delta(node: &ExprNode) -> Option<&ExprNode> {
    match &node.kind {
        ExprKind::Call { func, args } => {
            if func.name == "delta" {
                return Some(node);
            }
            args.iter().find_map(find_delta)
        }
        ExprKind::Neg(inner) => find_delta(inner),
        ExprKind::Sum(terms) => terms.iter().find_map(|(_, t)| find_delta(t)),
        ExprKind::Product(factors) => factors.iter().find_map(|(_, f)| find_delta(f)),
        ExprKind::Pow(b, e) => find_delta(b).or_else(|| find_delta(e)),
        ExprKind::Number(_) | ExprKind::MalformedNumber(_) | ExprKind::Name(_) => None,
    }
}
impl Validator<'_> {
    /// The delta call at `node`, as written, cut after 40 characters.
    pub(super) fn delta_text(&self, node: &ExprNode) -> String {
        let text = self
            .source
            .get(node.span.start..node.span.end)
            .unwrap_or("delta(...)");
        if text.chars().count() > 40 {
            format!("{}...", text.chars().take(37).collect::<String>())
        } else {
            text.to_string()
        }
    }

    pub(super) fn misplaced<T>(&self, node: &ExprNode, misuse: DeltaMisuse) -> Result<T> {
        fail(
            SemanticError::MisplacedDelta {
                delta: self.delta_text(node),
                misuse,
            },
            node.span,
        )
    }

    /// Refuses any `delta(...)` in `node`.
    pub(super) fn forbid_delta(&self, node: &ExprNode, misuse: DeltaMisuse) -> Result<()> {
        match find_delta(node) {
            Some(d) => self.misplaced(d, misuse),
            None => Ok(()),
        }
    }

    /// Checks the deltas of the drift of state `own`: each one a factor of a term (under
    /// sums, products and unary minus only), alone in its term, with an argument linear in
    /// one state that is not `own`.
    pub(super) fn check_drift_deltas(&self, node: &ExprNode, own: usize) -> Result<()> {
        match &node.kind {
            ExprKind::Number(_) | ExprKind::MalformedNumber(_) | ExprKind::Name(_) => Ok(()),
            ExprKind::Neg(inner) => self.check_drift_deltas(inner, own),
            ExprKind::Sum(terms) => terms
                .iter()
                .try_for_each(|(_, t)| self.check_drift_deltas(t, own)),
            ExprKind::Product(factors) => {
                let mut seen = false;
                for (op, f) in factors {
                    let Some(d) = find_delta(f) else { continue };
                    if *op == ProductOp::Divide {
                        return self.misplaced(d, DeltaMisuse::InDenominator);
                    }
                    if seen {
                        return self.misplaced(d, DeltaMisuse::TimesDelta);
                    }
                    seen = true;
                    self.check_drift_deltas(f, own)?;
                }
                Ok(())
            }
            ExprKind::Pow(base, exponent) => {
                if let Some(d) = find_delta(base) {
                    return self.misplaced(d, DeltaMisuse::InPower);
                }
                self.forbid_delta(exponent, DeltaMisuse::InExponent)
            }
            ExprKind::Call { func, args } if func.name == "delta" => {
                let Some(arg) = args.first() else {
                    return Ok(());
                };
                self.forbid_delta(
                    arg,
                    DeltaMisuse::InFunction {
                        func: "delta".into(),
                    },
                )?;
                let e = self
                    .scope
                    .lower(arg, Context::StateFunction("a delta argument"))?;
                let mentioned: Vec<usize> = (0..self.states.len().min(2))
                    .filter(|i| e.mentions(&self.states[*i].name))
                    .collect();
                let state = match mentioned.as_slice() {
                    [] => return self.misplaced(node, DeltaMisuse::NoState),
                    [s] => *s,
                    _ => return self.misplaced(node, DeltaMisuse::BothStates),
                };
                let name = &self.states[state].name;
                let slope = crate::symbolic::diff(&e, name).ok();
                let linear = slope.is_some_and(|d| {
                    !self.states.iter().any(|s| d.mentions(&s.name)) && !d.contains_delta()
                });
                if !linear {
                    return self.misplaced(
                        node,
                        DeltaMisuse::NonlinearArgument {
                            state: name.clone(),
                        },
                    );
                }
                if state == own {
                    return self.misplaced(
                        node,
                        DeltaMisuse::OwnDrift {
                            state: name.clone(),
                        },
                    );
                }
                Ok(())
            }
            ExprKind::Call { func, args } => match args.iter().find_map(find_delta) {
                Some(d) => self.misplaced(
                    d,
                    DeltaMisuse::InFunction {
                        func: func.name.clone(),
                    },
                ),
                None => Ok(()),
            },
        }
    }
}
