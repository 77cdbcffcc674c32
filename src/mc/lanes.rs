//! The simulator's own compiled form of the model's expressions: a flat instruction list
//! evaluated over chunks of [`CHUNK`] lanes inside one function compiled for the CPU's
//! vector extension (AVX-512 or AVX2, chosen at run time; the baseline build otherwise).
//!
//! The instructions are built by the rules of the crate's [`Tape`](crate::symbolic::Tape)
//! (left-to-right chains of sums and products with their constants combined last, integer
//! powers by binary exponentiation, the same bit-preserving peepholes, `a·(1/b)` as `a/b`,
//! constants folded by the same arithmetic), so every output is bit-for-bit the tape's
//! (tested below): the simulator's trajectories do not depend on which evaluator runs.
//! The tape itself checks the expressions ([`compile`] compiles both): a program is only
//! built for expressions the tape accepts.

use std::collections::HashMap;

use crate::symbolic::{powf, sgn, Expr, Func};

/// Lanes evaluated together: operands of an instruction stay in L1 and each instruction is
/// a loop of fixed length, unrolled over vector registers.
pub(crate) const CHUNK: usize = 64;
// The fused mechanical step reports a chunk's impacts as the bits of one u64.
const _: () = assert!(CHUNK <= 64);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Unary {
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
    fn apply(self, u: f64) -> f64 {
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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Op {
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
    PowC(u32, f64),
    Pow(u32, u32),
}

impl Op {
    /// The instruction's value from its operands' values: the one place of the arithmetic
    /// (constant folding and evaluation both call it).
    #[inline(always)]
    fn apply(self, a: f64, b: f64) -> f64 {
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
            Op::Pow(..) => powf(a, b),
        }
    }

    fn operands(self) -> ([u32; 2], usize) {
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
            | Op::PowC(a, _) => ([a, 0], 1),
        }
    }

    /// The sharing key: tag, operands (ordered for commutative operations), constant bits.
    fn key(self) -> (u8, u32, u32, u64) {
        let (tag, a, b, c) = match self {
            Op::Const(c) => (0, 0, 0, c.to_bits()),
            Op::Var(i) => (1, i, 0, 0),
            Op::Add(a, b) => (2, a.min(b), a.max(b), 0),
            Op::Sub(a, b) => (3, a, b, 0),
            Op::Mul(a, b) => (4, a.min(b), a.max(b), 0),
            Op::Div(a, b) => (5, a, b, 0),
            Op::AddC(a, c) => (6, a, 0, c.to_bits()),
            Op::MulC(a, c) => (7, a, 0, c.to_bits()),
            Op::Neg(a) => (8, a, 0, 0),
            Op::Recip(a) => (9, a, 0, 0),
            Op::Unary(f, a) => (10 + f as u8, a, 0, 0),
            Op::Min(a, b) => (30, a.min(b), a.max(b), 0),
            Op::Max(a, b) => (31, a.min(b), a.max(b), 0),
            Op::PowC(a, c) => (32, a, 0, c.to_bits()),
            Op::Pow(a, b) => (33, a, b, 0),
        };
        (tag, a, b, c)
    }
}

/// Expressions of the two states compiled for lane-parallel evaluation.
#[derive(Clone, Debug)]
pub(crate) struct LaneProgram {
    ops: Vec<Op>,
    outputs: Vec<u32>,
}

struct Builder<'a> {
    ops: Vec<Op>,
    seen: HashMap<(u8, u32, u32, u64), u32>,
    vars: &'a [&'a str],
}

impl Builder<'_> {
    fn constant(&self, slot: u32) -> Option<f64> {
        match self.ops[slot as usize] {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }

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
        if n == 0 {
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

    /// `None` for what the tape would refuse (the caller compiled the tape first, so this
    /// does not happen).
    fn compile(&mut self, e: &Expr) -> Option<u32> {
        Some(match e {
            Expr::Num(v) => self.emit(Op::Const(*v)),
            Expr::Sym(s) => {
                let i = self.vars.iter().position(|v| **v == **s)?;
                self.emit(Op::Var(i as u32))
            }
            Expr::Add(terms) => self.nary(terms, 0.0, Op::Add, Op::AddC)?,
            Expr::Mul(factors) => self.nary(factors, 1.0, Op::Mul, Op::MulC)?,
            Expr::Pow(base, exponent) => {
                let b = self.compile(base)?;
                let x = self.compile(exponent)?;
                match self.constant(x) {
                    Some(n) if n.fract() == 0.0 && n.abs() <= i32::MAX as f64 => {
                        self.int_pow(b, n as i64)
                    }
                    Some(0.5) => self.emit(Op::Unary(Unary::Sqrt, b)),
                    Some(c) => self.emit(Op::PowC(b, c)),
                    None => self.emit(Op::Pow(b, x)),
                }
            }
            Expr::Call(func, args) => {
                let unary = match func {
                    Func::Abs => Some(Unary::Abs),
                    Func::Sgn => Some(Unary::Sgn),
                    Func::Exp => Some(Unary::Exp),
                    Func::Log => Some(Unary::Log),
                    Func::Sqrt => Some(Unary::Sqrt),
                    Func::Sin => Some(Unary::Sin),
                    Func::Cos => Some(Unary::Cos),
                    Func::Tanh => Some(Unary::Tanh),
                    Func::Min | Func::Max | Func::Delta => None,
                };
                match (unary, func) {
                    (Some(u), _) => {
                        let a = self.compile(args.first()?)?;
                        self.emit(Op::Unary(u, a))
                    }
                    (None, Func::Min | Func::Max) => {
                        let a = self.compile(args.first()?)?;
                        let b = self.compile(args.get(1)?)?;
                        self.emit(if *func == Func::Min {
                            Op::Min(a, b)
                        } else {
                            Op::Max(a, b)
                        })
                    }
                    // Between impacts a delta is zero (the tape's `DeltaPolicy::Zero`).
                    _ => self.emit(Op::Const(0.0)),
                }
            }
        })
    }

    fn nary(
        &mut self,
        children: &[Expr],
        neutral: f64,
        binary: fn(u32, u32) -> Op,
        with_const: fn(u32, f64) -> Op,
    ) -> Option<u32> {
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
        Some(match acc {
            None => self.emit(Op::Const(constant)),
            Some(a) if constant == neutral => a,
            Some(a) if neutral == 1.0 && constant == -1.0 => self.emit(Op::Neg(a)),
            Some(a) => self.emit(with_const(a, constant)),
        })
    }

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
}

impl LaneProgram {
    /// `exprs` over the states `vars`, deltas as zero; `None` for an expression the tape
    /// refuses (an unbound symbol, a malformed call).
    pub(crate) fn compile(exprs: &[Expr], vars: [&str; 2]) -> Option<LaneProgram> {
        let mut b = Builder {
            ops: Vec::new(),
            seen: HashMap::new(),
            vars: &vars,
        };
        let outputs = exprs
            .iter()
            .map(|e| b.compile(e))
            .collect::<Option<Vec<_>>>()?;
        let mut p = LaneProgram {
            ops: b.ops,
            outputs,
        };
        p.drop_dead_code();
        Some(p)
    }

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
        let mut index = vec![u32::MAX; self.ops.len()];
        let mut ops = Vec::with_capacity(self.ops.len());
        for (i, &op) in self.ops.iter().enumerate() {
            if live[i] {
                index[i] = ops.len() as u32;
                let f = |a: u32| index[a as usize];
                ops.push(match op {
                    Op::Const(_) | Op::Var(_) => op,
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
                });
            }
        }
        for o in &mut self.outputs {
            *o = index[*o as usize];
        }
        self.ops = ops;
    }

    #[cfg(test)]
    /// How many outputs the program computes.
    pub(crate) fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// Slots (chunks of `W` values) the evaluation needs.
    pub(crate) fn n_slots(&self) -> usize {
        self.ops.len()
    }

    /// Evaluates the program at `W` points `(x[i], v[i])` into `slots` (one chunk per
    /// instruction); output `j` is then `slots[self.output(j)]`. Inlined into the caller,
    /// so that it is compiled for the caller's target features.
    #[inline(always)]
    pub(crate) fn run<const W: usize>(&self, x: &[f64; W], v: &[f64; W], slots: &mut [[f64; W]]) {
        for (i, &op) in self.ops.iter().enumerate() {
            let (done, rest) = slots.split_at_mut(i);
            let dst = &mut rest[0];
            let src = |a: u32| &done[a as usize];
            match op {
                Op::Const(c) => *dst = [c; W],
                Op::Var(k) => *dst = if k == 0 { *x } else { *v },
                Op::Add(a, b) => zip2(dst, src(a), src(b), |p, q| p + q),
                Op::Sub(a, b) => zip2(dst, src(a), src(b), |p, q| p - q),
                Op::Mul(a, b) => zip2(dst, src(a), src(b), |p, q| p * q),
                Op::Div(a, b) => zip2(dst, src(a), src(b), |p, q| p / q),
                Op::Min(a, b) => zip2(dst, src(a), src(b), f64::min),
                Op::Max(a, b) => zip2(dst, src(a), src(b), f64::max),
                Op::Pow(a, b) => zip2(dst, src(a), src(b), powf),
                Op::AddC(a, c) => zip1(dst, src(a), |p| p + c),
                Op::MulC(a, c) => zip1(dst, src(a), |p| p * c),
                Op::Neg(a) => zip1(dst, src(a), |p| -p),
                Op::Recip(a) => zip1(dst, src(a), |p| 1.0 / p),
                Op::PowC(a, c) => zip1(dst, src(a), |p| p.powf(c)),
                Op::Unary(f, a) => match f {
                    Unary::Abs => zip1(dst, src(a), f64::abs),
                    Unary::Sgn => zip1(dst, src(a), sgn),
                    Unary::Exp => zip1(dst, src(a), f64::exp),
                    Unary::Log => zip1(dst, src(a), f64::ln),
                    Unary::Sqrt => zip1(dst, src(a), f64::sqrt),
                    Unary::Sin => zip1(dst, src(a), f64::sin),
                    Unary::Cos => zip1(dst, src(a), f64::cos),
                    Unary::Tanh => zip1(dst, src(a), f64::tanh),
                },
            }
        }
    }

    /// The slot holding output `j` after [`LaneProgram::run`].
    #[inline(always)]
    pub(crate) fn output(&self, j: usize) -> usize {
        self.outputs[j] as usize
    }

    /// Every output at `n = x.len()` points: output `j` at point `i` goes to `out[j*n + i]`;
    /// `slots` is reusable working memory. Inlined, for the caller's target features.
    #[inline(always)]
    pub(crate) fn eval_rows(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        slots: &mut Vec<[f64; CHUNK]>,
    ) {
        let n = x.len();
        let k = self.outputs.len();
        let out = &mut out[..k * n];
        slots.resize(self.ops.len(), [0.0; CHUNK]);
        let mut start = 0;
        while start + CHUNK <= n {
            let xc: &[f64; CHUNK] = x[start..start + CHUNK].try_into().expect("chunk");
            let vc: &[f64; CHUNK] = v[start..start + CHUNK].try_into().expect("chunk");
            self.run(xc, vc, slots);
            for j in 0..k {
                out[j * n + start..j * n + start + CHUNK].copy_from_slice(&slots[self.output(j)]);
            }
            start += CHUNK;
        }
        if start == n {
            return;
        }
        let mut one = vec![[0.0; 1]; self.ops.len()];
        for i in start..n {
            self.run(&[x[i]], &[v[i]], &mut one);
            for j in 0..k {
                out[j * n + i] = one[self.output(j)][0];
            }
        }
    }

    /// Every output at one point (on the stack for programs of up to 32 instructions, such
    /// as impact laws, evaluated at every impact).
    pub(crate) fn eval_point(&self, x: f64, v: f64, out: &mut [f64]) {
        const STACK: usize = 32;
        let mut stack = [[0.0; 1]; STACK];
        let mut heap = Vec::new();
        let one: &mut [[f64; 1]] = if self.ops.len() <= STACK {
            &mut stack[..self.ops.len()]
        } else {
            heap.resize(self.ops.len(), [0.0; 1]);
            &mut heap
        };
        self.run(&[x], &[v], one);
        for (j, o) in out.iter_mut().enumerate().take(self.outputs.len()) {
            *o = one[self.output(j)][0];
        }
    }
}

#[inline(always)]
fn zip1<const W: usize>(dst: &mut [f64; W], a: &[f64; W], f: impl Fn(f64) -> f64) {
    for i in 0..W {
        dst[i] = f(a[i]);
    }
}

#[inline(always)]
fn zip2<const W: usize>(
    dst: &mut [f64; W],
    a: &[f64; W],
    b: &[f64; W],
    f: impl Fn(f64, f64) -> f64,
) {
    for i in 0..W {
        dst[i] = f(a[i], b[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::{DeltaPolicy, Tape};

    fn z() -> Expr {
        Expr::sym("z")
    }
    fn v() -> Expr {
        Expr::sym("v")
    }

    /// Every output equals the tape's bit for bit, at points chosen to hit signs, zeros,
    /// large and tiny values (the simulator relies on it: its trajectories must not depend
    /// on the evaluator).
    #[test]
    fn outputs_are_the_tapes_bit_for_bit() {
        let n = |x: f64| Expr::num(x);
        let exprs = vec![
            -(n(0.1) * v())
                - n(1.0) * z()
                - n(0.1) * Expr::pow(z(), n(3.0))
                - (n(1.0) - n(0.95))
                    * v()
                    * Expr::call(Func::Abs, v())
                    * Expr::call(Func::Delta, z()),
            n(1.0f64.sqrt()) * (Expr::call(Func::Sgn, z()) + n(0.1) * z()),
            Expr::pow(Expr::call(Func::Abs, z()), n(0.5)) / (n(1.0) + v() * v()),
            Expr::Call(Func::Max, vec![z(), Expr::call(Func::Tanh, v())]),
            Expr::Call(Func::Min, vec![z() * n(3.0), v() - n(2.0)]),
            Expr::pow(z() + n(0.3), n(-3.0)) + Expr::pow(v(), n(7.0)) * n(-1.0),
            Expr::pow(Expr::call(Func::Exp, z()), Expr::call(Func::Sin, v()))
                + Expr::call(Func::Log, Expr::call(Func::Abs, v()) + n(1e-3))
                + Expr::call(Func::Cos, z() * v()),
            Expr::pow(Expr::call(Func::Abs, v()), n(1.7)) - n(2.0) / (z() - n(5.0)),
            n(3.0),
            z(),
        ];
        let tape = Tape::compile(&exprs, &["z", "v"], DeltaPolicy::Zero).unwrap();
        let prog = LaneProgram::compile(&exprs, ["z", "v"]).unwrap();
        assert_eq!(prog.n_outputs(), exprs.len());
        let special = [0.0, -0.0, 1.0, -1.0, 1e-300, -2.5, 7.0, 1e10];
        let mut xs = Vec::new();
        let mut vs = Vec::new();
        for &a in &special {
            for &b in &special {
                xs.push(a);
                vs.push(b);
            }
        }
        let mut s = 0x1234_5678u64;
        for _ in 0..100 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            xs.push(((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 8.0);
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            vs.push(((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 8.0);
        }
        let np = xs.len();
        assert!(np % CHUNK != 0, "the test must cover a partial chunk");
        let mut got = vec![0.0; exprs.len() * np];
        let mut slots = Vec::new();
        prog.eval_rows(&xs, &vs, &mut got, &mut slots);
        let mut want = vec![0.0; exprs.len()];
        let mut scratch = Vec::new();
        let mut one = vec![0.0; exprs.len()];
        for i in 0..np {
            tape.eval(&[xs[i], vs[i]], &mut scratch, &mut want);
            prog.eval_point(xs[i], vs[i], &mut one);
            for j in 0..exprs.len() {
                let g = got[j * np + i];
                assert!(
                    g.to_bits() == want[j].to_bits() || (g.is_nan() && want[j].is_nan()),
                    "{} at ({}, {}): {g} vs the tape's {}",
                    exprs[j],
                    xs[i],
                    vs[i],
                    want[j]
                );
                assert!(one[j].to_bits() == g.to_bits() || (g.is_nan() && one[j].is_nan()));
            }
        }
    }

    #[test]
    fn shared_subexpressions_are_computed_once() {
        // z^3 and z^2 share z·z; the constant folds; nothing else is emitted.
        let e = [
            Expr::pow(z(), Expr::num(3.0)),
            Expr::pow(z(), Expr::num(2.0)) * Expr::num(2.0) * Expr::num(0.5),
        ];
        let p = LaneProgram::compile(&e, ["z", "v"]).unwrap();
        // z, z·z, z·(z·z): the product by 2·0.5 = 1 is no instruction.
        assert_eq!(p.n_slots(), 3);
        assert!(LaneProgram::compile(&[Expr::sym("k")], ["z", "v"]).is_none());
    }
}
