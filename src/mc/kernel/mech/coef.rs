//! The mechanical form's polynomials as one call of the kernel evaluates them: prescaled by
//! the call's step sizes, so that the step multiplies by neither h nor √h, and by Horner's
//! rule with zero coefficients skipped.
//!
//! The step needs h·f, √h·a·σ (a the three-point value, whose sign and zero the random bits
//! pick) and the Heun factor 1 + (h/2)·∂f/∂v: each is a [`Part`] `P₀(z) + sgn(z)·P₁(z)`
//! with the scale folded into its coefficients. `sgn(z)·P₁(z)` is P₁, −P₁ or 0 picked by the
//! two comparisons of z with zero (no product), made only by a part that has a sign part.
//!
//! The coefficients of a form that depends on the time change from step to step while the
//! layout (which parts, how many terms, folded or not) stays that of a template
//! ([`Coefs::shaped`]); the coefficients that differ are the template's [`Slot`]s holding
//! NaN, marked ([`Coefs::mark_step_values`]) so that the kernel reads each from the step's
//! values ([`StepValues`]) while it takes everything else, the layout included, from the
//! template, which stays the same for all the steps of a call.

use super::vector::{each, Vector};
use crate::mc::compile::mech_form::{InVelocity, MechForm, SgnPoly, ZPoly, MAX_V_DEGREE};

/// Coefficients a [`Horner`] holds (`mech_form`'s highest power plus one).
const MAX_COEFS: usize = 9;

/// A polynomial in z, coefficients from the constant up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Horner {
    /// The coefficients; one that is a step's value j holds the mark [`step_mark`]`(j)`.
    c: [f64; MAX_COEFS],
    n: usize,
}

/// The bits of a quiet NaN that marks a coefficient as a step's value (its low bits the
/// value's index): no coefficient of a model is NaN (a tape refuses a constant that is
/// not finite).
const MARK: u64 = 0x7ffc_0000_0000_0000;
const MARK_MASK: u64 = 0xffff_0000_0000_0000;

/// The mark of a step's value j.
fn step_mark(j: usize) -> f64 {
    f64::from_bits(MARK | j as u64)
}

/// Where the kernel reads the coefficients a [`Horner`] marks as a step's values.
pub(crate) trait StepValues {
    /// The value of a coefficient `c` of a [`Horner`].
    fn coef(&self, c: f64) -> f64;
}

/// No step values: every coefficient is the [`Horner`]'s own.
impl StepValues for () {
    #[inline(always)]
    fn coef(&self, c: f64) -> f64 {
        c
    }
}

/// One step's values, a marked coefficient read from them.
impl StepValues for [f64] {
    #[inline(always)]
    fn coef(&self, c: f64) -> f64 {
        let bits = c.to_bits();
        if bits & MARK_MASK == MARK {
            self[(bits & !MARK_MASK) as usize]
        } else {
            c
        }
    }
}

impl Horner {
    /// `k·p`, each coefficient multiplied by `k`, plus `add` on the constant term; as many
    /// terms as `like` has when given, else trailing zeros dropped.
    fn scaled(p: &ZPoly, k: f64, add: f64, like: Option<&Horner>) -> Horner {
        let mut c = [0.0; MAX_COEFS];
        for (c, &p) in c.iter_mut().zip(&p.coef) {
            *c = k * p;
        }
        let mut n = p.coef.len();
        if add != 0.0 {
            c[0] += add;
            n = n.max(1);
        }
        if let Some(like) = like {
            return Horner { c, n: like.n };
        }
        while n > 0 && c[n - 1] == 0.0 {
            n -= 1;
        }
        Horner { c, n }
    }

    /// The value when the polynomial is a constant (zero when it has no terms).
    fn constant(&self) -> Option<f64> {
        match self.n {
            0 => Some(0.0),
            1 => Some(self.c[0]),
            _ => None,
        }
    }

    /// Horner's rule from the highest power down, the coefficients read through `vals`; a
    /// zero coefficient (of the template: a step's value is never skipped) costs no addition.
    #[inline(always)]
    fn eval<V: Vector, const N: usize, S: StepValues + ?Sized>(
        &self,
        vals: &S,
        z: &[V; N],
    ) -> [V; N] {
        let Some(top) = self.n.checked_sub(1) else {
            return [V::splat(0.0); N];
        };
        let mut acc = [V::splat(vals.coef(self.c[top])); N];
        for &c in self.c[..top].iter().rev() {
            acc = each(|k| acc[k].mul(z[k]));
            if c != 0.0 {
                let c = V::splat(vals.coef(c));
                acc = each(|k| acc[k].add(c));
            }
        }
        acc
    }
}

/// `P₀(z) + sgn(z)·P₁(z)`, prescaled; the sign part absent when zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Part {
    plain: Horner,
    sgn: Option<Horner>,
}

impl Part {
    /// `k·p`, plus `add` on the constant term, with the layout of `like` when given, else
    /// zero terms and an empty sign part dropped.
    fn shaped(p: &SgnPoly, k: f64, add: f64, like: Option<&Part>) -> Part {
        let plain = Horner::scaled(&p.plain, k, add, like.map(|l| &l.plain));
        let sgn = match like {
            None => p
                .sgn
                .as_ref()
                .map(|q| Horner::scaled(q, k, 0.0, None))
                .filter(|q| q.n > 0),
            Some(l) => l.sgn.as_ref().map(|ls| {
                let none = ZPoly { coef: Vec::new() };
                Horner::scaled(p.sgn.as_ref().unwrap_or(&none), k, 0.0, Some(ls))
            }),
        };
        Part { plain, sgn }
    }

    /// Coefficient `power` of the plain or the sign part.
    fn horner(&self, sgn: bool) -> Option<&Horner> {
        if sgn {
            self.sgn.as_ref()
        } else {
            Some(&self.plain)
        }
    }

    fn horner_mut(&mut self, sgn: bool) -> Option<&mut Horner> {
        if sgn {
            self.sgn.as_mut()
        } else {
            Some(&mut self.plain)
        }
    }

    /// The value when the part is a constant.
    fn constant(&self) -> Option<f64> {
        match self.sgn {
            None => self.plain.constant(),
            Some(_) => None,
        }
    }

    /// The part at `z`, its coefficients read through `vals`.
    #[inline(always)]
    pub(crate) fn eval<V: Vector, const N: usize, S: StepValues + ?Sized>(
        &self,
        vals: &S,
        z: &[V; N],
    ) -> [V; N] {
        let p = self.plain.eval(vals, z);
        let Some(q) = &self.sgn else {
            return p;
        };
        // sgn(z)·q as q added where z > 0 and subtracted where z < 0 (at zero and for NaN
        // neither): no product, and on AVX-512 two masked operations.
        let zero = V::splat(0.0);
        let q: [V; N] = match q.constant() {
            Some(c) => [V::splat(vals.coef(c)); N],
            None => q.eval(vals, z),
        };
        each(|k| {
            p[k].add_where(z[k].gt(zero), q[k])
                .sub_where(z[k].lt(zero), q[k])
        })
    }
}

/// The parts of one kernel call with steps of size h and three-point value a.
///
/// For f affine in v the step's velocity update is `v ← v + (h·f + dw)·F` with
/// `h·f = force0(z) + v·h·f₁(z)` and F the Heun factor `1 + (h/2)·∂f/∂v`; for f of higher
/// degree in v, Heun's two evaluations of h·f ([`Velocity::Polynomial`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Coefs {
    /// The part of h·f free of v, times F when F is folded in ([`Velocity::Folded`]).
    pub(crate) force0: Part,
    /// √h·a·σ (times F when folded): the velocity increment of a three-point variable
    /// −a, 0 or a is its negative, zero or itself.
    pub(crate) sigma: Part,
    /// How v enters the update.
    pub(crate) velocity: Velocity,
}

/// How the velocity enters the step's update (see [`Coefs`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Velocity {
    /// F is a constant (∂f/∂v does not depend on z, as for linear damping), multiplied
    /// into the coefficients once per call: `v ← (force0(z) + v·keep(z)) + dw` with
    /// `keep = 1 + F·h·f₁`, absent when it is 1. Two operations a step fewer than
    /// [`Velocity::Heun`], the same update to rounding.
    Folded { keep: Option<Part> },
    /// `v ← v + ((force0(z) + v·force1(z)) + dw)·factor(z)`: `force1 = h·f₁` (absent when f
    /// does not depend on v) and `factor` = F, a function of z.
    Heun { force1: Option<Part>, factor: Part },
    /// f of degree 2 or more in v: `h·f(v) = force0(z) + v·(p₁(z) + v·(p₂(z) + v·p₃(z)))`
    /// with `p_l = h·f_l` (absent when zero), at v and at the predictor
    /// `v̄ = v + (h·f(v) + dw)`, then `v ← (v + (h·f(v) + h·f(v̄))/2) + dw`: the lane
    /// evaluator's corrector, to rounding.
    Polynomial {
        powers: [Option<Part>; MAX_V_DEGREE],
    },
}

/// Which part of a [`Coefs`] a [`Slot`] is in.
#[derive(Clone, Copy, Debug, PartialEq)]
enum PartId {
    Force0,
    Sigma,
    Keep,
    Force1,
    Factor,
    Power(usize),
}

/// One coefficient of a [`Coefs`]: its part, the plain or the sign polynomial, the power.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Slot {
    part: PartId,
    sgn: bool,
    power: usize,
}

impl Coefs {
    pub(crate) fn new(form: &MechForm, h: f64, a: f64) -> Coefs {
        Coefs::build(form, h, a, None)
    }

    /// The coefficients of `form` (of the shape `like` was made from) in the layout of
    /// `like`: the same parts with the same numbers of terms, folded or not as `like` is,
    /// whatever coefficients of `form` are zero. (`Coefs::new` drops terms and parts that
    /// are zero, and folds a Heun factor that is constant in z.)
    pub(crate) fn shaped(form: &MechForm, h: f64, a: f64, like: &Coefs) -> Coefs {
        Coefs::build(form, h, a, Some(like))
    }

    fn build(form: &MechForm, h: f64, a: f64, like: Option<&Coefs>) -> Coefs {
        let part = |id: PartId| like.and_then(|l| l.part(id));
        let (force1, slope) = match &form.in_v {
            InVelocity::Affine { force1, slope } => (force1, slope),
            InVelocity::Polynomial { powers } => {
                return Coefs {
                    force0: Part::shaped(&form.force0, h, 0.0, part(PartId::Force0)),
                    sigma: Part::shaped(&form.sigma, h.sqrt() * a, 0.0, part(PartId::Sigma)),
                    velocity: Velocity::Polynomial {
                        powers: std::array::from_fn(|l| {
                            powers[l]
                                .as_ref()
                                .map(|p| Part::shaped(p, h, 0.0, part(PartId::Power(l))))
                        }),
                    },
                }
            }
        };
        let factor = Part::shaped(slope, 0.5 * h, 1.0, part(PartId::Factor));
        let folded = match like.map(|l| &l.velocity) {
            None => factor.constant(),
            Some(Velocity::Folded { .. }) => Some(factor.plain.c[0]),
            Some(_) => None,
        };
        match folded {
            Some(f) => {
                // keep = 1 when f does not depend on v.
                let keep = force1
                    .as_ref()
                    .map(|b| Part::shaped(b, h * f, 1.0, part(PartId::Keep)));
                let keep = match like {
                    None => keep.filter(|k| k.constant() != Some(1.0)),
                    Some(_) => keep.filter(|_| part(PartId::Keep).is_some()),
                };
                Coefs {
                    force0: Part::shaped(&form.force0, h * f, 0.0, part(PartId::Force0)),
                    sigma: Part::shaped(&form.sigma, h.sqrt() * a * f, 0.0, part(PartId::Sigma)),
                    velocity: Velocity::Folded { keep },
                }
            }
            None => Coefs {
                force0: Part::shaped(&form.force0, h, 0.0, part(PartId::Force0)),
                sigma: Part::shaped(&form.sigma, h.sqrt() * a, 0.0, part(PartId::Sigma)),
                velocity: Velocity::Heun {
                    force1: force1
                        .as_ref()
                        .map(|b| Part::shaped(b, h, 0.0, part(PartId::Force1))),
                    factor,
                },
            },
        }
    }

    fn part(&self, id: PartId) -> Option<&Part> {
        match (id, &self.velocity) {
            (PartId::Force0, _) => Some(&self.force0),
            (PartId::Sigma, _) => Some(&self.sigma),
            (PartId::Keep, Velocity::Folded { keep }) => keep.as_ref(),
            (PartId::Force1, Velocity::Heun { force1, .. }) => force1.as_ref(),
            (PartId::Factor, Velocity::Heun { factor, .. }) => Some(factor),
            (PartId::Power(l), Velocity::Polynomial { powers }) => powers[l].as_ref(),
            _ => None,
        }
    }

    fn part_mut(&mut self, id: PartId) -> Option<&mut Part> {
        match (id, &mut self.velocity) {
            (PartId::Force0, _) => Some(&mut self.force0),
            (PartId::Sigma, _) => Some(&mut self.sigma),
            (PartId::Keep, Velocity::Folded { keep }) => keep.as_mut(),
            (PartId::Force1, Velocity::Heun { force1, .. }) => force1.as_mut(),
            (PartId::Factor, Velocity::Heun { factor, .. }) => Some(factor),
            (PartId::Power(l), Velocity::Polynomial { powers }) => powers[l].as_mut(),
            _ => None,
        }
    }

    /// Every coefficient the kernel reads (the terms of each part) and its value.
    pub(crate) fn slots(&self) -> Vec<(Slot, f64)> {
        let parts = [
            PartId::Force0,
            PartId::Sigma,
            PartId::Keep,
            PartId::Force1,
            PartId::Factor,
        ]
        .into_iter()
        .chain((0..MAX_V_DEGREE).map(PartId::Power));
        let mut out = Vec::new();
        for id in parts {
            let Some(p) = self.part(id) else { continue };
            for sgn in [false, true] {
                if let Some(h) = p.horner(sgn) {
                    for power in 0..h.n {
                        out.push((
                            Slot {
                                part: id,
                                sgn,
                                power,
                            },
                            h.c[power],
                        ));
                    }
                }
            }
        }
        out
    }

    /// The value of a coefficient of [`Coefs::slots`] (0 for one this layout lacks).
    pub(crate) fn get(&self, s: Slot) -> f64 {
        self.part(s.part)
            .and_then(|p| p.horner(s.sgn))
            .map_or(0.0, |h| h.c[s.power])
    }

    /// Marks the coefficients `slots` (of this layout) as a step's values 0, 1, …: the
    /// kernel then reads coefficient `slots[j]` as value j of each step ([`StepValues`]).
    pub(crate) fn mark_step_values(&mut self, slots: &[Slot]) {
        for (j, s) in slots.iter().enumerate() {
            if let Some(h) = self.part_mut(s.part).and_then(|p| p.horner_mut(s.sgn)) {
                h.c[s.power] = step_mark(j);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zpoly(c: &[f64]) -> ZPoly {
        ZPoly { coef: c.to_vec() }
    }

    /// Zero coefficients are skipped, trailing ones dropped, the scale and the added
    /// constant folded in.
    #[test]
    fn horner_skips_zero_coefficients_and_folds_the_scale() {
        let p = Horner::scaled(&zpoly(&[0.0, -1.0, 0.0, -0.1, 0.0]), 0.5, 0.0, None);
        assert_eq!(p.n, 4);
        let z = [2.0f64];
        // 0.5·(−2 − 0.8) with the products in Horner's order.
        assert_eq!(p.eval(&(), &z)[0], ((-0.05 * 2.0) * 2.0 + -0.5) * 2.0);
        let one = Horner::scaled(&zpoly(&[-0.1]), 0.005, 1.0, None);
        assert_eq!(one.constant(), Some(1.0 + 0.005 * -0.1));
        assert_eq!(
            Horner::scaled(&zpoly(&[]), 3.0, 0.0, None).constant(),
            Some(0.0)
        );
    }

    /// sgn(z)·q picks q, −q or 0 as the product with sgn would (up to the sign of a zero).
    #[test]
    fn the_sign_part_is_picked_not_multiplied() {
        let p = SgnPoly {
            plain: zpoly(&[0.0, 0.1]),
            sgn: Some(zpoly(&[1.0, 2.0])),
        };
        let part = Part::shaped(&p, 1.0, 0.0, None);
        for z in [-1.5f64, -0.0, 0.0, 0.25, f64::NAN] {
            let got = part.eval(&(), &[z])[0];
            let s = crate::mc::compile::mech_form::sgn(z);
            let want = 0.1 * z + s * (2.0 * z + 1.0);
            assert!(
                got == want || got.is_nan() && want.is_nan(),
                "{z}: {got} {want}"
            );
        }
    }
}
