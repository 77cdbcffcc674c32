//! The simulator's evaluator of a compiled [`Tape`]: the tape's own instruction list, run
//! over chunks of [`CHUNK`] lanes inside one function compiled for the CPU's vector
//! extension (AVX-512 or AVX2, chosen at run time; the baseline build otherwise).
//!
//! There is one compiler, the tape's: a program is the tape's instructions and output slots,
//! and every instruction's arithmetic is the tape's own (`Op::apply`), so every output is
//! bit-for-bit the tape's (tested below) and the simulator's trajectories do not depend on
//! which evaluator runs.
//!
//! A program of a time-dependent model takes the time `t` as its third variable. The
//! instructions that depend on the time only (`exp(-0.5*t)`, `cos(w*t)` and what is built
//! from them and constants) are the same for every lane: [`LaneProgram::set_time`] computes
//! each once, as a scalar, and writes it to its slot for all lanes; the lane code skips them.
//! A program of the states only has no such instruction, and its code is what it was.

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
    /// The tape's instructions, one for one (what recognisers of special forms read).
    ops: Vec<LaneOp>,
    /// What [`LaneProgram::run`] executes: the same instructions with the states read in
    /// place and single-use products folded into their sums (see [`Step`]).
    code: Vec<Step>,
    /// What [`LaneProgram::run_lean`] executes: `code` without an instruction for a constant
    /// (its slot filled once by [`LaneProgram::fill_constants`]) or for a state that is an
    /// output (read in place, [`LaneProgram::lean_source`]).
    lean: Vec<Step>,
    /// The constants' slots and values.
    constants: Vec<(u32, f64)>,
    /// What [`LaneProgram::set_time`] executes: the instructions that depend on the time
    /// only (and on constants), in the tape's order; neither `code` nor `lean` has them.
    time: Vec<(u32, LaneOp)>,
    /// The constants the time instructions read (their slots and values).
    time_constants: Vec<(u32, f64)>,
    /// Where output j is after [`LaneProgram::run_lean`]: a slot, or a state's code.
    lean_outputs: Vec<u32>,
    /// The tape's Gaussian delta instructions, by index.
    gauss: Vec<Op>,
    outputs: Vec<u32>,
}

impl LaneProgram {
    /// The program of `tape` (variables: the two states, in the tape's order, then the time
    /// when the tape has a third variable): its instructions one for one.
    pub(crate) fn from_tape(tape: &Tape) -> LaneProgram {
        debug_assert!(
            tape.n_vars() <= 3,
            "a lane program takes the two states and the time"
        );
        let mut gauss = Vec::new();
        let ops: Vec<LaneOp> = tape
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
        let outputs = tape.output_slots().to_vec();
        let timed = time_only(&ops);
        let (code, _) = lane_code(&ops, &outputs, &timed, false);
        let (lean, lean_outputs) = lane_code(&ops, &outputs, &timed, true);
        let constant = |i: u32| match ops[i as usize] {
            LaneOp::Const(c) => Some((i, Op::Const(c).apply(0.0, 0.0))),
            _ => None,
        };
        let constants = (0..ops.len() as u32).filter_map(constant).collect();
        let time: Vec<(u32, LaneOp)> = (0..ops.len())
            .filter(|&i| timed[i])
            .map(|i| (i as u32, ops[i]))
            .collect();
        let mut read: Vec<u32> = time.iter().flat_map(|&(_, op)| operands(op)).collect();
        read.sort_unstable();
        read.dedup();
        let time_constants = read.into_iter().filter_map(constant).collect();
        LaneProgram {
            ops,
            code,
            lean,
            constants,
            time,
            time_constants,
            lean_outputs,
            gauss,
            outputs,
        }
    }

    /// Whether the program depends on the time (it has a time instruction).
    pub(crate) fn is_timed(&self) -> bool {
        !self.time.is_empty()
    }

    /// Whether instruction `i` depends on the time only (its value is the same in every
    /// lane at a given time).
    pub(crate) fn is_time_only(&self, i: usize) -> bool {
        self.time.iter().any(|&(dst, _)| dst as usize == i)
    }

    /// Writes the value at time `t` of every instruction that depends on the time only into
    /// its slot, for all `W` lanes: [`LaneProgram::run`] and [`LaneProgram::run_lean`] read
    /// them there and do not compute them. Each is computed once, by the tape's arithmetic;
    /// a program of the states only writes nothing.
    #[inline(always)]
    pub(crate) fn set_time<const W: usize>(&self, t: f64, slots: &mut [[f64; W]]) {
        if self.time.is_empty() {
            return;
        }
        // Lane 0 holds the scalar values the time instructions read.
        for &(slot, c) in &self.time_constants {
            slots[slot as usize][0] = c;
        }
        for &(dst, op) in &self.time {
            let (operands, n) = self.tape_op(op).operands();
            let get = |k: usize| {
                if k < n {
                    slots[operands[k] as usize][0]
                } else {
                    0.0
                }
            };
            let value = match op {
                LaneOp::Var(_) => t,
                _ => self.tape_op(op).apply(get(0), get(1)),
            };
            slots[dst as usize] = [value; W];
        }
    }

    /// The tape's instruction of `op`.
    fn tape_op(&self, op: LaneOp) -> Op {
        match op {
            LaneOp::Const(c) => Op::Const(c),
            LaneOp::Var(k) => Op::Var(k),
            LaneOp::Add(a, b) => Op::Add(a, b),
            LaneOp::Sub(a, b) => Op::Sub(a, b),
            LaneOp::Mul(a, b) => Op::Mul(a, b),
            LaneOp::Div(a, b) => Op::Div(a, b),
            LaneOp::AddC(a, c) => Op::AddC(a, c),
            LaneOp::MulC(a, c) => Op::MulC(a, c),
            LaneOp::Neg(a) => Op::Neg(a),
            LaneOp::Recip(a) => Op::Recip(a),
            LaneOp::Unary(f, a) => Op::Unary(f, a),
            LaneOp::Min(a, b) => Op::Min(a, b),
            LaneOp::Max(a, b) => Op::Max(a, b),
            LaneOp::PowC(a, c) => Op::PowC(a, c),
            LaneOp::Pow(a, b) => Op::Pow(a, b),
            LaneOp::Gauss(_, k) => self.gauss[k as usize],
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
    /// instruction); output `j` is then `slots[self.output(j)]`. The time instructions'
    /// slots must hold their values ([`LaneProgram::set_time`], once per time). Inlined into
    /// the caller, so that it is compiled for the caller's target features.
    #[inline(always)]
    pub(crate) fn run<const W: usize>(&self, x: &[f64; W], v: &[f64; W], slots: &mut [[f64; W]]) {
        self.exec(&self.code, x, v, slots);
    }

    /// Writes the program's constants into their slots, once for slots that only
    /// [`LaneProgram::run_lean`] uses afterwards.
    pub(crate) fn fill_constants<const W: usize>(&self, slots: &mut [[f64; W]]) {
        for &(slot, c) in &self.constants {
            slots[slot as usize] = [c; W];
        }
    }

    /// As [`LaneProgram::run`], for slots whose constants [`LaneProgram::fill_constants`]
    /// wrote (no instruction rewrites them); output `j` is then where
    /// [`LaneProgram::lean_source`] says, which may be a state itself (no instruction
    /// copies it). Every value is that of [`LaneProgram::run`], bit for bit.
    #[inline(always)]
    pub(crate) fn run_lean<const W: usize>(
        &self,
        x: &[f64; W],
        v: &[f64; W],
        slots: &mut [[f64; W]],
    ) {
        self.exec(&self.lean, x, v, slots);
    }

    /// Output `j` after [`LaneProgram::run_lean`] at the points `(x, v)` into `slots`.
    #[cfg(test)]
    pub(crate) fn lean_output<'a, const W: usize>(
        &self,
        j: usize,
        x: &'a [f64; W],
        v: &'a [f64; W],
        slots: &'a [[f64; W]],
    ) -> &'a [f64; W] {
        match self.lean_source(j) {
            LeanOutput::Slot(s) => &slots[s],
            LeanOutput::State(0) => x,
            LeanOutput::State(_) => v,
        }
    }

    /// Whether [`LaneProgram::run_lean`] reads state `k` (0: x, 1: v) or gives it as an
    /// output: a caller need not write a state the program never looks at.
    pub(crate) fn lean_reads_state(&self, k: u8) -> bool {
        let state = if k == 0 { STATE_X } else { STATE_V };
        self.lean_outputs.contains(&state)
            || self.lean.iter().any(|s| match s.op {
                Code::Op(op) => operands(op).contains(&state),
                Code::MulCAdd(a, _, b)
                | Code::AddMulC(a, b, _)
                | Code::MulCSub(a, _, b)
                | Code::SubMulC(a, b, _) => a == state || b == state,
            })
    }

    /// Where output `j` is after [`LaneProgram::run_lean`].
    pub(crate) fn lean_source(&self, j: usize) -> LeanOutput {
        match self.lean_outputs[j] {
            STATE_X => LeanOutput::State(0),
            STATE_V => LeanOutput::State(1),
            s => LeanOutput::Slot(s as usize),
        }
    }

    /// Runs `code` (this program's [`LaneProgram::run`] or [`LaneProgram::run_lean`] code).
    #[inline(always)]
    fn exec<const W: usize>(
        &self,
        code: &[Step],
        x: &[f64; W],
        v: &[f64; W],
        slots: &mut [[f64; W]],
    ) {
        for &Step { dst, op } in code {
            let (done, rest) = slots.split_at_mut(dst as usize);
            let dst = &mut rest[0];
            // An operand is an earlier slot or one of the states, read where it is.
            let src = |a: u32| match a {
                STATE_X => x,
                STATE_V => v,
                _ => &done[a as usize],
            };
            // Each arm applies the tape's arithmetic of a variant known in the arm (rebuilt,
            // so that `apply` folds to the bare operation and the loop vectorises).
            let op = match op {
                Code::Op(op) => op,
                // The product rounded, then the sum rounded: the tape's two instructions.
                Code::MulCAdd(a, c, b) => {
                    zip2(dst, src(a), src(b), |p, q| {
                        Op::Add(0, 0).apply(Op::MulC(0, c).apply(p, 0.0), q)
                    });
                    continue;
                }
                Code::AddMulC(a, b, c) => {
                    zip2(dst, src(a), src(b), |p, q| {
                        Op::Add(0, 0).apply(p, Op::MulC(0, c).apply(q, 0.0))
                    });
                    continue;
                }
                Code::MulCSub(a, c, b) => {
                    zip2(dst, src(a), src(b), |p, q| {
                        Op::Sub(0, 0).apply(Op::MulC(0, c).apply(p, 0.0), q)
                    });
                    continue;
                }
                Code::SubMulC(a, b, c) => {
                    zip2(dst, src(a), src(b), |p, q| {
                        Op::Sub(0, 0).apply(p, Op::MulC(0, c).apply(q, 0.0))
                    });
                    continue;
                }
            };
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

    /// Every output at `n = x.len()` points at time `t`: output `j` at point `i` goes to
    /// `out[j*n + i]`; `slots` is reusable working memory. Inlined, for the caller's target
    /// features.
    #[inline(always)]
    pub(crate) fn eval_rows(
        &self,
        t: f64,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        slots: &mut Vec<[f64; CHUNK]>,
    ) {
        let n = x.len();
        let k = self.outputs.len();
        let out = &mut out[..k * n];
        slots.resize(self.ops.len(), [0.0; CHUNK]);
        self.set_time(t, slots);
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
        self.set_time(t, &mut one);
        for i in start..n {
            self.run(&[x[i]], &[v[i]], &mut one);
            for j in 0..k {
                out[j * n + i] = one[self.output(j)][0];
            }
        }
    }

    /// Every output at one point at time `t` (on the stack for programs of up to 32
    /// instructions, such as impact laws, evaluated at every impact).
    pub(crate) fn eval_point(&self, t: f64, x: f64, v: f64, out: &mut [f64]) {
        const STACK: usize = 32;
        let mut stack = [[0.0; 1]; STACK];
        let mut heap = Vec::new();
        let one: &mut [[f64; 1]] = if self.ops.len() <= STACK {
            &mut stack[..self.ops.len()]
        } else {
            heap.resize(self.ops.len(), [0.0; 1]);
            &mut heap
        };
        self.set_time(t, one);
        self.run(&[x], &[v], one);
        for (j, o) in out.iter_mut().enumerate().take(self.outputs.len()) {
            *o = one[self.output(j)][0];
        }
    }
}

/// Where an output of [`LaneProgram::run_lean`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LeanOutput {
    /// A slot of the program's.
    Slot(usize),
    /// The state x (0) or v (1) it was run at.
    State(u8),
}

/// Operand codes of the lane code for the states themselves (no tape has this many slots).
const STATE_X: u32 = u32::MAX;
const STATE_V: u32 = u32::MAX - 1;

/// One instruction of the lane code: what it computes and the slot it writes (the slot of
/// the tape instruction whose value it is).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Step {
    dst: u32,
    op: Code,
}

/// A lane-code instruction: a tape instruction, or a tape product by a constant fused with
/// the sum or difference that is its only use (`MulCAdd(a, c, b)` is `(a·c) + b`, operands
/// in the tape's order), each operation rounded as the tape rounds it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Code {
    Op(LaneOp),
    MulCAdd(u32, f64, u32),
    AddMulC(u32, u32, f64),
    MulCSub(u32, f64, u32),
    SubMulC(u32, u32, f64),
}

/// Which of `ops` depend on the time only: the time (variable 2) and every instruction
/// whose operands are time-only instructions or constants, one of them time-only.
fn time_only(ops: &[LaneOp]) -> Vec<bool> {
    let mut timed = vec![false; ops.len()];
    for (i, &op) in ops.iter().enumerate() {
        let reads = operands(op);
        timed[i] = match op {
            LaneOp::Var(k) => k == 2,
            _ => {
                reads.iter().any(|&a| timed[a as usize])
                    && reads
                        .iter()
                        .all(|&a| timed[a as usize] || matches!(ops[a as usize], LaneOp::Const(_)))
            }
        };
    }
    timed
}

/// The lane code of a tape's instructions `ops` with outputs `outputs`, and where each
/// output is then read: a state that is no output is read in place rather than copied into a
/// slot, and a product by a constant used only by one sum or difference is computed inside
/// it (one pass over the lanes, not two). Neither code has an instruction that depends on
/// the time only (`timed`: [`LaneProgram::set_time`] writes its slot). `lean` code has no
/// instruction for a constant (its slot is filled once) nor for a state (read in place even
/// when it is an output). Every value is computed by the same operations in the same order
/// as in the tape.
fn lane_code(ops: &[LaneOp], outputs: &[u32], timed: &[bool], lean: bool) -> (Vec<Step>, Vec<u32>) {
    let mut uses = vec![0usize; ops.len()];
    for &o in outputs {
        uses[o as usize] += 1;
    }
    for op in ops {
        for a in operands(*op) {
            uses[a as usize] += 1;
        }
    }
    let is_output = |i: usize| outputs.contains(&(i as u32));
    // Where each slot's value is read from: a state, or the slot itself.
    let mut at: Vec<u32> = (0..ops.len() as u32).collect();
    // Whether slot i is a product computed inside the sum that uses it.
    let mut fused = vec![false; ops.len()];
    let single_product = |a: u32| match ops[a as usize] {
        LaneOp::MulC(p, c)
            if uses[a as usize] == 1 && !is_output(a as usize) && !timed[a as usize] =>
        {
            Some((p, c))
        }
        _ => None,
    };
    let mut code = Vec::with_capacity(ops.len());
    for (i, &op) in ops.iter().enumerate() {
        if timed[i] {
            continue;
        }
        match op {
            LaneOp::Var(k) if lean || !is_output(i) => {
                at[i] = if k == 0 { STATE_X } else { STATE_V };
                continue;
            }
            LaneOp::Const(_) if lean => continue,
            _ => {}
        }
        let r = |a: u32| at[a as usize];
        let step = match op {
            LaneOp::Add(a, b) | LaneOp::Sub(a, b) if a != b => {
                let add = matches!(op, LaneOp::Add(..));
                match (single_product(a), single_product(b)) {
                    (Some((p, c)), _) => {
                        fused[a as usize] = true;
                        if add {
                            Code::MulCAdd(r(p), c, r(b))
                        } else {
                            Code::MulCSub(r(p), c, r(b))
                        }
                    }
                    (None, Some((q, c))) => {
                        fused[b as usize] = true;
                        if add {
                            Code::AddMulC(r(a), r(q), c)
                        } else {
                            Code::SubMulC(r(a), r(q), c)
                        }
                    }
                    (None, None) => Code::Op(remap(op, &r)),
                }
            }
            _ => Code::Op(remap(op, &r)),
        };
        code.push(Step {
            dst: i as u32,
            op: step,
        });
    }
    // Products computed inside their sum write no slot of their own.
    code.retain(|s| !fused[s.dst as usize]);
    let read_at = outputs.iter().map(|&o| at[o as usize]).collect();
    (code, read_at)
}

/// The slots an instruction reads.
fn operands(op: LaneOp) -> Vec<u32> {
    match op {
        LaneOp::Const(_) | LaneOp::Var(_) => vec![],
        LaneOp::Add(a, b)
        | LaneOp::Sub(a, b)
        | LaneOp::Mul(a, b)
        | LaneOp::Div(a, b)
        | LaneOp::Min(a, b)
        | LaneOp::Max(a, b)
        | LaneOp::Pow(a, b) => vec![a, b],
        LaneOp::AddC(a, _)
        | LaneOp::MulC(a, _)
        | LaneOp::Neg(a)
        | LaneOp::Recip(a)
        | LaneOp::Unary(_, a)
        | LaneOp::PowC(a, _)
        | LaneOp::Gauss(a, _) => vec![a],
    }
}

/// `op` with its operands read through `r`.
fn remap(op: LaneOp, r: &impl Fn(u32) -> u32) -> LaneOp {
    match op {
        LaneOp::Const(_) | LaneOp::Var(_) => op,
        LaneOp::Add(a, b) => LaneOp::Add(r(a), r(b)),
        LaneOp::Sub(a, b) => LaneOp::Sub(r(a), r(b)),
        LaneOp::Mul(a, b) => LaneOp::Mul(r(a), r(b)),
        LaneOp::Div(a, b) => LaneOp::Div(r(a), r(b)),
        LaneOp::Min(a, b) => LaneOp::Min(r(a), r(b)),
        LaneOp::Max(a, b) => LaneOp::Max(r(a), r(b)),
        LaneOp::Pow(a, b) => LaneOp::Pow(r(a), r(b)),
        LaneOp::AddC(a, c) => LaneOp::AddC(r(a), c),
        LaneOp::MulC(a, c) => LaneOp::MulC(r(a), c),
        LaneOp::Neg(a) => LaneOp::Neg(r(a)),
        LaneOp::Recip(a) => LaneOp::Recip(r(a)),
        LaneOp::Unary(f, a) => LaneOp::Unary(f, r(a)),
        LaneOp::PowC(a, c) => LaneOp::PowC(r(a), c),
        LaneOp::Gauss(a, k) => LaneOp::Gauss(r(a), k),
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
            assert!(!prog.is_timed());
            check_against_tape(&exprs, &tape, &prog, None);
        }
    }

    fn t() -> Expr {
        Expr::sym("t")
    }

    /// A program of the states and the time: its time instructions (`exp(-0.5 t)`, the
    /// envelope, `cos(2t)`, a time-only output, a product of a state with a time-only
    /// factor) are computed once per time by `set_time`, not by the lane code, and every
    /// output is still the tape's bit for bit, at several times, whatever the slots held
    /// before.
    #[test]
    fn time_instructions_are_computed_once_per_time_and_agree_with_the_tape() {
        let n = |x: f64| Expr::num(x);
        let env =
            n(4.0) * (Expr::call(Func::Exp, n(-0.5) * t()) - Expr::call(Func::Exp, n(-1.0) * t()));
        let exprs = vec![
            -(n(0.5) * v()) - z() + n(0.3) * Expr::call(Func::Cos, n(2.0) * t()),
            env.clone(),
            env * (Expr::call(Func::Sgn, z()) + n(0.1) * z()),
            -(n(0.1) + n(0.05) * Expr::call(Func::Sin, t())) * v() - Expr::pow(z(), n(3.0)),
            Expr::pow(t() + n(1.0), n(-1.5)) * v() / (n(1.0) + t() * t()),
            z(),
            n(2.0),
        ];
        let tape = Tape::compile(&exprs, &["z", "v", "t"], DeltaPolicy::Zero).unwrap();
        let prog = LaneProgram::from_tape(&tape);
        assert!(prog.is_timed());
        // The lane code computes no time instruction.
        assert!(prog
            .code
            .iter()
            .chain(&prog.lean)
            .all(|s| !prog.is_time_only(s.dst as usize)));
        assert!(
            prog.is_time_only(prog.output(1)),
            "the envelope is a time instruction"
        );
        for time in [0.0, 0.3, 1.7, 25.0] {
            check_against_tape(&exprs, &tape, &prog, Some(time));
        }
    }

    /// `prog`'s outputs (every evaluator: rows, point, lean code) against `tape`'s, bit for
    /// bit, at many points; at the time `time` when the program takes one.
    fn check_against_tape(exprs: &[Expr], tape: &Tape, prog: &LaneProgram, time: Option<f64>) {
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
        let tt = time.unwrap_or(f64::NAN);
        // Slots left over from another time: set_time must rewrite what depends on it.
        let mut slots = vec![[f64::NAN; CHUNK]; prog.n_slots()];
        prog.set_time(tt + 1.0, &mut slots);
        prog.eval_rows(tt, &xs, &vs, &mut got, &mut slots);
        let mut want = vec![0.0; exprs.len()];
        let mut scratch = Vec::new();
        let mut one = vec![0.0; exprs.len()];
        // The lean code on slots that only its constants (and the time's values) were
        // written into, reused from point to point as the simulator reuses them from step
        // to step.
        let mut lean = vec![[f64::NAN; 1]; prog.n_slots()];
        prog.fill_constants(&mut lean);
        prog.set_time(tt, &mut lean);
        for i in 0..np {
            match time {
                Some(t) => tape.eval(&[xs[i], vs[i], t], &mut scratch, &mut want),
                None => tape.eval(&[xs[i], vs[i]], &mut scratch, &mut want),
            }
            prog.eval_point(tt, xs[i], vs[i], &mut one);
            let (x, v) = ([xs[i]], [vs[i]]);
            prog.run_lean(&x, &v, &mut lean);
            for j in 0..exprs.len() {
                let l = prog.lean_output(j, &x, &v, &lean)[0];
                assert!(l.to_bits() == want[j].to_bits() || (l.is_nan() && want[j].is_nan()));
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

    /// The lane code reads the states in place and computes a single-use product by a
    /// constant inside its sum; a product that is itself an output keeps its slot. (That the
    /// values are the tape's bit for bit is `outputs_are_the_tapes_bit_for_bit`.)
    #[test]
    fn lane_code_reads_states_in_place_and_fuses_single_use_products() {
        let n = |x: f64| Expr::num(x);
        let force = -(n(0.1) * v()) - z() - n(0.5) * Expr::pow(z(), n(3.0));
        let tape =
            Tape::compile(std::slice::from_ref(&force), &["z", "v"], DeltaPolicy::Zero).unwrap();
        let p = LaneProgram::from_tape(&tape);
        let vars = p
            .ops()
            .iter()
            .filter(|o| matches!(o, LaneOp::Var(_)))
            .count();
        let fused = |p: &LaneProgram| {
            p.code
                .iter()
                .filter(|s| !matches!(s.op, Code::Op(_)))
                .count()
        };
        assert_eq!(vars, 2);
        assert!(p
            .code
            .iter()
            .all(|s| !matches!(s.op, Code::Op(LaneOp::Var(_)))));
        assert_eq!(fused(&p), 2, "{:?}", p.code);
        assert_eq!(p.code.len(), p.ops().len() - vars - 2);
        // The product −0.1·v as an output too: it keeps its slot and its own instruction.
        let tape =
            Tape::compile(&[force, -(n(0.1) * v())], &["z", "v"], DeltaPolicy::Zero).unwrap();
        let q = LaneProgram::from_tape(&tape);
        assert_eq!(fused(&q), 1, "{:?}", q.code);
        let mut out = [0.0; 2];
        q.eval_point(0.0, 0.3, -2.0, &mut out);
        assert_eq!(out[1], -0.1 * -2.0);
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
