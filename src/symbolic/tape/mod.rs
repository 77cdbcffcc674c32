//! Expressions compiled to a flat instruction tape for hot loops (Monte Carlo steps, quadrature).
//!
//! The tree form is right for differentiation and printing, but walking it per point costs a
//! closure call per symbol and a branch per node. A [`Tape`] is one flat list of instructions,
//! children before parents, whose operands are indices of earlier instructions: constants are
//! folded, common subexpressions are shared between all outputs (hash-consing), integer powers
//! become multiplications, and `delta(...)` is resolved once by a [`DeltaPolicy`].

mod build;
mod op;
#[cfg(test)]
mod tests;

use std::collections::HashMap;

use super::{DeltaPolicy, Expr, SymbolicError};
use build::Builder;
use op::{Op, Unary};

/// Several expressions compiled together into one flat instruction list.
///
/// ```
/// use fpsolve::symbolic::{DeltaPolicy, Expr, Tape};
/// let z = Expr::sym("z");
/// let v = Expr::sym("v");
/// let drift = Expr::num(-0.1) * v.clone() - z.clone() - Expr::num(0.1) * Expr::pow(z, Expr::num(3.0));
/// let tape = Tape::compile(&[v, drift], &["z", "v"], DeltaPolicy::Reject).unwrap();
/// let mut scratch = Vec::new();
/// let mut out = [0.0; 2];
/// tape.eval(&[-2.0, 1.0], &mut scratch, &mut out);
/// assert_eq!(out, [1.0, -0.1 + 2.0 + 0.8]);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    ops: Vec<Op>,
    outputs: Vec<u32>,
    n_vars: usize,
}

/// Reusable working memory for [`Tape::eval_batch`], so that batches allocate only when they
/// first meet a larger tape.
#[derive(Clone, Debug, Default)]
pub struct TapeScratch {
    slots: Vec<f64>,
}

impl TapeScratch {
    /// Empty working memory; it grows on first use.
    ///
    /// ```
    /// let _s = fpsolve::symbolic::TapeScratch::new();
    /// ```
    pub fn new() -> TapeScratch {
        TapeScratch::default()
    }
}

/// Points per block in [`Tape::eval_batch`]: long enough for the inner loops to vectorise,
/// short enough that a tape's slots for one block stay in cache.
const BLOCK: usize = 128;

impl Tape {
    /// Compiles `exprs` (the outputs, in order) over the variables `vars` (the inputs, in the
    /// order [`Tape::eval`] takes them), treating `delta(...)` as `delta` says.
    ///
    /// # Errors
    /// [`SymbolicError::Unbound`] for a symbol not in `vars`; [`SymbolicError::DeltaRejected`]
    /// for a delta under [`DeltaPolicy::Reject`]; [`SymbolicError::BadDeltaWidth`];
    /// [`SymbolicError::NotFinite`] for a constant subexpression such as `log(-1)`;
    /// [`SymbolicError::Arity`] for a malformed call.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Func, SymbolicError, Tape};
    /// let e = Expr::call(Func::Delta, Expr::sym("z")) * Expr::sym("k");
    /// assert_eq!(
    ///     Tape::compile(std::slice::from_ref(&e), &["z"], DeltaPolicy::Zero),
    ///     Err(SymbolicError::Unbound("k".into()))
    /// );
    /// assert!(Tape::compile(&[e], &["z", "k"], DeltaPolicy::Reject).is_err());
    /// ```
    pub fn compile(
        exprs: &[Expr],
        vars: &[&str],
        delta: DeltaPolicy,
    ) -> Result<Tape, SymbolicError> {
        let mut b = Builder {
            ops: Vec::new(),
            seen: HashMap::new(),
            vars,
            delta,
        };
        let outputs = exprs
            .iter()
            .map(|e| b.compile(e))
            .collect::<Result<Vec<_>, _>>()?;
        let mut tape = Tape {
            ops: b.ops,
            outputs,
            n_vars: vars.len(),
        };
        tape.drop_dead_code();
        Ok(tape)
    }

    /// Removes instructions no output depends on (left behind by folding and peepholes) and
    /// renumbers the rest, keeping children before parents.
    fn drop_dead_code(&mut self) {
        let mut live = vec![false; self.ops.len()];
        for &o in &self.outputs {
            live[o as usize] = true;
        }
        for i in (0..self.ops.len()).rev() {
            if live[i] {
                let (operands, n) = self.ops[i].operands();
                for &a in &operands[..n] {
                    live[a as usize] = true;
                }
            }
        }
        let mut new_index = vec![u32::MAX; self.ops.len()];
        let mut ops = Vec::with_capacity(self.ops.len());
        for (i, op) in self.ops.iter().enumerate() {
            if live[i] {
                new_index[i] = ops.len() as u32;
                ops.push(op.map_operands(|a| new_index[a as usize]));
            }
        }
        for o in &mut self.outputs {
            *o = new_index[*o as usize];
        }
        self.ops = ops;
    }

    /// How many expressions the tape computes.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Tape};
    /// let t = Tape::compile(&[Expr::sym("x"), Expr::num(2.0)], &["x"], DeltaPolicy::Reject).unwrap();
    /// assert_eq!(t.n_outputs(), 2);
    /// ```
    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// How many variables [`Tape::eval`] expects.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Tape};
    /// let t = Tape::compile(&[Expr::sym("x")], &["x", "y"], DeltaPolicy::Reject).unwrap();
    /// assert_eq!(t.n_vars(), 2);
    /// ```
    pub fn n_vars(&self) -> usize {
        self.n_vars
    }

    /// How many instructions the tape has (after folding and sharing).
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Tape};
    /// // x^4 = (x·x)·(x·x): the variable and two multiplications.
    /// let t = Tape::compile(&[Expr::pow(Expr::sym("x"), Expr::num(4.0))], &["x"], DeltaPolicy::Reject).unwrap();
    /// assert_eq!(t.len(), 3);
    /// ```
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// Whether the tape has no instructions (only when it has no outputs).
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Tape};
    /// assert!(Tape::compile(&[], &[], DeltaPolicy::Reject).unwrap().is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// Evaluates every output at one point `x` (values of the variables in compile order) into
    /// `out`. `scratch` is working memory, resized on first use and reused afterwards, so a
    /// loop over points does not allocate.
    ///
    /// # Panics
    /// If `x.len() != self.n_vars()` or `out.len() != self.n_outputs()`.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Func, Tape};
    /// let c = Expr::pow(Expr::call(Func::Sgn, Expr::sym("z")) + Expr::num(0.1) * Expr::sym("z"), Expr::num(2.0));
    /// let tape = Tape::compile(&[c], &["z"], DeltaPolicy::Reject).unwrap();
    /// let (mut scratch, mut out) = (Vec::new(), [0.0]);
    /// tape.eval(&[0.0], &mut scratch, &mut out);
    /// assert_eq!(out[0], 0.0); // sgn(0) = 0
    /// tape.eval(&[-2.0], &mut scratch, &mut out);
    /// assert!((out[0] - 1.44).abs() < 1e-15);
    /// ```
    pub fn eval(&self, x: &[f64], scratch: &mut Vec<f64>, out: &mut [f64]) {
        assert_eq!(
            x.len(),
            self.n_vars,
            "Tape::eval: wrong number of variables"
        );
        assert_eq!(
            out.len(),
            self.outputs.len(),
            "Tape::eval: wrong number of outputs"
        );
        scratch.resize(self.ops.len(), 0.0);
        let s = scratch.as_mut_slice();
        for (i, &op) in self.ops.iter().enumerate() {
            // Operands always precede their instruction, so every read is of a value already
            // computed. One flat match keeps the dispatch to a single jump per instruction;
            // in each arm the variant is known, so `apply` folds to the bare operation.
            let g = |a: u32| s[a as usize];
            let v = match op {
                Op::Const(_) => op.apply(0.0, 0.0),
                Op::Var(k) => op.apply(x[k as usize], 0.0),
                Op::Add(a, b) => op.apply(g(a), g(b)),
                Op::Sub(a, b) => op.apply(g(a), g(b)),
                Op::Mul(a, b) => op.apply(g(a), g(b)),
                Op::Div(a, b) => op.apply(g(a), g(b)),
                Op::Min(a, b) => op.apply(g(a), g(b)),
                Op::Max(a, b) => op.apply(g(a), g(b)),
                Op::Pow(a, b) => op.apply(g(a), g(b)),
                Op::AddC(a, _) => op.apply(g(a), 0.0),
                Op::MulC(a, _) => op.apply(g(a), 0.0),
                Op::Neg(a) => op.apply(g(a), 0.0),
                Op::Recip(a) => op.apply(g(a), 0.0),
                Op::PowC(a, _) => op.apply(g(a), 0.0),
                Op::Unary(_, a) => op.apply(g(a), 0.0),
                Op::Gauss { arg, .. } => op.apply(g(arg), 0.0),
            };
            s[i] = v;
        }
        for (o, &slot) in out.iter_mut().zip(&self.outputs) {
            *o = s[slot as usize];
        }
    }

    /// Evaluates every output over a batch of points given as columns (`cols[k][p]` is variable
    /// `k` at point `p`), writing `out[j][p]`. Each instruction runs as a tight loop over a
    /// block of points, so the work vectorises; `scratch` is reused between calls.
    ///
    /// # Panics
    /// If `cols.len() != self.n_vars()`, `out.len() != self.n_outputs()`, or the columns and
    /// output rows do not all have the same length.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Tape, TapeScratch};
    /// let e = Expr::sym("x") * Expr::sym("y") + Expr::num(1.0);
    /// let tape = Tape::compile(&[e], &["x", "y"], DeltaPolicy::Reject).unwrap();
    /// let (x, y) = ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]);
    /// let mut out = vec![vec![0.0; 3]];
    /// tape.eval_batch(&[&x, &y], &mut out, &mut TapeScratch::new());
    /// assert_eq!(out[0], [5.0, 11.0, 19.0]);
    /// ```
    pub fn eval_batch<O: AsMut<[f64]>>(
        &self,
        cols: &[&[f64]],
        out: &mut [O],
        scratch: &mut TapeScratch,
    ) {
        assert_eq!(
            cols.len(),
            self.n_vars,
            "Tape::eval_batch: wrong number of variables"
        );
        assert_eq!(
            out.len(),
            self.outputs.len(),
            "Tape::eval_batch: wrong number of outputs"
        );
        let n = cols
            .first()
            .map(|c| c.len())
            .or_else(|| out.first_mut().map(|o| o.as_mut().len()))
            .unwrap_or(0);
        assert!(
            cols.iter().all(|c| c.len() == n),
            "Tape::eval_batch: columns of different lengths"
        );
        assert!(
            out.iter_mut().all(|o| o.as_mut().len() == n),
            "Tape::eval_batch: output rows must have the columns' length"
        );
        scratch.slots.resize(self.ops.len() * BLOCK, 0.0);
        let mut start = 0;
        while start < n {
            let len = BLOCK.min(n - start);
            self.eval_block(cols, start, len, &mut scratch.slots);
            for (o, &slot) in out.iter_mut().zip(&self.outputs) {
                let src = &scratch.slots[slot as usize * BLOCK..][..len];
                o.as_mut()[start..start + len].copy_from_slice(src);
            }
            start += len;
        }
    }

    /// Runs the tape over points `start..start + len` into `slots` (`BLOCK` values per slot).
    fn eval_block(&self, cols: &[&[f64]], start: usize, len: usize, slots: &mut [f64]) {
        for (i, &op) in self.ops.iter().enumerate() {
            // Operands precede instruction `i`, so splitting at its slot gives disjoint borrows.
            let (done, rest) = slots.split_at_mut(i * BLOCK);
            let dst = &mut rest[..len];
            let src = |a: u32| &done[a as usize * BLOCK..][..len];
            // Each arm runs `apply` of a known variant over the block (it folds to the bare
            // operation, which vectorises); unary functions are split per function for that.
            let unary = |u: Unary| move |x: f64| u.apply(x);
            match op {
                Op::Const(_) => dst.fill(op.apply(0.0, 0.0)),
                Op::Var(k) => zip1(dst, &cols[k as usize][start..start + len], |x| {
                    op.apply(x, 0.0)
                }),
                Op::Add(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Sub(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Mul(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Div(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Min(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Max(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::Pow(a, b) => zip2(dst, src(a), src(b), |x, y| op.apply(x, y)),
                Op::AddC(a, _) => zip1(dst, src(a), |x| op.apply(x, 0.0)),
                Op::MulC(a, _) => zip1(dst, src(a), |x| op.apply(x, 0.0)),
                Op::Neg(a) => zip1(dst, src(a), |x| op.apply(x, 0.0)),
                Op::Recip(a) => zip1(dst, src(a), |x| op.apply(x, 0.0)),
                Op::PowC(a, _) => zip1(dst, src(a), |x| op.apply(x, 0.0)),
                Op::Unary(f, a) => match f {
                    Unary::Abs => zip1(dst, src(a), unary(Unary::Abs)),
                    Unary::Sgn => zip1(dst, src(a), unary(Unary::Sgn)),
                    Unary::Exp => zip1(dst, src(a), unary(Unary::Exp)),
                    Unary::Log => zip1(dst, src(a), unary(Unary::Log)),
                    Unary::Sqrt => zip1(dst, src(a), unary(Unary::Sqrt)),
                    Unary::Sin => zip1(dst, src(a), unary(Unary::Sin)),
                    Unary::Cos => zip1(dst, src(a), unary(Unary::Cos)),
                    Unary::Tanh => zip1(dst, src(a), unary(Unary::Tanh)),
                },
                Op::Gauss { arg, .. } => zip1(dst, src(arg), |x| op.apply(x, 0.0)),
            }
        }
    }
}

#[inline(always)]
fn zip1(dst: &mut [f64], a: &[f64], f: impl Fn(f64) -> f64) {
    for (d, &x) in dst.iter_mut().zip(a) {
        *d = f(x);
    }
}

#[inline(always)]
fn zip2(dst: &mut [f64], a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> f64) {
    for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
        *d = f(x, y);
    }
}
