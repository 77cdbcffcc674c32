//! The simulator's evaluator of a compiled [`Tape`]: the tape's own instruction list, run
//! over chunks of [`CHUNK`] lanes inside one function compiled for the CPU's vector
//! extension (AVX-512 or AVX2, chosen at run time; the baseline build otherwise).
//!
//! There is one compiler, the tape's: a program is the tape's instructions and output slots,
//! and every instruction's arithmetic is the tape's own (`Op::apply`), so every output is
//! bit-for-bit the tape's (tested below) and the simulator's trajectories do not depend on
//! which evaluator runs.

use crate::symbolic::{Tape, TapeOp as Op, TapeUnary as Unary};

/// Lanes evaluated together: operands of an instruction stay in L1 and each instruction is
/// a loop of fixed length, unrolled over vector registers.
pub(crate) const CHUNK: usize = 64;
// The fused mechanical step reports a chunk's impacts as the bits of one u64.
const _: () = assert!(CHUNK <= 64);

/// A tape instruction as the lane loop reads it: the same instruction in 16 bytes (the
/// Gaussian delta's two constants are in a side table), the layout the lane loop had before
/// it ran the tape's instructions (running the tape's 24-byte ones directly measured 1–10 %
/// slower on `vibro_duffing`, under a load of 4–7 that did not resolve it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum LaneOp {
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
    /// Operand, index into `LaneProgram::gauss`.
    Gauss(u32, u32),
}

/// A compiled tape's instructions, evaluated lane-parallel.
#[derive(Clone, Debug)]
pub(crate) struct LaneProgram {
    ops: Vec<LaneOp>,
    /// The tape's Gaussian delta instructions, by index.
    gauss: Vec<Op>,
    outputs: Vec<u32>,
}

impl LaneProgram {
    /// The program of `tape` (variables: the two states, in the tape's order): its
    /// instructions one for one.
    pub(crate) fn from_tape(tape: &Tape) -> LaneProgram {
        debug_assert!(tape.n_vars() <= 2, "a lane program takes the two states");
        let mut gauss = Vec::new();
        let ops = tape
            .instructions()
            .iter()
            .map(|&op| match op {
                Op::Const(c) => LaneOp::Const(c),
                Op::Var(k) => LaneOp::Var(k),
                Op::Add(a, b) => LaneOp::Add(a, b),
                Op::Sub(a, b) => LaneOp::Sub(a, b),
                Op::Mul(a, b) => LaneOp::Mul(a, b),
                Op::Div(a, b) => LaneOp::Div(a, b),
                Op::AddC(a, c) => LaneOp::AddC(a, c),
                Op::MulC(a, c) => LaneOp::MulC(a, c),
                Op::Neg(a) => LaneOp::Neg(a),
                Op::Recip(a) => LaneOp::Recip(a),
                Op::Unary(f, a) => LaneOp::Unary(f, a),
                Op::Min(a, b) => LaneOp::Min(a, b),
                Op::Max(a, b) => LaneOp::Max(a, b),
                Op::PowC(a, c) => LaneOp::PowC(a, c),
                Op::Pow(a, b) => LaneOp::Pow(a, b),
                Op::Gauss { arg, .. } => {
                    gauss.push(op);
                    LaneOp::Gauss(arg, gauss.len() as u32 - 1)
                }
            })
            .collect();
        LaneProgram {
            ops,
            gauss,
            outputs: tape.output_slots().to_vec(),
        }
    }

    #[cfg(test)]
    /// How many outputs the program computes.
    pub(crate) fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// The instructions, in the tape's order (for recognisers of special forms).
    pub(crate) fn ops(&self) -> &[LaneOp] {
        &self.ops
    }

    /// The slots holding the outputs.
    pub(crate) fn outputs(&self) -> &[u32] {
        &self.outputs
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
            // Each arm applies the tape's arithmetic of a variant known in the arm (rebuilt,
            // so that `apply` folds to the bare operation and the loop vectorises).
            match op {
                LaneOp::Const(c) => *dst = [Op::Const(c).apply(0.0, 0.0); W],
                LaneOp::Var(k) => *dst = if k == 0 { *x } else { *v },
                LaneOp::Add(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Add(a, b).apply(p, q)),
                LaneOp::Sub(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Sub(a, b).apply(p, q)),
                LaneOp::Mul(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Mul(a, b).apply(p, q)),
                LaneOp::Div(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Div(a, b).apply(p, q)),
                LaneOp::Min(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Min(a, b).apply(p, q)),
                LaneOp::Max(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Max(a, b).apply(p, q)),
                LaneOp::Pow(a, b) => zip2(dst, src(a), src(b), |p, q| Op::Pow(a, b).apply(p, q)),
                LaneOp::AddC(a, c) => zip1(dst, src(a), |p| Op::AddC(a, c).apply(p, 0.0)),
                LaneOp::MulC(a, c) => zip1(dst, src(a), |p| Op::MulC(a, c).apply(p, 0.0)),
                LaneOp::Neg(a) => zip1(dst, src(a), |p| Op::Neg(a).apply(p, 0.0)),
                LaneOp::Recip(a) => zip1(dst, src(a), |p| Op::Recip(a).apply(p, 0.0)),
                LaneOp::PowC(a, c) => zip1(dst, src(a), |p| Op::PowC(a, c).apply(p, 0.0)),
                LaneOp::Unary(f, a) => match f {
                    Unary::Abs => zip1(dst, src(a), |p| Unary::Abs.apply(p)),
                    Unary::Sgn => zip1(dst, src(a), |p| Unary::Sgn.apply(p)),
                    Unary::Exp => zip1(dst, src(a), |p| Unary::Exp.apply(p)),
                    Unary::Log => zip1(dst, src(a), |p| Unary::Log.apply(p)),
                    Unary::Sqrt => zip1(dst, src(a), |p| Unary::Sqrt.apply(p)),
                    Unary::Sin => zip1(dst, src(a), |p| Unary::Sin.apply(p)),
                    Unary::Cos => zip1(dst, src(a), |p| Unary::Cos.apply(p)),
                    Unary::Tanh => zip1(dst, src(a), |p| Unary::Tanh.apply(p)),
                },
                LaneOp::Gauss(a, k) => {
                    let g = self.gauss[k as usize];
                    zip1(dst, src(a), |p| g.apply(p, 0.0))
                }
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
    use crate::symbolic::{DeltaPolicy, Expr, Func};

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
        // The simulator's tapes drop deltas; a Gaussian stand-in covers the last instruction.
        for policy in [DeltaPolicy::Zero, DeltaPolicy::Gaussian { width: 0.3 }] {
            let tape = Tape::compile(&exprs, &["z", "v"], policy).unwrap();
            let prog = LaneProgram::from_tape(&tape);
            check_against_tape(&exprs, &tape, &prog);
        }
    }

    fn check_against_tape(exprs: &[Expr], tape: &Tape, prog: &LaneProgram) {
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
        let tape = Tape::compile(&e, &["z", "v"], DeltaPolicy::Zero).unwrap();
        let p = LaneProgram::from_tape(&tape);
        // z, z·z, z·(z·z): the product by 2·0.5 = 1 is no instruction.
        assert_eq!(p.n_slots(), 3);
        assert_eq!(p.n_slots(), tape.len());
    }
}
