//! Name resolution and lowering: AST expressions become [`Expr`], each name checked against
//! what the expression may mention, with a close declared name suggested for a typo.

use std::collections::HashMap;

use super::super::ast::{ExprKind, ExprNode, ProductOp, Span, SumOp};
use super::super::TIME;
use super::error::{fail, Result, SemanticError};
use crate::symbolic::{Expr, Func};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Parameter,
    State,
    Noise,
    Observable,
}

impl Kind {
    pub(super) fn noun(self) -> &'static str {
        match self {
            Kind::Parameter => "parameter",
            Kind::State => "state",
            Kind::Noise => "noise source",
            Kind::Observable => "observable",
        }
    }
}

/// Which names an expression may mention.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Context {
    /// Parameters only: defaults, intensities, correlations, barrier positions.
    Constant(&'static str),
    /// States and parameters: drifts, jump maps, observables.
    StateFunction(&'static str),
    /// States, parameters and noise sources: `diffusion` lines.
    Diffusion,
    /// States, observables and parameters: the quantity of a `safe` line.
    SafeQuantity,
    /// Anything; names are left for binding to resolve (`--set` values).
    Free,
}

#[derive(Clone, Debug)]
pub(super) struct Declaration {
    pub(super) kind: Kind,
    pub(super) index: usize,
    pub(super) span: Span,
}

/// Resolves names and lowers AST expressions to [`Expr`].
pub(super) struct Scope<'a> {
    pub(super) names: HashMap<&'a str, Declaration>,
    /// Declared names in declaration order, for suggestions.
    pub(super) order: Vec<&'a str>,
}

impl<'a> Scope<'a> {
    pub(super) fn empty() -> Scope<'a> {
        Scope {
            names: HashMap::new(),
            order: Vec::new(),
        }
    }

    pub(super) fn kind_of(&self, name: &str) -> Option<Kind> {
        self.names.get(name).map(|d| d.kind)
    }

    pub(super) fn suggest(&self, name: &str, kinds: &[Kind]) -> Option<String> {
        let candidates = self
            .order
            .iter()
            .filter(|n| self.kind_of(n).is_some_and(|k| kinds.contains(&k)))
            .copied();
        closest(name, candidates)
    }

    /// Lowers `node` to the canonical [`Expr`] vocabulary, checking each name against
    /// `context`.
    pub(super) fn lower(&self, node: &ExprNode, context: Context) -> Result<Expr> {
        Ok(match &node.kind {
            ExprKind::Number(v) => Expr::num(*v),
            ExprKind::MalformedNumber(text) => {
                return fail(
                    SemanticError::MalformedNumber { text: text.clone() },
                    node.span,
                )
            }
            ExprKind::Name(name) => self.lower_name(name, node.span, context)?,
            ExprKind::Call { func, args } => {
                let f = match Func::from_name(&func.name) {
                    Some(f) => f,
                    None => {
                        let names = Func::ALL.iter().map(|f| f.name());
                        return fail(
                            SemanticError::UnknownFunction {
                                name: func.name.clone(),
                                suggestion: closest(&func.name, names),
                            },
                            func.span,
                        );
                    }
                };
                if args.len() != f.arity() {
                    return fail(
                        SemanticError::WrongArity {
                            func: f.name(),
                            expected: f.arity(),
                            found: args.len(),
                        },
                        node.span,
                    );
                }
                let args = args
                    .iter()
                    .map(|a| self.lower(a, context))
                    .collect::<Result<Vec<_>>>()?;
                Expr::Call(f, args)
            }
            ExprKind::Neg(inner) => -self.lower(inner, context)?,
            ExprKind::Sum(terms) => {
                let mut parts = Vec::with_capacity(terms.len());
                for (op, t) in terms {
                    let e = self.lower(t, context)?;
                    parts.push(match op {
                        SumOp::Plus => e,
                        SumOp::Minus => -e,
                    });
                }
                Expr::sum(parts)
            }
            ExprKind::Product(factors) => {
                let mut parts = Vec::with_capacity(factors.len());
                for (op, f) in factors {
                    let e = self.lower(f, context)?;
                    parts.push(match op {
                        ProductOp::Times => e,
                        ProductOp::Divide => Expr::pow(e, Expr::num(-1.0)),
                    });
                }
                Expr::product(parts)
            }
            ExprKind::Pow(b, e) => Expr::pow(self.lower(b, context)?, self.lower(e, context)?),
        })
    }

    pub(super) fn lower_name(&self, name: &str, span: Span, context: Context) -> Result<Expr> {
        if let Some(decl) = self.names.get(name) {
            let (what, allowed) = match context {
                Context::Constant(what) => (what, decl.kind == Kind::Parameter),
                Context::StateFunction(what) => {
                    (what, matches!(decl.kind, Kind::Parameter | Kind::State))
                }
                Context::Diffusion => (
                    "a diffusion",
                    matches!(decl.kind, Kind::Parameter | Kind::State | Kind::Noise),
                ),
                Context::SafeQuantity => (
                    "a safe set",
                    matches!(decl.kind, Kind::Parameter | Kind::State | Kind::Observable),
                ),
                Context::Free => ("", true),
            };
            if !allowed {
                let name = name.to_string();
                let error = match decl.kind {
                    Kind::Noise => SemanticError::NoiseOutsideDiffusion {
                        name,
                        context: what,
                    },
                    Kind::State => SemanticError::StateInConstant {
                        name,
                        context: what,
                    },
                    _ => SemanticError::ObservableInExpression {
                        name,
                        context: what,
                    },
                };
                return fail(error, span);
            }
            return Ok(Expr::sym(name));
        }
        match name {
            "pi" => return Ok(Expr::num(std::f64::consts::PI)),
            "e" => return Ok(Expr::num(std::f64::consts::E)),
            TIME => {
                // The equations of motion may change in time; what is fixed when the model
                // is read (parameters, intensities, barriers) and the maps of the state
                // (impact laws, observables, delta arguments) may not.
                return match context {
                    Context::Free | Context::Diffusion | Context::StateFunction("a drift") => {
                        Ok(Expr::sym(name))
                    }
                    Context::Constant(what) | Context::StateFunction(what) => {
                        fail(SemanticError::TimeOutsideEquations { context: what }, span)
                    }
                    Context::SafeQuantity => fail(
                        SemanticError::TimeOutsideEquations {
                            context: "a safe line",
                        },
                        span,
                    ),
                };
            }
            _ => {}
        }
        if context == Context::Free {
            return Ok(Expr::sym(name));
        }
        let usable: &[Kind] = match context {
            Context::Constant(_) => &[Kind::Parameter],
            Context::StateFunction(_) => &[Kind::Parameter, Kind::State],
            Context::SafeQuantity => &[Kind::Parameter, Kind::State, Kind::Observable],
            _ => &[Kind::Parameter, Kind::State, Kind::Noise],
        };
        let suggestion = self.suggest(name, usable);
        if context == Context::Diffusion && suggestion.is_none() {
            // In a diffusion line a name nobody declared is most likely a noise source
            // whose `noise` line is missing.
            return fail(
                SemanticError::UndeclaredNoise {
                    name: name.to_string(),
                },
                span,
            );
        }
        fail(
            SemanticError::UnknownIdentifier {
                name: name.to_string(),
                suggestion,
            },
            span,
        )
    }
}

/// The candidate closest to `name` by edit distance, if close enough to be a likely typo.
pub(super) fn closest<'n>(name: &str, candidates: impl Iterator<Item = &'n str>) -> Option<String> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .filter(|c| *c != name)
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c.to_string())
}

/// Levenshtein distance over characters.
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitution = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitution.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// 1-based line of a byte offset.
pub(super) fn line_of(source: &str, offset: usize) -> usize {
    source.as_bytes()[..offset.min(source.len())]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

/// Lowers a lone expression whose names are left unresolved (a `--set` value).
pub(crate) fn lower_free(node: &ExprNode) -> Result<Expr> {
    Scope::empty().lower(node, Context::Free)
}
