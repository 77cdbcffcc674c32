//! Symbolic expressions: the tree, its simplification and differentiation (with the
//! distributional rules for `abs`, `sgn` and `delta`), and compilation to a flat tape.

mod delta;
mod expr;

pub use delta::{DeltaLine, DeltaSplit};
pub use expr::{powf, sgn, DeltaPolicy, EvalError, Expr, Func, Symbol};
