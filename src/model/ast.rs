//! The syntax tree of a model file: what was written, where, before any name is resolved.
//!
//! Every node keeps its [`Span`] (a byte range into the source) so that the validator can
//! point at the exact place a mistake was made. Sums and products are n-ary
//! ([`ExprKind::Sum`], [`ExprKind::Product`]): a left-associative chain `a - b - c` is one
//! node, so the tree's height grows only with parentheses, calls, `^` and unary minus, which
//! the parser bounds before any recursive stage runs.

/// A byte range `start..end` into the model source.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// The span from `start` to `end`.
    pub fn new(start: usize, end: usize) -> Span {
        Span { start, end }
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }
}

/// A name as written, with where it was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ident {
    /// The name.
    pub name: String,
    /// Where.
    pub span: Span,
}

/// The sign in front of a term of a [`ExprKind::Sum`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SumOp {
    /// `+` (also the implicit sign of the first term).
    Plus,
    /// `-`.
    Minus,
}

/// The operator in front of a factor of a [`ExprKind::Product`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProductOp {
    /// `*` (also the implicit operator of the first factor).
    Times,
    /// `/`.
    Divide,
}

/// An expression node with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct ExprNode {
    /// What the node is.
    pub kind: ExprKind,
    /// Where it was written (parentheses around it excluded).
    pub span: Span,
}

/// The kinds of expression node.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A numeric literal, already converted.
    Number(f64),
    /// A literal glued to letters or dots (`1e`, `2x`, `1.2.3`): kept so that the validator
    /// can name it in its error.
    MalformedNumber(String),
    /// A name: parameter, state, noise source, or the constants `pi` and `e`.
    Name(String),
    /// `f(a, b, ...)`, the function not yet looked up.
    Call {
        /// The function's name as written.
        func: Ident,
        /// The arguments.
        args: Vec<ExprNode>,
    },
    /// Unary minus.
    Neg(Box<ExprNode>),
    /// `a + b - c ...`: the first term's operator is always [`SumOp::Plus`].
    Sum(Vec<(SumOp, ExprNode)>),
    /// `a * b / c ...`: the first factor's operator is always [`ProductOp::Times`].
    Product(Vec<(ProductOp, ExprNode)>),
    /// `base ^ exponent`.
    Pow(Box<ExprNode>, Box<ExprNode>),
}

/// `name = expression`, in `param` and `observe` lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Binding {
    /// The name being defined.
    pub name: Ident,
    /// Its definition.
    pub value: ExprNode,
}

/// The argument of a `delta:` line.
#[derive(Clone, Debug, PartialEq)]
pub enum DeltaSpec {
    /// `exact`.
    Exact,
    /// `gaussian(width)`.
    Gaussian(ExprNode),
}

/// One bound of a `domain` line: `>= at` / `> at` (a lower bound) or `<= at` / `< at`.
#[derive(Clone, Debug, PartialEq)]
pub struct DomainLimit {
    /// Where the bound is.
    pub at: ExprNode,
    /// `<` or `>` rather than `<=` or `>=` (the same density; kept for printing).
    pub strict: bool,
}

/// One line of a model file.
#[derive(Clone, Debug, PartialEq)]
pub struct Statement {
    /// What the line says.
    pub kind: StatementKind,
    /// The whole statement (comments excluded).
    pub span: Span,
    /// The span of its leading keyword.
    pub keyword: Span,
}

/// The statements of the model language.
#[derive(Clone, Debug, PartialEq)]
pub enum StatementKind {
    /// `model name "description"`.
    Model {
        /// The model's name.
        name: Ident,
        /// The description without its quotes (empty if absent).
        description: String,
    },
    /// `param a = 1, b = 2*a`.
    Param(Vec<Binding>),
    /// `state z, v`.
    State(Vec<Ident>),
    /// `drift v: expression`.
    Drift {
        /// The state whose rate this is.
        state: Ident,
        /// The rate.
        expr: ExprNode,
    },
    /// `noise xi: intensity expression`.
    Noise {
        /// The source's name.
        name: Ident,
        /// Its intensity.
        intensity: ExprNode,
    },
    /// `correlate xi, eta: rho`.
    Correlate {
        /// First source.
        a: Ident,
        /// Second source.
        b: Ident,
        /// The correlation coefficient.
        coefficient: ExprNode,
    },
    /// `diffusion v: expression linear in the noise symbols`.
    Diffusion {
        /// The state whose equation the noise enters.
        state: Ident,
        /// The noise term.
        expr: ExprNode,
    },
    /// `interpretation: ito` or `stratonovich`.
    Interpretation(super::Interpretation),
    /// `impact z = at: v -> map`.
    Impact {
        /// The state that meets the barrier.
        state: Ident,
        /// The barrier's position.
        at: ExprNode,
        /// The state that jumps.
        other: Ident,
        /// Its value after the impact.
        map: ExprNode,
    },
    /// `domain y >= 0`, `domain y <= b`, `domain a <= y <= b`.
    Domain {
        /// The state the domain restricts.
        state: Ident,
        /// Its lower bound, if any.
        lower: Option<DomainLimit>,
        /// Its upper bound, if any.
        upper: Option<DomainLimit>,
    },
    /// `domain theta periodic 2*pi`: the state is an angle, taken modulo the period.
    Periodic {
        /// The periodic state.
        state: Ident,
        /// The period, a constant.
        period: ExprNode,
    },
    /// `observe y = abs(z), ydot = v*sgn(z)`.
    Observe(Vec<Binding>),
    /// `delta: exact` or `delta: gaussian(width)`.
    Delta(DeltaSpec),
    /// `safe abs(z) < 2.5`, `safe -2 < z < 3`: the safe set of a first-passage problem.
    Safe(SafeSpec),
    /// `initial rest`, `initial point ...`, `initial gaussian mean ... cov ...`.
    Initial(InitialAst),
}

/// Where a transient starts, as written.
#[derive(Clone, Debug, PartialEq)]
pub enum InitialAst {
    /// `rest`.
    Rest,
    /// `point z = 1, v = 0`.
    Point(Vec<Binding>),
    /// `gaussian mean z = 0, v = 0 cov 1, 0, 0, 1`.
    Gaussian {
        /// The mean of each state.
        mean: Vec<Binding>,
        /// The covariance's entries, row by row.
        covariance: Vec<ExprNode>,
        /// The span of the entries.
        span: Span,
    },
}

/// The safe set as written: a quantity (a function of states, observables and parameters)
/// with a lower bound, an upper bound, or both.
#[derive(Clone, Debug, PartialEq)]
pub struct SafeSpec {
    /// The quantity bounded.
    pub quantity: ExprNode,
    /// Its lower bound, if any.
    pub lower: Option<DomainLimit>,
    /// Its upper bound, if any.
    pub upper: Option<DomainLimit>,
}

/// A parsed model file: its statements in order.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ModelAst {
    /// The statements, in file order.
    pub statements: Vec<Statement>,
}

#[cfg(test)]
mod tests {
    use super::Span;

    #[test]
    fn a_span_joined_to_another_covers_both() {
        assert_eq!(Span::new(1, 3).to(Span::new(6, 9)), Span::new(1, 9));
        assert_eq!(Span::new(6, 9).to(Span::new(1, 3)), Span::new(1, 9));
    }
}
