//! Model evaluation for the simulator: expressions of the two states, compiled once and
//! evaluated over a whole batch of trajectories at a time (structure-of-arrays).
//!
//! Everything the simulator evaluates goes through [`BatchKernel`] and [`compile`], which
//! uses the crate's compiled [`Tape`]; another evaluator needs only a new `compile`.

use super::error::McError;
use crate::symbolic::{DeltaPolicy, Expr, Tape, TapeScratch};

/// Working memory of a kernel's batch evaluation.
pub(crate) type Scratch = TapeScratch;

/// Expressions of the states `(x, v)`, evaluated for many points at once.
pub(crate) trait BatchKernel: Send + Sync {
    /// Evaluates every output at the points `(x[i], v[i])`: output `j` at point `i` goes to
    /// `out[j * n + i]`, `n = x.len()`. `scratch` is the caller's reusable buffer.
    fn eval_batch(&self, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch);
    /// Evaluates every output at one point.
    fn eval_point(&self, x: f64, v: f64, out: &mut [f64]);
}

/// Compiles `exprs` (expressions of the states named `states`) with `delta(·) = 0`, as is
/// right between impacts.
pub(crate) fn compile(exprs: &[Expr], states: [&str; 2]) -> Result<Box<dyn BatchKernel>, McError> {
    Ok(Box::new(Tape::compile(exprs, &states, DeltaPolicy::Zero)?))
}

impl BatchKernel for Tape {
    fn eval_batch(&self, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch) {
        let n = x.len();
        let out = &mut out[..n * self.n_outputs()];
        // Output rows as slices of `out`, on the stack for the kernels the schemes use.
        const STACK_ROWS: usize = 8;
        let k = self.n_outputs();
        if k == 0 || n == 0 {
            return;
        }
        if k <= STACK_ROWS {
            let mut chunks = out.chunks_mut(n);
            let mut rows: [&mut [f64]; STACK_ROWS] =
                std::array::from_fn(|_| chunks.next().unwrap_or(&mut []));
            Tape::eval_batch(self, &[x, v], &mut rows[..k], scratch);
        } else {
            let mut rows: Vec<&mut [f64]> = out.chunks_mut(n).collect();
            Tape::eval_batch(self, &[x, v], &mut rows, scratch);
        }
    }

    fn eval_point(&self, x: f64, v: f64, out: &mut [f64]) {
        let mut scratch = Vec::new();
        self.eval(&[x, v], &mut scratch, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::{DeltaPolicy, Func};

    fn z() -> Expr {
        Expr::sym("z")
    }
    fn v() -> Expr {
        Expr::sym("v")
    }

    #[test]
    fn agrees_with_tree_evaluation_with_deltas_as_zero() {
        let exprs = vec![
            -(Expr::num(0.1) * v())
                - Expr::num(2.0) * z()
                - Expr::num(0.5) * Expr::pow(z(), Expr::num(3.0))
                - Expr::num(0.3) * v() * Expr::call(Func::Abs, v()) * Expr::call(Func::Delta, z()),
            Expr::call(Func::Sgn, z()) + Expr::num(0.2) * z(),
            Expr::pow(Expr::call(Func::Abs, z()), Expr::num(0.5)) / (Expr::num(1.0) + v() * v()),
            Expr::Call(Func::Max, vec![z(), Expr::call(Func::Tanh, v())]),
            Expr::num(3.0),
        ];
        {
            let k = compile(&exprs, ["z", "v"]).unwrap();
            let xs = [-1.5, -0.0, 0.0, 0.7, 2.0];
            let vs = [0.3, -2.0, 1.0, -0.1, 0.0];
            let mut out = vec![0.0; exprs.len() * xs.len()];
            let mut scratch = Scratch::new();
            k.eval_batch(&xs, &vs, &mut out, &mut scratch);
            for (j, e) in exprs.iter().enumerate() {
                for i in 0..xs.len() {
                    let want = e
                        .eval_with(
                            &|s| Some(if s == "z" { xs[i] } else { vs[i] }),
                            DeltaPolicy::Zero,
                        )
                        .unwrap();
                    let got = out[j * xs.len() + i];
                    assert!(
                        (got - want).abs() <= 1e-14 * want.abs().max(1.0),
                        "{e} at ({}, {}): {got} vs {want}",
                        xs[i],
                        vs[i]
                    );
                }
            }
            let mut one = vec![0.0; exprs.len()];
            k.eval_point(0.7, -0.1, &mut one);
            assert_eq!(one[1], 1.0 + 0.2 * 0.7);
        }
    }

    #[test]
    fn unknown_symbols_are_errors() {
        let e = Expr::sym("k") * z();
        assert!(matches!(
            compile(&[e], ["z", "v"]),
            Err(McError::Compile(crate::symbolic::SymbolicError::Unbound(s))) if &*s == "k"
        ));
    }
}
