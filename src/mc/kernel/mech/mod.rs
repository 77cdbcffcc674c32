//! The fast mechanical path: the Strang splitting of `compile/scheme.rs` for a model in the
//! recognised form (`compile/mech_form.rs`), at most one barrier and three-point
//! increments, with the loops interchanged. Each group of lanes keeps its whole state
//! (position, velocity, barrier side, generator, last draw) in registers for all the steps
//! of a call, draws its
//! increments inside the step and evaluates h·f, √h·σ and the Heun factor by Horner's rule
//! on coefficients prescaled once per call (`kernel/mech/coef.rs`): no pass over arrays per step,
//! no dispatch per instruction.
//!
//! One step, written with few operations (the same scheme as the lane-evaluator path, to
//! rounding):
//! - the Heun velocity update at frozen z with f affine in v, collapsed:
//!   `v ← v + (h·f + dw)·(1 + (h/2)·∂f/∂v)`; when ∂f/∂v is constant the factor is folded
//!   into the coefficients, `v ← (h·F·f₀(z) + v·(1 + h·F·f₁)) + F·dw` ([`Velocity`]);
//! - `dw = ±√h·a·σ(z)` or 0, picked by the three-point bits (no product by the variable):
//!   its sign flipped and its sum taken where the bits say (masked operations on AVX-512);
//! - the barrier distance `(x − b)·side` as a flip of the sign bit, and the meets test as
//!   one comparison `d ≤ 0` per flight, the exact test (`impact::meets`) only when some
//!   lane is on or beyond the barrier.
//!
//! A model whose coefficients depend on the time ([`crate::mc::compile::mech_form::TimedForm`])
//! runs the same kernel with the coefficients of each step (a [`Table`]): a template in
//! the layout of every step's, its coefficients that change marked, and each step's values
//! of them, computed once for all the lanes of a call; the kernel reads the layout and the
//! fixed coefficients from the template, the same at every step, and the marked ones from
//! the step's values. A model without the time has one set of coefficients for all steps.
//!
//! Impacts are resolved in vector form for the laws `v → r·v` (the compiled map recognised,
//! [`Barrier::gain`]): located, jumped and continued with masked operations, the division
//! only when some lane met the barrier, the same arithmetic as the scalar
//! `impact_in_flight`; any other law is resolved lane by lane by `impact_in_flight` itself.
//!
//! The kernel is written once, generic over the vector type of `kernel/mech/vector.rs`: groups of
//! [`VECTORS_512`] AVX-512 vectors, [`VECTORS_256`] AVX2 vectors, then single vectors, then
//! single lanes (`f64`), every one the same IEEE operations in the same order (no fused
//! multiply-add), so the vector width does not change a bit (tested).

use crate::mc::compile::eval::Simd;
#[cfg(test)]
use crate::mc::compile::impact::impact_in_flight;
use crate::mc::compile::impact::Barrier;
use crate::mc::compile::mech_form::MAX_V_DEGREE;
use crate::mc::compile::tally::ImpactSink;
use crate::mc::kernel::rng::THREE_POINT_FIELDS;

mod coef;
mod flight;
mod vector;

use coef::StepValues;
use coef::Velocity;
pub(crate) use coef::{Coefs, Slot};
#[cfg(test)]
use flight::impacts;
use flight::{dist, Flight, Impacts, Jump};
use vector::{each, Vector};

/// AVX-512 vectors (8 lanes) a group interleaves: independent dependency chains keep the
/// vector units busy, and a group's state still fits the 32 registers.
#[cfg(target_arch = "x86_64")]
const VECTORS_512: usize = 4;
/// AVX2 vectors (4 lanes) a group interleaves (16 registers).
#[cfg(target_arch = "x86_64")]
const VECTORS_256: usize = 4;

/// The batch's columns the kernel advances in place.
pub(crate) struct Columns<'a> {
    pub(crate) x: &'a mut [f64],
    pub(crate) v: &'a mut [f64],
    pub(crate) side: &'a mut [f64],
    pub(crate) impacts: ImpactSink<'a>,
    /// The xoshiro256++ state words of each lane.
    pub(crate) rng: [&'a mut [u64]; 4],
    /// Each lane's last draw, whose fields from [`Steps::field`] on are the next steps'
    /// three-point variables (`rng::IncrementStream`).
    pub(crate) draws: &'a mut [u64],
    /// Where the states at each sample point go, when the call records them.
    pub(crate) rows: Option<Rows<'a>>,
}

/// The states of the lanes at each sample point of a call: lane i's state at sample j at
/// `x[j * stride + i]`, `v[j * stride + i]`.
pub(crate) struct Rows<'a> {
    pub(crate) x: &'a mut [f64],
    pub(crate) v: &'a mut [f64],
    pub(crate) stride: usize,
}

impl Columns<'_> {
    /// The lanes `r` of every column.
    fn slice(&mut self, r: std::ops::Range<usize>) -> Columns<'_> {
        let [s0, s1, s2, s3] = &mut self.rng;
        Columns {
            x: &mut self.x[r.clone()],
            v: &mut self.v[r.clone()],
            side: &mut self.side[r.clone()],
            impacts: self.impacts.slice(r.clone()),
            rng: [
                &mut s0[r.clone()],
                &mut s1[r.clone()],
                &mut s2[r.clone()],
                &mut s3[r.clone()],
            ],
            draws: &mut self.draws[r.clone()],
            rows: self.rows.as_mut().map(|w| Rows {
                x: &mut w.x[r.start..],
                v: &mut w.v[r.start..],
                stride: w.stride,
            }),
        }
    }
}

/// The prescaled coefficients of each step of a call.
pub(crate) trait StepCoefs {
    /// A step's values of the coefficients that change.
    type Values: StepValues + ?Sized;
    /// The coefficients (their layout and fixed values) and step `k`'s values (counted
    /// over the whole call).
    fn at(&self, k: u64) -> (&Coefs, &Self::Values);
}

/// The same coefficients at every step.
impl StepCoefs for Coefs {
    type Values = ();
    #[inline(always)]
    fn at(&self, _: u64) -> (&Coefs, &()) {
        (self, &())
    }
}

/// The coefficients of every step of a call: `template` (its changing coefficients marked
/// by [`Coefs::mark_step_values`]), step k's values of them `values[k·m..(k + 1)·m]`.
#[derive(Clone, Copy)]
pub(crate) struct Table<'a> {
    pub(crate) template: &'a Coefs,
    /// The number m of marked coefficients.
    pub(crate) width: usize,
    pub(crate) values: &'a [f64],
}

impl StepCoefs for Table<'_> {
    type Values = [f64];
    #[inline(always)]
    fn at(&self, k: u64) -> (&Coefs, &[f64]) {
        let m = self.width;
        (self.template, &self.values[k as usize * m..][..m])
    }
}

/// What one call does to every lane.
struct Steps<'a, C> {
    /// Steps per sample point.
    steps: u64,
    /// Sample points: the call advances `samples · steps` steps, by `steps` at a time.
    samples: u64,
    h: f64,
    /// The field of the lanes' last draws the first step takes (0: a new draw first).
    field: u8,
    coefs: C,
    jump: Option<Jump<'a>>,
}

/// Advances every lane by `samples` times `steps` steps of size `h`, each `steps` as one
/// `BatchState::advance` on the lane-evaluator path (half flight, then velocity update and
/// flight per step, the last flight a half), step k with the coefficients `coefs.at(k)`
/// (a [`Coefs`] of the form for every step, or a [`Table`] of a form that depends on the
/// time); the states after each `steps` go to `c.rows` when given. `field` is the increment
/// stream's next field, updated.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn advance<C: StepCoefs>(
    coefs: C,
    bar: Option<&Barrier>,
    c: Columns<'_>,
    field: &mut u8,
    samples: u64,
    steps: u64,
    h: f64,
    simd: Simd,
) {
    if steps == 0 || samples == 0 {
        return;
    }
    let st = Steps {
        steps,
        samples,
        h,
        field: *field,
        coefs,
        jump: bar.map(|bar| Jump {
            bar,
            gain: bar.gain(),
        }),
    };
    let mut c = c;
    let done = match simd {
        Simd::Baseline => 0,
        // SAFETY: `simd` names an extension only when it was detected on this CPU.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2(_) => unsafe { groups_avx2(&st, &mut c) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512(_) => unsafe { groups_avx512(&st, &mut c) },
    };
    let n = c.x.len();
    for i in done..n {
        group::<f64, 1, C>(&st, c.slice(i..i + 1));
    }
    let fields = u64::from(THREE_POINT_FIELDS);
    *field = ((u64::from(*field) + steps % fields * (samples % fields)) % fields) as u8;
}

/// The kernel compiled for AVX-512: groups of [`VECTORS_512`] vectors, then single vectors;
/// the lanes done.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn groups_avx512<C: StepCoefs>(st: &Steps<'_, C>, c: &mut Columns<'_>) -> usize {
    groups::<vector::Avx512, VECTORS_512, C>(st, c)
}

/// The kernel compiled for AVX2, as [`groups_avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn groups_avx2<C: StepCoefs>(st: &Steps<'_, C>, c: &mut Columns<'_>) -> usize {
    groups::<vector::Avx2, VECTORS_256, C>(st, c)
}

/// Groups of `N` vectors over the columns, then single vectors; the lanes done (the rest
/// are fewer than a vector).
#[inline(always)]
fn groups<V: Impacts, const N: usize, C: StepCoefs>(
    st: &Steps<'_, C>,
    c: &mut Columns<'_>,
) -> usize {
    let n = c.x.len();
    let (wide, one) = (N * V::LANES, V::LANES);
    let mut start = 0;
    while start + wide <= n {
        group::<V, N, C>(st, c.slice(start..start + wide));
        start += wide;
    }
    while start + one <= n {
        group::<V, 1, C>(st, c.slice(start..start + one));
        start += one;
    }
    start
}

/// The flight x → x + v·τ of `N` vectors of lanes, impacts resolved out of line when some
/// lane is on or beyond the barrier.
#[inline(always)]
fn fly<V: Impacts, const N: usize>(
    jump: Option<&Jump<'_>>,
    x: &mut [V; N],
    v: &mut [V; N],
    side: &mut [V; N],
    impacts: &mut ImpactSink<'_>,
    tau: f64,
) {
    let t = V::splat(tau);
    let x0 = *x;
    *x = each(
        #[inline(always)]
        |k| x0[k].add(v[k].mul(t)),
    );
    let Some(jump) = jump else { return };
    let zero = V::splat(0.0);
    // meets() needs d1 < 0 or d1 = 0: one comparison d1 ≤ 0 rules both out for most flights.
    let mut near = 0;
    for k in 0..N {
        near |= V::mask_bits(dist(jump.bar.at, x[k], side[k]).le(zero)) << (k * V::LANES);
    }
    if near != 0 {
        V::impacts(&mut Flight {
            jump,
            x0: &x0,
            x,
            v,
            side,
            impacts,
            tau,
            near,
        });
    }
}

/// The velocity update of one step at frozen z = `x`, the step's three-point variables in
/// the top fields of `words`: `v ← v + (h·f + dw)·(1 + (h/2)·∂f/∂v)`, as [`Coefs`]
/// arranges it ([`Velocity`]).
#[inline(always)]
fn kick<V: Vector, const N: usize, S: StepValues + ?Sized>(
    c: &Coefs,
    vals: &S,
    x: &[V; N],
    v: &mut [V; N],
    words: &[V::Bits; N],
) {
    let f0 = c.force0.eval(vals, x);
    let s = c.sigma.eval(vals, x);
    // g + dw: dw = ±s or 0 as the three-point bits say, added where it is not zero.
    #[inline(always)]
    fn noise<V: Vector>(g: V, s: V, word: V::Bits) -> V {
        let (neg, nonzero) = V::three_point_high(word);
        g.add_where(nonzero, s.neg_where(neg))
    }
    match &c.velocity {
        Velocity::Folded { keep } => {
            // v·keep, or v itself when keep is 1.
            let vk = match keep {
                None => *v,
                Some(b) => {
                    let b = b.eval(vals, x);
                    each(
                        #[inline(always)]
                        |k| v[k].mul(b[k]),
                    )
                }
            };
            *v = each(
                #[inline(always)]
                |k| noise(f0[k].add(vk[k]), s[k], words[k]),
            );
        }
        Velocity::Heun { force1, factor } => {
            let hf = match force1 {
                None => f0,
                Some(b) => {
                    let b = b.eval(vals, x);
                    each(
                        #[inline(always)]
                        |k| f0[k].add(v[k].mul(b[k])),
                    )
                }
            };
            let f = factor.eval(vals, x);
            *v = each(
                #[inline(always)]
                |k| v[k].add(noise(hf[k], s[k], words[k]).mul(f[k])),
            );
        }
        Velocity::Polynomial { powers } => {
            // The coefficients of v's powers at the frozen z, once for both evaluations.
            let p: [Option<[V; N]>; MAX_V_DEGREE] = each(
                #[inline(always)]
                |l| match &powers[l] {
                    Some(q) => Some(q.eval(vals, x)),
                    None => None,
                },
            );
            let hf0 = in_v(&f0, &p, v);
            let vbar: [V; N] = each(
                #[inline(always)]
                |k| v[k].add(noise(hf0[k], s[k], words[k])),
            );
            let hf1 = in_v(&f0, &p, &vbar);
            let half = V::splat(0.5);
            *v = each(
                #[inline(always)]
                |k| noise(v[k].add(hf0[k].add(hf1[k]).mul(half)), s[k], words[k]),
            );
        }
    }
}

/// `f0 + u·(p₁ + u·(p₂ + u·p₃))` by Horner's rule in u, absent powers skipped: h·f at the
/// velocities `u` for [`Velocity::Polynomial`].
#[inline(always)]
fn in_v<V: Vector, const N: usize>(
    f0: &[V; N],
    p: &[Option<[V; N]>; MAX_V_DEGREE],
    u: &[V; N],
) -> [V; N] {
    let mut acc: Option<[V; N]> = None;
    for q in p.iter().rev() {
        acc = match (acc, q) {
            (None, q) => *q,
            (Some(a), q) => {
                let m: [V; N] = each(
                    #[inline(always)]
                    |k| a[k].mul(u[k]),
                );
                Some(match q {
                    None => m,
                    Some(q) => each(
                        #[inline(always)]
                        |k| m[k].add(q[k]),
                    ),
                })
            }
        };
    }
    match acc {
        None => *f0,
        Some(a) => each(
            #[inline(always)]
            |k| f0[k].add(a[k].mul(u[k])),
        ),
    }
}

/// `N` vectors of lanes (the columns hold exactly `N · V::LANES`) through all the steps of
/// a call.
#[inline(always)]
fn group<V: Impacts, const N: usize, C: StepCoefs>(st: &Steps<'_, C>, c: Columns<'_>) {
    // A flight's lanes near the barrier are the bits of one u32 (`Flight::near`).
    const { assert!(N * V::LANES <= 32) };
    let w = V::LANES;
    let Columns {
        x: xs,
        v: vs,
        side: sides,
        mut impacts,
        mut rng,
        draws,
        mut rows,
    } = c;
    let sign = V::splat(-0.0);
    let mut x: [V; N] = each(
        #[inline(always)]
        |k| V::load(&xs[k * w..]),
    );
    let mut v: [V; N] = each(
        #[inline(always)]
        |k| V::load(&vs[k * w..]),
    );
    let mut side: [V; N] = each(
        #[inline(always)]
        |k| V::load(&sides[k * w..]).and(sign),
    );
    let mut r: [[V::Bits; 4]; N] = each(
        #[inline(always)]
        |k| {
            each(
                #[inline(always)]
                |j| V::load_bits(&rng[j][k * w..]),
            )
        },
    );
    // The last draw, whose fields from `field` on are the next steps' variables.
    let mut draw: [V::Bits; N] = each(
        #[inline(always)]
        |k| V::load_bits(&draws[k * w..]),
    );
    let mut field = st.field;
    let jump = st.jump.as_ref();
    let (h, half) = (st.h, 0.5 * st.h);
    for j in 0..st.samples {
        impacts.set_row(j);
        fly(jump, &mut x, &mut v, &mut side, &mut impacts, half);
        for step in 0..st.steps {
            let tau = if step + 1 == st.steps { half } else { h };
            // Three variables a draw: its fields in turn, moved to the top bits.
            let words: [V::Bits; N] = match field {
                0 => {
                    draw = each(
                        #[inline(always)]
                        |k| V::xoshiro(&mut r[k]),
                    );
                    draw
                }
                1 => each(
                    #[inline(always)]
                    |k| V::field_up(draw[k], 1),
                ),
                _ => each(
                    #[inline(always)]
                    |k| V::field_up(draw[k], 2),
                ),
            };
            field = if field + 1 == THREE_POINT_FIELDS {
                0
            } else {
                field + 1
            };
            let (coefs, values) = st.coefs.at(j * st.steps + step);
            kick(coefs, values, &x, &mut v, &words);
            fly(jump, &mut x, &mut v, &mut side, &mut impacts, tau);
        }
        if let Some(rows) = rows.as_mut() {
            let at = j as usize * rows.stride;
            for k in 0..N {
                x[k].store(&mut rows.x[at + k * w..]);
                v[k].store(&mut rows.v[at + k * w..]);
            }
        }
    }
    for k in 0..N {
        x[k].store(&mut xs[k * w..]);
        v[k].store(&mut vs[k * w..]);
        side[k].or(V::splat(1.0)).store(&mut sides[k * w..]);
        V::store_bits(draw[k], &mut draws[k * w..]);
        for (j, col) in rng.iter_mut().enumerate() {
            V::store_bits(r[k][j], &mut col[k * w..]);
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
