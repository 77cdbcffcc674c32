//! Noise linearity: a `diffusion` line is split into the coefficient of each noise source by
//! a recursive analysis of the tree, refusing noise that enters other than linearly.

use std::collections::BTreeMap;

use super::super::ast::{ExprKind, ExprNode, ProductOp, Span, SumOp};
use super::error::{fail, Result, SemanticError};
use super::scope::{Context, Declaration, Kind, Scope};
use super::Validator;
use crate::symbolic::Expr;

impl Scope<'_> {
    /// Splits a diffusion expression into the coefficient of each noise source, by a
    /// recursive linearity analysis on the tree. The result maps the index of each source
    /// that appears to its coefficient; `Err` points at what breaks linearity.
    pub(super) fn noise_coefficients(
        &self,
        node: &ExprNode,
        state: &str,
    ) -> Result<BTreeMap<usize, Expr>> {
        match self.linear(node)? {
            Linear::Noisy(map) => Ok(map),
            Linear::Free(_) => fail(
                SemanticError::NoiseFreeTerm {
                    state: state.to_string(),
                },
                node.span,
            ),
        }
    }

    fn linear(&self, node: &ExprNode) -> Result<Linear> {
        match &node.kind {
            ExprKind::Name(name) => {
                if let Some(Declaration {
                    kind: Kind::Noise,
                    index,
                    ..
                }) = self.names.get(name.as_str())
                {
                    return Ok(Linear::Noisy(BTreeMap::from([(*index, Expr::num(1.0))])));
                }
                Ok(Linear::Free(self.lower(node, Context::Diffusion)?))
            }
            ExprKind::Neg(inner) => Ok(match self.linear(inner)? {
                Linear::Free(e) => Linear::Free(-e),
                Linear::Noisy(map) => {
                    Linear::Noisy(map.into_iter().map(|(k, c)| (k, -c)).collect())
                }
            }),
            ExprKind::Sum(terms) => {
                let mut analysed = Vec::with_capacity(terms.len());
                for (op, t) in terms {
                    analysed.push((*op, t.span, self.linear(t)?));
                }
                let noisy = analysed
                    .iter()
                    .any(|(_, _, l)| matches!(l, Linear::Noisy(_)));
                if !noisy {
                    return Ok(Linear::Free(self.lower(node, Context::Diffusion)?));
                }
                let mut sums: BTreeMap<usize, Vec<Expr>> = BTreeMap::new();
                for (op, span, l) in analysed {
                    match l {
                        Linear::Free(_) => {
                            return fail(
                                SemanticError::NoiseFreeTerm {
                                    state: String::new(),
                                },
                                span,
                            )
                        }
                        Linear::Noisy(map) => {
                            for (k, c) in map {
                                let c = if op == SumOp::Minus { -c } else { c };
                                sums.entry(k).or_default().push(c);
                            }
                        }
                    }
                }
                Ok(Linear::Noisy(
                    sums.into_iter().map(|(k, v)| (k, Expr::sum(v))).collect(),
                ))
            }
            ExprKind::Product(factors) => {
                let mut noisy: Option<(usize, BTreeMap<usize, Expr>)> = None;
                let mut free = Vec::with_capacity(factors.len());
                for (position, (op, f)) in factors.iter().enumerate() {
                    match self.linear(f)? {
                        Linear::Free(e) => free.push(match op {
                            ProductOp::Times => e,
                            ProductOp::Divide => Expr::pow(e, Expr::num(-1.0)),
                        }),
                        Linear::Noisy(_) if *op == ProductOp::Divide => {
                            return fail(
                                SemanticError::NonlinearNoise {
                                    reason: "division by a noise source",
                                },
                                f.span,
                            )
                        }
                        Linear::Noisy(_) if noisy.is_some() => {
                            return fail(
                                SemanticError::NonlinearNoise {
                                    reason: "a product of two factors that both contain noise",
                                },
                                f.span,
                            )
                        }
                        Linear::Noisy(map) => noisy = Some((position, map)),
                    }
                }
                let Some((position, map)) = noisy else {
                    return Ok(Linear::Free(Expr::product(free)));
                };
                // The coefficient keeps the factors in their written order, the noise's own
                // coefficient in the noise's place (dropped when it is 1).
                let coefficient = |c: Expr| {
                    let mut parts = free.clone();
                    if c != Expr::num(1.0) {
                        parts.insert(position.min(parts.len()), c);
                    }
                    Expr::product(parts)
                };
                Ok(Linear::Noisy(
                    map.into_iter().map(|(k, c)| (k, coefficient(c))).collect(),
                ))
            }
            ExprKind::Pow(..) | ExprKind::Call { .. } => {
                let e = self.lower(node, Context::Diffusion)?;
                let noisy = e
                    .symbols()
                    .iter()
                    .any(|s| self.kind_of(s) == Some(Kind::Noise));
                if noisy {
                    let reason = if matches!(node.kind, ExprKind::Pow(..)) {
                        "a power of a noise source"
                    } else {
                        "a function of a noise source"
                    };
                    return fail(SemanticError::NonlinearNoise { reason }, node.span);
                }
                Ok(Linear::Free(e))
            }
            ExprKind::Number(_) | ExprKind::MalformedNumber(_) => {
                Ok(Linear::Free(self.lower(node, Context::Diffusion)?))
            }
        }
    }
}

/// A diffusion sub-expression: free of noise, or linear in it with these coefficients.
enum Linear {
    Free(Expr),
    Noisy(BTreeMap<usize, Expr>),
}

impl Validator<'_> {
    pub(super) fn noise_matrix(
        &self,
        diffusion: [Option<(BTreeMap<usize, Expr>, Span)>; 2],
    ) -> Result<[Vec<Expr>; 2]> {
        let m = self.noises.len();
        let mut used = vec![false; m];
        let rows: Vec<Vec<Expr>> = diffusion
            .into_iter()
            .map(|d| {
                let map = d.map(|(map, _)| map).unwrap_or_default();
                (0..m)
                    .map(|k| match map.get(&k) {
                        Some(c) => {
                            used[k] = true;
                            c.clone()
                        }
                        None => Expr::num(0.0),
                    })
                    .collect()
            })
            .collect();
        if let Some(k) = used.iter().position(|u| !u) {
            let (name, _) = self.noises[k];
            return fail(
                SemanticError::UnusedNoise {
                    name: name.name.clone(),
                },
                name.span,
            );
        }
        let [r0, r1]: [Vec<Expr>; 2] = rows.try_into().expect("two states");
        Ok([r0, r1])
    }
}
