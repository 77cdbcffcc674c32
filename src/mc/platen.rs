//! Platen's weak order-2 step (see `scheme.rs`) of a batch, chunk by chunk of lanes: every
//! kernel evaluated by its lane program on the chunk, the supporting values and the
//! increments combined while the chunk is in L1, in fixed-length loops without bounds
//! checks (so they vectorise). The arithmetic of each lane is that of the scalar scheme, in
//! the same order, so the result does not depend on the chunking; the working memory is
//! sized once per batch, so a step allocates nothing.

use super::eval::BatchKernel;
use super::fused::{chunk, chunk_mut};
use super::lanes::LaneProgram;

/// Lanes of a chunk of Platen's step: a batch's default 128 lanes in one chunk (each
/// instruction of a lane program dispatched once per 128 lanes; measured faster than 64,
/// and 32 slower, on the barrier model).
const CHUNK: usize = 128;
use super::scheme::PlatenKernels;

type Lanes = [f64; CHUNK];

/// Working memory of Platen's step, sized for a batch once.
pub(super) struct PlatenWork {
    /// The kernel's slots (drift, then the columns b̃ of x, then of v), kept for the step.
    e0: Vec<Lanes>,
    /// Slots of the supporting evaluations at the + and − points.
    plus: Vec<Lanes>,
    minus: Vec<Lanes>,
    /// The chunk's increments ΔŴ_j and pair signs ±Δ (one row each).
    dw: Vec<Lanes>,
    vpair: Vec<Lanes>,
    /// The random bits of the pair signs of the whole batch, pair p of lane i at `p*n + i`
    /// (the sign of V is the top bit).
    pub(super) pair_bits: Vec<u64>,
    /// The batch's new states, exchanged with the old ones after a step.
    pub(super) nx: Vec<f64>,
    pub(super) nv: Vec<f64>,
    /// For each r, how the cross terms' b̃_j(U±_r) are evaluated.
    cross: Vec<Cross>,
    /// A chunk's supporting points, accumulated increments and Y + aΔ (rows of x and v),
    /// kept here so that a chunk neither zeroes nor moves them.
    rows: Box<Rows>,
}

/// The rows of a chunk's step: a supporting point, the increment and Y + aΔ, each of x
/// then of v; aligned to a cache line (a vector load never splits one).
#[repr(C, align(64))]
struct Rows([Lanes; 6]);

/// The evaluation at the supporting points U±_r of one source r.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cross {
    /// Every other column is state-independent: no cross terms.
    None,
    /// One other column j depends on the state: its own program.
    Column(usize),
    /// Several do: the program of all columns.
    All,
}

impl PlatenWork {
    /// Working memory for `lanes` lanes of `m` sources.
    pub(super) fn new(
        kernel: &dyn BatchKernel,
        pk: &PlatenKernels,
        m: usize,
        lanes: usize,
    ) -> Self {
        let slots = pk
            .column
            .iter()
            .map(|c| c.program().n_slots())
            .chain([pk.drift.program().n_slots(), pk.noise.program().n_slots()])
            .max()
            .unwrap_or(0);
        let pairs = m * m.saturating_sub(1) / 2;
        let cross = (0..m)
            .map(|r| {
                let mut varying = (0..m).filter(|&j| j != r && !pk.constant[j]);
                match (varying.next(), varying.next()) {
                    (None, _) => Cross::None,
                    (Some(j), None) => Cross::Column(j),
                    _ => Cross::All,
                }
            })
            .collect();
        PlatenWork {
            e0: vec![[0.0; CHUNK]; kernel.program().n_slots()],
            plus: vec![[0.0; CHUNK]; slots],
            minus: vec![[0.0; CHUNK]; slots],
            dw: vec![[0.0; CHUNK]; m],
            vpair: vec![[0.0; CHUNK]; pairs],
            pair_bits: vec![0; pairs * lanes],
            nx: vec![0.0; lanes],
            nv: vec![0.0; lanes],
            cross,
            rows: Box::new(Rows([[0.0; CHUNK]; 6])),
        }
    }

    /// One step of every lane from `(x, v)` into `(self.nx, self.nv)`: the increments are
    /// ΔŴ = `sq`·`z` (source k of lane i at `z[k*n + i]`, `sq` = √h), the pair signs from
    /// `self.pair_bits`, both formed chunk by chunk while the chunk is in L1.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &mut self,
        kernel: &LaneProgram,
        pk: &PlatenKernels,
        m: usize,
        h: f64,
        x: &[f64],
        v: &[f64],
        z: &[f64],
    ) {
        let n = x.len();
        let pairs = self.vpair.len();
        let sq = h.sqrt();
        let mut nx = std::mem::take(&mut self.nx);
        let mut nv = std::mem::take(&mut self.nv);
        let mut start = 0;
        while start < n {
            // A partial last chunk is padded with zeros; its padding lanes are discarded.
            let len = CHUNK.min(n - start);
            for k in 0..m {
                let (src, dst) = (&z[k * n + start..k * n + start + len], &mut self.dw[k]);
                for i in 0..len {
                    dst[i] = sq * src[i];
                }
                dst[len..].fill(0.0);
            }
            for p in 0..pairs {
                let src = &self.pair_bits[p * n + start..p * n + start + len];
                let dst = &mut self.vpair[p];
                for i in 0..len {
                    dst[i] = if src[i] >> 63 == 0 { h } else { -h };
                }
                dst[len..].fill(0.0);
            }
            let r = start..start + len;
            if len == CHUNK {
                let (ox, ov) = (chunk_mut(&mut nx[r.clone()]), chunk_mut(&mut nv[r.clone()]));
                self.chunk(kernel, pk, m, h, chunk(&x[r.clone()]), chunk(&v[r]), ox, ov);
            } else {
                let (mut xc, mut vc) = ([0.0; CHUNK], [0.0; CHUNK]);
                xc[..len].copy_from_slice(&x[r.clone()]);
                vc[..len].copy_from_slice(&v[r.clone()]);
                let (mut ox, mut ov) = ([0.0; CHUNK], [0.0; CHUNK]);
                self.chunk(kernel, pk, m, h, &xc, &vc, &mut ox, &mut ov);
                nx[r.clone()].copy_from_slice(&ox[..len]);
                nv[r].copy_from_slice(&ov[..len]);
            }
            start += len;
        }
        self.nx = nx;
        self.nv = nv;
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
        out_x: &mut Lanes,
        out_v: &mut Lanes,
    ) {
        let sq = h.sqrt();
        let inv_sq = 1.0 / sq;
        let Self {
            e0,
            plus,
            minus,
            dw,
            vpair,
            cross,
            rows,
            ..
        } = self;
        // The increment (ax, av) first holds the predictor's, then the step's.
        let [px, pv, ax, av, yx, yv] = &mut rows.0;
        kernel.run(x, v, e0);
        let e = |o: usize| &e0[kernel.output(o)];
        // The drift's rows, looked up once (not in every lane's iteration).
        let (e0x, e0v) = (e(0), e(1));
        // The Euler–Maruyama predictor Y + aΔ + Σ_k b_k ΔW_k.
        let (dx, dv) = (&mut *ax, &mut *av);
        for i in 0..CHUNK {
            dx[i] = e0x[i] * h;
            dv[i] = e0v[i] * h;
        }
        for k in 0..m {
            let (bx, bv, w) = (e(2 + k), e(2 + m + k), &dw[k]);
            for i in 0..CHUNK {
                dx[i] += bx[i] * w[i];
                dv[i] += bv[i] * w[i];
            }
        }
        for i in 0..CHUNK {
            px[i] = x[i] + dx[i];
            pv[i] = v[i] + dv[i];
        }
        let drift = pk.drift.program();
        drift.run(px, pv, plus);
        let (a1x, a1v) = (&plus[drift.output(0)], &plus[drift.output(1)]);
        for i in 0..CHUNK {
            ax[i] = 0.5 * (e0x[i] + a1x[i]) * h;
            av[i] = 0.5 * (e0v[i] + a1v[i]) * h;
            // Y + aΔ, the same for every column's R±.
            yx[i] = x[i] + e0x[i] * h;
            yv[i] = v[i] + e0v[i] * h;
        }
        for j in 0..m {
            let (cx, cv, w) = (e(2 + j), e(2 + m + j), &dw[j]);
            if pk.constant[j] {
                for i in 0..CHUNK {
                    ax[i] += cx[i] * w[i];
                    av[i] += cv[i] * w[i];
                }
                continue;
            }
            let col = pk.column[j].program();
            for (sign, out) in [(1.0, &mut *plus), (-1.0, &mut *minus)] {
                for i in 0..CHUNK {
                    px[i] = yx[i] + sign * cx[i] * sq;
                    pv[i] = yv[i] + sign * cv[i] * sq;
                }
                col.run(px, pv, out);
            }
            // Column j's program gives (b̃_0j, b̃_1j) as its outputs 0 and 1.
            let (bpx, bmx) = (&plus[col.output(0)], &minus[col.output(0)]);
            let (bpv, bmv) = (&plus[col.output(1)], &minus[col.output(1)]);
            for i in 0..CHUNK {
                let w = w[i];
                let q = (w * w - h) * inv_sq;
                ax[i] += 0.25 * ((bpx[i] + bmx[i] + 2.0 * cx[i]) * w + (bpx[i] - bmx[i]) * q);
                av[i] += 0.25 * ((bpv[i] + bmv[i] + 2.0 * cv[i]) * w + (bpv[i] - bmv[i]) * q);
            }
        }
        for r in 0..m {
            // b̃_j(U±_r) for the state-dependent columns j ≠ r: column j's own program when
            // it is the only one (the same outputs, fewer instructions), else all columns.
            let (program, only) = match cross[r] {
                Cross::None => continue,
                Cross::Column(j) => (pk.column[j].program(), Some(j)),
                Cross::All => (pk.noise.program(), None),
            };
            let (rx, rv) = (e(2 + r), e(2 + m + r));
            for (sign, out) in [(1.0, &mut *plus), (-1.0, &mut *minus)] {
                for i in 0..CHUNK {
                    px[i] = x[i] + sign * rx[i] * sq;
                    pv[i] = v[i] + sign * rv[i] * sq;
                }
                program.run(px, pv, out);
            }
            for j in 0..m {
                if j == r || pk.constant[j] {
                    continue;
                }
                // The slots of (b̃_0j, b̃_1j) among the program's outputs.
                let (ox, ov) = match only {
                    Some(_) => (program.output(0), program.output(1)),
                    None => (program.output(j), program.output(m + j)),
                };
                let (cx, cv) = (e(2 + j), e(2 + m + j));
                let (bpx, bmx) = (&plus[ox], &minus[ox]);
                let (bpv, bmv) = (&plus[ov], &minus[ov]);
                let (pair, sign) = pair_slot(r, j, m);
                let (wj, wr, vp) = (&dw[j], &dw[r], &vpair[pair]);
                for i in 0..CHUNK {
                    let w = wj[i];
                    let q = (w * wr[i] + sign * vp[i]) * inv_sq;
                    ax[i] += 0.25 * ((bpx[i] + bmx[i] - 2.0 * cx[i]) * w + (bpx[i] - bmx[i]) * q);
                    av[i] += 0.25 * ((bpv[i] + bmv[i] - 2.0 * cv[i]) * w + (bpv[i] - bmv[i]) * q);
                }
            }
        }
        for i in 0..CHUNK {
            out_x[i] = x[i] + ax[i];
            out_v[i] = v[i] + av[i];
        }
    }
}

/// The slot of the pair {r, j} (r ≠ j) among the m(m−1)/2 two-point variables, and the sign
/// making V antisymmetric.
pub(super) fn pair_slot(r: usize, j: usize, m: usize) -> (usize, f64) {
    let (a, b) = if r < j { (r, j) } else { (j, r) };
    (
        a * (2 * m - a - 1) / 2 + (b - a - 1),
        if r < j { 1.0 } else { -1.0 },
    )
}

/// Working memory of a single trajectory's step (the remainder after an event), sized once
/// for `m` sources so that an event allocates nothing.
pub(super) struct PointWork {
    /// The kernel's outputs at the point (drift, then the columns of x, then of v), and a
    /// second evaluation (the order-1 corrector).
    pub(super) e0: Vec<f64>,
    pub(super) e1: Vec<f64>,
    /// The noise columns at the + and − supporting points.
    bp: Vec<f64>,
    bm: Vec<f64>,
}

impl PointWork {
    /// No memory (a placeholder).
    pub(super) fn empty() -> PointWork {
        PointWork {
            e0: Vec::new(),
            e1: Vec::new(),
            bp: Vec::new(),
            bm: Vec::new(),
        }
    }

    pub(super) fn new(m: usize) -> PointWork {
        PointWork {
            e0: vec![0.0; 2 + 2 * m],
            e1: vec![0.0; 2 + 2 * m],
            bp: vec![0.0; 2 * m],
            bm: vec![0.0; 2 * m],
        }
    }
}

/// One step of Platen's scheme for a single trajectory (the remainder after an event).
#[allow(clippy::too_many_arguments)]
pub(super) fn platen_point_step(
    pk: &PlatenKernels,
    kernel: &dyn BatchKernel,
    m: usize,
    p: [f64; 2],
    h: f64,
    w: &[f64],
    vpair: &[f64],
    work: &mut PointWork,
) -> [f64; 2] {
    let sq = h.sqrt();
    let PointWork { e0, bp, bm, .. } = work;
    kernel.eval_point(p[0], p[1], e0);
    let e0 = &*e0;
    let col = |e: &[f64], k: usize, j: usize| e[k * m + j];
    let b0 = |k: usize, j: usize| e0[2 + k * m + j];
    let mut bar = [p[0] + e0[0] * h, p[1] + e0[1] * h];
    for j in 0..m {
        bar[0] += b0(0, j) * w[j];
        bar[1] += b0(1, j) * w[j];
    }
    let mut a1 = [0.0; 2];
    pk.drift.eval_point(bar[0], bar[1], &mut a1);
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
            pk.noise
                .eval_point(p[0] + sign * b0(0, r) * sq, p[1] + sign * b0(1, r) * sq, b);
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
#[path = "platen_order_tests.rs"]
mod order_tests;
