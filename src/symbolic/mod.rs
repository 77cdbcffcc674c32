//! Symbolic expressions: the tree, its simplification and differentiation (with the
//! distributional rules for `abs`, `sgn` and `delta`), and compilation to a flat tape.

mod delta;
mod diff;
mod error;
mod expr;
mod print;
mod sift;
mod simplify;
mod tape;

pub use delta::{DeltaLine, DeltaSplit};
pub use diff::diff;
pub use error::SymbolicError;
pub use expr::{powf, sgn, DeltaPolicy, EvalError, Expr, Func, Symbol};
pub use sift::sift;
pub use simplify::{expand, simplify};
pub(crate) use tape::Interval;
pub(crate) use tape::{Op as TapeOp, Unary as TapeUnary};
pub use tape::{Tape, TapeScratch};
