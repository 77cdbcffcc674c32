//! The symbolic layer's error type.

use super::Symbol;

/// Why a symbolic operation (compilation, differentiation, sifting) failed. Expressions are
/// carried as printed text so the message shows the user what went wrong.
///
/// ```
/// use fpsolve::symbolic::{DeltaPolicy, Expr, SymbolicError, Tape};
/// let err = Tape::compile(&[Expr::sym("k")], &["z"], DeltaPolicy::Reject).unwrap_err();
/// assert_eq!(err, SymbolicError::Unbound("k".into()));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SymbolicError {
    /// A symbol that is neither a tape variable nor bound to a number.
    #[error("unbound symbol `{0}`: give it a value or list it as a variable")]
    Unbound(Symbol),
    /// A Dirac delta met by a compilation that was told to refuse them.
    #[error("`{expr}` has no pointwise value (a Dirac delta); choose a delta policy")]
    DeltaRejected {
        /// The delta call, printed.
        expr: String,
    },
    /// A Gaussian delta regulariser whose width is not a positive finite number.
    #[error("delta regulariser width {width} must be positive and finite")]
    BadDeltaWidth {
        /// The offending width.
        width: f64,
    },
    /// A subexpression made only of numbers that evaluates to NaN or ±∞.
    #[error("`{expr}` evaluates to {value}, not a finite number")]
    NotFinite {
        /// The constant subexpression, printed.
        expr: String,
        /// What it evaluates to.
        value: f64,
    },
    /// A call with the wrong number of arguments.
    #[error("`{func}` takes {expected} argument(s), got {got}")]
    Arity {
        /// The function's name.
        func: &'static str,
        /// Its arity.
        expected: usize,
        /// How many arguments the call had.
        got: usize,
    },
    /// The derivative of a Dirac delta with respect to a variable its argument depends on:
    /// δ′ is not representable in this layer and must not be turned into a number.
    #[error("derivative of `{expr}` with respect to `{var}`: delta' is not supported")]
    DeltaDerivative {
        /// The delta call, printed.
        expr: String,
        /// The differentiation variable.
        var: Symbol,
    },
    /// A product of distributions (δ·δ, δ·sgn on the same line) that has no meaning.
    #[error("`{product}` multiplies a Dirac delta by a function discontinuous on its support; the product is meaningless")]
    MeaninglessProduct {
        /// The offending product, printed.
        product: String,
    },
    /// A term with deltas of both states: a point mass, which the line split cannot hold.
    #[error("`{term}` is a point mass (deltas of both states); only line deltas are supported")]
    PointMass {
        /// The offending term, printed.
        term: String,
    },
    /// A delta whose argument is not linear in exactly one state (or is constant).
    #[error("`{expr}`: the delta's argument must be a*x + b in exactly one state with a != 0")]
    NonLinearDelta {
        /// The delta call, printed.
        expr: String,
    },
    /// A line weight that still depends on the delta's state after sifting.
    #[error("weight `{weight}` of a delta in `{state}` still depends on `{state}` after sifting")]
    SiftFailed {
        /// The weight after substitution, printed.
        weight: String,
        /// The state.
        state: Symbol,
    },
}
