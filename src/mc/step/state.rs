//! One batch of trajectories in flight and the time steps of every scheme (see `compile/scheme.rs`
//! for the schemes and why each is used): structure-of-arrays loops over the lanes, the
//! events of an impact law resolved lane by lane.

use crate::mc::compile::eval::{BatchKernel, Scratch, Simd};
use crate::mc::compile::impact::{free_flight, impact_in_flight, meets, Barrier, Crossing};
use crate::mc::compile::lanes::{LaneProgram, CHUNK};
use crate::mc::compile::scheme::{Dynamics, Plan, PlatenKernels, MAX_EVENTS_PER_STEP};
use crate::mc::compile::tally::{ImpactSink, ImpactTally};
use crate::mc::kernel::fused::{chunk, chunk_mut, fused_chunk, Kinematics};
use crate::mc::kernel::rng::{IncrementStream, Increments, LaneRng};
use crate::mc::step::events::{crossings, EventWork};
use crate::mc::step::platen::{platen_point_step, PlatenWork, PointWork};
use crate::mc::step::timed::{SpanTable, TimedSteps};

/// A batch of trajectories in flight: states, barrier sides, event counts and generators,
/// all structure-of-arrays, plus the work buffers of the schemes.
pub(crate) struct BatchState {
    /// The time of the states: 0 at the start, advanced by [`BatchState::advance`]; a
    /// time-dependent model's coefficients are evaluated at the times within each step that
    /// the scheme takes (see [`BatchState::advance`]).
    pub(crate) t: f64,
    pub(crate) x: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) side: Vec<f64>,
    pub(crate) impacts: Vec<u64>,
    /// Steps whose events ran out beyond a wall, the overshoot reflected back into the
    /// domain (general schemes; see [`BatchState::resolve_events`]).
    pub(crate) folded: Vec<u64>,
    /// The impact statistics of each wall, when the run records them (set after the
    /// burn-in).
    pub(crate) tally: Option<ImpactTally>,
    pub(in crate::mc::step) rng: LaneRng,
    pub(in crate::mc::step) inc: IncrementStream,
    buf: [Vec<f64>; 6],
    /// Working memory of Platen's scheme, sized once (when that scheme runs).
    platen: Option<PlatenWork>,
    /// Working memory of the fast path of a form whose coefficients depend on the time
    /// (when that path runs).
    pub(in crate::mc::step) timed: Option<Box<TimedSteps>>,
    /// Working memory of the general schemes' events, sized once (an event allocates
    /// nothing).
    events: EventWork,
    z: Vec<f64>,
    /// One working memory per kernel, so none is resized between calls.
    scratch: [Scratch; 2],
    /// The vector extension the lane loops run with.
    pub(in crate::mc::step) simd: Simd,
}

impl BatchState {
    /// Trajectories `first..first + lanes` of the run seeded with `seed`, started from the
    /// linearised stationary Gaussian (`spread` from [`Plan::initial_spread`]), reflected
    /// into the barrier's side, or folded into a strip by reflections at its walls (never
    /// on a wall: a start that lands on one moves to the strip's middle).
    pub(crate) fn new(
        plan: &Plan,
        spread: &[[f64; 2]; 2],
        seed: u64,
        first: u64,
        lanes: usize,
        increments: Increments,
    ) -> BatchState {
        let side0 = plan.barriers.first().map_or(1.0, |b| b.side);
        let sides: Vec<f64> = plan.barriers.iter().map(|b| b.side).collect();
        let noises = match &plan.dynamics {
            Dynamics::Mechanical { .. } => 1,
            Dynamics::General { noises, .. } => *noises,
        };
        let mut st = BatchState {
            t: 0.0,
            x: vec![0.0; lanes],
            v: vec![0.0; lanes],
            side: if sides.len() > 1 {
                sides.iter().flat_map(|&s| vec![s; lanes]).collect()
            } else {
                vec![side0; lanes]
            },
            impacts: vec![0; lanes],
            folded: vec![0; lanes],
            tally: None,
            rng: LaneRng::new(seed, first, lanes),
            inc: IncrementStream::new(increments, lanes),
            buf: std::array::from_fn(|_| vec![0.0; lanes * (2 + 2 * noises)]),
            platen: match &plan.dynamics {
                Dynamics::General {
                    kernel,
                    platen: Some(pk),
                    ..
                } => Some(PlatenWork::new(kernel.as_ref(), pk, noises, lanes)),
                _ => None,
            },
            timed: None,
            events: EventWork::new(noises),
            z: vec![0.0; lanes * noises.max(1)],
            scratch: [Scratch::new(), Scratch::new()],
            simd: Simd::detect(),
        };
        for i in 0..lanes {
            st.start_lane(plan, spread, i);
        }
        st
    }

    /// Lane `i`'s start, from its generator: the linearised stationary Gaussian (two
    /// normals), reflected or folded into the barriers' side.
    fn start_lane(&mut self, plan: &Plan, spread: &[[f64; 2]; 2], i: usize) {
        let side0 = plan.barriers.first().map_or(1.0, |b| b.side);
        let (z0, z1) = (self.lane_normal(i), self.lane_normal(i));
        let mut p = [spread[0][0] * z0, spread[1][0] * z0 + spread[1][1] * z1];
        match plan.barriers.as_slice() {
            [] => {}
            [bar] => {
                let s = &mut p[bar.state];
                if (*s - bar.at) * side0 < 0.0 {
                    *s = 2.0 * bar.at - *s;
                }
            }
            [lo, hi, ..] => p[lo.state] = fold_into(p[lo.state], lo.at, hi.at),
        }
        self.x[i] = p[0];
        self.v[i] = p[1];
    }

    /// Lane `i` started over as trajectory `index` of the run seeded with `seed` starts in a
    /// new batch ([`BatchState::new`]): its generator, start, barrier sides and impact count.
    /// `false` (nothing done) unless the increment stream is three-point at a new draw
    /// (after a multiple of three steps), where its next numbers depend on the generator
    /// alone; a plan whose coefficients depend on the time must not restart lanes (the
    /// batch's time is shared).
    pub(crate) fn restart_lane(
        &mut self,
        plan: &Plan,
        spread: &[[f64; 2]; 2],
        seed: u64,
        index: u64,
        i: usize,
    ) -> bool {
        if self.inc.three_point_mut().is_none_or(|tp| *tp.field != 0) {
            return false;
        }
        let n = self.x.len();
        self.rng.reseed_lane(seed, index, i);
        self.side[i] = plan.barriers.first().map_or(1.0, |b| b.side);
        for (k, bar) in plan.barriers.iter().enumerate().skip(1) {
            self.side[k * n + i] = bar.side;
        }
        self.impacts[i] = 0;
        self.folded[i] = 0;
        self.start_lane(plan, spread, i);
        true
    }

    /// Advances every trajectory by `steps` steps of size `h`, from the time [`BatchState::t`]
    /// to `t + steps·h`.
    ///
    /// A time-dependent model's coefficients are evaluated where each scheme, applied to the
    /// system with the time as a third state (dt/dt = 1, no noise), evaluates them, which
    /// keeps its weak order:
    /// - the mechanical splitting A(h/2) B(h) A(h/2) moves the time with the free flight A,
    ///   so the velocity update B of step k is taken at the step's midpoint t + (k + ½)h
    ///   (weak order 2);
    /// - Euler–Maruyama evaluates at the step's start; stochastic Heun's predictor at the
    ///   start and its corrector at the end (weak order 1);
    /// - Platen's scheme evaluates the drift and the noise at the start Y, the drift at the
    ///   predictor Ῡ and the noise at R±_j = Y + aΔ ± b̃_j√Δ at the end of the step, and the
    ///   noise at U±_r = Y ± b̃_r√Δ at its start (weak order 2);
    /// - a general scheme's step cut at an impact continues from the impact's time
    ///   t + θh (θ the interpolated fraction of the step); impact laws do not depend on
    ///   the time.
    ///
    /// On x86-64 with AVX2 or AVX-512 the lane loops are compiled again for 4- or 8-wide
    /// vectors (chosen at run time). The results are bit-identical to the baseline build:
    /// the loops use only IEEE-exact operations (no fused multiply-add), whatever the width.
    pub(crate) fn advance(&mut self, plan: &Plan, steps: u64, h: f64) {
        self.advance_with(plan, steps, h, None);
    }

    /// [`BatchState::advance`] with the coefficients of a time-dependent form over these
    /// steps computed beforehand (`span`, for every batch that takes the same steps; one
    /// made for other steps is not used): the same numbers as without it, sooner.
    pub(crate) fn advance_with(
        &mut self,
        plan: &Plan,
        steps: u64,
        h: f64,
        span: Option<&SpanTable>,
    ) {
        match self.simd {
            Simd::Baseline => self.advance_body(plan, steps, h, span),
            // SAFETY: `simd` was detected on this CPU (`Simd::detect`).
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2(_) => unsafe { self.advance_avx2(plan, steps, h, span) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512(_) => unsafe { self.advance_avx512(plan, steps, h, span) },
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn advance_avx2(&mut self, plan: &Plan, steps: u64, h: f64, span: Option<&SpanTable>) {
        self.advance_body(plan, steps, h, span);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn advance_avx512(&mut self, plan: &Plan, steps: u64, h: f64, span: Option<&SpanTable>) {
        self.advance_body(plan, steps, h, span);
    }

    #[inline(always)]
    fn advance_body(&mut self, plan: &Plan, steps: u64, h: f64, span: Option<&SpanTable>) {
        if steps == 0 {
            return;
        }
        let t0 = self.t;
        self.steps_body(plan, t0, steps, h, span);
        self.t = t0 + steps as f64 * h;
    }

    /// The steps of [`BatchState::advance_body`] from the time `t0`.
    #[inline(always)]
    fn steps_body(&mut self, plan: &Plan, t0: f64, steps: u64, h: f64, span: Option<&SpanTable>) {
        match &plan.dynamics {
            Dynamics::Mechanical {
                step,
                force,
                affine,
                form,
                timed,
            } => {
                let bar = plan.barriers.as_slice();
                if let (Some(form), [] | [_]) = (form, bar) {
                    if self.mech_fast(form, bar.first(), steps, h) {
                        return;
                    }
                }
                if let (Some(timed), [] | [_]) = (timed, bar) {
                    if self.mech_fast_timed(timed, bar.first(), t0, steps, h, span) {
                        return;
                    }
                }
                self.flight(bar, 0.5 * h);
                // f affine in v and at most one barrier: the velocity update and the flight
                // in one pass over each chunk of lanes.
                let fused = *affine && bar.len() <= 1;
                for k in 0..steps {
                    let tau = if k + 1 == steps { 0.5 * h } else { h };
                    // The velocity update at the step's midpoint (the flights move the time).
                    let mid = t0 + (k as f64 + 0.5) * h;
                    if fused {
                        self.fused_step(step.program(), bar.first(), mid, h, tau);
                    } else {
                        self.velocity_update(step.as_ref(), force.as_ref(), *affine, mid, h);
                        self.flight(bar, tau);
                    }
                }
            }
            Dynamics::General { .. } => {
                for k in 0..steps {
                    self.general_step(plan, t0 + k as f64 * h, h);
                }
            }
        }
    }

    #[inline(always)]
    fn flight(&mut self, bar: &[Barrier], tau: f64) {
        free_flight(
            &mut self.x,
            &mut self.v,
            &mut self.side,
            &mut ImpactSink::new(&mut self.impacts, self.tally.as_mut()),
            tau,
            bar,
            &mut self.buf[5],
        );
    }

    /// [`BatchState::velocity_update`] (f affine in v) at time `t` and then
    /// [`BatchState::flight`] over `tau` with at most one barrier, the same arithmetic in one
    /// pass per chunk of lanes: the step kernel evaluated on the chunk, the velocity updated
    /// and the free flight taken while the chunk is in registers; the rare impacts resolved
    /// after.
    #[inline(always)]
    fn fused_step(
        &mut self,
        program: &LaneProgram,
        bar: Option<&Barrier>,
        t: f64,
        h: f64,
        tau: f64,
    ) {
        let n = self.x.len();
        let z = &mut self.z[..n];
        self.inc.next(&mut self.rng, z);
        let z = &self.z[..n];
        let sqrt_h = h.sqrt();
        let at = bar.map(|b| b.at);
        let mut xn = std::mem::take(&mut self.buf[5]);
        xn.resize(n, 0.0);
        let slots = &mut self.scratch[0];
        slots.resize(program.n_slots(), [0.0; CHUNK]);
        program.set_time(t, slots);
        let mut start = 0;
        let (x, v, side) = (&self.x[..n], &mut self.v[..n], &mut self.side[..n]);
        let mut impacts = ImpactSink::new(&mut self.impacts[..n], self.tally.as_mut());
        let k = Kinematics { h, sqrt_h, tau, at };
        // The lanes of a chunk that met the barrier get their impacts at once.
        let mut impact =
            |first: usize, mut met: u64, xn: &mut [f64], v: &mut [f64], side: &mut [f64]| {
                while met != 0 {
                    let i = first + met.trailing_zeros() as usize;
                    met &= met - 1;
                    let bar = bar.expect("only a barrier is met");
                    let before = v[i];
                    impact_in_flight(x[i], &mut xn[i], &mut v[i], &mut side[i], tau, bar);
                    impacts.hit(i, 0, before, v[i]);
                }
            };
        while start + CHUNK <= n {
            let r = start..start + CHUNK;
            let met = fused_chunk::<CHUNK>(
                program,
                slots,
                chunk(&x[r.clone()]),
                chunk_mut(&mut v[r.clone()]),
                chunk(&z[r.clone()]),
                chunk(&side[r.clone()]),
                chunk_mut(&mut xn[r]),
                &k,
            );
            impact(start, met, &mut xn, v, side);
            start += CHUNK;
        }
        if start < n {
            let mut one = vec![[0.0; 1]; program.n_slots()];
            program.set_time(t, &mut one);
            for i in start..n {
                let met = fused_chunk::<1>(
                    program,
                    &mut one,
                    chunk(&x[i..=i]),
                    chunk_mut(&mut v[i..=i]),
                    chunk(&z[i..=i]),
                    chunk(&side[i..=i]),
                    chunk_mut(&mut xn[i..=i]),
                    &k,
                );
                impact(i, met, &mut xn, v, side);
            }
        }
        self.buf[5] = std::mem::replace(&mut self.x, xn);
    }

    /// The `B` flow over `h`: `dv = f(x, v) dt + σ(x) dW` at frozen `x` and frozen time
    /// `t`, Heun for additive noise (weak order 2).
    #[inline(always)]
    fn velocity_update(
        &mut self,
        step: &dyn BatchKernel,
        force: &dyn BatchKernel,
        affine: bool,
        t: f64,
        h: f64,
    ) {
        let n = self.x.len();
        let outs = if affine { 3 } else { 2 };
        let [e, f1, vbar, dw, ..] = &mut self.buf;
        step.eval_batch(
            t,
            &self.x,
            &self.v,
            &mut e[..outs * n],
            &mut self.scratch[0],
        );
        let z = &mut self.z[..n];
        self.inc.next(&mut self.rng, z);
        let (f0, rest) = e.split_at(n);
        let (sigma, rest) = rest.split_at(n);
        let v = &mut self.v[..n];
        let dw = &mut dw[..n];
        let sqrt_h = h.sqrt();
        for ((d, &z), &s) in dw.iter_mut().zip(z.iter()).zip(sigma) {
            *d = z * (s * sqrt_h);
        }
        if affine {
            // f(x, v̄) = f0 + (∂f/∂v)(v̄ − v): the corrector without a second evaluation.
            let slope = &rest[..n];
            for (((v, &f0), &b), &dw) in v.iter_mut().zip(f0).zip(slope).zip(dw.iter()) {
                let f1 = f0 + b * (f0 * h + dw);
                *v += 0.5 * (f0 + f1) * h + dw;
            }
        } else {
            let vbar = &mut vbar[..n];
            for (((vb, &v), &f0), &dw) in vbar.iter_mut().zip(v.iter()).zip(f0).zip(dw.iter()) {
                *vb = v + f0 * h + dw;
            }
            force.eval_batch(t, &self.x, vbar, &mut f1[..n], &mut self.scratch[1]);
            for (((v, &f0), &f1), &dw) in v.iter_mut().zip(f0).zip(f1.iter()).zip(dw.iter()) {
                *v += 0.5 * (f0 + f1) * h + dw;
            }
        }
    }

    /// One step of the general scheme from time `t` for the whole batch, then the barrier
    /// events.
    // Inlined into `advance`'s target-feature functions, so its loops use wide vectors.
    #[inline(always)]
    fn general_step(&mut self, plan: &Plan, t: f64, h: f64) {
        let Dynamics::General {
            kernel,
            sqrt_s,
            noises,
            stratonovich,
            platen,
        } = &plan.dynamics
        else {
            unreachable!("general step on a mechanical plan")
        };
        if let Some(pk) = platen {
            self.platen_step(plan, pk, kernel.as_ref(), *noises, t, h);
            return;
        }
        let (n, m) = (self.x.len(), *noises);
        // Correlated increments ΔW = √h · L·z, noise k of lane i at dw[k*n + i].
        // The buffers are moved out so that event handling below may borrow `self`.
        let mut buf = std::mem::take(&mut self.buf);
        let [e0, e1, dw, xp, vp, _] = &mut buf;
        for k in 0..m {
            self.inc
                .next(&mut self.rng, &mut self.z[k * n..(k + 1) * n]);
        }
        let sq = h.sqrt();
        for k in 0..m {
            for i in 0..n {
                let mut acc = 0.0;
                for l in 0..=k {
                    acc += sqrt_s[k * m + l] * self.z[l * n + i];
                }
                dw[k * n + i] = sq * acc;
            }
        }
        kernel.eval_batch(t, &self.x, &self.v, e0, &mut self.scratch[0]);
        xp.resize(n, 0.0);
        vp.resize(n, 0.0);
        euler_predictor(&self.x, &self.v, e0, dw, h, m, xp, vp);
        if *stratonovich {
            kernel.eval_batch(t + h, &xp[..n], &vp[..n], e1, &mut self.scratch[0]);
            for i in 0..n {
                let (mut dx, mut dv) =
                    (0.5 * (e0[i] + e1[i]) * h, 0.5 * (e0[n + i] + e1[n + i]) * h);
                for k in 0..m {
                    let w = dw[k * n + i];
                    dx += 0.5 * (e0[(2 + k) * n + i] + e1[(2 + k) * n + i]) * w;
                    dv += 0.5 * (e0[(2 + m + k) * n + i] + e1[(2 + m + k) * n + i]) * w;
                }
                xp[i] = self.x[i] + dx;
                vp[i] = self.v[i] + dv;
            }
        }
        self.step_events(plan, t, &mut xp[..n], &mut vp[..n], &dw[..m * n], 1.0, m, h);
        self.x[..n].copy_from_slice(&xp[..n]);
        self.v[..n].copy_from_slice(&vp[..n]);
        self.buf = buf;
    }

    /// Applies the barrier events of a step `(x, v) → (xp, vp)` from time `t` taken with the
    /// increments `scale`·`w` (source k of lane i at `w[k*n + i]`), in place in `(xp, vp)`.
    // Inlined into `advance`'s target-feature functions, so its loops use wide vectors.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn step_events(
        &mut self,
        plan: &Plan,
        t: f64,
        xp: &mut [f64],
        vp: &mut [f64],
        w: &[f64],
        scale: f64,
        m: usize,
        h: f64,
    ) {
        let n = self.x.len();
        if plan.barriers.is_empty() {
            return;
        }
        let mut ev = std::mem::take(&mut self.events);
        // Which lanes met a barrier, a chunk of lanes at a time in fixed-length loops (so
        // the test vectorises); the rare events are then resolved lane by lane, each from
        // its own generator, so the order of resolution changes no bit.
        let mut start = 0;
        while start < n {
            let len = CHUNK.min(n - start);
            let mut met = 0u64;
            for (k, bar) in plan.barriers.iter().enumerate() {
                let (s0, s1) = if bar.state == 0 {
                    (&self.x[start..start + len], &xp[start..start + len])
                } else {
                    (&self.v[start..start + len], &vp[start..start + len])
                };
                let side = &self.side[k * n + start..k * n + start + len];
                met |= if len == CHUNK {
                    crossings::<CHUNK>(bar.at, chunk(side), chunk(s0), chunk(s1))
                } else {
                    (0..len).fold(0, |m, i| {
                        m | (meets(bar.at, side[i], s0[i], s1[i]) as u64) << i
                    })
                };
            }
            while met != 0 {
                let i = start + met.trailing_zeros() as usize;
                met &= met - 1;
                for k in 0..m {
                    ev.w[k] = scale * w[k * n + i];
                }
                let (x1, v1) = self.resolve_events(
                    plan,
                    i,
                    t,
                    [self.x[i], self.v[i]],
                    [xp[i], vp[i]],
                    h,
                    &mut ev,
                );
                xp[i] = x1;
                vp[i] = v1;
            }
            start += len;
        }
        self.events = ev;
    }

    /// One step of Platen's explicit weak order-2.0 scheme (Kloeden & Platen Eq. 15.1.5)
    /// for the whole batch, on the Itô form with independent columns b̃_j:
    ///
    /// ```text
    /// Y' = Y + ½(a(Ῡ) + a)Δ
    ///   + ¼ Σ_j [(b̃_j(R⁺_j) + b̃_j(R⁻_j) + 2b̃_j) ΔŴ_j + (b̃_j(R⁺_j) − b̃_j(R⁻_j))(ΔŴ_j² − Δ)/√Δ]
    ///   + ¼ Σ_j Σ_{r≠j} [(b̃_j(U⁺_r) + b̃_j(U⁻_r) − 2b̃_j) ΔŴ_j
    ///                     + (b̃_j(U⁺_r) − b̃_j(U⁻_r))(ΔŴ_j ΔŴ_r + V_rj)/√Δ],
    /// ```
    ///
    /// Ῡ = Y + aΔ + Σ_j b̃_j ΔŴ_j, R±_j = Y + aΔ ± b̃_j√Δ, U±_r = Y ± b̃_r√Δ, V_rj = −V_jr
    /// two-point ±Δ. State-independent columns need no supporting values.
    // Inlined into `advance`'s target-feature functions, so its loops use wide vectors.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn platen_step(
        &mut self,
        plan: &Plan,
        pk: &PlatenKernels,
        kernel: &dyn BatchKernel,
        m: usize,
        t: f64,
        h: f64,
    ) {
        let n = self.x.len();
        let mut work = self.platen.take().expect("Platen's working memory");
        // The random numbers in the order they always had: the increments of every source,
        // then the bits of the pair signs; both become ΔŴ and V in the chunk pass.
        for k in 0..m {
            self.inc
                .next(&mut self.rng, &mut self.z[k * n..(k + 1) * n]);
        }
        let pairs = m * m.saturating_sub(1) / 2;
        for p in 0..pairs {
            self.rng.fill(&mut work.pair_bits[p * n..(p + 1) * n]);
        }
        work.step(
            kernel.program(),
            pk,
            m,
            t,
            h,
            &self.x,
            &self.v,
            &self.z[..m * n],
        );
        let (mut nx, mut nv) = (std::mem::take(&mut work.nx), std::mem::take(&mut work.nv));
        let z = std::mem::take(&mut self.z);
        self.step_events(plan, t, &mut nx, &mut nv, &z[..m * n], h.sqrt(), m, h);
        self.z = z;
        // The new states become the batch's; the old ones are the next step's output.
        std::mem::swap(&mut self.x, &mut nx);
        std::mem::swap(&mut self.v, &mut nv);
        (work.nx, work.nv) = (nx, nv);
        self.platen = Some(work);
    }

    /// Cuts lane `i`'s step `p0 → p1` (from time `t`, increment `w` over `h`) at the first
    /// barrier it meets (the earliest crossing, at time t + θh), applies the jump and
    /// finishes the step from there, repeating for further events up to a limit.
    #[allow(clippy::too_many_arguments)]
    fn resolve_events(
        &mut self,
        plan: &Plan,
        i: usize,
        mut t: f64,
        mut p0: [f64; 2],
        mut p1: [f64; 2],
        mut h: f64,
        ev: &mut EventWork,
    ) -> (f64, f64) {
        let Dynamics::General { sqrt_s, noises, .. } = &plan.dynamics else {
            unreachable!("general events on a mechanical plan")
        };
        let m = *noises;
        let n = self.x.len();
        for _ in 0..MAX_EVENTS_PER_STEP {
            // The barrier met first along the step (the only one, but in a strip).
            let mut first: Option<(usize, f64)> = None;
            for (k, bar) in plan.barriers.iter().enumerate() {
                let s = bar.state;
                if meets(bar.at, self.side[k * n + i], p0[s], p1[s]) {
                    let theta = ((bar.at - p0[s]) / (p1[s] - p0[s])).clamp(0.0, 1.0);
                    if first.is_none_or(|(_, t)| theta < t) {
                        first = Some((k, theta));
                    }
                }
            }
            let Some((k, theta)) = first else {
                break;
            };
            let bar = &plan.barriers[k];
            let (s, o) = (bar.state, bar.other);
            // The rest of the step starts at the impact.
            t += theta * h;
            let mut c = [0.0; 2];
            for k in 0..2 {
                c[k] = p0[k] + theta * (p1[k] - p0[k]);
            }
            c[s] = bar.at;
            let before = c[o];
            c[o] = bar.jump(c[0], c[1]);
            ImpactSink::new(&mut self.impacts, self.tally.as_mut()).hit(i, k, before, c[o]);
            // Past a pass-through law the side follows the barrier state's drift there; a
            // wall keeps its side whatever the step did to the other state (a velocity that
            // changed sign within the step is no reason to live beyond the wall).
            if bar.crossing == Crossing::PassesThrough {
                let mut drift = [0.0; 2];
                plan.drift.eval_point(t, c[0], c[1], &mut drift);
                if drift[s] * self.side[k * n + i] < 0.0 {
                    self.side[k * n + i] = -self.side[k * n + i];
                }
            }
            // Brownian bridge: given W(h) − W(0) = w, W(h) − W(θh) ~ N((1−θ)w, θ(1−θ)h·S).
            let rest = (1.0 - theta) * h;
            let spread = (theta * (1.0 - theta) * h).sqrt();
            for z in &mut ev.z[..m] {
                *z = self.lane_normal(i);
            }
            for k in 0..m {
                let mut acc = 0.0;
                for l in 0..=k {
                    acc += sqrt_s[k * m + l] * ev.z[l];
                }
                ev.w_rest[k] = (1.0 - theta) * ev.w[k] + spread * acc;
            }
            let pairs = m * m.saturating_sub(1) / 2;
            for p in 0..pairs {
                ev.vpair[p] = if self.rng.next_lane(i) >> 63 == 0 {
                    rest
                } else {
                    -rest
                };
            }
            p0 = c;
            p1 = general_point_step(
                plan,
                t,
                c,
                rest,
                &ev.w_rest,
                &ev.vpair[..pairs],
                &mut ev.point,
            );
            h = rest;
            std::mem::swap(&mut ev.w, &mut ev.w_rest);
        }
        // A step still beyond a wall after the last event it may resolve (a trajectory
        // chattering against the wall) has its overshoot reflected back into the domain,
        // counted: no state is ever recorded outside it.
        match plan.barriers.as_slice() {
            [lo, hi] if lo.crossing == Crossing::Reflects && hi.crossing == Crossing::Reflects => {
                let s = lo.state;
                if !(lo.at <= p1[s] && p1[s] <= hi.at) {
                    p1[s] = reflect_into(p1[s], lo.at, hi.at);
                    self.folded[i] += 1;
                }
            }
            [bar] if bar.crossing == Crossing::Reflects => {
                let s = bar.state;
                if (p1[s] - bar.at) * self.side[i] < 0.0 {
                    p1[s] = 2.0 * bar.at - p1[s];
                    self.folded[i] += 1;
                }
            }
            _ => {}
        }
        debug_assert!(
            plan.barriers
                .iter()
                .enumerate()
                .all(|(k, b)| b.crossing == Crossing::PassesThrough
                    || (p1[b.state] - b.at) * self.side[k * n + i] >= 0.0),
            "a trajectory beyond a wall: {p1:?}"
        );
        (p1[0], p1[1])
    }

    /// A standard normal from lane `i`'s own generator (Box–Muller on two draws).
    pub(crate) fn lane_normal(&mut self, i: usize) -> f64 {
        let a = self.rng.next_lane(i);
        let b = self.rng.next_lane(i);
        let u1 = ((a >> 11) as f64 + 0.5) / 9_007_199_254_740_992.0;
        let u2 = ((b >> 11) as f64 + 0.5) / 9_007_199_254_740_992.0;
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// `s` folded into the strip [lo, hi] by reflections at its walls; a value that lands on a
/// wall goes to the middle (a trajectory starts inside, never on a wall).
fn fold_into(s: f64, lo: f64, hi: f64) -> f64 {
    let s = reflect_into(s, lo, hi);
    if s <= lo || s >= hi || !s.is_finite() {
        0.5 * (lo + hi)
    } else {
        s
    }
}

/// `s` reflected into the strip [lo, hi] at its walls, as often as it takes.
fn reflect_into(s: f64, lo: f64, hi: f64) -> f64 {
    let w = hi - lo;
    let mut y = (s - lo).rem_euclid(2.0 * w);
    if y > w {
        y = 2.0 * w - y;
    }
    lo + y
}

/// One general-scheme step of a single trajectory from time `t` (used for the remainder
/// after an event).
pub(in crate::mc) fn general_point_step(
    plan: &Plan,
    t: f64,
    p: [f64; 2],
    h: f64,
    w: &[f64],
    vpair: &[f64],
    work: &mut PointWork,
) -> [f64; 2] {
    let Dynamics::General {
        kernel,
        noises,
        stratonovich,
        platen,
        ..
    } = &plan.dynamics
    else {
        unreachable!("general step on a mechanical plan")
    };
    let m = *noises;
    if let Some(pk) = platen {
        return platen_point_step(pk, kernel.as_ref(), m, t, p, h, w, vpair, work);
    }
    let PointWork { e0, e1, .. } = work;
    kernel.eval_point(t, p[0], p[1], e0);
    let incr = |e: &[f64], i: usize| -> f64 {
        e[i] * h + (0..m).map(|k| e[2 + i * m + k] * w[k]).sum::<f64>()
    };
    let pred = [p[0] + incr(e0, 0), p[1] + incr(e0, 1)];
    if !*stratonovich {
        return pred;
    }
    kernel.eval_point(t + h, pred[0], pred[1], e1);
    [
        p[0] + 0.5 * (incr(e0, 0) + incr(e1, 0)),
        p[1] + 0.5 * (incr(e0, 1) + incr(e1, 1)),
    ]
}

/// The Euler–Maruyama predictor Y + aΔ + Σ_k b_k ΔW_k of every lane, from the kernel's
/// outputs `e0` (drift of x and v, then the m diffusion columns of x, then of v, lane-major
/// blocks of n) and the increments `dw` (noise k of lane i at `dw[k*n + i]`): the one
/// predictor of the general scheme and of Platen's.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn euler_predictor(
    x: &[f64],
    v: &[f64],
    e0: &[f64],
    dw: &[f64],
    h: f64,
    m: usize,
    px: &mut [f64],
    pv: &mut [f64],
) {
    let n = x.len();
    for i in 0..n {
        let (mut dx, mut dv) = (e0[i] * h, e0[n + i] * h);
        for k in 0..m {
            dx += e0[(2 + k) * n + i] * dw[k * n + i];
            dv += e0[(2 + m + k) * n + i] * dw[k * n + i];
        }
        px[i] = x[i] + dx;
        pv[i] = v[i] + dv;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::compile::scheme::SchemeChoice;
    use crate::mc::reference::{vibro_impact, VibroImpact};

    #[test]
    fn vector_width_does_not_change_a_bit() {
        let p = VibroImpact {
            c: 0.2,
            k: 1.0,
            mu: 0.5,
            eps: 0.3,
            r: 0.7,
            big_k: 0.1,
        };
        let model = vibro_impact(p).bind(&[]).unwrap();
        for choice in [SchemeChoice::Auto, SchemeChoice::General] {
            let specs = crate::mc::compile::scheme::impact_specs(&model).unwrap();
            let plan = Plan::of_model(&model, choice, specs).unwrap();
            let spread = plan.initial_spread();
            // 150 lanes: two whole chunks of the kernels' evaluation and a partial one.
            let lanes = 150;
            let mut b = BatchState::new(&plan, &spread, 5, 0, lanes, Increments::ThreePoint);
            b.advance_body(&plan, 500, 0.01, None);
            for simd in Simd::available() {
                let mut a = BatchState::new(&plan, &spread, 5, 0, lanes, Increments::ThreePoint);
                a.simd = simd;
                a.advance(&plan, 500, 0.01);
                for i in 0..lanes {
                    assert_eq!(a.x[i].to_bits(), b.x[i].to_bits(), "{simd:?}");
                    assert_eq!(a.v[i].to_bits(), b.v[i].to_bits(), "{simd:?}");
                }
                assert_eq!(a.impacts, b.impacts);
            }
            assert!(b.impacts.iter().sum::<u64>() > 0);
        }
    }
}

#[cfg(test)]
pub(in crate::mc) mod fast_path_tests {
    use super::*;
    use crate::mc::compile::mech_form::tests::{mechanical_plans, plan_named};

    /// The fast kernel against the lane evaluator, from the same random states and streams,
    /// a few steps at a time (4, so that calls start at every field of a draw): the
    /// states agree to rounding. The kernel evaluates f, σ, ∂f/∂v by Horner's rule, the
    /// lane evaluator in the tape's order, a few ulps of the terms' magnitudes apart
    /// (`mech_form`'s test); over four steps of h = 0.01 that moves the states by far
    /// less than 1e-13·(1 + |x| + |v|)³. Impacts agree exactly.
    #[test]
    fn the_fast_kernel_follows_the_lane_evaluator() {
        let plans = mechanical_plans();
        for (name, fast) in plans.iter().filter(|(n, _)| *n != "vibro_impact_strip") {
            let mut slow = plan_named(name).unwrap();
            if let Dynamics::Mechanical { form, .. } = &mut slow.dynamics {
                *form = None;
            }
            assert_follows(name, fast, &slow, 1e-13);
        }
    }

    /// `fast` (a plan on the fast kernel) against `slow` (the same model on the lane
    /// evaluator), 20 rounds of 4 steps of 0.01 from the same random states spread up to 5
    /// (each on its lane's side of a barrier: the sign of x kept, a wall's side by
    /// reflection), round r from the time 0.37·r: the states within
    /// `tol`·(1 + |x| + |v|)³, the impacts and sides equal.
    pub(in crate::mc) fn assert_follows(name: &str, fast: &Plan, slow: &Plan, tol: f64) {
        let spread = fast.initial_spread();
        let lanes = 150;
        let new = |p: &Plan| BatchState::new(p, &spread, 11, 0, lanes, Increments::ThreePoint);
        let (mut a, mut b) = (new(fast), new(slow));
        let mut uniform = crate::mc::kernel::mech::tests::uniforms(0x2545_F491_4F6C_DD1D);
        for round in 0..20 {
            // Random states (the same for both), then step both.
            let scale = 1.0 + round as f64 * 0.2;
            for i in 0..lanes {
                let mut x = a.x[i].signum() * uniform() * scale;
                if let [bar] = fast.barriers.as_slice() {
                    if bar.crossing == Crossing::Reflects && (x - bar.at) * bar.side < 0.0 {
                        x = 2.0 * bar.at - x;
                    }
                }
                a.x[i] = x;
                a.v[i] = (2.0 * uniform() - 1.0) * scale;
                b.x[i] = a.x[i];
                b.v[i] = a.v[i];
            }
            let t = 0.37 * round as f64;
            (a.t, b.t) = (t, t);
            a.advance(fast, 4, 0.01);
            b.advance(slow, 4, 0.01);
            for i in 0..lanes {
                let m = 1.0 + a.x[i].abs() + a.v[i].abs();
                let tol = tol * m * m * m;
                assert!(
                    (a.x[i] - b.x[i]).abs() <= tol && (a.v[i] - b.v[i]).abs() <= tol,
                    "{name} lane {i} at t = {t}: ({}, {}) vs ({}, {})",
                    a.x[i],
                    a.v[i],
                    b.x[i],
                    b.v[i]
                );
                // The rounding difference must not make one path see an impact the
                // other does not.
                a.x[i] = b.x[i];
                a.v[i] = b.v[i];
            }
            assert_eq!(a.impacts, b.impacts, "{name}");
            assert_eq!(a.side, b.side, "{name}");
        }
        if !fast.barriers.is_empty() {
            assert!(
                a.impacts.iter().sum::<u64>() > 0,
                "{name}: no impact tested"
            );
        }
    }
}
