//! Model evaluation for the simulator: expressions of the two states and the time, compiled
//! once and evaluated over a whole batch of trajectories at a time (structure-of-arrays),
//! all at one time `t` (an expression that does not mention the time ignores it).
//!
//! Everything the simulator evaluates goes through [`BatchKernel`] and [`compile`]: the
//! crate's [`Tape`] compiles and checks the expressions, and the simulator's [`LaneProgram`]
//! (the tape's instructions) evaluates them in chunks of lanes inside one function compiled
//! for the CPU's widest vector extension, detected once at compile time.

use crate::mc::compile::lanes::{LaneProgram, CHUNK};
use crate::mc::error::McError;
use crate::model::TIME;
use crate::symbolic::{DeltaPolicy, Expr, Tape};

/// Working memory of a kernel's batch evaluation.
pub(crate) type Scratch = Vec<[f64; CHUNK]>;

/// Expressions of the states `(x, v)` and the time, evaluated for many points at once.
pub(crate) trait BatchKernel: Send + Sync {
    /// Evaluates every output at the points `(x[i], v[i])` at time `t`: output `j` at point
    /// `i` goes to `out[j * n + i]`, `n = x.len()`. `scratch` is the caller's reusable
    /// buffer.
    fn eval_batch(&self, t: f64, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch);
    /// Evaluates every output at one point at time `t`.
    fn eval_point(&self, t: f64, x: f64, v: f64, out: &mut [f64]);
    /// The compiled program, for loops that evaluate it chunk by chunk themselves.
    fn program(&self) -> &LaneProgram;
}

pub(crate) use crate::base::simd::Simd;

/// The time given to expressions the model language keeps free of it (impact laws,
/// observables): NaN, so that one that mentioned it could give no number, never a wrong one.
pub(crate) const NO_TIME: f64 = f64::NAN;

/// A compiled kernel: the program and the extension its batch evaluation uses.
struct Kernel {
    program: LaneProgram,
    simd: Simd,
}

/// Compiles `exprs` (expressions of the states named `states` and, when one mentions it,
/// of the time [`TIME`]) with `delta(·) = 0`, as is right between impacts.
pub(crate) fn compile(exprs: &[Expr], states: [&str; 2]) -> Result<Box<dyn BatchKernel>, McError> {
    // One compiler: the tape reports what is wrong with an expression, and the program
    // runs the tape's instructions. Expressions of the states only compile over the states
    // only, to the program they always had.
    let timed = exprs.iter().any(|e| e.mentions(TIME));
    let vars = [states[0], states[1], TIME];
    let tape = Tape::compile(exprs, &vars[..if timed { 3 } else { 2 }], DeltaPolicy::Zero)?;
    let program = LaneProgram::from_tape(&tape);
    Ok(Box::new(Kernel {
        program,
        simd: Simd::detect(),
    }))
}

impl Kernel {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn eval_avx2(&self, t: f64, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch) {
        self.program.eval_rows(t, x, v, out, scratch);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn eval_avx512(&self, t: f64, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch) {
        self.program.eval_rows(t, x, v, out, scratch);
    }
}

impl BatchKernel for Kernel {
    fn eval_batch(&self, t: f64, x: &[f64], v: &[f64], out: &mut [f64], scratch: &mut Scratch) {
        match self.simd {
            Simd::Baseline => self.program.eval_rows(t, x, v, out, scratch),
            // SAFETY: `simd` was detected on this CPU (`Simd::detect`).
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(_) => unsafe { self.eval_avx2(t, x, v, out, scratch) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(_) => unsafe { self.eval_avx512(t, x, v, out, scratch) },
        }
    }

    fn eval_point(&self, t: f64, x: f64, v: f64, out: &mut [f64]) {
        self.program.eval_point(t, x, v, out);
    }

    fn program(&self) -> &LaneProgram {
        &self.program
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use super::{Kernel, LaneProgram, Simd};
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
            k.eval_batch(0.0, &xs, &vs, &mut out, &mut scratch);
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
            k.eval_point(0.0, 0.7, -0.1, &mut one);
            assert_eq!(one[1], 1.0 + 0.2 * 0.7);
        }
    }

    #[test]
    fn every_vector_extension_gives_the_same_bits() {
        let e = vec![
            -(Expr::num(0.1) * v()) - z() - Expr::num(0.1) * Expr::pow(z(), Expr::num(3.0)),
            Expr::num(0.7) * (Expr::call(Func::Sgn, z()) + Expr::num(0.1) * z()),
            Expr::call(Func::Abs, z()) / (Expr::num(1.0) + v() * v()),
        ];
        let xs: Vec<f64> = (0..150).map(|i| (i as f64 * 0.37).sin() * 3.0).collect();
        let vs: Vec<f64> = (0..150).map(|i| (i as f64 * 0.71).cos() * 2.0).collect();
        let tape = Tape::compile(&e, &["z", "v"], DeltaPolicy::Zero).unwrap();
        let program = LaneProgram::from_tape(&tape);
        let mut want = vec![0.0; e.len() * xs.len()];
        program.eval_rows(0.0, &xs, &vs, &mut want, &mut Scratch::new());
        for simd in Simd::available() {
            let k = Kernel {
                program: program.clone(),
                simd,
            };
            let mut got = vec![0.0; want.len()];
            k.eval_batch(0.0, &xs, &vs, &mut got, &mut Scratch::new());
            let same = got
                .iter()
                .zip(&want)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{simd:?}");
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
