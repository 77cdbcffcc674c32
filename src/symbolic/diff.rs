//! Symbolic differentiation, in the sense of distributions for the non-smooth functions.
//!
//! The chain rule is applied once, generically; what each function contributes is one entry of
//! [`OUTER_DERIVATIVES`]. The non-smooth entries follow the distributional calculus the FPK
//! operator needs: d|u| = sgn(u)·du and d sgn(u) = 2δ(u)·du, while δ′ is refused rather than
//! turned into a number.

use super::{simplify, Expr, Func, SymbolicError};

/// How f′(u) is built from u.
type OuterRule = fn(&Expr) -> Expr;

/// f′(u) for each one-argument function f, as an expression in u: the rules as data.
/// `delta` is absent on purpose: its derivative is not representable (see [`diff`]); `min` and
/// `max` take two arguments and are rewritten through `abs`.
const OUTER_DERIVATIVES: [(Func, OuterRule); 8] = [
    (Func::Abs, |u| Expr::call(Func::Sgn, u.clone())),
    (Func::Sgn, |u| {
        Expr::num(2.0) * Expr::call(Func::Delta, u.clone())
    }),
    (Func::Exp, |u| Expr::call(Func::Exp, u.clone())),
    (Func::Log, |u| Expr::pow(u.clone(), Expr::num(-1.0))),
    // 1/(2 sqrt(u)) keeps sqrt's domain (u^-0.5 would too, but prints worse).
    (Func::Sqrt, |u| {
        Expr::num(0.5) * Expr::pow(Expr::call(Func::Sqrt, u.clone()), Expr::num(-1.0))
    }),
    (Func::Sin, |u| Expr::call(Func::Cos, u.clone())),
    (Func::Cos, |u| -Expr::call(Func::Sin, u.clone())),
    (Func::Tanh, |u| {
        Expr::num(1.0) - Expr::pow(Expr::call(Func::Tanh, u.clone()), Expr::num(2.0))
    }),
];

/// The derivative of `e` with respect to symbol `var`, simplified.
///
/// Constant exponents use `d(u^n) = n·u^(n−1)·du` (no logarithm of a possibly negative base);
/// a general power uses `d(u^w) = u^w·(dw·log(u) + w·du/u)`. `min(u, w) = (u + w)/2 − |u − w|/2`
/// and `max(u, w) = (u + w)/2 + |u − w|/2` are differentiated through `abs`.
///
/// # Errors
/// [`SymbolicError::DeltaDerivative`] when a `delta` whose argument depends on `var` would have
/// to be differentiated; [`SymbolicError::Arity`] for a malformed call.
///
/// ```
/// use fpsolve::symbolic::{diff, Expr, Func};
/// let (z, v) = (Expr::sym("z"), Expr::sym("v"));
/// // d/dv of the impact damping term v·|v|: 2|v|.
/// let e = v.clone() * Expr::call(Func::Abs, v.clone());
/// assert_eq!(diff(&e, "v").unwrap().to_string(), "2*abs(v)");
/// // d/dz sgn(z) = 2 delta(z).
/// assert_eq!(diff(&Expr::call(Func::Sgn, z.clone()), "z").unwrap().to_string(), "2*delta(z)");
/// // delta(z) is constant in v, but has no derivative in z.
/// let d = Expr::call(Func::Delta, z) * v;
/// assert_eq!(diff(&d, "v").unwrap().to_string(), "delta(z)");
/// assert!(diff(&d, "z").is_err());
/// ```
pub fn diff(e: &Expr, var: &str) -> Result<Expr, SymbolicError> {
    Ok(simplify(&derivative(e, var)?))
}

fn derivative(e: &Expr, var: &str) -> Result<Expr, SymbolicError> {
    if !e.mentions(var) {
        return Ok(Expr::num(0.0));
    }
    Ok(match e {
        Expr::Num(_) => Expr::num(0.0),
        Expr::Sym(s) => Expr::num(if &**s == var { 1.0 } else { 0.0 }),
        Expr::Add(terms) => Expr::sum(
            terms
                .iter()
                .map(|t| derivative(t, var))
                .collect::<Result<_, _>>()?,
        ),
        Expr::Mul(factors) => {
            let mut terms = Vec::with_capacity(factors.len());
            for (i, f) in factors.iter().enumerate() {
                if !f.mentions(var) {
                    continue;
                }
                let mut term = factors.clone();
                term[i] = derivative(f, var)?;
                terms.push(Expr::product(term));
            }
            Expr::sum(terms)
        }
        Expr::Pow(u, w) if !w.mentions(var) => {
            // d(u^n) = n u^(n-1) du, for a number or any var-free exponent.
            let n = (**w).clone();
            let lowered = Expr::pow((**u).clone(), n.clone() - Expr::num(1.0));
            n * lowered * derivative(u, var)?
        }
        Expr::Pow(u, w) => {
            let (u, w) = ((**u).clone(), (**w).clone());
            let du = derivative(&u, var)?;
            let dw = derivative(&w, var)?;
            Expr::pow(u.clone(), w.clone()) * (dw * Expr::call(Func::Log, u.clone()) + w * du / u)
        }
        Expr::Call(f, args) => {
            if args.len() != f.arity() {
                return Err(SymbolicError::Arity {
                    func: f.name(),
                    expected: f.arity(),
                    got: args.len(),
                });
            }
            match f {
                Func::Min | Func::Max => {
                    let (u, w) = (args[0].clone(), args[1].clone());
                    let half_sum = Expr::num(0.5) * (u.clone() + w.clone());
                    let half_gap = Expr::num(0.5) * Expr::call(Func::Abs, u - w);
                    let rewritten = if *f == Func::Min {
                        half_sum - half_gap
                    } else {
                        half_sum + half_gap
                    };
                    derivative(&rewritten, var)?
                }
                Func::Delta => {
                    return Err(SymbolicError::DeltaDerivative {
                        expr: e.to_string(),
                        var: var.into(),
                    })
                }
                _ => {
                    let u = &args[0];
                    let outer = OUTER_DERIVATIVES
                        .iter()
                        .find(|(g, _)| g == f)
                        .map(|(_, rule)| rule(u))
                        .expect("every one-argument function but delta has a rule");
                    outer * derivative(u, var)?
                }
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn x() -> Expr {
        Expr::sym("x")
    }
    fn y() -> Expr {
        Expr::sym("y")
    }
    fn n(v: f64) -> Expr {
        Expr::num(v)
    }
    fn d(e: &Expr) -> String {
        diff(e, "x").unwrap().to_string()
    }

    #[test]
    fn every_function_but_delta_has_a_rule() {
        for f in Func::ALL {
            let has = OUTER_DERIVATIVES.iter().any(|(g, _)| *g == f);
            assert_eq!(has, f.arity() == 1 && f != Func::Delta, "{f:?}");
        }
    }

    #[test]
    fn polynomial_and_product_rules() {
        assert_eq!(d(&Expr::pow(x(), n(3.0))), "3*x^2");
        assert_eq!(d(&(x() * y() + n(2.0))), "y");
        assert_eq!(d(&(n(1.0) / x())), "-1/x^2");
        // Duffing drift: d/dx (-c v - k x - mu x^3).
        let m = -(Expr::sym("c") * y())
            - Expr::sym("k") * x()
            - Expr::sym("mu") * Expr::pow(x(), n(3.0));
        assert_eq!(d(&m), "-k - 3*mu*x^2");
    }

    #[test]
    fn constant_exponent_of_negative_base_stays_finite() {
        let e = diff(&Expr::pow(x(), n(3.0)), "x").unwrap();
        assert_eq!(e.eval(&|_| Some(-2.0)).unwrap(), 12.0);
        let e = diff(&Expr::pow(x(), Expr::sym("p")), "x").unwrap();
        assert_eq!(e.to_string(), "p*x^(p - 1)");
        let v = e
            .eval(&|s| Some(if s == "x" { -2.0 } else { 3.0 }))
            .unwrap();
        assert_relative_eq!(v, 12.0);
    }

    #[test]
    fn general_power() {
        let e = diff(&Expr::pow(x(), x()), "x").unwrap();
        let v = e.eval(&|_| Some(2.0)).unwrap();
        assert_relative_eq!(v, 4.0 * (2f64.ln() + 1.0), max_relative = 1e-14);
    }

    #[test]
    fn smooth_functions() {
        assert_eq!(d(&Expr::call(Func::Sin, n(2.0) * x())), "2*cos(2*x)");
        assert_eq!(
            d(&Expr::call(Func::Exp, -Expr::pow(x(), n(2.0)))),
            "-2*x*exp(-x^2)"
        );
        let e = diff(&Expr::call(Func::Tanh, x()), "x").unwrap();
        assert_relative_eq!(e.eval(&|_| Some(0.3)).unwrap(), 1.0 - 0.3f64.tanh().powi(2));
        let e = diff(&Expr::call(Func::Sqrt, x()), "x").unwrap();
        assert_relative_eq!(e.eval(&|_| Some(4.0)).unwrap(), 0.25);
        let e = diff(&Expr::call(Func::Log, x()), "x").unwrap();
        assert_relative_eq!(e.eval(&|_| Some(4.0)).unwrap(), 0.25);
    }

    #[test]
    fn distributional_rules() {
        assert_eq!(d(&Expr::call(Func::Abs, x())), "sgn(x)");
        assert_eq!(d(&Expr::call(Func::Sgn, x() - n(0.3))), "2*delta(x - 0.3)");
        // Second derivative of |x| is 2 delta(x).
        let once = diff(&Expr::call(Func::Abs, x()), "x").unwrap();
        assert_eq!(d(&once), "2*delta(x)");
        // Eq. 12: d/dv [(1 - r) v |v| delta(z)] = 2 (1 - r) |v| delta(z).
        let z = Expr::sym("z");
        let e = (n(1.0) - Expr::sym("r"))
            * y()
            * Expr::call(Func::Abs, y())
            * Expr::call(Func::Delta, z);
        assert_eq!(
            diff(&e, "y").unwrap().to_string(),
            "2*abs(y)*delta(z)*(1 - r)"
        );
    }

    #[test]
    fn delta_derivative_is_an_error() {
        let e = x() * Expr::call(Func::Delta, x() - n(1.0));
        assert_eq!(
            diff(&e, "x"),
            Err(SymbolicError::DeltaDerivative {
                expr: "delta(x - 1)".into(),
                var: "x".into()
            })
        );
    }

    #[test]
    fn min_and_max() {
        let e = diff(&Expr::Call(Func::Max, vec![x(), n(0.0)]), "x").unwrap();
        assert_eq!(e.eval(&|_| Some(2.0)).unwrap(), 1.0);
        assert_eq!(e.eval(&|_| Some(-2.0)).unwrap(), 0.0);
        let e = diff(&Expr::Call(Func::Min, vec![x(), y()]), "x").unwrap();
        assert_eq!(
            e.eval(&|s| Some(if s == "x" { 1.0 } else { 3.0 })).unwrap(),
            1.0
        );
        assert_eq!(
            e.eval(&|s| Some(if s == "x" { 5.0 } else { 3.0 })).unwrap(),
            0.0
        );
    }
}
