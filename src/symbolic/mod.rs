//! Symbolic expressions: the tree, its simplification and differentiation (with the
//! distributional rules for `abs`, `sgn` and `delta`), and compilation to a flat tape.

mod expr;

pub use expr::{powf, sgn, DeltaPolicy, EvalError, Expr, Func, Symbol};
