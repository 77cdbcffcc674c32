//! A tape evaluated over a box of points: an interval that holds every value
//! [`Tape::eval`] can compute at a point of the box, or nothing when that cannot be promised
//! cheaply (a division by an interval around zero, a logarithm of one reaching zero, a
//! variable exponent, a Gaussian stand-in for delta: wherever a point might give NaN or an
//! infinity, or where nothing needs it).
//!
//! The enclosure is of the values `eval` computes, rounding included, not of the exact
//! values. For the correctly rounded operations (+, −, ×, ÷, √, and the exact ones: |·|, sgn,
//! min, max, negation) the ends are computed by the same operation on the operands' ends in
//! the same rounding: rounding to nearest is monotone, so a point's computed value lies
//! between them without widening. The library functions (exp, ln, sin, cos, tanh, powf) are
//! not promised to be correctly rounded or monotone; their ends are widened by [`LIBM_SLACK`]
//! (relative) and the smallest normal number, far beyond their few-ulp errors.

use super::{Op, Tape, Unary};

/// The relative widening of a library function's ends.
const LIBM_SLACK: f64 = 1e-12;

/// The closed interval [`lo`, `hi`] of finite numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Interval {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
}

impl Interval {
    /// [`lo`, `hi`]; `None` unless both are finite and `lo ≤ hi`.
    pub(crate) fn new(lo: f64, hi: f64) -> Option<Interval> {
        (lo.is_finite() && hi.is_finite() && lo <= hi).then_some(Interval { lo, hi })
    }

    /// The interval of the four products (or quotients) of the ends, `None` unless finite.
    fn corners(self, b: Interval, f: impl Fn(f64, f64) -> f64) -> Option<Interval> {
        let p = [
            f(self.lo, b.lo),
            f(self.lo, b.hi),
            f(self.hi, b.lo),
            f(self.hi, b.hi),
        ];
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if p.iter().any(|x| x.is_nan()) {
            return None;
        }
        Interval::new(lo, hi)
    }

    /// `f` (monotone increasing where defined) on both ends, widened as a library function.
    fn increasing(self, f: impl Fn(f64) -> f64) -> Option<Interval> {
        widened(f(self.lo), f(self.hi))
    }

    /// `f` (monotone decreasing where defined) on both ends, widened as a library function.
    fn decreasing(self, f: impl Fn(f64) -> f64) -> Option<Interval> {
        widened(f(self.hi), f(self.lo))
    }

    /// Whether zero lies in the interval.
    fn holds_zero(self) -> bool {
        self.lo <= 0.0 && 0.0 <= self.hi
    }
}

/// [`lo`, `hi`] widened by [`LIBM_SLACK`] and the smallest normal number.
fn widened(lo: f64, hi: f64) -> Option<Interval> {
    let slack = |x: f64| x.abs() * LIBM_SLACK + f64::MIN_POSITIVE;
    Interval::new(lo - slack(lo), hi + slack(hi))
}

impl Tape {
    /// Encloses every output over the box `x` (one interval per variable, in compile order)
    /// into `out`: any point of the box evaluated by [`Tape::eval`] gives values inside.
    /// `false` (and `out` unspecified) when that cannot be promised (see the module's doc).
    /// `scratch` is reused between calls.
    ///
    /// # Panics
    /// If `x.len() != self.n_vars()` or `out.len() != self.n_outputs()`.
    pub(crate) fn enclose(
        &self,
        x: &[Interval],
        scratch: &mut Vec<Interval>,
        out: &mut [Interval],
    ) -> bool {
        assert_eq!(
            x.len(),
            self.n_vars,
            "Tape::enclose: wrong number of variables"
        );
        assert_eq!(
            out.len(),
            self.outputs.len(),
            "Tape::enclose: wrong number of outputs"
        );
        scratch.clear();
        for &op in &self.ops {
            let g = |a: u32| scratch[a as usize];
            let value = match op {
                Op::Const(c) => Interval::new(c, c),
                Op::Var(k) => Some(x[k as usize]),
                Op::Add(a, b) => Interval::new(g(a).lo + g(b).lo, g(a).hi + g(b).hi),
                Op::Sub(a, b) => Interval::new(g(a).lo - g(b).hi, g(a).hi - g(b).lo),
                // A square is never negative, whatever the signs of its operand's ends.
                Op::Mul(a, b) if a == b => square(g(a)),
                Op::Mul(a, b) => g(a).corners(g(b), |p, q| p * q),
                Op::Div(_, b) if g(b).holds_zero() => None,
                Op::Div(a, b) => g(a).corners(g(b), |p, q| p / q),
                Op::AddC(a, c) => Interval::new(g(a).lo + c, g(a).hi + c),
                Op::MulC(a, c) => g(a).corners(Interval { lo: c, hi: c }, |p, q| p * q),
                Op::Neg(a) => Interval::new(-g(a).hi, -g(a).lo),
                Op::Recip(a) if g(a).holds_zero() => None,
                Op::Recip(a) => Interval::new(1.0 / g(a).hi, 1.0 / g(a).lo),
                Op::Min(a, b) => Interval::new(g(a).lo.min(g(b).lo), g(a).hi.min(g(b).hi)),
                Op::Max(a, b) => Interval::new(g(a).lo.max(g(b).lo), g(a).hi.max(g(b).hi)),
                Op::Unary(f, a) => unary(f, g(a)),
                // Only a base that stays positive: powf is monotone there, either way.
                Op::PowC(a, c) if g(a).lo > 0.0 && c >= 0.0 => g(a).increasing(|u| u.powf(c)),
                Op::PowC(a, c) if g(a).lo > 0.0 => g(a).decreasing(|u| u.powf(c)),
                Op::PowC(..) | Op::Pow(..) | Op::Gauss { .. } => None,
            };
            let Some(value) = value else {
                return false;
            };
            scratch.push(value);
        }
        for (o, &slot) in out.iter_mut().zip(&self.outputs) {
            *o = scratch[slot as usize];
        }
        true
    }
}

/// `a·a` over `a`: the products of its ends, and zero when it holds zero.
fn square(a: Interval) -> Option<Interval> {
    let (l, h) = (a.lo * a.lo, a.hi * a.hi);
    let lo = if a.holds_zero() { 0.0 } else { l.min(h) };
    Interval::new(lo, l.max(h))
}

fn unary(f: Unary, a: Interval) -> Option<Interval> {
    match f {
        Unary::Abs if a.holds_zero() => Interval::new(0.0, (-a.lo).max(a.hi)),
        Unary::Abs if a.hi < 0.0 => Interval::new(-a.hi, -a.lo),
        Unary::Abs => Some(a),
        Unary::Sgn => Interval::new(f.apply(a.lo), f.apply(a.hi)),
        Unary::Exp => a.increasing(f64::exp),
        Unary::Log if a.lo > 0.0 => a.increasing(f64::ln),
        Unary::Sqrt if a.lo >= 0.0 => Interval::new(a.lo.sqrt(), a.hi.sqrt()),
        Unary::Log | Unary::Sqrt => None,
        Unary::Sin | Unary::Cos => widened(-1.0, 1.0),
        Unary::Tanh => a.increasing(f64::tanh),
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
    fn n(x: f64) -> Expr {
        Expr::num(x)
    }
    fn call(f: Func, u: Expr) -> Expr {
        Expr::call(f, u)
    }
    fn min(a: Expr, b: Expr) -> Expr {
        Expr::Call(Func::Min, vec![a, b])
    }
    fn max(a: Expr, b: Expr) -> Expr {
        Expr::Call(Func::Max, vec![a, b])
    }

    /// Expressions through every operation the enclosure handles.
    fn expressions() -> Vec<Expr> {
        vec![
            z() * z() + v() * v(),
            z() * v() - n(3.0) * z() + n(0.1) * Expr::pow(z(), n(3.0)),
            call(Func::Abs, z() - n(0.3)) + call(Func::Sgn, v()),
            call(Func::Sqrt, z() * z() + n(0.5) * v() * v()) - call(Func::Tanh, v()),
            call(Func::Exp, n(0.2) * z()) + call(Func::Log, n(1.0) + z() * z()),
            z() / (n(1.0) + v() * v()) - n(1.0) / (n(2.0) + z() * z()),
            call(Func::Sin, z()) * call(Func::Cos, v()),
            min(z(), v()) - max(z() * v(), n(0.1)),
            Expr::pow(n(1.0) + z() * z(), n(1.5)) - Expr::pow(n(2.0) + v() * v(), n(-0.5)),
        ]
    }

    /// A tiny deterministic generator of numbers in [0, 1).
    fn uniforms() -> impl FnMut() -> f64 {
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn every_point_of_the_box_evaluates_inside_the_enclosure() {
        let mut u = uniforms();
        let (mut scratch, mut slots) = (Vec::new(), Vec::new());
        for e in expressions() {
            let tape =
                Tape::compile(std::slice::from_ref(&e), &["z", "v"], DeltaPolicy::Reject).unwrap();
            let mut enclosed = 0;
            for round in 0..400 {
                // Boxes from tiny to wide, some around zero, some touching it.
                let width = 10f64.powi(round % 7 - 5);
                let side = |u: &mut dyn FnMut() -> f64| {
                    let lo = if round % 11 == 0 {
                        0.0
                    } else {
                        4.0 * u() - 2.0
                    };
                    Interval::new(lo, lo + width * u()).unwrap()
                };
                let b = [side(&mut u), side(&mut u)];
                let mut out = [Interval { lo: 0.0, hi: 0.0 }];
                if !tape.enclose(&b, &mut slots, &mut out) {
                    continue;
                }
                enclosed += 1;
                let [q] = out;
                // The ends and the corners, then points within.
                for k in 0..40 {
                    let pick = |i: &Interval, t: f64| i.lo + t * (i.hi - i.lo);
                    let (s, t) = match k {
                        0..4 => ((k & 1) as f64, (k >> 1) as f64),
                        _ => (u(), u()),
                    };
                    let p = [pick(&b[0], s).min(b[0].hi), pick(&b[1], t).min(b[1].hi)];
                    let mut val = [0.0];
                    tape.eval(&p, &mut scratch, &mut val);
                    assert!(
                        q.lo <= val[0] && val[0] <= q.hi,
                        "{e} at {p:?}: {} outside [{}, {}] over {b:?}",
                        val[0],
                        q.lo,
                        q.hi
                    );
                }
            }
            assert!(enclosed > 100, "{e}: only {enclosed} boxes enclosed");
        }
    }

    #[test]
    fn a_box_where_a_point_may_fail_is_refused() {
        let cases = [
            (call(Func::Log, z()), [-0.5, 0.5]),
            (call(Func::Sqrt, z()), [-1e-300, 1.0]),
            (n(1.0) / z(), [-1.0, 1.0]),
            (v() / z(), [0.0, 1.0]),
            (Expr::pow(z(), v()), [1.0, 2.0]),
            (Expr::pow(z(), n(1.5)), [-1.0, 1.0]),
            (call(Func::Exp, n(1000.0) * z()), [0.0, 1.0]),
        ];
        for (e, [lo, hi]) in cases {
            let tape =
                Tape::compile(std::slice::from_ref(&e), &["z", "v"], DeltaPolicy::Reject).unwrap();
            let b = [
                Interval::new(lo, hi).unwrap(),
                Interval::new(1.0, 2.0).unwrap(),
            ];
            let mut out = [Interval { lo: 0.0, hi: 0.0 }];
            assert!(!tape.enclose(&b, &mut Vec::new(), &mut out), "{e}");
        }
    }
}
