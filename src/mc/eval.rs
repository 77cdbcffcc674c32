//! Model evaluation for the simulator: expressions of the two states, compiled once and
//! evaluated over a whole batch of trajectories at a time (structure-of-arrays).
//!
//! Everything the simulator evaluates goes through [`BatchKernel`] and [`compile`], which
//! uses the crate's compiled [`Tape`]. A minimal register tape of this module's own is kept
//! as [`compile_register`], the reference the tape is benchmarked and tested against.

use super::McError;
use crate::symbolic::{powf, sgn, DeltaPolicy, Expr, Func, Tape, TapeScratch};

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
        // The hot kernels have one output: no allocation for them.
        match self.n_outputs() {
            0 => {}
            1 => Tape::eval_batch(self, &[x, v], &mut [out], scratch),
            _ => {
                let mut rows: Vec<&mut [f64]> = out.chunks_mut(n).collect();
                Tape::eval_batch(self, &[x, v], &mut rows, scratch)
            }
        }
    }

    fn eval_point(&self, x: f64, v: f64, out: &mut [f64]) {
        let mut scratch = Vec::new();
        self.eval(&[x, v], &mut scratch, out);
    }
}

/// Compiles `exprs` to this module's register tape (no sharing of subexpressions).
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn compile_register(
    exprs: &[Expr],
    states: [&str; 2],
) -> Result<Box<dyn BatchKernel>, McError> {
    let mut tape = RegisterTape {
        ops: Vec::new(),
        outputs: Vec::new(),
    };
    for e in exprs {
        let r = tape.emit(e, e, states)?;
        tape.outputs.push(r);
    }
    Ok(Box::new(tape))
}

/// An operand: a state, a constant or an earlier instruction's result.
#[derive(Clone, Copy, Debug)]
enum Operand {
    X,
    V,
    Const(f64),
    Reg(usize),
}

#[derive(Clone, Copy, Debug)]
enum Op {
    Add(Operand, Operand),
    Mul(Operand, Operand),
    PowI(Operand, i32),
    PowF(Operand, Operand),
    Unary(Func, Operand),
    Binary(Func, Operand, Operand),
}

struct RegisterTape {
    ops: Vec<Op>,
    outputs: Vec<Operand>,
}

impl RegisterTape {
    fn push(&mut self, op: Op) -> Operand {
        self.ops.push(op);
        Operand::Reg(self.ops.len() - 1)
    }

    fn emit(&mut self, e: &Expr, whole: &Expr, states: [&str; 2]) -> Result<Operand, McError> {
        Ok(match e {
            Expr::Num(c) => Operand::Const(*c),
            Expr::Sym(s) if &**s == states[0] => Operand::X,
            Expr::Sym(s) if &**s == states[1] => Operand::V,
            Expr::Sym(s) => {
                return Err(McError::UnboundSymbol {
                    expr: whole.to_string(),
                    symbol: s.to_string(),
                })
            }
            Expr::Add(terms) | Expr::Mul(terms) => {
                let is_add = matches!(e, Expr::Add(_));
                let mut acc: Option<Operand> = None;
                for t in terms {
                    let o = self.emit(t, whole, states)?;
                    acc = Some(match acc {
                        None => o,
                        Some(Operand::Const(a)) if matches!(o, Operand::Const(_)) => {
                            let Operand::Const(b) = o else { unreachable!() };
                            Operand::Const(if is_add { a + b } else { a * b })
                        }
                        Some(a) if is_add => self.push(Op::Add(a, o)),
                        Some(a) => self.push(Op::Mul(a, o)),
                    });
                }
                acc.unwrap_or(Operand::Const(if is_add { 0.0 } else { 1.0 }))
            }
            Expr::Pow(b, x) => {
                let b = self.emit(b, whole, states)?;
                let x = self.emit(x, whole, states)?;
                match (b, x) {
                    (Operand::Const(b), Operand::Const(x)) => Operand::Const(powf(b, x)),
                    (b, Operand::Const(x)) if x.fract() == 0.0 && x.abs() <= 64.0 => {
                        self.push(Op::PowI(b, x as i32))
                    }
                    (b, x) => self.push(Op::PowF(b, x)),
                }
            }
            Expr::Call(Func::Delta, _) => Operand::Const(0.0),
            Expr::Call(f, args) => {
                let a = self.emit(&args[0], whole, states)?;
                if f.arity() == 2 {
                    let b = self.emit(&args[1], whole, states)?;
                    if let (Operand::Const(a), Operand::Const(b)) = (a, b) {
                        return Ok(Operand::Const(apply2(*f, a, b)));
                    }
                    self.push(Op::Binary(*f, a, b))
                } else if let Operand::Const(a) = a {
                    Operand::Const(apply1(*f, a))
                } else {
                    self.push(Op::Unary(*f, a))
                }
            }
        })
    }
}

#[inline(always)]
fn apply1(f: Func, a: f64) -> f64 {
    match f {
        Func::Abs => a.abs(),
        Func::Sgn => sgn(a),
        Func::Delta => 0.0,
        Func::Exp => a.exp(),
        Func::Log => a.ln(),
        Func::Sqrt => a.sqrt(),
        Func::Sin => a.sin(),
        Func::Cos => a.cos(),
        Func::Tanh => a.tanh(),
        Func::Min | Func::Max => f64::NAN,
    }
}

#[inline(always)]
fn apply2(f: Func, a: f64, b: f64) -> f64 {
    match f {
        Func::Min => a.min(b),
        Func::Max => a.max(b),
        _ => f64::NAN,
    }
}

/// The column of an operand: states and registers are slices, constants are broadcast.
enum Col<'a> {
    Slice(&'a [f64]),
    Const(f64),
}

fn col<'a>(o: Operand, x: &'a [f64], v: &'a [f64], regs: &'a [f64], n: usize) -> Col<'a> {
    match o {
        Operand::X => Col::Slice(x),
        Operand::V => Col::Slice(v),
        Operand::Const(c) => Col::Const(c),
        Operand::Reg(r) => Col::Slice(&regs[r * n..(r + 1) * n]),
    }
}

/// `dst[i] = f(a[i], b[i])`, with the constant-operand cases split out so that each loop is a
/// plain slice loop the compiler vectorises.
#[inline(always)]
fn zip2(dst: &mut [f64], a: &Col, b: &Col, f: impl Fn(f64, f64) -> f64) {
    match (a, b) {
        (Col::Slice(a), Col::Slice(b)) => {
            for ((d, &a), &b) in dst.iter_mut().zip(a.iter()).zip(b.iter()) {
                *d = f(a, b);
            }
        }
        (Col::Slice(a), Col::Const(b)) => {
            for (d, &a) in dst.iter_mut().zip(a.iter()) {
                *d = f(a, *b);
            }
        }
        (Col::Const(a), Col::Slice(b)) => {
            for (d, &b) in dst.iter_mut().zip(b.iter()) {
                *d = f(*a, b);
            }
        }
        (Col::Const(a), Col::Const(b)) => dst.fill(f(*a, *b)),
    }
}

#[inline(always)]
fn map1(dst: &mut [f64], a: &Col, f: impl Fn(f64) -> f64) {
    match a {
        Col::Slice(a) => {
            for (d, &a) in dst.iter_mut().zip(a.iter()) {
                *d = f(a);
            }
        }
        Col::Const(a) => dst.fill(f(*a)),
    }
}

impl BatchKernel for RegisterTape {
    fn eval_point(&self, x: f64, v: f64, out: &mut [f64]) {
        self.eval_batch(&[x], &[v], out, &mut TapeScratch::new());
    }

    fn eval_batch(&self, x: &[f64], v: &[f64], out: &mut [f64], _scratch: &mut Scratch) {
        let n = x.len();
        let mut regs = vec![0.0; self.ops.len() * n];
        let scratch = &mut regs;
        for (k, op) in self.ops.iter().enumerate() {
            // Operands always precede their instruction, so the registers split cleanly
            // into the (read) past and the (written) current one.
            let (past, rest) = scratch.split_at_mut(k * n);
            let dst = &mut rest[..n];
            match *op {
                Op::Add(a, b) => zip2(
                    dst,
                    &col(a, x, v, past, n),
                    &col(b, x, v, past, n),
                    |a, b| a + b,
                ),
                Op::Mul(a, b) => zip2(
                    dst,
                    &col(a, x, v, past, n),
                    &col(b, x, v, past, n),
                    |a, b| a * b,
                ),
                Op::PowI(a, p) => {
                    let a = col(a, x, v, past, n);
                    match p {
                        0 => dst.fill(1.0),
                        1 => map1(dst, &a, |a| a),
                        2 => map1(dst, &a, |a| a * a),
                        3 => map1(dst, &a, |a| a * a * a),
                        -1 => map1(dst, &a, |a| 1.0 / a),
                        -2 => map1(dst, &a, |a| 1.0 / (a * a)),
                        p => map1(dst, &a, |a| a.powi(p)),
                    }
                }
                Op::PowF(a, b) => zip2(dst, &col(a, x, v, past, n), &col(b, x, v, past, n), powf),
                Op::Unary(f, a) => {
                    let a = col(a, x, v, past, n);
                    match f {
                        Func::Abs => map1(dst, &a, f64::abs),
                        Func::Sgn => map1(dst, &a, |a| {
                            let p = if a > 0.0 { 1.0 } else { 0.0 };
                            let m = if a < 0.0 { 1.0 } else { 0.0 };
                            p - m
                        }),
                        Func::Sqrt => map1(dst, &a, f64::sqrt),
                        f => map1(dst, &a, |a| apply1(f, a)),
                    }
                }
                Op::Binary(f, a, b) => zip2(
                    dst,
                    &col(a, x, v, past, n),
                    &col(b, x, v, past, n),
                    |a, b| apply2(f, a, b),
                ),
            }
        }
        for (j, o) in self.outputs.iter().enumerate() {
            let dst = &mut out[j * n..(j + 1) * n];
            match col(*o, x, v, scratch, n) {
                Col::Slice(s) => dst.copy_from_slice(s),
                Col::Const(c) => dst.fill(c),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::DeltaPolicy;

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
        for k in [
            compile(&exprs, ["z", "v"]).unwrap(),
            compile_register(&exprs, ["z", "v"]).unwrap(),
        ] {
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
            Err(McError::UnboundSymbol { symbol, .. }) if symbol == "k"
        ));
    }
}
