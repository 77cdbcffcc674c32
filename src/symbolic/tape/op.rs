//! The tape's instruction set: [`Op`] and its arithmetic, [`Op::apply`], the one place each
//! instruction's value is defined. Constant folding calls it, and so do the point and the
//! batch evaluators, arm by arm, so that each arm compiles to the bare operation.

use crate::symbolic::sgn;

/// One tape instruction. The value of instruction `i` lives in slot `i`; operands are slots of
/// earlier instructions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Op {
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

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Unary {
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
    pub(super) fn apply(self, u: f64) -> f64 {
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
pub(super) struct Key(u8, u32, u32, u64, u64);

impl Op {
    pub(super) fn key(self) -> Key {
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
    pub(super) fn operands(self) -> ([u32; 2], usize) {
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

    pub(super) fn map_operands(self, f: impl Fn(u32) -> u32) -> Op {
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

    /// Applies the instruction to operand values `a`, `b` (the single source of the
    /// arithmetic, shared by constant folding and the point evaluator).
    #[inline(always)]
    pub(super) fn apply(self, a: f64, b: f64) -> f64 {
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
