//! The mechanical form's polynomials as one call of the kernel evaluates them: prescaled by
//! the call's step sizes, so that the step multiplies by neither h nor √h, and by Horner's
//! rule with zero coefficients skipped.
//!
//! The step needs h·f, √h·a·σ (a the three-point value, whose sign and zero the random bits
//! pick) and the Heun factor 1 + (h/2)·∂f/∂v: each is a [`Part`] `P₀(z) + sgn(z)·P₁(z)`
//! with the scale folded into its coefficients. `sgn(z)·P₁(z)` is P₁, −P₁ or 0 picked by the
//! two comparisons of z with zero (no product), made only by a part that has a sign part.

use super::vector::{each, Vector};
use crate::mc::compile::mech_form::{InVelocity, MechForm, SgnPoly, ZPoly, MAX_V_DEGREE};

/// Coefficients a [`Horner`] holds (`mech_form`'s highest power plus one).
const MAX_COEFS: usize = 9;

/// A polynomial in z, coefficients from the constant up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Horner {
    c: [f64; MAX_COEFS],
    n: usize,
}

impl Horner {
    /// `k·p`, each coefficient multiplied by `k`, plus `add` on the constant term.
    fn scaled(p: &ZPoly, k: f64, add: f64) -> Horner {
        let mut c = [0.0; MAX_COEFS];
        for (c, &p) in c.iter_mut().zip(&p.coef) {
            *c = k * p;
        }
        let mut n = p.coef.len();
        if add != 0.0 {
            c[0] += add;
            n = n.max(1);
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

    /// Horner's rule from the highest power down; a zero coefficient costs no addition.
    #[inline(always)]
    fn eval<V: Vector, const N: usize>(&self, z: &[V; N]) -> [V; N] {
        let Some(top) = self.n.checked_sub(1) else {
            return [V::splat(0.0); N];
        };
        let mut acc = [V::splat(self.c[top]); N];
        for &c in self.c[..top].iter().rev() {
            acc = each(|k| acc[k].mul(z[k]));
            if c != 0.0 {
                let c = V::splat(c);
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
    fn scaled(p: &SgnPoly, k: f64, add: f64) -> Part {
        let sgn = p.sgn.as_ref().map(|q| Horner::scaled(q, k, 0.0));
        Part {
            plain: Horner::scaled(&p.plain, k, add),
            sgn: sgn.filter(|q| q.n > 0),
        }
    }

    /// The value when the part is a constant.
    fn constant(&self) -> Option<f64> {
        match self.sgn {
            None => self.plain.constant(),
            Some(_) => None,
        }
    }

    /// The part at `z`.
    #[inline(always)]
    pub(crate) fn eval<V: Vector, const N: usize>(&self, z: &[V; N]) -> [V; N] {
        let p = self.plain.eval(z);
        let Some(q) = &self.sgn else {
            return p;
        };
        // sgn(z)·q as q added where z > 0 and subtracted where z < 0 (at zero and for NaN
        // neither): no product, and on AVX-512 two masked operations.
        let zero = V::splat(0.0);
        let q: [V; N] = match q.constant() {
            Some(c) => [V::splat(c); N],
            None => q.eval(z),
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

impl Coefs {
    pub(crate) fn new(form: &MechForm, h: f64, a: f64) -> Coefs {
        let (force1, slope) = match &form.in_v {
            InVelocity::Affine { force1, slope } => (force1, slope),
            InVelocity::Polynomial { powers } => {
                return Coefs {
                    force0: Part::scaled(&form.force0, h, 0.0),
                    sigma: Part::scaled(&form.sigma, h.sqrt() * a, 0.0),
                    velocity: Velocity::Polynomial {
                        powers: std::array::from_fn(|l| {
                            powers[l].as_ref().map(|p| Part::scaled(p, h, 0.0))
                        }),
                    },
                }
            }
        };
        let factor = Part::scaled(slope, 0.5 * h, 1.0);
        match factor.constant() {
            Some(f) => {
                // keep = 1 when f does not depend on v.
                let keep = force1.as_ref().map(|b| Part::scaled(b, h * f, 1.0));
                Coefs {
                    force0: Part::scaled(&form.force0, h * f, 0.0),
                    sigma: Part::scaled(&form.sigma, h.sqrt() * a * f, 0.0),
                    velocity: Velocity::Folded {
                        keep: keep.filter(|k| k.constant() != Some(1.0)),
                    },
                }
            }
            None => Coefs {
                force0: Part::scaled(&form.force0, h, 0.0),
                sigma: Part::scaled(&form.sigma, h.sqrt() * a, 0.0),
                velocity: Velocity::Heun {
                    force1: force1.as_ref().map(|b| Part::scaled(b, h, 0.0)),
                    factor,
                },
            },
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
        let p = Horner::scaled(&zpoly(&[0.0, -1.0, 0.0, -0.1, 0.0]), 0.5, 0.0);
        assert_eq!(p.n, 4);
        let z = [2.0f64];
        // 0.5·(−2 − 0.8) with the products in Horner's order.
        assert_eq!(p.eval(&z)[0], ((-0.05 * 2.0) * 2.0 + -0.5) * 2.0);
        let one = Horner::scaled(&zpoly(&[-0.1]), 0.005, 1.0);
        assert_eq!(one.constant(), Some(1.0 + 0.005 * -0.1));
        assert_eq!(Horner::scaled(&zpoly(&[]), 3.0, 0.0).constant(), Some(0.0));
    }

    /// sgn(z)·q picks q, −q or 0 as the product with sgn would (up to the sign of a zero).
    #[test]
    fn the_sign_part_is_picked_not_multiplied() {
        let p = SgnPoly {
            plain: zpoly(&[0.0, 0.1]),
            sgn: Some(zpoly(&[1.0, 2.0])),
        };
        let part = Part::scaled(&p, 1.0, 0.0);
        for z in [-1.5f64, -0.0, 0.0, 0.25, f64::NAN] {
            let got = part.eval(&[z])[0];
            let s = crate::mc::compile::mech_form::sgn(z);
            let want = 0.1 * z + s * (2.0 * z + 1.0);
            assert!(
                got == want || got.is_nan() && want.is_nan(),
                "{z}: {got} {want}"
            );
        }
    }
}
