//! [`ModelAst`] → validated [`Model`]: names resolved, expressions lowered to [`Expr`], the
//! noise matrix extracted, and every mistake reported as a typed [`SemanticError`] at the
//! span where it was made.

use std::collections::{BTreeMap, HashMap};

use super::ast::{
    Binding, DeltaSpec, ExprKind, ExprNode, Ident, ModelAst, ProductOp, Span, Statement,
    StatementKind, SumOp,
};
use super::{
    Correlation, DeltaTreatment, ImpactLaw, Interpretation, Model, NoiseSource, Observable, Origin,
    Parameter,
};
use crate::symbolic::{Expr, Func, Symbol};

/// Longest chain of parameters defined through one another (`a = b`, `b = c`, ...) accepted;
/// binding evaluates such chains recursively.
pub const MAX_PARAMETER_CHAIN: usize = 256;

/// What is wrong with a model that parses. Each variant is one kind of mistake; the
/// [`crate::model::ModelError`] that carries it also says where.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SemanticError {
    /// The file has no `model` line.
    #[error("no `model` line: a model file starts with `model NAME \"description\"`")]
    MissingModelLine,
    /// Something comes before the `model` line.
    #[error("the `model` line must come first")]
    ModelNotFirst,
    /// A second `model` line.
    #[error("a second `model` line (the first is on line {previous_line})")]
    DuplicateModelLine {
        /// Line of the first `model` line.
        previous_line: usize,
    },
    /// A statement that may appear once appears again (`state`, `interpretation`, `impact`,
    /// `delta`).
    #[error("`{keyword}` may appear only once (first on line {previous_line})")]
    DuplicateStatement {
        /// The statement's keyword.
        keyword: &'static str,
        /// Line of the first one.
        previous_line: usize,
    },
    /// A name defined twice, or for two kinds of thing (a drift or diffusion given twice
    /// for one state counts too).
    #[error("{}", duplicate_message(name, kind, previous_kind, *previous_line))]
    DuplicateDefinition {
        /// The name.
        name: String,
        /// What this definition makes it.
        kind: &'static str,
        /// What it already was.
        previous_kind: &'static str,
        /// Line of the earlier definition.
        previous_line: usize,
    },
    /// A declared name that is reserved: the constants `pi`, `e` or a function name.
    #[error("`{name}` is reserved ({what}) and cannot be declared as a {kind}")]
    ReservedName {
        /// The name.
        name: String,
        /// What it is reserved for.
        what: &'static str,
        /// What the declaration tried to make it.
        kind: &'static str,
    },
    /// A name that is declared nowhere.
    #[error("unknown identifier `{name}`")]
    UnknownIdentifier {
        /// The name.
        name: String,
        /// A declared name that is close, if any.
        suggestion: Option<String>,
    },
    /// A call of a function the language does not have.
    #[error("unknown function `{name}`")]
    UnknownFunction {
        /// The name.
        name: String,
        /// A function with a close name, if any.
        suggestion: Option<String>,
    },
    /// A call with the wrong number of arguments.
    #[error("`{func}` takes {expected} argument{}, but {found} {} given",
        if *expected == 1 { "" } else { "s" }, if *found == 1 { "was" } else { "were" })]
    WrongArity {
        /// The function.
        func: &'static str,
        /// How many it takes.
        expected: usize,
        /// How many it was given.
        found: usize,
    },
    /// A literal that is not a number (`1e`, `2x`, `1.2.3`) or does not fit an f64.
    #[error("malformed number `{text}`")]
    MalformedNumber {
        /// The text as written.
        text: String,
    },
    /// The `state` line does not declare exactly two states (or is missing).
    #[error("a model has exactly two states, but {}", match found {
        0 => "none is declared (add `state x, v`)".to_string(),
        1 => "only one is declared".to_string(),
        n => format!("{n} are declared"),
    })]
    StateCount {
        /// How many were declared.
        found: usize,
    },
    /// A state without a `drift` line.
    #[error("state `{state}` has no `drift` line")]
    MissingDrift {
        /// The state.
        state: String,
    },
    /// A `drift` line for a name that is not a state.
    #[error("`drift {name}`: `{name}` is not a state")]
    DriftForUnknownState {
        /// The name.
        name: String,
        /// A state with a close name, if any.
        suggestion: Option<String>,
    },
    /// An impact, observable or diffusion that names something that is not a state.
    #[error("{context}: `{name}` is not a state")]
    UnknownState {
        /// The name.
        name: String,
        /// Where it was used (`impact`, `diffusion`, ...).
        context: &'static str,
        /// A state with a close name, if any.
        suggestion: Option<String>,
    },
    /// An impact law whose jumping state is the barrier state itself.
    #[error("the impact on `{state}` must make the other state jump, not `{state}` itself")]
    ImpactOnItself {
        /// The state.
        state: String,
    },
    /// Parameters defined through one another in a cycle.
    #[error("parameter `{name}` is defined through itself: {chain}")]
    ParameterCycle {
        /// Where the cycle starts.
        name: String,
        /// The chain, `a -> b -> a`.
        chain: String,
    },
    /// A chain of parameter definitions longer than [`MAX_PARAMETER_CHAIN`].
    #[error("parameter `{name}` depends on a chain of more than {limit} parameters")]
    ParameterChainTooLong {
        /// The parameter at the end of the chain.
        name: String,
        /// The limit.
        limit: usize,
    },
    /// A noise source (or what must be one) that is not declared.
    #[error("noise source `{name}` is not declared (add `noise {name}: intensity ...`)")]
    UndeclaredNoise {
        /// The name.
        name: String,
    },
    /// A declared noise source that no `diffusion` line uses.
    #[error("noise source `{name}` enters no equation (no `diffusion` line uses it)")]
    UnusedNoise {
        /// The source.
        name: String,
    },
    /// A noise symbol outside a `diffusion` line.
    #[error("noise source `{name}` used in {context}; noise may only appear in `diffusion` lines")]
    NoiseOutsideDiffusion {
        /// The source.
        name: String,
        /// Where it was used.
        context: &'static str,
    },
    /// A state in an expression that must be a constant (parameters only).
    #[error("state `{name}` used in {context}, which may only depend on parameters")]
    StateInConstant {
        /// The state.
        name: String,
        /// Which expression (`a parameter default`, `a noise intensity`, ...).
        context: &'static str,
    },
    /// An observable's name used inside an expression.
    #[error("observable `{name}` used in {context}; observables are outputs, not inputs")]
    ObservableInExpression {
        /// The observable.
        name: String,
        /// Where it was used.
        context: &'static str,
    },
    /// An observable that has no probability density: a constant, a map taking only discrete
    /// values (`sgn(z)`), or one containing `delta(...)`.
    #[error("observable `{name} = {text}` {reason}")]
    ObservableWithoutDensity {
        /// The observable.
        name: String,
        /// Its definition as written.
        text: String,
        /// What is wrong, in words.
        reason: &'static str,
    },
    /// Noise entering a `diffusion` line other than linearly.
    #[error("noise must enter linearly: {reason}")]
    NonlinearNoise {
        /// What makes it nonlinear here.
        reason: &'static str,
    },
    /// A term of a `diffusion` line without any noise source (it belongs in the drift).
    #[error("this term of `diffusion {state}` contains no noise source (move it to the drift)")]
    NoiseFreeTerm {
        /// The state of the `diffusion` line.
        state: String,
    },
    /// `correlate xi, xi`.
    #[error("noise source `{name}` cannot be correlated with itself")]
    SelfCorrelation {
        /// The source.
        name: String,
    },
    /// The same pair correlated twice.
    #[error("the correlation of `{a}` and `{b}` is already given on line {previous_line}")]
    DuplicateCorrelation {
        /// First source.
        a: String,
        /// Second source.
        b: String,
        /// Line of the first.
        previous_line: usize,
    },
    /// `gaussian(width)` whose width is not a positive number.
    #[error("the gaussian width must be a positive number{}", detail)]
    BadGaussianWidth {
        /// What was wrong, with its leading separator (`, not -1`).
        detail: String,
    },
    /// A `delta(...)` written where a Dirac delta has no meaning.
    #[error("{}", misuse.describe(delta))]
    MisplacedDelta {
        /// The delta call as written (cut after 40 characters).
        delta: String,
        /// What is wrong with it there.
        misuse: DeltaMisuse,
    },
}

/// Where a `delta(...)` was written that has no meaning there. A Dirac delta is a
/// distribution: in a drift it may only multiply an ordinary function, with an argument
/// linear in one state (`-(1 - r)*v*abs(v)*delta(z)`); everywhere else it is refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeltaMisuse {
    /// Inside a function call: `abs(delta(z))`, `exp(delta(z))`.
    InFunction {
        /// The function.
        func: String,
    },
    /// Raised to a power: `delta(z)^2`.
    InPower,
    /// In an exponent: `2^delta(z)`.
    InExponent,
    /// Divided by: `v/delta(z)`.
    InDenominator,
    /// Multiplied by another delta: `delta(z)*delta(v)`.
    TimesDelta,
    /// In an impact's jump map.
    InImpactMap,
    /// In a diffusion line (white noise times a delta).
    InDiffusion,
    /// In an expression that must be a number (`a parameter default`, ...).
    InConstant {
        /// Which expression.
        context: &'static str,
    },
    /// Its argument depends on no state.
    NoState,
    /// Its argument depends on both states.
    BothStates,
    /// Its argument is not linear in its state.
    NonlinearArgument {
        /// The state.
        state: String,
    },
    /// In the drift of the state its argument depends on (the operator would need δ′).
    OwnDrift {
        /// The state.
        state: String,
    },
}

impl DeltaMisuse {
    /// The message for the delta call `delta` (as written).
    ///
    /// ```
    /// use fpsolve::model::DeltaMisuse;
    /// let m = DeltaMisuse::InFunction { func: "abs".into() };
    /// assert!(m.describe("delta(z)").starts_with("delta(z) inside abs(...) has no meaning"));
    /// ```
    pub fn describe(&self, delta: &str) -> String {
        const ONLY: &str =
            "a Dirac delta may only multiply an ordinary function, as in `-(1 - r)*v*abs(v)*delta(z)`";
        match self {
            DeltaMisuse::InFunction { func } => {
                format!("{delta} inside {func}(...) has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InPower => {
                format!("{delta} raised to a power has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InExponent => {
                format!("{delta} in an exponent has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InDenominator => {
                format!("division by {delta} has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::TimesDelta => format!(
                "{delta} multiplies another delta: a product of deltas is not a line term and \
                 has no meaning here"
            ),
            DeltaMisuse::InImpactMap => format!(
                "{delta} in an impact map: the jump must be an ordinary function of the states \
                 (the impact term belongs in the drift)"
            ),
            DeltaMisuse::InDiffusion => format!(
                "{delta} in a diffusion line: white noise times a Dirac delta has no meaning"
            ),
            DeltaMisuse::InConstant { context } => {
                format!("{delta} in {context}, which must be a number: a delta has no value")
            }
            DeltaMisuse::NoState => format!(
                "{delta}: its argument depends on no state, so it is not a line in the plane"
            ),
            DeltaMisuse::BothStates => format!(
                "{delta}: its argument depends on both states; only a line delta(x - a) in \
                 one state is supported"
            ),
            DeltaMisuse::NonlinearArgument { state } => {
                format!("{delta}: its argument must be linear in `{state}` (a*{state} + b)")
            }
            DeltaMisuse::OwnDrift { state } => format!(
                "{delta} in the drift of `{state}` itself: the Fokker-Planck operator would need \
                 its derivative, which has no meaning here"
            ),
        }
    }
}

/// The first `delta(...)` call in `node`, if any.
fn find_delta(node: &ExprNode) -> Option<&ExprNode> {
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

fn duplicate_message(name: &str, kind: &str, previous_kind: &str, line: usize) -> String {
    if kind == previous_kind {
        format!("{kind} `{name}` is defined twice (first on line {line})")
    } else {
        format!("`{name}` is already a {previous_kind} (line {line}); it cannot also be a {kind}")
    }
}

impl SemanticError {
    /// A hint for fixing the mistake, where there is one.
    ///
    /// ```
    /// use fpsolve::model::SemanticError;
    /// let e = SemanticError::UnknownIdentifier { name: "mux".into(), suggestion: Some("mu".into()) };
    /// assert_eq!(e.help().as_deref(), Some("did you mean `mu`?"));
    /// ```
    pub fn help(&self) -> Option<String> {
        match self {
            SemanticError::UnknownIdentifier { suggestion, .. }
            | SemanticError::UnknownFunction { suggestion, .. }
            | SemanticError::DriftForUnknownState { suggestion, .. }
            | SemanticError::UnknownState { suggestion, .. } => {
                suggestion.as_ref().map(|s| format!("did you mean `{s}`?"))
            }
            SemanticError::NonlinearNoise { .. } => Some(
                "a diffusion term must read `coefficient * noise`, the coefficient free of noise"
                    .into(),
            ),
            _ => None,
        }
    }
}

/// A semantic error with the span it concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Located {
    pub(crate) error: SemanticError,
    pub(crate) span: Span,
}

type Result<T> = std::result::Result<T, Box<Located>>;

fn fail<T>(error: SemanticError, span: Span) -> Result<T> {
    Err(Box::new(Located { error, span }))
}

/// What kind of thing a declared name is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Parameter,
    State,
    Noise,
    Observable,
}

impl Kind {
    fn noun(self) -> &'static str {
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
enum Context {
    /// Parameters only: defaults, intensities, correlations, barrier positions.
    Constant(&'static str),
    /// States and parameters: drifts, jump maps, observables.
    StateFunction(&'static str),
    /// States, parameters and noise sources: `diffusion` lines.
    Diffusion,
    /// Anything; names are left for binding to resolve (`--set` values).
    Free,
}

#[derive(Clone, Debug)]
struct Declaration {
    kind: Kind,
    index: usize,
    span: Span,
}

/// Resolves names and lowers AST expressions to [`Expr`].
struct Scope<'a> {
    names: HashMap<&'a str, Declaration>,
    /// Declared names in declaration order, for suggestions.
    order: Vec<&'a str>,
}

impl<'a> Scope<'a> {
    fn empty() -> Scope<'a> {
        Scope {
            names: HashMap::new(),
            order: Vec::new(),
        }
    }

    fn kind_of(&self, name: &str) -> Option<Kind> {
        self.names.get(name).map(|d| d.kind)
    }

    fn suggest(&self, name: &str, kinds: &[Kind]) -> Option<String> {
        let candidates = self
            .order
            .iter()
            .filter(|n| self.kind_of(n).is_some_and(|k| kinds.contains(&k)))
            .copied();
        closest(name, candidates)
    }

    /// Lowers `node` to the canonical [`Expr`] vocabulary, checking each name against
    /// `context`.
    fn lower(&self, node: &ExprNode, context: Context) -> Result<Expr> {
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

    fn lower_name(&self, name: &str, span: Span, context: Context) -> Result<Expr> {
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
            _ => {}
        }
        if context == Context::Free {
            return Ok(Expr::sym(name));
        }
        let usable: &[Kind] = match context {
            Context::Constant(_) => &[Kind::Parameter],
            Context::StateFunction(_) => &[Kind::Parameter, Kind::State],
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

    /// Splits a diffusion expression into the coefficient of each noise source, by a
    /// recursive linearity analysis on the tree. The result maps the index of each source
    /// that appears to its coefficient; `Err` points at what breaks linearity.
    fn noise_coefficients(&self, node: &ExprNode, state: &str) -> Result<BTreeMap<usize, Expr>> {
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

/// The candidate closest to `name` by edit distance, if close enough to be a likely typo.
fn closest<'n>(name: &str, candidates: impl Iterator<Item = &'n str>) -> Option<String> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .filter(|c| *c != name)
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c.to_string())
}

/// Levenshtein distance over characters.
fn edit_distance(a: &str, b: &str) -> usize {
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
fn line_of(source: &str, offset: usize) -> usize {
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
        let mut impact = None;
        let mut observables = Vec::new();
        let mut delta = DeltaTreatment::default();
        let mut intensity_spans = Vec::new();
        let mut correlation_spans = Vec::new();
        let mut barrier_span = None;
        let mut map_span = None;
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
                    barrier_span = Some(at.span);
                    map_span = Some(map.span);
                    impact = Some(law);
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
            impact,
            observables,
            delta,
            origin: Some(std::sync::Arc::new(Origin {
                source: self.source.to_string(),
                path: self.path.map(str::to_string),
                params: self.params.iter().map(|b| b.value.span).collect(),
                intensities: intensity_spans,
                correlations: correlation_spans,
                barrier: barrier_span,
                map: map_span,
                drifts: drift_spans,
                diffusions: diffusion_spans,
            })),
        })
    }

    /// The delta call at `node`, as written, cut after 40 characters.
    fn delta_text(&self, node: &ExprNode) -> String {
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

    fn misplaced<T>(&self, node: &ExprNode, misuse: DeltaMisuse) -> Result<T> {
        fail(
            SemanticError::MisplacedDelta {
                delta: self.delta_text(node),
                misuse,
            },
            node.span,
        )
    }

    /// Refuses any `delta(...)` in `node`.
    fn forbid_delta(&self, node: &ExprNode, misuse: DeltaMisuse) -> Result<()> {
        match find_delta(node) {
            Some(d) => self.misplaced(d, misuse),
            None => Ok(()),
        }
    }

    /// Checks the deltas of the drift of state `own`: each one a factor of a term (under
    /// sums, products and unary minus only), alone in its term, with an argument linear in
    /// one state that is not `own`.
    fn check_drift_deltas(&self, node: &ExprNode, own: usize) -> Result<()> {
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
    fn observable_has_density(&self, b: &Binding, o: &Observable) -> Result<()> {
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

    fn duplicate<T>(
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
    fn model_line(&self) -> Result<(String, String)> {
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

    /// `state`, `interpretation`, `impact` and `delta` appear at most once.
    fn once_only(&self) -> Result<()> {
        let mut seen: HashMap<&'static str, Span> = HashMap::new();
        for st in &self.ast.statements {
            let keyword = match st.kind {
                StatementKind::State(_) => "state",
                StatementKind::Interpretation(_) => "interpretation",
                StatementKind::Impact { .. } => "impact",
                StatementKind::Delta(_) => "delta",
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
    fn declare_all(&mut self) -> Result<()> {
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

    fn declare(&mut self, name: &'a Ident, kind: Kind, index: usize) -> Result<()> {
        let reserved = match name.name.as_str() {
            "pi" | "e" => Some("a mathematical constant"),
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
    fn state_pair(&self) -> Result<[Symbol; 2]> {
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

    fn lower_params(&self) -> Result<Vec<Parameter>> {
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

    fn state_index(&self, name: &Ident, context: Option<&'static str>) -> Result<usize> {
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

    fn noise_index(&self, name: &Ident) -> Result<usize> {
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

    fn correlation(
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

    fn delta(&self, spec: &DeltaSpec) -> Result<DeltaTreatment> {
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
            Ok(w) => bad(format!(", not {}", super::number(w))),
            Err(_) => bad(String::new()),
        }
    }

    fn noise_matrix(
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

    /// Parameters must not be defined through themselves, and chains must stay short enough
    /// for binding's recursive evaluation. Iterative, so a long chain cannot overflow here.
    fn check_parameter_graph(&self, params: &[Parameter]) -> Result<()> {
        let index: HashMap<&str, usize> = params
            .iter()
            .enumerate()
            .map(|(i, p)| (&*p.name, i))
            .collect();
        let deps: Vec<Vec<usize>> = params
            .iter()
            .map(|p| {
                p.default
                    .symbols()
                    .iter()
                    .filter_map(|s| index.get(&**s).copied())
                    .collect()
            })
            .collect();
        // 0 = unvisited, 1 = on the current path, 2 = done; `height` is the longest chain
        // below a finished parameter.
        let mut state = vec![0u8; params.len()];
        let mut height = vec![0usize; params.len()];
        for root in 0..params.len() {
            if state[root] != 0 {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
            state[root] = 1;
            while let Some(&mut (node, ref mut next)) = stack.last_mut() {
                if let Some(&dep) = deps[node].get(*next) {
                    *next += 1;
                    match state[dep] {
                        0 => {
                            state[dep] = 1;
                            stack.push((dep, 0));
                        }
                        1 => {
                            let from = stack.iter().position(|(n, _)| *n == dep).unwrap_or(0);
                            let mut chain: Vec<&str> = stack[from..]
                                .iter()
                                .map(|(n, _)| &*params[*n].name)
                                .collect();
                            chain.push(&params[dep].name);
                            return fail(
                                SemanticError::ParameterCycle {
                                    name: params[dep].name.to_string(),
                                    chain: chain.join(" -> "),
                                },
                                self.params[dep].name.span,
                            );
                        }
                        _ => {}
                    }
                } else {
                    stack.pop();
                    state[node] = 2;
                    height[node] = deps[node].iter().map(|d| height[*d] + 1).max().unwrap_or(0);
                    if height[node] > MAX_PARAMETER_CHAIN {
                        return fail(
                            SemanticError::ParameterChainTooLong {
                                name: params[node].name.to_string(),
                                limit: MAX_PARAMETER_CHAIN,
                            },
                            self.params[node].name.span,
                        );
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{parse_model, ModelError};

    const BASE: &str = "\
model m \"test\"
param c = 0.1, k = 1
state z, v
drift z: v
drift v: -c*v - k*z
noise xi: intensity 1
diffusion v: xi
";

    /// Parses `BASE` with `edit` applied and returns the semantic error and its position.
    fn error(src: &str) -> (SemanticError, usize, usize) {
        match parse_model(src, None) {
            Err(ModelError::Semantic { error, diagnostic }) => {
                (*error, diagnostic.line(), diagnostic.column())
            }
            other => panic!("expected a semantic error for\n{src}\ngot {other:?}"),
        }
    }

    fn with(line: &str) -> String {
        format!("{BASE}{line}\n")
    }

    fn replaced(from: &str, to: &str) -> String {
        assert!(BASE.contains(from));
        BASE.replacen(from, to, 1)
    }

    #[test]
    fn the_base_model_is_valid() {
        let m = parse_model(BASE, None).unwrap();
        assert_eq!(m.noise_matrix()[0][0], Expr::num(0.0));
        assert_eq!(m.noise_matrix()[1][0], Expr::num(1.0));
    }

    #[test]
    fn unknown_identifiers_come_with_a_suggestion() {
        let (e, l, c) = error(&replaced("-c*v - k*z", "-c*v - kk*z"));
        assert_eq!(
            e,
            SemanticError::UnknownIdentifier {
                name: "kk".into(),
                suggestion: Some("k".into())
            }
        );
        assert_eq!((l, c), (5, 17));
        let (e, ..) = error(&replaced("-c*v - k*z", "-c*v - zeta"));
        assert!(matches!(
            e,
            SemanticError::UnknownIdentifier {
                suggestion: None,
                ..
            }
        ));
    }

    #[test]
    fn unknown_functions_and_wrong_arity() {
        let (e, l, c) = error(&replaced("- k*z", "- k*sinh(z)"));
        assert_eq!(
            e,
            SemanticError::UnknownFunction {
                name: "sinh".into(),
                suggestion: Some("sin".into())
            }
        );
        assert_eq!((l, c), (5, 19));
        let (e, ..) = error(&replaced("- k*z", "- k*max(z)"));
        assert_eq!(
            e,
            SemanticError::WrongArity {
                func: "max",
                expected: 2,
                found: 1
            }
        );
        let (e, ..) = error(&replaced("- k*z", "- k*abs(z, v)"));
        assert!(matches!(e, SemanticError::WrongArity { found: 2, .. }));
    }

    #[test]
    fn duplicate_and_reserved_names() {
        let (e, l, c) = error(&with("param c = 2"));
        assert_eq!(
            e,
            SemanticError::DuplicateDefinition {
                name: "c".into(),
                kind: "parameter",
                previous_kind: "parameter",
                previous_line: 2
            }
        );
        assert_eq!((l, c), (8, 7));
        let (e, ..) = error(&with("param z = 2"));
        assert!(matches!(
            e,
            SemanticError::DuplicateDefinition {
                kind: "parameter",
                previous_kind: "state",
                ..
            }
        ));
        let (e, ..) = error(&with("observe xi = z"));
        assert!(matches!(
            e,
            SemanticError::DuplicateDefinition {
                previous_kind: "noise source",
                ..
            }
        ));
        let (e, ..) = error(&with("drift v: 0"));
        assert!(matches!(
            e,
            SemanticError::DuplicateDefinition { kind: "drift", .. }
        ));
        let (e, ..) = error(&with("diffusion v: xi"));
        assert!(matches!(
            e,
            SemanticError::DuplicateDefinition {
                kind: "diffusion",
                ..
            }
        ));
        let (e, ..) = error(&with("param pi = 3"));
        assert!(matches!(e, SemanticError::ReservedName { .. }));
        let (e, ..) = error(&with("param abs = 3"));
        assert!(matches!(
            e,
            SemanticError::ReservedName {
                what: "a function",
                ..
            }
        ));
    }

    #[test]
    fn statements_that_may_appear_once() {
        let (e, l, _) = error(&format!("{BASE}delta: exact\ndelta: exact\n"));
        assert_eq!(
            e,
            SemanticError::DuplicateStatement {
                keyword: "delta",
                previous_line: 8
            }
        );
        assert_eq!(l, 9);
        let (e, ..) = error(&with("model n"));
        assert_eq!(e, SemanticError::DuplicateModelLine { previous_line: 1 });
        let (e, l, c) = error(&format!("param a = 1\n{BASE}"));
        assert_eq!((e, l, c), (SemanticError::ModelNotFirst, 2, 1));
        let (e, ..) = error(&BASE.replacen("model m \"test\"\n", "", 1));
        assert_eq!(e, SemanticError::MissingModelLine);
    }

    #[test]
    fn states_and_drifts() {
        let (e, l, _) = error(&replaced("state z, v", "state z, v, w"));
        assert_eq!((e, l), (SemanticError::StateCount { found: 3 }, 3));
        let (e, ..) = error(&replaced("state z, v", "state z"));
        assert_eq!(e, SemanticError::StateCount { found: 1 });
        let (e, l, c) = error(&replaced("drift z: v\n", ""));
        assert_eq!(e, SemanticError::MissingDrift { state: "z".into() });
        assert_eq!((l, c), (3, 7));
        let (e, ..) = error(&replaced("drift z: v", "drift zz: v"));
        assert_eq!(
            e,
            SemanticError::DriftForUnknownState {
                name: "zz".into(),
                suggestion: Some("z".into())
            }
        );
    }

    #[test]
    fn impacts_diffusions_and_observables_need_states() {
        let (e, ..) = error(&with("impact w = 0: v -> -v"));
        assert!(matches!(
            e,
            SemanticError::UnknownState {
                context: "impact",
                ..
            }
        ));
        let (e, l, c) = error(&with("impact z = 0: z -> -v"));
        assert_eq!(e, SemanticError::ImpactOnItself { state: "z".into() });
        assert_eq!((l, c), (8, 15));
        let (e, ..) = error(&replaced("diffusion v: xi", "diffusion w: xi"));
        assert!(matches!(
            e,
            SemanticError::UnknownState {
                context: "diffusion",
                ..
            }
        ));
        let (e, ..) = error(&with("observe y = abs(w)"));
        assert!(matches!(e, SemanticError::UnknownIdentifier { .. }));
        let (e, ..) = error(&with("observe y = z\nobserve q = y"));
        assert!(matches!(e, SemanticError::ObservableInExpression { .. }));
    }

    #[test]
    fn parameter_cycles_show_the_chain() {
        let (e, l, c) = error(&with("param a = 2*b, b = c + d, d = a"));
        assert_eq!(
            e,
            SemanticError::ParameterCycle {
                name: "a".into(),
                chain: "a -> b -> d -> a".into()
            }
        );
        assert_eq!((l, c), (8, 7));
        let (e, ..) = error(&with("param a = a"));
        assert!(matches!(e, SemanticError::ParameterCycle { .. }));
    }

    #[test]
    fn long_parameter_chains_are_refused_without_recursion() {
        let n = MAX_PARAMETER_CHAIN + 5;
        let mut src = String::from(BASE);
        for i in 0..n {
            src.push_str(&format!("param p{i} = p{} + 1\n", i + 1));
        }
        src.push_str(&format!("param p{n} = 1\n"));
        let (e, ..) = error(&src);
        assert!(matches!(e, SemanticError::ParameterChainTooLong { .. }));
    }

    #[test]
    fn noise_sources_declared_used_and_only_in_diffusion() {
        let (e, l, c) = error(&replaced("diffusion v: xi", "diffusion v: xi + eta"));
        assert_eq!(e, SemanticError::UndeclaredNoise { name: "eta".into() });
        assert_eq!((l, c), (7, 19));
        let (e, l, _) = error(&with("noise eta: intensity 1"));
        assert_eq!(
            (e, l),
            (SemanticError::UnusedNoise { name: "eta".into() }, 8)
        );
        let (e, ..) = error(&replaced("- k*z", "- k*z + xi"));
        assert_eq!(
            e,
            SemanticError::NoiseOutsideDiffusion {
                name: "xi".into(),
                context: "a drift"
            }
        );
        let (e, ..) = error(&with("observe y = xi"));
        assert!(matches!(e, SemanticError::NoiseOutsideDiffusion { .. }));
        let (e, ..) = error(&with("correlate xi, eta: 0.5"));
        assert_eq!(e, SemanticError::UndeclaredNoise { name: "eta".into() });
    }

    #[test]
    fn states_are_not_allowed_in_constants() {
        for (line, context) in [
            ("param a = z", "a parameter default"),
            ("impact z = v: v -> -v", "a barrier position"),
        ] {
            let (e, ..) = error(&with(line));
            assert!(
                matches!(e, SemanticError::StateInConstant { context: c, .. } if c == context),
                "{line}: {e:?}"
            );
        }
        let (e, ..) = error(&replaced("intensity 1", "intensity z"));
        assert!(matches!(
            e,
            SemanticError::StateInConstant {
                context: "a noise intensity",
                ..
            }
        ));
        let src = format!("{BASE}noise eta: intensity 1\ndiffusion z: eta\ncorrelate xi, eta: v\n");
        let (e, ..) = error(&src);
        assert!(matches!(
            e,
            SemanticError::StateInConstant {
                context: "a correlation coefficient",
                ..
            }
        ));
    }

    #[test]
    fn correlations_pair_two_distinct_sources_once() {
        let two = format!("{BASE}noise eta: intensity 1\ndiffusion z: eta\n");
        let (e, ..) = error(&format!("{two}correlate xi, xi: 0.5\n"));
        assert_eq!(e, SemanticError::SelfCorrelation { name: "xi".into() });
        let (e, l, _) = error(&format!(
            "{two}correlate xi, eta: 0.5\ncorrelate eta, xi: 0.1\n"
        ));
        assert!(matches!(
            e,
            SemanticError::DuplicateCorrelation {
                previous_line: 10,
                ..
            }
        ));
        assert_eq!(l, 11);
        let m = parse_model(&format!("{two}correlate eta, xi: 0.3\n"), None).unwrap();
        assert_eq!((m.correlations()[0].a, m.correlations()[0].b), (1, 0));
    }

    #[test]
    fn gaussian_width_must_be_a_positive_number() {
        for w in ["0", "-1e-3", "c", "1/0"] {
            let (e, ..) = error(&with(&format!("delta: gaussian({w})")));
            assert!(
                matches!(e, SemanticError::BadGaussianWidth { .. }),
                "{w}: {e:?}"
            );
        }
        let m = parse_model(&with("delta: gaussian(1e-3)"), None).unwrap();
        assert_eq!(
            m.delta_treatment(),
            DeltaTreatment::Gaussian { width: 1e-3 }
        );
    }

    #[test]
    fn noise_must_enter_linearly() {
        for (rhs, col) in [
            ("xi^2", 14),
            ("xi*z*xi", 19),
            ("z/xi", 16),
            ("sin(xi)", 14),
            ("2*abs(xi)", 16),
        ] {
            let (e, l, c) = error(&replaced("diffusion v: xi", &format!("diffusion v: {rhs}")));
            assert!(
                matches!(e, SemanticError::NonlinearNoise { .. }),
                "{rhs}: {e:?}"
            );
            assert_eq!((l, c), (7, col), "{rhs}");
        }
        let (e, l, c) = error(&replaced("diffusion v: xi", "diffusion v: xi + z"));
        assert_eq!(e, SemanticError::NoiseFreeTerm { state: "v".into() });
        assert_eq!((l, c), (7, 19));
        let (e, ..) = error(&replaced("diffusion v: xi", "diffusion v: c*z"));
        assert!(matches!(e, SemanticError::NoiseFreeTerm { .. }));
    }

    #[test]
    fn noise_coefficients_are_extracted_term_by_term() {
        let src = "model m\nparam a = 1, b = 2\nstate x, v\ndrift x: v\ndrift v: -x\n\
                   noise xi: intensity 1\nnoise eta: intensity 1\n\
                   diffusion v: a*xi + b*eta - (a + b)*xi\ndiffusion x: -eta/2\n";
        let m = parse_model(src, None).unwrap();
        let at = |e: &Expr| {
            e.eval(&|s| match s {
                "a" => Some(1.0),
                "b" => Some(2.0),
                _ => None,
            })
        };
        let g = m.noise_matrix();
        assert_eq!(at(&g[1][0]).unwrap(), -2.0);
        assert_eq!(at(&g[1][1]).unwrap(), 2.0);
        assert_eq!(at(&g[0][0]).unwrap(), 0.0);
        assert_eq!(at(&g[0][1]).unwrap(), -0.5);
        // A coefficient that is a sum keeps its shape.
        let src = BASE.replacen("diffusion v: xi", "diffusion v: (1 + c*z)*xi", 1);
        let m = parse_model(&src, None).unwrap();
        assert_eq!(m.noise_matrix()[1][0].to_string(), "1 + c*z");
    }

    #[test]
    fn malformed_numbers_are_syntax_errors() {
        for bad in ["1e", "2x", "1.2.3", "1e999"] {
            let src = replaced("intensity 1", &format!("intensity {bad}"));
            let err = parse_model(&src, None).unwrap_err();
            assert!(matches!(err, ModelError::Syntax(_)), "{bad}: {err}");
            assert!(err.to_string().contains("malformed number"), "{bad}: {err}");
            assert_eq!((err.line(), err.column()), (Some(6), Some(21)), "{bad}");
        }
    }

    #[test]
    fn misplaced_deltas_are_named_where_they_are_written() {
        let misuse = |drift: &str| match error(&replaced("-c*v - k*z", drift)) {
            (SemanticError::MisplacedDelta { delta, misuse }, l, c) => (delta, misuse, l, c),
            other => panic!("{drift}: {other:?}"),
        };
        let abs = DeltaMisuse::InFunction { func: "abs".into() };
        assert_eq!(
            misuse("-c*v - k*z - abs(delta(z))"),
            ("delta(z)".into(), abs, 5, 27)
        );
        assert_eq!(misuse("-c*v - delta(z)^2").1, DeltaMisuse::InPower);
        assert_eq!(misuse("-c*v - 2^delta(z)").1, DeltaMisuse::InExponent);
        assert_eq!(misuse("-c*v - v/delta(z)").1, DeltaMisuse::InDenominator);
        assert_eq!(
            misuse("-c*v - delta(z)*v*delta(v)").1,
            DeltaMisuse::TimesDelta
        );
        assert_eq!(misuse("-c*v - delta(c)").1, DeltaMisuse::NoState);
        assert_eq!(misuse("-c*v - delta(z + v)").1, DeltaMisuse::BothStates);
        assert_eq!(
            misuse("-c*v - delta(z*z)").1,
            DeltaMisuse::NonlinearArgument { state: "z".into() }
        );
        assert_eq!(
            misuse("-c*v - delta(v)").1,
            DeltaMisuse::OwnDrift { state: "v".into() }
        );
        // The paper's term and its relatives are fine.
        for ok in [
            "-c*v - k*z - (1 - c)*v*abs(v)*delta(z)",
            "-c*v - (1 + delta(z - 1))*v",
            "-c*v - v*delta(2*z + c)",
        ] {
            assert!(
                parse_model(&replaced("-c*v - k*z", ok), None).is_ok(),
                "{ok}"
            );
        }
        let (e, l, c) = error(&with("impact z = 0: v -> delta(z)*v"));
        assert!(matches!(
            e,
            SemanticError::MisplacedDelta {
                misuse: DeltaMisuse::InImpactMap,
                ..
            }
        ));
        assert_eq!((l, c), (8, 20));
        let (e, ..) = error(&replaced("diffusion v: xi", "diffusion v: delta(z)*xi"));
        assert!(matches!(
            e,
            SemanticError::MisplacedDelta {
                misuse: DeltaMisuse::InDiffusion,
                ..
            }
        ));
        let (e, ..) = error(&replaced("intensity 1", "intensity delta(1)"));
        assert!(matches!(
            e,
            SemanticError::MisplacedDelta {
                misuse: DeltaMisuse::InConstant {
                    context: "a noise intensity"
                },
                ..
            }
        ));
    }

    #[test]
    fn edit_distance_counts_single_edits() {
        assert_eq!(edit_distance("mu", "mu"), 0);
        assert_eq!(edit_distance("mux", "mu"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(
            closest("epss", ["eps", "c"].into_iter()),
            Some("eps".into())
        );
        assert_eq!(closest("q", ["eps", "c"].into_iter()), Some("c".into()));
        assert_eq!(closest("zeta", ["eps", "c"].into_iter()), None);
    }
}
