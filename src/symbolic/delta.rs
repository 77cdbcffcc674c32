//! Expressions with Dirac deltas, split into a regular part and line terms (sifting).

use super::Expr;

/// One term `weight · δ(x_axis − at)` of a split expression. By the sifting rule the weight
/// no longer depends on `x_axis`: it is the factor evaluated on the line `x_axis = at`.
///
/// ```
/// use fpsolve::symbolic::{sift, Expr, Func};
/// let e = Expr::sym("v") * Expr::call(Func::Delta, Expr::sym("z"));
/// let split = sift(&e, &["z".into(), "v".into()]).unwrap();
/// assert_eq!((split.lines[0].axis, split.lines[0].at), (0, 0.0));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DeltaLine {
    /// Index (0 or 1) of the state the delta acts on.
    pub axis: usize,
    /// Where the line is: the delta is `δ(x_axis − at)`.
    pub at: f64,
    /// The weight, an expression of the other state only.
    pub weight: Expr,
}

/// An expression split as `regular + Σ lines`: `regular` has no delta, each line term is a
/// weight times one delta of one state.
///
/// ```
/// use fpsolve::symbolic::{sift, Expr, Func};
/// let e = Expr::sym("z") + Expr::call(Func::Delta, Expr::sym("z"));
/// let split = sift(&e, &["z".into(), "v".into()]).unwrap();
/// assert_eq!((split.regular.to_string(), split.lines.len()), ("z".to_string(), 1));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DeltaSplit {
    /// The part without deltas (an ordinary function of the states).
    pub regular: Expr,
    /// The delta terms, at most one per (axis, position) after collection.
    pub lines: Vec<DeltaLine>,
}
