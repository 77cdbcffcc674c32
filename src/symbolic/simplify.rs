//! A deterministic canonical form for expressions, and expansion of products over sums.
//!
//! The canonical form keeps derived FPK coefficients readable: numbers folded (never into NaN
//! or ±∞), sums and products flattened, like terms and powers of like bases collected, the
//! numeric coefficient first and the other factors in one stable order. For `abs` and `sgn` it
//! uses the identities that hold everywhere (`sgn(u)·|u| = u`, `u·sgn(u) = |u|`,
//! `|u|^(2k) = u^(2k)`, `sgn(c·u) = sgn(c)·sgn(u)`, ...), plus one that holds almost
//! everywhere, which is what matters under an integral against a density:
//! `sgn(u)^(2k) = 1`, applied only when `u` is built from smooth functions, so that its zero
//! set has measure zero.

use std::cmp::Ordering;

use super::{powf, Expr, Func};

/// The canonical form of `e`.
///
/// ```
/// use fpsolve::symbolic::{simplify, Expr, Func};
/// let (x, y) = (Expr::sym("x"), Expr::sym("y"));
/// let e = Expr::num(2.0) * x.clone() * y.clone() + Expr::num(3.0) * y.clone() * x.clone();
/// assert_eq!(simplify(&e).to_string(), "5*x*y");
/// let e = x.clone() * Expr::pow(x.clone(), Expr::num(2.0)) + Expr::num(0.0) * y;
/// assert_eq!(simplify(&e).to_string(), "x^3");
/// let e = Expr::call(Func::Sgn, x.clone()) * Expr::call(Func::Abs, x.clone());
/// assert_eq!(simplify(&e).to_string(), "x");
/// let e = Expr::pow(Expr::call(Func::Sgn, x.clone()), Expr::num(2.0));
/// assert_eq!(simplify(&e).to_string(), "1");
/// // 0^(-1) is not folded into inf.
/// let e = Expr::pow(Expr::num(0.0), Expr::num(-1.0));
/// assert_eq!(simplify(&e).to_string(), "0^(-1)");
/// ```
pub fn simplify(e: &Expr) -> Expr {
    match e {
        Expr::Num(v) => number(*v),
        Expr::Sym(_) => e.clone(),
        Expr::Add(terms) => sum(terms.iter().map(simplify).collect()),
        Expr::Mul(factors) => product(factors.iter().map(simplify).collect()),
        Expr::Pow(b, x) => power(simplify(b), simplify(x)),
        Expr::Call(f, args) => call(*f, args.iter().map(simplify).collect()),
    }
}

/// The canonical form of `e` with products distributed over sums and positive integer powers
/// of sums multiplied out, so that the result is a sum of products (a polynomial in the
/// symbols and calls it contains). Call arguments are expanded too.
///
/// ```
/// use fpsolve::symbolic::{expand, Expr, Func};
/// let z = Expr::sym("z");
/// // The vibro-impact noise coefficient (sgn(z) + eps z)^2 with eps = 0.5.
/// let e = Expr::pow(Expr::call(Func::Sgn, z.clone()) + Expr::num(0.5) * z, Expr::num(2.0));
/// assert_eq!(expand(&e).to_string(), "0.25*z^2 + abs(z) + 1");
/// ```
pub fn expand(e: &Expr) -> Expr {
    expanded(&simplify(e))
}

/// Expands an expression that is already canonical; the result is canonical.
fn expanded(e: &Expr) -> Expr {
    match e {
        Expr::Num(_) | Expr::Sym(_) => e.clone(),
        Expr::Add(terms) => sum(terms.iter().map(expanded).collect()),
        Expr::Mul(factors) => factors
            .iter()
            .map(expanded)
            .fold(Expr::Num(1.0), |acc, f| multiply_out(&acc, &f)),
        Expr::Pow(b, x) => {
            let b = expanded(b);
            match x.as_num() {
                Some(n) if n > 0.0 && n.fract() == 0.0 && matches!(b, Expr::Add(_)) => {
                    let mut acc = b.clone();
                    for _ in 1..n as u64 {
                        acc = multiply_out(&acc, &b);
                    }
                    acc
                }
                _ => power(b, expanded(x)),
            }
        }
        Expr::Call(f, args) => call(*f, args.iter().map(expanded).collect()),
    }
}

/// `a · b` for expanded `a`, `b`, distributed term by term and collected.
fn multiply_out(a: &Expr, b: &Expr) -> Expr {
    let terms = |e: &Expr| match e {
        Expr::Add(t) => t.clone(),
        other => vec![other.clone()],
    };
    let (ta, tb) = (terms(a), terms(b));
    let mut out = Vec::with_capacity(ta.len() * tb.len());
    for x in &ta {
        for y in &tb {
            out.push(product(vec![x.clone(), y.clone()]));
        }
    }
    sum(out)
}

/// A number, with −0 made +0 so that printing and comparison see one zero.
fn number(v: f64) -> Expr {
    Expr::Num(if v == 0.0 { 0.0 } else { v })
}

fn is_int(v: f64) -> bool {
    v.fract() == 0.0 && v.is_finite()
}

/// Whether the zero set of `u` has measure zero for sure enough to drop `sgn(u)^2`: `u` is
/// not a number and is built from smooth functions only (no abs, sgn, min, max, delta, whose
/// combinations such as `abs(x) − x` vanish on whole half-planes).
fn smooth_nonconstant(u: &Expr) -> bool {
    let mut smooth = true;
    u.walk(&mut |e| {
        if let Expr::Call(Func::Abs | Func::Sgn | Func::Min | Func::Max | Func::Delta, _) = e {
            smooth = false;
        }
    });
    smooth && !u.symbols().is_empty()
}

/// A canonical sum of canonical terms.
fn sum(terms: Vec<Expr>) -> Expr {
    let mut flat = Vec::with_capacity(terms.len());
    for t in terms {
        match t {
            Expr::Add(inner) => flat.extend(inner),
            other => flat.push(other),
        }
    }
    let mut constant = 0.0;
    let mut numbers = Vec::new();
    let mut pairs: Vec<(f64, Expr)> = Vec::new();
    for t in flat {
        match t {
            Expr::Num(v) => {
                constant += v;
                numbers.push(v);
            }
            other => pairs.push(split_coefficient(other)),
        }
    }
    pairs.sort_by(|a, b| cmp(&a.1, &b.1));
    let mut out: Vec<Expr> = Vec::with_capacity(pairs.len() + 1);
    let mut i = 0;
    while i < pairs.len() {
        let mut c = pairs[i].0;
        let mut j = i + 1;
        while j < pairs.len() && cmp(&pairs[i].1, &pairs[j].1) == Ordering::Equal {
            c += pairs[j].0;
            j += 1;
        }
        if !c.is_finite() {
            // Collecting overflowed: keep the terms as they were rather than invent ±∞.
            out.extend(
                pairs[i..j]
                    .iter()
                    .map(|(c, r)| with_coefficient(*c, r.clone())),
            );
        } else if c != 0.0 {
            out.push(with_coefficient(c, pairs[i].1.clone()));
        }
        i = j;
    }
    if constant.is_finite() {
        if constant != 0.0 {
            out.push(number(constant));
        }
    } else {
        out.extend(numbers.into_iter().map(Expr::Num));
    }
    // A sum reads best starting with a positive term: `abs(x) - x` and `1 - r`, not
    // `-x + abs(x)` and `-r + 1`.
    if out.first().is_some_and(is_negative) {
        if let Some(p) = out.iter().position(|t| !is_negative(t)) {
            let t = out.remove(p);
            out.insert(0, t);
        }
    }
    match out.len() {
        0 => Expr::Num(0.0),
        1 => out.pop().expect("one term"),
        _ => Expr::Add(out),
    }
}

fn is_negative(t: &Expr) -> bool {
    match t {
        Expr::Num(c) => *c < 0.0,
        Expr::Mul(fs) => matches!(fs[0], Expr::Num(c) if c < 0.0),
        _ => false,
    }
}

/// Splits a canonical term into its numeric coefficient and the rest.
fn split_coefficient(t: Expr) -> (f64, Expr) {
    match t {
        Expr::Mul(mut fs) if matches!(fs[0], Expr::Num(_)) => {
            let c = fs.remove(0).as_num().expect("number");
            (c, Expr::product(fs))
        }
        other => (1.0, other),
    }
}

/// `c · rest` for a canonical `rest` without a coefficient.
fn with_coefficient(c: f64, rest: Expr) -> Expr {
    if c == 1.0 {
        return rest;
    }
    match rest {
        Expr::Mul(fs) => {
            let mut v = Vec::with_capacity(fs.len() + 1);
            v.push(number(c));
            v.extend(fs);
            Expr::Mul(v)
        }
        other => Expr::Mul(vec![number(c), other]),
    }
}

/// A canonical product of canonical factors.
fn product(factors: Vec<Expr>) -> Expr {
    let mut factors = factors;
    // Each round collects powers of like bases; a round that rewrites a factor into a new shape
    // (sgn(u)^2 -> 1, abs(u)^2 -> u^2, sgn(u)·u -> abs(u)) needs another round to collect it.
    for _ in 0..64 {
        match product_round(factors) {
            Ok(done) => return done,
            Err(again) => factors = again,
        }
    }
    // Each round removes a sign factor or merges a power group, so this is not reached; if it
    // were, the plain product still has the right value.
    Expr::product(factors)
}

/// One collection round: `Ok` with the canonical product, or `Err` with factors to collect again.
fn product_round(factors: Vec<Expr>) -> Result<Expr, Vec<Expr>> {
    let mut flat = Vec::with_capacity(factors.len());
    for f in factors {
        match f {
            Expr::Mul(inner) => flat.extend(inner),
            other => flat.push(other),
        }
    }
    let mut coefficient = 1.0;
    let mut numbers = Vec::new();
    let mut groups: Vec<(Expr, Expr)> = Vec::new();
    for f in flat {
        match f {
            Expr::Num(v) => {
                coefficient *= v;
                numbers.push(v);
            }
            Expr::Pow(b, x) => groups.push((*b, *x)),
            other => groups.push((other, Expr::Num(1.0))),
        }
    }
    if coefficient == 0.0 {
        return Ok(Expr::Num(0.0));
    }
    groups.sort_by(|a, b| cmp(&a.0, &b.0).then_with(|| cmp(&a.1, &b.1)));
    let mut rebuilt: Vec<Expr> = Vec::with_capacity(groups.len());
    let mut reshaped = false;
    let mut i = 0;
    while i < groups.len() {
        let mut j = i + 1;
        while j < groups.len() && cmp(&groups[i].0, &groups[j].0) == Ordering::Equal {
            j += 1;
        }
        let base = groups[i].0.clone();
        let exponent = sum(groups[i..j].iter().map(|g| g.1.clone()).collect());
        let p = power(base.clone(), exponent);
        let same_shape = match &p {
            Expr::Pow(b, _) => cmp(b, &base) == Ordering::Equal,
            Expr::Num(_) | Expr::Mul(_) => false,
            other => cmp(other, &base) == Ordering::Equal,
        };
        reshaped |= !same_shape;
        rebuilt.push(p);
        i = j;
    }
    if !coefficient.is_finite() {
        rebuilt.extend(numbers.into_iter().map(Expr::Num));
        coefficient = 1.0;
    }
    if reshaped || sign_identity(&mut rebuilt) {
        rebuilt.push(number(coefficient));
        return Err(rebuilt);
    }
    rebuilt.sort_by(cmp);
    if rebuilt.is_empty() {
        return Ok(number(coefficient));
    }
    Ok(with_coefficient(coefficient, Expr::product(rebuilt)))
}

/// Applies one of `sgn(u)·|u|^b = u·|u|^(b−1)` and `sgn(u)·u^a = |u|·u^(a−1)` (exact for
/// integers a, b ≥ 1) to collected factors; returns whether it did.
fn sign_identity(factors: &mut [Expr]) -> bool {
    let split = |f: &Expr| match f {
        Expr::Pow(b, x) => ((**b).clone(), (**x).clone()),
        other => (other.clone(), Expr::Num(1.0)),
    };
    for s in 0..factors.len() {
        let Expr::Call(Func::Sgn, args) = &factors[s] else {
            continue;
        };
        let u = args[0].clone();
        let abs_u = Expr::call(Func::Abs, u.clone());
        for k in 0..factors.len() {
            let (base, x) = split(&factors[k]);
            let Some(a) = x.as_num().filter(|a| is_int(*a) && *a >= 1.0) else {
                continue;
            };
            let replacement = if cmp(&base, &abs_u) == Ordering::Equal {
                u.clone()
            } else if cmp(&base, &u) == Ordering::Equal {
                abs_u.clone()
            } else {
                continue;
            };
            factors[k] = power(base, Expr::Num(a - 1.0));
            factors[s] = replacement;
            return true;
        }
    }
    false
}

/// The canonical form of `b^x` for canonical `b`, `x`.
fn power(b: Expr, x: Expr) -> Expr {
    let n = x.as_num();
    match (n, &b) {
        (Some(0.0), _) => return Expr::Num(1.0),
        (Some(1.0), _) => return b,
        (Some(n), Expr::Num(v)) => {
            let r = powf(*v, n);
            return if r.is_finite() {
                number(r)
            } else {
                Expr::pow(b, x)
            };
        }
        (_, Expr::Num(v)) if *v == 1.0 => return Expr::Num(1.0),
        _ => {}
    }
    if let Expr::Call(Func::Exp, args) = &b {
        // exp(u)^x = exp(x·u): exp is positive, so this holds for every x.
        return call(Func::Exp, vec![product(vec![x, args[0].clone()])]);
    }
    let Some(n) = n.filter(|n| is_int(*n)) else {
        return Expr::pow(b, x);
    };
    match b {
        Expr::Mul(fs) => product(fs.into_iter().map(|f| power(f, Expr::Num(n))).collect()),
        Expr::Pow(inner, e1) => power(*inner, product(vec![*e1, Expr::Num(n)])),
        Expr::Call(Func::Sgn, args) if n > 0.0 => {
            if n % 2.0 != 0.0 {
                Expr::Call(Func::Sgn, args)
            } else if smooth_nonconstant(&args[0]) {
                Expr::Num(1.0)
            } else {
                Expr::pow(Expr::Call(Func::Sgn, args), Expr::Num(2.0))
            }
        }
        Expr::Call(Func::Abs, args) if n % 2.0 == 0.0 => {
            power(args.into_iter().next().expect("one argument"), Expr::Num(n))
        }
        other => Expr::pow(other, Expr::Num(n)),
    }
}

/// The canonical form of a call with canonical arguments.
fn call(f: Func, args: Vec<Expr>) -> Expr {
    if args.len() != f.arity() {
        return Expr::Call(f, args);
    }
    if f != Func::Delta && args.iter().all(|a| a.as_num().is_some()) {
        let e = Expr::Call(f, args);
        return match e.eval(&|_| None) {
            Ok(v) if v.is_finite() => number(v),
            _ => e,
        };
    }
    let mut args = args;
    let u = args.remove(0);
    match (f, u) {
        (Func::Abs, Expr::Call(Func::Abs, w)) => Expr::Call(Func::Abs, w),
        (Func::Abs, Expr::Call(Func::Sgn, w)) => power(Expr::Call(Func::Sgn, w), Expr::Num(2.0)),
        (Func::Abs, Expr::Mul(fs)) => {
            product(fs.into_iter().map(|g| call(Func::Abs, vec![g])).collect())
        }
        (Func::Abs, Expr::Pow(w, x)) => match x.as_num() {
            Some(n) if is_int(n) && n % 2.0 == 0.0 => Expr::Pow(w, x),
            Some(n) if is_int(n) => power(call(Func::Abs, vec![*w]), *x),
            // A real non-integer power is non-negative wherever it is defined.
            Some(_) => Expr::Pow(w, x),
            None => Expr::call(Func::Abs, Expr::Pow(w, x)),
        },
        (Func::Abs, e @ Expr::Call(Func::Exp | Func::Sqrt, _)) => e,
        (Func::Sgn, Expr::Call(Func::Sgn, w)) => Expr::Call(Func::Sgn, w),
        // |w| > 0 exactly where w ≠ 0.
        (Func::Sgn, Expr::Call(Func::Abs, w)) => power(Expr::Call(Func::Sgn, w), Expr::Num(2.0)),
        (Func::Sgn, Expr::Call(Func::Exp, _)) => Expr::Num(1.0),
        (Func::Sgn, Expr::Mul(fs)) => {
            product(fs.into_iter().map(|g| call(Func::Sgn, vec![g])).collect())
        }
        (Func::Sgn, Expr::Pow(w, x)) => match x.as_num() {
            Some(n) if is_int(n) => power(call(Func::Sgn, vec![*w]), Expr::Num(n.abs())),
            _ => Expr::call(Func::Sgn, Expr::Pow(w, x)),
        },
        // δ(c·w) = δ(w)/|c|.
        (Func::Delta, Expr::Mul(mut fs)) if matches!(fs[0], Expr::Num(c) if c != 0.0) => {
            let c = fs.remove(0).as_num().expect("number");
            product(vec![
                number(1.0 / c.abs()),
                Expr::call(Func::Delta, Expr::product(fs)),
            ])
        }
        (Func::Log, Expr::Call(Func::Exp, w)) => w.into_iter().next().expect("one argument"),
        (Func::Sqrt, Expr::Pow(w, x)) if x.as_num() == Some(2.0) => call(Func::Abs, vec![*w]),
        (Func::Min | Func::Max, u) if cmp(&u, &args[0]) == Ordering::Equal => u,
        (f, u) => {
            let mut all = vec![u];
            all.extend(args);
            Expr::Call(f, all)
        }
    }
}

/// The stable order of canonical forms: products compare as their factor lists, a power
/// `b^x` as the pair `(b, x)` with a plain factor `b` being `(b, 1)`, so that `x < x*y < x^2 < y`;
/// otherwise numbers < symbols < calls < sums.
pub(crate) fn cmp(a: &Expr, b: &Expr) -> Ordering {
    const ONE: Expr = Expr::Num(1.0);
    match (a, b) {
        (Expr::Mul(fa), Expr::Mul(fb)) => lex(fa, fb),
        (Expr::Mul(fa), _) => lex(fa, std::slice::from_ref(b)),
        (_, Expr::Mul(fb)) => lex(std::slice::from_ref(a), fb),
        (Expr::Pow(ba, xa), Expr::Pow(bb, xb)) => cmp(ba, bb).then_with(|| cmp(xa, xb)),
        (Expr::Pow(ba, xa), _) => cmp(ba, b).then_with(|| cmp(xa, &ONE)),
        (_, Expr::Pow(bb, xb)) => cmp(a, bb).then_with(|| cmp(&ONE, xb)),
        (Expr::Num(x), Expr::Num(y)) => x.total_cmp(y),
        (Expr::Sym(x), Expr::Sym(y)) => x.cmp(y),
        (Expr::Call(f, xs), Expr::Call(g, ys)) => f.cmp(g).then_with(|| lex(xs, ys)),
        (Expr::Add(xs), Expr::Add(ys)) => lex(xs, ys),
        _ => rank(a).cmp(&rank(b)),
    }
}

fn rank(e: &Expr) -> u8 {
    match e {
        Expr::Num(_) => 0,
        Expr::Sym(_) => 1,
        Expr::Call(..) => 2,
        Expr::Pow(..) => 3,
        Expr::Mul(_) => 4,
        Expr::Add(_) => 5,
    }
}

fn lex(a: &[Expr], b: &[Expr]) -> Ordering {
    for (x, y) in a.iter().zip(b) {
        match cmp(x, y) {
            Ordering::Equal => {}
            other => return other,
        }
    }
    a.len().cmp(&b.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn x() -> Expr {
        Expr::sym("x")
    }
    fn y() -> Expr {
        Expr::sym("y")
    }
    fn n(v: f64) -> Expr {
        Expr::num(v)
    }
    fn pow(b: Expr, e: f64) -> Expr {
        Expr::pow(b, n(e))
    }
    fn sgn(u: Expr) -> Expr {
        Expr::call(Func::Sgn, u)
    }
    fn abs(u: Expr) -> Expr {
        Expr::call(Func::Abs, u)
    }
    fn s(e: &Expr) -> String {
        simplify(e).to_string()
    }

    #[test]
    fn neutral_and_absorbing_elements() {
        assert_eq!(s(&(x() + n(0.0))), "x");
        assert_eq!(s(&(x() * n(1.0))), "x");
        assert_eq!(s(&(x() * n(0.0) + y())), "y");
        assert_eq!(s(&pow(x(), 1.0)), "x");
        assert_eq!(s(&pow(x(), 0.0)), "1");
        assert_eq!(s(&(n(2.0) * n(3.0) + n(1.0))), "7");
        assert_eq!(s(&(x() - x())), "0");
        assert_eq!(s(&(x() / x())), "1");
    }

    #[test]
    fn folding_never_invents_nan_or_inf() {
        assert_eq!(s(&pow(n(0.0), -1.0)), "0^(-1)");
        assert_eq!(s(&Expr::call(Func::Log, n(-1.0))), "log(-1)");
        assert_eq!(s(&Expr::call(Func::Sqrt, n(-4.0))), "sqrt(-4)");
        assert_eq!(s(&(n(1e300) * n(1e300) * x())), "1e300*1e300*x");
    }

    #[test]
    fn collects_terms_and_powers_with_coefficient_first() {
        assert_eq!(s(&(n(2.0) * x() * y() + n(3.0) * y() * x())), "5*x*y");
        assert_eq!(s(&(x() * pow(x(), 2.0))), "x^3");
        assert_eq!(s(&(y() * n(2.0) * x() * x())), "2*x^2*y");
        assert_eq!(s(&(pow(x() * y(), 2.0) * pow(x(), -1.0))), "x*y^2");
        assert_eq!(s(&pow(pow(x(), 2.0), 3.0)), "x^6");
        // Not collected across a non-integer outer exponent: (x^2)^0.5 is |x|, not x.
        assert_eq!(s(&pow(pow(x(), 2.0), 0.5)), "(x^2)^0.5");
        // The order does not depend on the input order.
        let a = simplify(&(y() + x() * y() + pow(x(), 2.0) + x() + n(1.0)));
        let b = simplify(&(n(1.0) + x() + pow(x(), 2.0) + x() * y() + y()));
        assert_eq!(a, b);
        assert_eq!(a.to_string(), "x + x*y + x^2 + y + 1");
    }

    #[test]
    fn sign_and_abs_identities() {
        assert_eq!(s(&pow(sgn(x()), 2.0)), "1");
        assert_eq!(s(&pow(sgn(x()), 4.0)), "1");
        assert_eq!(s(&pow(sgn(x()), 3.0)), "sgn(x)");
        assert_eq!(s(&(sgn(x()) * abs(x()))), "x");
        assert_eq!(s(&(x() * sgn(x()))), "abs(x)");
        assert_eq!(s(&(y() * abs(y()) * sgn(y()))), "y^2");
        assert_eq!(s(&pow(abs(x()), 2.0)), "x^2");
        assert_eq!(s(&(abs(x()) * abs(x()))), "x^2");
        assert_eq!(s(&abs(abs(x()))), "abs(x)");
        assert_eq!(s(&sgn(sgn(x()))), "sgn(x)");
        assert_eq!(s(&abs(n(-3.0) * x())), "3*abs(x)");
        assert_eq!(s(&sgn(n(-3.0) * x())), "-sgn(x)");
        assert_eq!(s(&abs(-x())), "abs(x)");
        assert_eq!(s(&sgn(-x())), "-sgn(x)");
        assert_eq!(s(&(sgn(x() - n(0.3)) * (x() - n(0.3)))), "abs(x - 0.3)");
        // sgn(u)^2 = 1 only where u vanishes on a null set: not for u = abs(x) - x.
        let u = abs(x()) - x();
        assert_eq!(s(&pow(sgn(u), 2.0)), "sgn(abs(x) - x)^2");
    }

    #[test]
    fn paper_coefficients_read_as_in_eq_13() {
        // {sgn(x1) + eps x1}^2 = 1 + 2 eps |x1| + eps^2 x1^2 (Eq. 12 to Eq. 13).
        let e = pow(sgn(x()) + Expr::sym("eps") * x(), 2.0);
        assert_eq!(expand(&e).to_string(), "2*eps*abs(x) + eps^2*x^2 + 1");
        // (1 - r) x2 sgn(x2) = (1 - r)|x2|.
        let r = Expr::sym("r");
        let e = (n(1.0) - r) * y() * sgn(y());
        assert_eq!(expand(&e).to_string(), "abs(y) - r*abs(y)");
    }

    #[test]
    fn expand_distributes() {
        let e = (x() + y()) * (x() - y());
        assert_eq!(expand(&e).to_string(), "x^2 - y^2");
        let e = pow(x() + n(1.0), 3.0);
        assert_eq!(expand(&e).to_string(), "3*x + 3*x^2 + x^3 + 1");
        // Negative powers of sums stay.
        let e = pow(x() + n(1.0), -1.0) * (x() + n(1.0));
        assert_eq!(expand(&e).to_string(), "1");
    }

    #[test]
    fn delta_scaling() {
        let d = Expr::call(Func::Delta, n(-2.0) * x());
        assert_eq!(s(&d), "0.5*delta(x)");
    }
}
