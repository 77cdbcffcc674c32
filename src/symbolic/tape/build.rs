//! [`Builder`]: expression tree → instructions, with hash-consing, constant folding and
//! peephole rewrites (integer powers as multiplications, `delta` by its policy).

use std::collections::HashMap;

use super::op::{Key, Op, Unary};
use crate::symbolic::{DeltaPolicy, Expr, Func, SymbolicError};

/// Builds a tape with hash-consing and peephole folding.
pub(super) struct Builder<'a> {
    pub(super) ops: Vec<Op>,
    pub(super) seen: HashMap<Key, u32>,
    pub(super) vars: &'a [&'a str],
    pub(super) delta: DeltaPolicy,
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

    pub(super) fn compile(&mut self, e: &Expr) -> Result<u32, SymbolicError> {
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
