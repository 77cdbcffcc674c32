//! Platen's weak order-2 step (see `compile/scheme.rs`) of a batch, chunk by chunk of lanes: every
//! kernel evaluated by its lane program on the chunk, the predictor, the supporting points
//! and the sums of the step formed in few passes over the chunk while it is in L1 (the
//! increments and pair signs formed where they are used, from the standardised draws), in
//! fixed-length loops without bounds checks (so they vectorise). The arithmetic of each lane
//! is that of the scalar scheme, in the same order, so the result does not depend on the
//! chunking; the working memory is sized once per batch, so a step allocates nothing.

use crate::mc::compile::eval::BatchKernel;
use crate::mc::compile::lanes::{LaneProgram, LeanOutput};
use crate::mc::compile::scheme::PlatenKernels;
use crate::mc::kernel::fused::{chunk, chunk_mut};

/// Lanes of a chunk of Platen's step: a batch's default 128 lanes in one chunk (each
/// instruction of a lane program dispatched once per 128 lanes; measured faster than 64,
/// and 32 slower, on the barrier model; with every evaluation in its own rows, 64 and 256
/// measured 5 % and 75 % slower than 128 on `cubic_damping_two_noises`: 256 leaves L1).
const CHUNK: usize = 128;

type Lanes = [f64; CHUNK];

/// A row of a chunk's working memory: an index into [`PlatenWork::rows`], or one of the
/// chunk's states ([`ROW_X`], [`ROW_V`]: a kernel output that is a state itself).
type Row = u32;
const ROW_X: Row = u32::MAX;
const ROW_V: Row = u32::MAX - 1;

/// Working memory of Platen's step, sized for a batch once.
pub(in crate::mc) struct PlatenWork {
    /// A chunk's rows: the predictor's x and v, each supporting point's x and v, then the
    /// slots of the kernel at the states, of the drift at the predictor and of each
    /// supporting evaluation (their constants written once, as no step rewrites them).
    rows: Vec<Lanes>,
    /// Where the kernel's slots start among the rows, and its outputs (the drift, then the
    /// columns b̃ of x, then of v).
    e0_at: usize,
    e0_out: Vec<Row>,
    /// Where the drift's slots start, and its outputs.
    a1_at: usize,
    a1_out: [Row; 2],
    /// The supporting evaluations.
    support: Vec<Support>,
    /// For each column j, its R⁺_j evaluation in `support` (R⁻_j the next); `None` for a
    /// state-independent column.
    at_r: Vec<Option<usize>>,
    /// For each source r, its U⁺_r evaluation in `support` (U⁻_r the next); `None` when
    /// every other column is state-independent (no cross terms).
    at_u: Vec<Option<usize>>,
    /// The random bits of the pair signs of the whole batch, pair p of lane i at `p*n + i`
    /// (the sign of V is the top bit).
    pub(in crate::mc) pair_bits: Vec<u64>,
    /// The batch's new states, exchanged with the old ones after a step.
    pub(in crate::mc) nx: Vec<f64>,
    pub(in crate::mc) nv: Vec<f64>,
    /// A partial last chunk's draws and pair bits, padded to a whole chunk.
    pad_z: Vec<f64>,
    pad_bits: Vec<u64>,
    /// A chunk's sums of the step's terms.
    sums: Box<Sums>,
}

/// One evaluation of noise columns at a supporting point, the s-th: its point is rows
/// `2 + 2s` (x) and `3 + 2s` (v).
struct Support {
    /// Column j's own program (outputs b̃_0j, b̃_1j), or `None`: every column's.
    column: Option<usize>,
    /// The point is (Y + aΔ, for R±) or (Y, for U±) `± b̃_shift·√Δ` (+ for the first
    /// of a pair, − for the second).
    drifted: bool,
    shift: usize,
    /// Whether its program reads the point's x, v (a coordinate it does not read is not
    /// written).
    reads: [bool; 2],
    /// Where its slots start among the rows, and its outputs.
    at: usize,
    out: Vec<Row>,
}

impl Support {
    fn program<'a>(&self, pk: &'a PlatenKernels) -> &'a LaneProgram {
        match self.column {
            Some(j) => pk.column[j].program(),
            None => pk.noise.program(),
        }
    }
}

/// The rows of a program's outputs after [`LaneProgram::run_lean`] into slots starting at
/// row `at`, at the point in rows `(x, v)`.
fn output_rows(program: &LaneProgram, at: usize, x: Row, v: Row) -> Vec<Row> {
    (0..program.outputs().len())
        .map(|j| match program.lean_source(j) {
            LeanOutput::Slot(s) => (at + s) as Row,
            LeanOutput::State(0) => x,
            LeanOutput::State(_) => v,
        })
        .collect()
}

/// Row `r` of a chunk with states `(x, v)` and working rows `rows`.
#[inline(always)]
fn row<'a>(rows: &'a [Lanes], x: &'a Lanes, v: &'a Lanes, r: Row) -> &'a Lanes {
    match r {
        ROW_X => x,
        ROW_V => v,
        _ => &rows[r as usize],
    }
}

/// A chunk's sums of the step's terms, of x and of v.
#[repr(C, align(64))]
struct Sums([Lanes; 2]);

impl PlatenWork {
    /// Working memory for `lanes` lanes of `m` sources.
    pub(in crate::mc) fn new(
        kernel: &dyn BatchKernel,
        pk: &PlatenKernels,
        m: usize,
        lanes: usize,
    ) -> Self {
        let mut plan = Vec::new();
        let mut at_r = vec![None; m];
        for j in 0..m {
            if pk.constant[j] {
                continue;
            }
            at_r[j] = Some(plan.len());
            // R⁺_j, then R⁻_j.
            plan.extend([(Some(j), true, j); 2]);
        }
        let mut at_u = vec![None; m];
        for r in 0..m {
            // b̃_j(U±_r) for the state-dependent columns j ≠ r: column j's own program when
            // it is the only one (the same outputs, fewer instructions), else all columns.
            let mut varying = (0..m).filter(|&j| j != r && !pk.constant[j]);
            let column = match (varying.next(), varying.next()) {
                (None, _) => continue,
                (Some(j), None) => Some(j),
                _ => None,
            };
            at_u[r] = Some(plan.len());
            plan.extend([(column, false, r); 2]);
        }
        let (kernel, drift) = (kernel.program(), pk.drift.program());
        let e0_at = 2 + 2 * plan.len();
        let a1_at = e0_at + kernel.n_slots();
        let mut at = a1_at + drift.n_slots();
        let a1_out = output_rows(drift, a1_at, 0, 1);
        let support: Vec<Support> = plan
            .into_iter()
            .enumerate()
            .map(|(s, (column, drifted, shift))| {
                let mut sup = Support {
                    column,
                    drifted,
                    shift,
                    reads: [false; 2],
                    at,
                    out: Vec::new(),
                };
                let program = sup.program(pk);
                sup.reads = [program.lean_reads_state(0), program.lean_reads_state(1)];
                sup.out = output_rows(program, at, (2 + 2 * s) as Row, (3 + 2 * s) as Row);
                at += program.n_slots();
                sup
            })
            .collect();
        let mut rows = vec![[0.0; CHUNK]; at];
        kernel.fill_constants(&mut rows[e0_at..a1_at]);
        drift.fill_constants(&mut rows[a1_at..]);
        for s in &support {
            s.program(pk).fill_constants(&mut rows[s.at..]);
        }
        let pairs = m * m.saturating_sub(1) / 2;
        PlatenWork {
            rows,
            e0_at,
            e0_out: output_rows(kernel, e0_at, ROW_X, ROW_V),
            a1_at,
            a1_out: [a1_out[0], a1_out[1]],
            support,
            at_r,
            at_u,
            pair_bits: vec![0; pairs * lanes],
            nx: vec![0.0; lanes],
            nv: vec![0.0; lanes],
            pad_z: vec![0.0; m * CHUNK],
            pad_bits: vec![0; pairs * CHUNK],
            sums: Box::new(Sums([[0.0; CHUNK]; 2])),
        }
    }

    /// One step of every lane from `(x, v)` at time `t` into `(self.nx, self.nv)`: the
    /// increments are ΔŴ = √h·`z` (source k of lane i at `z[k*n + i]`), the pair signs from
    /// `self.pair_bits`, both formed where the chunk's passes use them.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(in crate::mc) fn step(
        &mut self,
        kernel: &LaneProgram,
        pk: &PlatenKernels,
        m: usize,
        t: f64,
        h: f64,
        x: &[f64],
        v: &[f64],
        z: &[f64],
    ) {
        self.set_time(kernel, pk, t, h);
        let n = x.len();
        let mut nx = std::mem::take(&mut self.nx);
        let mut nv = std::mem::take(&mut self.nv);
        let bits = std::mem::take(&mut self.pair_bits);
        let mut start = 0;
        while start + CHUNK <= n {
            let r = start..start + CHUNK;
            let (ox, ov) = (chunk_mut(&mut nx[r.clone()]), chunk_mut(&mut nv[r.clone()]));
            let draws = Draws {
                z,
                bits: &bits,
                stride: n,
                start,
            };
            self.chunk(
                kernel,
                pk,
                m,
                h,
                chunk(&x[r.clone()]),
                chunk(&v[r]),
                &draws,
                ox,
                ov,
            );
            start += CHUNK;
        }
        if start < n {
            // A partial last chunk is padded with zeros; its padding lanes are discarded.
            let len = n - start;
            let (mut pad_z, mut pad_bits) = (
                std::mem::take(&mut self.pad_z),
                std::mem::take(&mut self.pad_bits),
            );
            for (k, row) in pad_z.chunks_exact_mut(CHUNK).enumerate() {
                row[..len].copy_from_slice(&z[k * n + start..k * n + n]);
                row[len..].fill(0.0);
            }
            for (p, row) in pad_bits.chunks_exact_mut(CHUNK).enumerate() {
                row[..len].copy_from_slice(&bits[p * n + start..p * n + n]);
                row[len..].fill(0);
            }
            let (mut xc, mut vc) = ([0.0; CHUNK], [0.0; CHUNK]);
            xc[..len].copy_from_slice(&x[start..]);
            vc[..len].copy_from_slice(&v[start..]);
            let (mut ox, mut ov) = ([0.0; CHUNK], [0.0; CHUNK]);
            let draws = Draws {
                z: &pad_z,
                bits: &pad_bits,
                stride: CHUNK,
                start: 0,
            };
            self.chunk(kernel, pk, m, h, &xc, &vc, &draws, &mut ox, &mut ov);
            nx[start..].copy_from_slice(&ox[..len]);
            nv[start..].copy_from_slice(&ov[..len]);
            (self.pad_z, self.pad_bits) = (pad_z, pad_bits);
        }
        self.nx = nx;
        self.nv = nv;
        self.pair_bits = bits;
    }

    /// Writes the time instructions' values of every program into its slots: the kernel's
    /// (at the state Y) and the U± evaluations' at the step's start `t`, the drift's (at the
    /// predictor Ῡ) and the R± evaluations' at its end `t + h`, as the scheme applied to
    /// the system with the time as a state takes them. Nothing for programs of the states
    /// only.
    fn set_time(&mut self, kernel: &LaneProgram, pk: &PlatenKernels, t: f64, h: f64) {
        let rows = &mut self.rows;
        kernel.set_time(t, &mut rows[self.e0_at..self.a1_at]);
        pk.drift.program().set_time(t + h, &mut rows[self.a1_at..]);
        for s in &self.support {
            let at = if s.drifted { t + h } else { t };
            s.program(pk).set_time(at, &mut rows[s.at..]);
        }
    }

    /// Platen's step of one chunk into `(out_x, out_v)` (the arithmetic of
    /// [`platen_point_step`], lane-parallel).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn chunk(
        &mut self,
        kernel: &LaneProgram,
        pk: &PlatenKernels,
        m: usize,
        h: f64,
        x: &Lanes,
        v: &Lanes,
        draws: &Draws,
        out_x: &mut Lanes,
        out_v: &mut Lanes,
    ) {
        let sq = h.sqrt();
        let inv_sq = 1.0 / sq;
        let Self {
            rows,
            e0_at,
            e0_out,
            a1_at,
            a1_out,
            support,
            at_r,
            at_u,
            sums,
            ..
        } = self;
        let (e0_at, a1_at) = (*e0_at, *a1_at);
        kernel.run_lean(x, v, &mut rows[e0_at..a1_at]);
        {
            // The predictor Ῡ = Y + aΔ + Σ_k b̃_k ΔŴ_k and the supporting points, written
            // to the rows before the kernel's, which they read.
            let (points, after) = rows.split_at_mut(e0_at);
            let e = |o: usize| match e0_out[o] {
                ROW_X => x,
                ROW_V => v,
                r => &after[r as usize - e0_at],
            };
            let (fx, fv) = (e(0), e(1));
            let [px, pv, points @ ..] = points else {
                unreachable!("the predictor's rows")
            };
            // Two sources a pass (one pass for the common m ≤ 2), each lane's sum in the
            // sources' order.
            let mut k = 0;
            while k < m {
                let two = k + 1 < m;
                let k1 = if two { k + 1 } else { k };
                let pass = Predictor {
                    f: [fx, fv],
                    b: [[e(2 + k), e(2 + m + k)], [e(2 + k1), e(2 + m + k1)]],
                    z: [draws.z(k), draws.z(k1)],
                    y: [x, v],
                    h,
                    sq,
                };
                let (first, last) = (k == 0, k1 + 1 == m);
                pass.run(first, last, two, [&mut *px, &mut *pv]);
                k = k1 + 1;
            }
            for (pair, p) in support.chunks_exact(2).zip(points.chunks_exact_mut(4)) {
                let [p0, p1, p2, p3] = p else {
                    unreachable!("two points of two rows")
                };
                // Both points of a pair are evaluated by one program: of each coordinate
                // (x: rows p0 and p2, v: p1 and p3) only those it reads are written.
                let (sup, shift) = (&pair[0], pair[0].shift);
                let coordinates = [
                    (p0, p2, x, fx, e(2 + shift)),
                    (p1, p3, v, fv, e(2 + m + shift)),
                ];
                for ((plus, minus, y, f, c), reads) in coordinates.into_iter().zip(sup.reads) {
                    match (reads, sup.drifted) {
                        (false, _) => {}
                        (true, true) => supporting_coordinate::<true>(plus, minus, y, f, c, h, sq),
                        (true, false) => {
                            supporting_coordinate::<false>(plus, minus, y, f, c, h, sq)
                        }
                    }
                }
            }
        }
        {
            let (points, slots) = rows.split_at_mut(a1_at);
            let drift = pk.drift.program();
            drift.run_lean(&points[0], &points[1], &mut slots[..drift.n_slots()]);
        }
        for (s, sup) in support.iter().enumerate() {
            let (points, slots) = rows.split_at_mut(sup.at);
            let program = sup.program(pk);
            program.run_lean(
                &points[2 + 2 * s],
                &points[3 + 2 * s],
                &mut slots[..program.n_slots()],
            );
        }
        // The sums of the step, a term per pass: the first starts them from
        // ½(a(Ῡ) + a)Δ, the last writes Y plus them to the output.
        let rows = &*rows;
        let r = |i: Row| row(rows, x, v, i);
        let start = Start {
            x,
            v,
            f: [r(e0_out[0]), r(e0_out[1])],
            g: [r(a1_out[0]), r(a1_out[1])],
        };
        let cross = (0..m)
            .filter(|&rr| at_u[rr].is_some())
            .map(|rr| (0..m).filter(|&j| j != rr && at_r[j].is_some()).count())
            .sum::<usize>();
        let terms = m + cross;
        let Sums([sx, sv]) = &mut **sums;
        let mut out = Out {
            sums: [sx, sv],
            new: [out_x, out_v],
        };
        if terms == 0 {
            add_term::<true, true>(&mut out, &start, h, |_| (0.0, 0.0));
            return;
        }
        let mut t = 0;
        for j in 0..m {
            let (cx, cv, zj) = (r(e0_out[2 + j]), r(e0_out[2 + m + j]), draws.z(j));
            let (first, last) = (t == 0, t + 1 == terms);
            t += 1;
            let Some(s) = at_r[j] else {
                let term = |i: usize| {
                    let w = sq * zj[i];
                    (cx[i] * w, cv[i] * w)
                };
                add(first, last, &mut out, &start, h, term);
                continue;
            };
            // Column j's program gives (b̃_0j, b̃_1j) as its outputs 0 and 1.
            let (p, n) = (&support[s].out, &support[s + 1].out);
            let (bpx, bmx, bpv, bmv) = (r(p[0]), r(n[0]), r(p[1]), r(n[1]));
            let term = |i: usize| {
                let w = sq * zj[i];
                let q = (w * w - h) * inv_sq;
                (
                    0.25 * ((bpx[i] + bmx[i] + 2.0 * cx[i]) * w + (bpx[i] - bmx[i]) * q),
                    0.25 * ((bpv[i] + bmv[i] + 2.0 * cv[i]) * w + (bpv[i] - bmv[i]) * q),
                )
            };
            add(first, last, &mut out, &start, h, term);
        }
        for rr in 0..m {
            let Some(s) = at_u[rr] else { continue };
            let zr = draws.z(rr);
            for j in 0..m {
                if j == rr || at_r[j].is_none() {
                    continue;
                }
                // The slots of (b̃_0j, b̃_1j) among the program's outputs.
                let (ox, ov) = match support[s].column {
                    Some(_) => (0, 1),
                    None => (j, m + j),
                };
                let (cx, cv, zj) = (r(e0_out[2 + j]), r(e0_out[2 + m + j]), draws.z(j));
                let (p, n) = (&support[s].out, &support[s + 1].out);
                let (bpx, bmx, bpv, bmv) = (r(p[ox]), r(n[ox]), r(p[ov]), r(n[ov]));
                let (pair, sign) = pair_slot(rr, j, m);
                let bits = draws.bits(pair);
                let last = t + 1 == terms;
                t += 1;
                let term = |i: usize| {
                    let w = sq * zj[i];
                    let vp = if bits[i] >> 63 == 0 { h } else { -h };
                    let q = (w * (sq * zr[i]) + sign * vp) * inv_sq;
                    (
                        0.25 * ((bpx[i] + bmx[i] - 2.0 * cx[i]) * w + (bpx[i] - bmx[i]) * q),
                        0.25 * ((bpv[i] + bmv[i] - 2.0 * cv[i]) * w + (bpv[i] - bmv[i]) * q),
                    )
                };
                add(false, last, &mut out, &start, h, term);
            }
        }
    }
}

/// The predictor's increment d = aΔ + Σ_k b̃_k ΔŴ_k of one or two sources (`b`, `z`: the
/// second's the first's again when there is one only).
struct Predictor<'a> {
    /// The drift at the state, x and v.
    f: [&'a Lanes; 2],
    /// Each source's column (x, v) and standardised draws.
    b: [[&'a Lanes; 2]; 2],
    z: [&'a Lanes; 2],
    /// The state.
    y: [&'a Lanes; 2],
    h: f64,
    sq: f64,
}

impl Predictor<'_> {
    /// Adds the sources' shares to `d` (rows of x and v): the first pass starts from aΔ,
    /// the last adds the state (d becomes Ῡ); `two`: both sources, else the first only.
    #[inline(always)]
    fn run(&self, first: bool, last: bool, two: bool, d: [&mut Lanes; 2]) {
        match (first, last, two) {
            (true, true, true) => self.pass::<true, true, true>(d),
            (true, true, false) => self.pass::<true, true, false>(d),
            (true, false, true) => self.pass::<true, false, true>(d),
            (true, false, false) => self.pass::<true, false, false>(d),
            (false, true, true) => self.pass::<false, true, true>(d),
            (false, true, false) => self.pass::<false, true, false>(d),
            (false, false, true) => self.pass::<false, false, true>(d),
            (false, false, false) => self.pass::<false, false, false>(d),
        }
    }

    #[inline(always)]
    fn pass<const FIRST: bool, const LAST: bool, const TWO: bool>(&self, d: [&mut Lanes; 2]) {
        let [dx, dv] = d;
        let Predictor { f, b, z, y, h, sq } = *self;
        for i in 0..CHUNK {
            let (ax, av) = if FIRST {
                (f[0][i] * h, f[1][i] * h)
            } else {
                (dx[i], dv[i])
            };
            let w = sq * z[0][i];
            let (mut nx, mut nv) = (ax + b[0][0][i] * w, av + b[0][1][i] * w);
            if TWO {
                let w = sq * z[1][i];
                (nx, nv) = (nx + b[1][0][i] * w, nv + b[1][1][i] * w);
            }
            (dx[i], dv[i]) = if LAST {
                (y[0][i] + nx, y[1][i] + nv)
            } else {
                (nx, nv)
            };
        }
    }
}

/// One coordinate of the points (Y + aΔ or Y) ± b̃√Δ (`DRIFTED` or not) of a column: into
/// `plus` and `minus`, from that coordinate's state `y`, drift `f` and column `c`.
#[inline(always)]
fn supporting_coordinate<const DRIFTED: bool>(
    plus: &mut Lanes,
    minus: &mut Lanes,
    y: &Lanes,
    f: &Lanes,
    c: &Lanes,
    h: f64,
    sq: f64,
) {
    for i in 0..CHUNK {
        let u = if DRIFTED { y[i] + f[i] * h } else { y[i] };
        // u ± b̃√Δ: u + (−b̃)√Δ is u − b̃√Δ exactly.
        let w = c[i] * sq;
        plus[i] = u + w;
        minus[i] = u - w;
    }
}

/// What the first term of the step's sums starts from, and the state the last adds them to.
struct Start<'a> {
    x: &'a Lanes,
    v: &'a Lanes,
    /// The drift at Y and at Ῡ (x, v).
    f: [&'a Lanes; 2],
    g: [&'a Lanes; 2],
}

/// Where the terms of the step go: the sums, then the new state.
struct Out<'a> {
    sums: [&'a mut Lanes; 2],
    new: [&'a mut Lanes; 2],
}

/// [`add_term`] for a term known to be first or last at run time.
#[inline(always)]
fn add(
    first: bool,
    last: bool,
    out: &mut Out,
    start: &Start,
    h: f64,
    term: impl Fn(usize) -> (f64, f64) + Copy,
) {
    match (first, last) {
        (true, true) => add_term::<true, true>(out, start, h, term),
        (true, false) => add_term::<true, false>(out, start, h, term),
        (false, true) => add_term::<false, true>(out, start, h, term),
        (false, false) => add_term::<false, false>(out, start, h, term),
    }
}

/// Adds a term (x and v of lane i: `term(i)`) to the step's sums: the first term starts
/// them from ½(a(Ῡ) + a)Δ, the last writes Y plus them to the new state.
#[inline(always)]
fn add_term<const FIRST: bool, const LAST: bool>(
    out: &mut Out,
    start: &Start,
    h: f64,
    term: impl Fn(usize) -> (f64, f64),
) {
    let [sx, sv] = &mut out.sums;
    let [nx, nv] = &mut out.new;
    let ([fx, fv], [gx, gv]) = (start.f, start.g);
    for i in 0..CHUNK {
        let (tx, tv) = term(i);
        let (ax, av) = if FIRST {
            (0.5 * (fx[i] + gx[i]) * h, 0.5 * (fv[i] + gv[i]) * h)
        } else {
            (sx[i], sv[i])
        };
        let (ax, av) = (ax + tx, av + tv);
        if LAST {
            nx[i] = start.x[i] + ax;
            nv[i] = start.v[i] + av;
        } else {
            sx[i] = ax;
            sv[i] = av;
        }
    }
}

/// A chunk's standardised draws and pair bits: source k's (pair p's) lanes of the chunk at
/// `stride·k + start` onwards.
struct Draws<'a> {
    z: &'a [f64],
    bits: &'a [u64],
    stride: usize,
    start: usize,
}

impl Draws<'_> {
    /// Source k's draws.
    #[inline(always)]
    fn z(&self, k: usize) -> &Lanes {
        chunk(&self.z[self.stride * k + self.start..][..CHUNK])
    }

    /// Pair p's bits.
    #[inline(always)]
    fn bits(&self, p: usize) -> &[u64; CHUNK] {
        self.bits[self.stride * p + self.start..][..CHUNK]
            .try_into()
            .expect("a chunk")
    }
}

/// The slot of the pair {r, j} (r ≠ j) among the m(m−1)/2 two-point variables, and the sign
/// making V antisymmetric.
pub(in crate::mc) fn pair_slot(r: usize, j: usize, m: usize) -> (usize, f64) {
    let (a, b) = if r < j { (r, j) } else { (j, r) };
    (
        a * (2 * m - a - 1) / 2 + (b - a - 1),
        if r < j { 1.0 } else { -1.0 },
    )
}

/// Working memory of a single trajectory's step (the remainder after an event), sized once
/// for `m` sources so that an event allocates nothing.
pub(in crate::mc) struct PointWork {
    /// The kernel's outputs at the point (drift, then the columns of x, then of v), and a
    /// second evaluation (the order-1 corrector).
    pub(in crate::mc) e0: Vec<f64>,
    pub(in crate::mc) e1: Vec<f64>,
    /// The noise columns at the + and − supporting points.
    bp: Vec<f64>,
    bm: Vec<f64>,
}

impl PointWork {
    /// No memory (a placeholder).
    pub(in crate::mc) fn empty() -> PointWork {
        PointWork {
            e0: Vec::new(),
            e1: Vec::new(),
            bp: Vec::new(),
            bm: Vec::new(),
        }
    }

    pub(in crate::mc) fn new(m: usize) -> PointWork {
        PointWork {
            e0: vec![0.0; 2 + 2 * m],
            e1: vec![0.0; 2 + 2 * m],
            bp: vec![0.0; 2 * m],
            bm: vec![0.0; 2 * m],
        }
    }
}

/// One step of Platen's scheme for a single trajectory from time `t` (the remainder after
/// an event); the times of its evaluations as in [`PlatenWork::step`].
#[allow(clippy::too_many_arguments)]
pub(in crate::mc) fn platen_point_step(
    pk: &PlatenKernels,
    kernel: &dyn BatchKernel,
    m: usize,
    t: f64,
    p: [f64; 2],
    h: f64,
    w: &[f64],
    vpair: &[f64],
    work: &mut PointWork,
) -> [f64; 2] {
    let sq = h.sqrt();
    let PointWork { e0, bp, bm, .. } = work;
    kernel.eval_point(t, p[0], p[1], e0);
    let e0 = &*e0;
    let col = |e: &[f64], k: usize, j: usize| e[k * m + j];
    let b0 = |k: usize, j: usize| e0[2 + k * m + j];
    let mut bar = [p[0] + e0[0] * h, p[1] + e0[1] * h];
    for j in 0..m {
        bar[0] += b0(0, j) * w[j];
        bar[1] += b0(1, j) * w[j];
    }
    let mut a1 = [0.0; 2];
    pk.drift.eval_point(t + h, bar[0], bar[1], &mut a1);
    let mut out = [
        p[0] + 0.5 * (e0[0] + a1[0]) * h,
        p[1] + 0.5 * (e0[1] + a1[1]) * h,
    ];
    for j in 0..m {
        if pk.constant[j] {
            out[0] += b0(0, j) * w[j];
            out[1] += b0(1, j) * w[j];
            continue;
        }
        for (sign, b) in [(1.0, &mut *bp), (-1.0, &mut *bm)] {
            pk.noise.eval_point(
                t + h,
                p[0] + e0[0] * h + sign * b0(0, j) * sq,
                p[1] + e0[1] * h + sign * b0(1, j) * sq,
                b,
            );
        }
        let q = (w[j] * w[j] - h) / sq;
        for k in 0..2 {
            out[k] += 0.25
                * ((col(bp, k, j) + col(bm, k, j) + 2.0 * b0(k, j)) * w[j]
                    + (col(bp, k, j) - col(bm, k, j)) * q);
        }
    }
    for r in 0..m {
        if (0..m).all(|j| j == r || pk.constant[j]) {
            continue;
        }
        for (sign, b) in [(1.0, &mut *bp), (-1.0, &mut *bm)] {
            pk.noise.eval_point(
                t,
                p[0] + sign * b0(0, r) * sq,
                p[1] + sign * b0(1, r) * sq,
                b,
            );
        }
        for j in 0..m {
            if j == r || pk.constant[j] {
                continue;
            }
            let (pair, sign) = pair_slot(r, j, m);
            let q = (w[j] * w[r] + sign * vpair[pair]) / sq;
            for k in 0..2 {
                out[k] += 0.25
                    * ((col(bp, k, j) + col(bm, k, j) - 2.0 * b0(k, j)) * w[j]
                        + (col(bp, k, j) - col(bm, k, j)) * q);
            }
        }
    }
    out
}

#[cfg(test)]
mod order_tests;
