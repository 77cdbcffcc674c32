//! Expressions compiled to a flat instruction tape for hot loops (Monte Carlo steps, quadrature).
//!
//! The tree form is right for differentiation and printing, but walking it per point costs a
//! closure call per symbol and a branch per node. A [`Tape`] is one flat list of instructions,
//! children before parents, whose operands are indices of earlier instructions: constants are
//! folded, common subexpressions are shared between all outputs (hash-consing), integer powers
//! become multiplications, and `delta(...)` is resolved once by a [`DeltaPolicy`].
//!
//! The instruction set, the builder and the evaluators stay in this one file on purpose: split
//! into modules, the point evaluator measured 10–20% slower in `benches/tape.rs` (the code lands
//! in other codegen units), with the same source.

mod interval;
#[cfg(test)]
mod tests;

pub(crate) use interval::Interval;

use std::collections::HashMap;

use super::{sgn, DeltaPolicy, Expr, Func, SymbolicError};

/// One tape instruction. The value of instruction `i` lives in slot `i`; operands are slots of
/// earlier instructions. Crate-visible so that other evaluators of a compiled tape (the
/// simulator's lane programs) run the same instructions rather than compiling their own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Op {
    Const(f64),
    Var(u32),
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    AddC(u32, f64),
    MulC(u32, f64),
    Neg(u32),
    Recip(u32),
    Unary(Unary, u32),
    Min(u32, u32),
    Max(u32, u32),
    /// `a ^ c` for a constant, non-integer `c`.
    PowC(u32, f64),
    /// `a ^ b` for a variable exponent (integer exponents still exact, via [`super::powf`]).
    Pow(u32, u32),
    /// The Gaussian stand-in for `delta(a)`: `norm · exp(−(a·inv_width)²/2)`.
    Gauss {
        arg: u32,
        inv_width: f64,
        norm: f64,
    },
}

/// The one-operand functions of [`Op::Unary`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Unary {
    Abs,
    Sgn,
    Exp,
    Log,
    Sqrt,
    Sin,
    Cos,
    Tanh,
}

impl Unary {
    #[inline(always)]
    pub(crate) fn apply(self, u: f64) -> f64 {
        match self {
            Unary::Abs => u.abs(),
            Unary::Sgn => sgn(u),
            Unary::Exp => u.exp(),
            Unary::Log => u.ln(),
            Unary::Sqrt => u.sqrt(),
            Unary::Sin => u.sin(),
            Unary::Cos => u.cos(),
            Unary::Tanh => u.tanh(),
        }
    }
}

/// The hash-consing key of an instruction: its tag, operands and constants' bit patterns.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct Key(u8, u32, u32, u64, u64);

impl Op {
    fn key(self) -> Key {
        match self {
            Op::Const(c) => Key(0, 0, 0, c.to_bits(), 0),
            Op::Var(i) => Key(1, i, 0, 0, 0),
            // Commutative operations: order the operands so that a+b and b+a share a slot.
            Op::Add(a, b) => Key(2, a.min(b), a.max(b), 0, 0),
            Op::Sub(a, b) => Key(3, a, b, 0, 0),
            Op::Mul(a, b) => Key(4, a.min(b), a.max(b), 0, 0),
            Op::Div(a, b) => Key(5, a, b, 0, 0),
            Op::AddC(a, c) => Key(6, a, 0, c.to_bits(), 0),
            Op::MulC(a, c) => Key(7, a, 0, c.to_bits(), 0),
            Op::Neg(a) => Key(8, a, 0, 0, 0),
            Op::Recip(a) => Key(9, a, 0, 0, 0),
            Op::Unary(f, a) => Key(10 + f as u8, a, 0, 0, 0),
            Op::Min(a, b) => Key(30, a.min(b), a.max(b), 0, 0),
            Op::Max(a, b) => Key(31, a.min(b), a.max(b), 0, 0),
            Op::PowC(a, c) => Key(32, a, 0, c.to_bits(), 0),
            Op::Pow(a, b) => Key(33, a, b, 0, 0),
            Op::Gauss {
                arg,
                inv_width,
                norm,
            } => Key(34, arg, 0, inv_width.to_bits(), norm.to_bits()),
        }
    }

    /// The operand slots of the instruction.
    pub(crate) fn operands(self) -> ([u32; 2], usize) {
        match self {
            Op::Const(_) | Op::Var(_) => ([0, 0], 0),
            Op::Add(a, b)
            | Op::Sub(a, b)
            | Op::Mul(a, b)
            | Op::Div(a, b)
            | Op::Min(a, b)
            | Op::Max(a, b)
            | Op::Pow(a, b) => ([a, b], 2),
            Op::AddC(a, _)
            | Op::MulC(a, _)
            | Op::Neg(a)
            | Op::Recip(a)
            | Op::Unary(_, a)
            | Op::PowC(a, _)
            | Op::Gauss { arg: a, .. } => ([a, 0], 1),
        }
    }

    fn map_operands(self, f: impl Fn(u32) -> u32) -> Op {
        match self {
            Op::Const(_) | Op::Var(_) => self,
            Op::Add(a, b) => Op::Add(f(a), f(b)),
            Op::Sub(a, b) => Op::Sub(f(a), f(b)),
            Op::Mul(a, b) => Op::Mul(f(a), f(b)),
            Op::Div(a, b) => Op::Div(f(a), f(b)),
            Op::Min(a, b) => Op::Min(f(a), f(b)),
            Op::Max(a, b) => Op::Max(f(a), f(b)),
            Op::Pow(a, b) => Op::Pow(f(a), f(b)),
            Op::AddC(a, c) => Op::AddC(f(a), c),
            Op::MulC(a, c) => Op::MulC(f(a), c),
            Op::Neg(a) => Op::Neg(f(a)),
            Op::Recip(a) => Op::Recip(f(a)),
            Op::Unary(u, a) => Op::Unary(u, f(a)),
            Op::PowC(a, c) => Op::PowC(f(a), c),
            Op::Gauss {
                arg,
                inv_width,
                norm,
            } => Op::Gauss {
                arg: f(arg),
                inv_width,
                norm,
            },
        }
    }

    /// Applies the instruction to operand values `a`, `b`: the single source of the tape's
    /// arithmetic. Constant folding calls it, and so do both evaluators ([`Tape::eval`],
    /// [`Tape::eval_batch`]), arm by arm with the variant known, so that it folds to the bare
    /// operation there.
    #[inline(always)]
    pub(crate) fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Op::Const(c) => c,
            Op::Var(_) => a,
            Op::Add(..) => a + b,
            Op::Sub(..) => a - b,
            Op::Mul(..) => a * b,
            Op::Div(..) => a / b,
            Op::AddC(_, c) => a + c,
            Op::MulC(_, c) => a * c,
            Op::Neg(_) => -a,
            Op::Recip(_) => 1.0 / a,
            Op::Unary(f, _) => f.apply(a),
            Op::Min(..) => a.min(b),
            Op::Max(..) => a.max(b),
            Op::PowC(_, c) => a.powf(c),
            Op::Pow(..) => crate::symbolic::powf(a, b),
            Op::Gauss {
                inv_width, norm, ..
            } => {
                let s = a * inv_width;
                norm * (-0.5 * s * s).exp()
            }
        }
    }
}

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

/// Builds a tape with hash-consing and peephole folding.
struct Builder<'a> {
    ops: Vec<Op>,
    seen: HashMap<Key, u32>,
    vars: &'a [&'a str],
    delta: DeltaPolicy,
}

impl Builder<'_> {
    fn constant(&self, slot: u32) -> Option<f64> {
        match self.ops[slot as usize] {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }

    /// Appends `op` (or finds an identical earlier instruction), folding it to a constant when
    /// all its operands are constants.
    fn emit(&mut self, op: Op) -> u32 {
        let op = self.fold(op);
        let key = op.key();
        if let Some(&slot) = self.seen.get(&key) {
            return slot;
        }
        let slot = self.ops.len() as u32;
        self.ops.push(op);
        self.seen.insert(key, slot);
        slot
    }

    fn fold(&self, op: Op) -> Op {
        let (operands, n) = op.operands();
        if n == 0 || matches!(op, Op::Var(_)) {
            return op;
        }
        let mut vals = [0.0; 2];
        for (v, &slot) in vals.iter_mut().zip(&operands[..n]) {
            match self.constant(slot) {
                Some(c) => *v = c,
                None => return self.peephole(op),
            }
        }
        Op::Const(op.apply(vals[0], vals[1]))
    }

    /// Rewrites that keep the value bit-for-bit: binary operations with one constant operand
    /// become their one-operand forms, `a + (−b)` becomes `a − b` and `a · (1/b)` becomes `a / b`.
    fn peephole(&self, op: Op) -> Op {
        match op {
            Op::Add(a, b) => match (self.constant(a), self.constant(b)) {
                (Some(c), _) => Op::AddC(b, c),
                (_, Some(c)) => Op::AddC(a, c),
                _ => match (self.ops[a as usize], self.ops[b as usize]) {
                    (_, Op::Neg(nb)) => Op::Sub(a, nb),
                    (Op::Neg(na), _) => Op::Sub(b, na),
                    _ => op,
                },
            },
            Op::Mul(a, b) => match (self.constant(a), self.constant(b)) {
                (Some(c), _) | (_, Some(c)) if c == -1.0 => {
                    Op::Neg(if self.constant(a).is_some() { b } else { a })
                }
                (Some(c), _) => Op::MulC(b, c),
                (_, Some(c)) => Op::MulC(a, c),
                _ => match (self.ops[a as usize], self.ops[b as usize]) {
                    (_, Op::Recip(rb)) => Op::Div(a, rb),
                    (Op::Recip(ra), _) => Op::Div(b, ra),
                    _ => op,
                },
            },
            Op::Div(a, b) if self.constant(a) == Some(1.0) => Op::Recip(b),
            other => other,
        }
    }

    fn compile(&mut self, e: &Expr) -> Result<u32, SymbolicError> {
        match e {
            Expr::Num(v) => Ok(self.emit(Op::Const(*v))),
            Expr::Sym(s) => match self.vars.iter().position(|v| **v == **s) {
                Some(i) => Ok(self.emit(Op::Var(i as u32))),
                None => Err(SymbolicError::Unbound(s.clone())),
            },
            Expr::Add(terms) => self.nary(terms, 0.0, Op::Add, Op::AddC),
            Expr::Mul(factors) => self.nary(factors, 1.0, Op::Mul, Op::MulC),
            Expr::Pow(base, exponent) => {
                let b = self.compile(base)?;
                let x = self.compile(exponent)?;
                match self.constant(x) {
                    Some(n) if n.fract() == 0.0 && n.abs() <= i32::MAX as f64 => {
                        Ok(self.int_pow(b, n as i64))
                    }
                    Some(0.5) => Ok(self.emit(Op::Unary(Unary::Sqrt, b))),
                    Some(c) => Ok(self.emit(Op::PowC(b, c))),
                    None => Ok(self.emit(Op::Pow(b, x))),
                }
            }
            Expr::Call(func, args) => self.call(e, *func, args),
        }
        .and_then(|slot| self.check_finite(e, slot))
    }

    /// A constant that folded to NaN or ±∞ is a modelling error, reported rather than carried.
    fn check_finite(&self, e: &Expr, slot: u32) -> Result<u32, SymbolicError> {
        match self.constant(slot) {
            Some(c) if !c.is_finite() => Err(SymbolicError::NotFinite {
                expr: e.to_string(),
                value: c,
            }),
            _ => Ok(slot),
        }
    }

    /// A sum or product: constant children are combined into one, the others chained left
    /// to right.
    fn nary(
        &mut self,
        children: &[Expr],
        neutral: f64,
        binary: fn(u32, u32) -> Op,
        with_const: fn(u32, f64) -> Op,
    ) -> Result<u32, SymbolicError> {
        let mut constant = neutral;
        let mut acc: Option<u32> = None;
        for child in children {
            let slot = self.compile(child)?;
            if let Some(c) = self.constant(slot) {
                constant = binary(0, 0).apply(constant, c);
                continue;
            }
            acc = Some(match acc {
                None => slot,
                Some(a) => self.emit(binary(a, slot)),
            });
        }
        Ok(match acc {
            None => self.emit(Op::Const(constant)),
            Some(a) if constant == neutral => a,
            Some(a) if neutral == 1.0 && constant == -1.0 => self.emit(Op::Neg(a)),
            Some(a) => self.emit(with_const(a, constant)),
        })
    }

    /// `b^n` by binary exponentiation: multiplications only (exact for negative bases), squares
    /// shared through hash-consing, and one reciprocal for negative `n`.
    fn int_pow(&mut self, b: u32, n: i64) -> u32 {
        if n == 0 {
            return self.emit(Op::Const(1.0));
        }
        let mut m = n.unsigned_abs();
        let mut square = b;
        let mut acc: Option<u32> = None;
        loop {
            if m & 1 == 1 {
                acc = Some(match acc {
                    None => square,
                    Some(a) => self.emit(Op::Mul(a, square)),
                });
            }
            m >>= 1;
            if m == 0 {
                break;
            }
            square = self.emit(Op::Mul(square, square));
        }
        let pos = acc.expect("n != 0 sets a bit");
        if n < 0 {
            self.emit(Op::Recip(pos))
        } else {
            pos
        }
    }

    fn call(&mut self, e: &Expr, func: Func, args: &[Expr]) -> Result<u32, SymbolicError> {
        if args.len() != func.arity() {
            return Err(SymbolicError::Arity {
                func: func.name(),
                expected: func.arity(),
                got: args.len(),
            });
        }
        let unary = |u| Ok(Some(u));
        let u = match func {
            Func::Abs => unary(Unary::Abs),
            Func::Sgn => unary(Unary::Sgn),
            Func::Exp => unary(Unary::Exp),
            Func::Log => unary(Unary::Log),
            Func::Sqrt => unary(Unary::Sqrt),
            Func::Sin => unary(Unary::Sin),
            Func::Cos => unary(Unary::Cos),
            Func::Tanh => unary(Unary::Tanh),
            Func::Min | Func::Max | Func::Delta => Ok(None),
        }?;
        if let Some(u) = u {
            let a = self.compile(&args[0])?;
            return Ok(self.emit(Op::Unary(u, a)));
        }
        match func {
            Func::Min | Func::Max => {
                let a = self.compile(&args[0])?;
                let b = self.compile(&args[1])?;
                Ok(self.emit(if func == Func::Min {
                    Op::Min(a, b)
                } else {
                    Op::Max(a, b)
                }))
            }
            _ => match self.delta {
                DeltaPolicy::Reject => Err(SymbolicError::DeltaRejected {
                    expr: e.to_string(),
                }),
                DeltaPolicy::Zero => {
                    // The argument is not evaluated, but an unbound symbol in it is still an
                    // error: the same expression must not compile under one policy only.
                    if let Some(s) = args[0]
                        .symbols()
                        .into_iter()
                        .find(|s| !self.vars.iter().any(|v| **v == **s))
                    {
                        return Err(SymbolicError::Unbound(s));
                    }
                    Ok(self.emit(Op::Const(0.0)))
                }
                DeltaPolicy::Gaussian { width } => {
                    if !(width.is_finite() && width > 0.0) {
                        return Err(SymbolicError::BadDeltaWidth { width });
                    }
                    let arg = self.compile(&args[0])?;
                    Ok(self.emit(Op::Gauss {
                        arg,
                        inv_width: 1.0 / width,
                        norm: 1.0 / (width * (2.0 * std::f64::consts::PI).sqrt()),
                    }))
                }
            },
        }
    }
}

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

    /// The instructions, children before parents (for evaluators of the tape elsewhere in
    /// the crate).
    pub(crate) fn instructions(&self) -> &[Op] {
        &self.ops
    }

    /// The slot of each output, in output order.
    pub(crate) fn output_slots(&self) -> &[u32] {
        &self.outputs
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
            // computed. One flat match keeps the dispatch to a single jump per instruction:
            // each arm rebuilds its variant, so `apply`'s own match is decided at compile time
            // and folds to the bare operation.
            let g = |a: u32| s[a as usize];
            let v = match op {
                Op::Const(c) => Op::Const(c).apply(0.0, 0.0),
                Op::Var(k) => Op::Var(k).apply(x[k as usize], 0.0),
                Op::Add(a, b) => Op::Add(a, b).apply(g(a), g(b)),
                Op::Sub(a, b) => Op::Sub(a, b).apply(g(a), g(b)),
                Op::Mul(a, b) => Op::Mul(a, b).apply(g(a), g(b)),
                Op::Div(a, b) => Op::Div(a, b).apply(g(a), g(b)),
                Op::Min(a, b) => Op::Min(a, b).apply(g(a), g(b)),
                Op::Max(a, b) => Op::Max(a, b).apply(g(a), g(b)),
                Op::Pow(a, b) => Op::Pow(a, b).apply(g(a), g(b)),
                Op::AddC(a, c) => Op::AddC(a, c).apply(g(a), 0.0),
                Op::MulC(a, c) => Op::MulC(a, c).apply(g(a), 0.0),
                Op::Neg(a) => Op::Neg(a).apply(g(a), 0.0),
                Op::Recip(a) => Op::Recip(a).apply(g(a), 0.0),
                Op::PowC(a, c) => Op::PowC(a, c).apply(g(a), 0.0),
                Op::Unary(f, a) => Op::Unary(f, a).apply(g(a), 0.0),
                Op::Gauss {
                    arg,
                    inv_width,
                    norm,
                } => Op::Gauss {
                    arg,
                    inv_width,
                    norm,
                }
                .apply(g(arg), 0.0),
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
