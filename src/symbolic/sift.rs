//! Checking distributional terms and sifting them onto lines.
//!
//! A derived FPK coefficient such as `(1 − r)·v·|v|·δ(z)` (the paper's Eq. 10–13) is a
//! distribution: it only acts under an integral. [`sift`] splits an expression into a regular
//! function plus terms `w(y)·δ(x − x0)`, using δ(a·x + b)·g(x, y) = g(x0, y)·δ(x − x0)/|a| with
//! x0 = −b/a, and refuses the products for which this has no meaning.

use super::{diff, expand, simplify, DeltaLine, DeltaSplit, Expr, Func, Symbol, SymbolicError};

/// Splits `e` into its regular part and its line deltas over the two `states`.
///
/// The expression is expanded, then each term is sorted out: no delta, the term is regular;
/// one `delta(a·x + b)` with a numeric `a ≠ 0` and `b` in exactly one state `x`, the rest of
/// the term `g` is evaluated on the line (`weight = g(x0, y)/|a|`). Lines at the same place are
/// collected and lines with zero weight dropped.
///
/// # Errors
/// - [`SymbolicError::MeaninglessProduct`]: the rest of the term jumps on the line
///   (`δ(z)·sgn(z)`), the delta is squared (`δ(z)·δ(z)`), or a delta sits inside a nonlinear
///   function or a power.
/// - [`SymbolicError::PointMass`]: deltas of both states in one term.
/// - [`SymbolicError::NonLinearDelta`]: the delta's argument is constant, depends on both
///   states, or is not of the form `a·x + b` with numbers `a ≠ 0`, `b`.
/// - [`SymbolicError::SiftFailed`]: the weight is singular on the line (e.g. `δ(z)/z`).
///
/// ```
/// use fpsolve::symbolic::{sift, Expr, Func, Symbol};
/// let (z, v) = (Expr::sym("z"), Expr::sym("v"));
/// let states: [Symbol; 2] = ["z".into(), "v".into()];
/// // The impact damping of Eq. 10 times a smooth function of both states.
/// let e = Expr::num(-0.05) * v.clone() * Expr::call(Func::Abs, v.clone())
///     * Expr::call(Func::Delta, z.clone())
///     * Expr::call(Func::Exp, z.clone() * v.clone())
///     + z.clone();
/// let split = sift(&e, &states).unwrap();
/// assert_eq!(split.regular.to_string(), "z");
/// assert_eq!(split.lines.len(), 1);
/// assert_eq!((split.lines[0].axis, split.lines[0].at), (0, 0.0));
/// assert_eq!(split.lines[0].weight.to_string(), "-0.05*v*abs(v)");
/// // delta(z)·sgn(z) has no meaning.
/// let bad = Expr::call(Func::Delta, z.clone()) * Expr::call(Func::Sgn, z);
/// assert!(sift(&bad, &states).is_err());
/// ```
pub fn sift(e: &Expr, states: &[Symbol; 2]) -> Result<DeltaSplit, SymbolicError> {
    let expanded = expand(e);
    let terms = match expanded {
        Expr::Add(terms) => terms,
        other => vec![other],
    };
    let mut regular = Vec::new();
    let mut lines: Vec<DeltaLine> = Vec::new();
    for term in terms {
        if !term.contains_delta() {
            regular.push(term);
            continue;
        }
        let line = sift_term(&term, states)?;
        match lines
            .iter_mut()
            .find(|l| l.axis == line.axis && l.at == line.at)
        {
            Some(l) => l.weight = simplify(&(l.weight.clone() + line.weight)),
            None => lines.push(line),
        }
    }
    lines.retain(|l| l.weight != Expr::Num(0.0));
    lines.sort_by(|a, b| a.axis.cmp(&b.axis).then(a.at.total_cmp(&b.at)));
    Ok(DeltaSplit {
        regular: simplify(&Expr::sum(regular)),
        lines,
    })
}

/// Sifts one expanded term that contains a delta.
fn sift_term(term: &Expr, states: &[Symbol; 2]) -> Result<DeltaLine, SymbolicError> {
    let factors = match term {
        Expr::Mul(fs) => fs.clone(),
        other => vec![other.clone()],
    };
    let meaningless = || SymbolicError::MeaninglessProduct {
        product: term.to_string(),
    };
    let (deltas, rest): (Vec<Expr>, Vec<Expr>) = factors
        .into_iter()
        .partition(|f| matches!(f, Expr::Call(Func::Delta, _)));
    if rest.iter().any(Expr::contains_delta) {
        // δ^2, exp(δ(z)), 1/(1 + δ(z)), δ inside another delta, ...
        return Err(meaningless());
    }
    let mut located = Vec::with_capacity(deltas.len());
    for d in &deltas {
        if let Expr::Call(_, args) = d {
            located.push(locate(d, &args[0], states)?);
        }
    }
    if located.len() > 1 {
        return Err(if located.iter().any(|l| l.0 != located[0].0) {
            SymbolicError::PointMass {
                term: term.to_string(),
            }
        } else {
            meaningless()
        });
    }
    let Some(&(axis, at, scale)) = located.first() else {
        return Err(meaningless());
    };
    let state = &states[axis];
    let g = Expr::product(rest);
    // g must be continuous across the line: a sgn(w) with w vanishing on the whole line jumps
    // there, and δ times a jump has no value.
    let mut jumps = false;
    g.walk(&mut |e| {
        if let Expr::Call(Func::Sgn, w) = e {
            if w[0].mentions(state)
                && simplify(&w[0].substitute(state, &Expr::num(at))) == Expr::Num(0.0)
            {
                jumps = true;
            }
        }
    });
    if jumps {
        return Err(meaningless());
    }
    let weight = simplify(&(Expr::num(scale) * g.substitute(state, &Expr::num(at))));
    if weight.mentions(state) || has_unfolded_constant(&weight) {
        return Err(SymbolicError::SiftFailed {
            weight: weight.to_string(),
            state: state.clone(),
        });
    }
    Ok(DeltaLine { axis, at, weight })
}

/// For `delta(arg)`: the state index, the line position x0 and the scale 1/|a| of
/// `arg = a·x + b`.
fn locate(
    delta: &Expr,
    arg: &Expr,
    states: &[Symbol; 2],
) -> Result<(usize, f64, f64), SymbolicError> {
    let nonlinear = || SymbolicError::NonLinearDelta {
        expr: delta.to_string(),
    };
    let mentioned: Vec<usize> = (0..2).filter(|&i| arg.mentions(&states[i])).collect();
    let [axis] = mentioned[..] else {
        return Err(nonlinear());
    };
    let state = &states[axis];
    let a = diff(arg, state).map_err(|_| nonlinear())?;
    let b = simplify(&arg.substitute(state, &Expr::num(0.0)));
    match (a.as_num(), b.as_num()) {
        (Some(a), Some(b)) if a != 0.0 && a.is_finite() => Ok((axis, -b / a, 1.0 / a.abs())),
        _ => Err(nonlinear()),
    }
}

/// Whether simplification left a constant subexpression unfolded because it is not finite
/// (`0^(-1)`, `log(0)`): the weight is singular on the line.
fn has_unfolded_constant(e: &Expr) -> bool {
    let mut found = false;
    e.walk(&mut |x| match x {
        Expr::Pow(b, p) if b.as_num().is_some() && p.as_num().is_some() => found = true,
        Expr::Call(_, args) if args.iter().all(|a| a.as_num().is_some()) => found = true,
        _ => {}
    });
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn z() -> Expr {
        Expr::sym("z")
    }
    fn v() -> Expr {
        Expr::sym("v")
    }
    fn n(x: f64) -> Expr {
        Expr::num(x)
    }
    fn delta(u: Expr) -> Expr {
        Expr::call(Func::Delta, u)
    }
    fn states() -> [Symbol; 2] {
        ["z".into(), "v".into()]
    }

    #[test]
    fn paper_impact_term() {
        // A0 of Eq. 13 contains 2 (1 - r)|x2| delta(x1); with r = 0.9 and p's factor exp(Q).
        let q = n(-0.5) * Expr::pow(z(), n(2.0)) - n(0.5) * Expr::pow(v(), n(2.0));
        let e =
            n(0.2) * Expr::call(Func::Abs, v()) * delta(z()) * Expr::call(Func::Exp, q) + n(0.1);
        let s = sift(&e, &states()).unwrap();
        assert_eq!(s.regular, n(0.1));
        assert_eq!(s.lines.len(), 1);
        assert_eq!(s.lines[0].weight.to_string(), "0.2*abs(v)*exp(-0.5*v^2)");
    }

    #[test]
    fn shifted_and_scaled_lines_are_collected() {
        // delta(2v - 1) = delta(v - 0.5)/2; two terms on the same line add up.
        let e = z() * delta(n(2.0) * v() - n(1.0)) + v() * delta(v() - n(0.5));
        let s = sift(&e, &states()).unwrap();
        assert_eq!(s.regular, n(0.0));
        assert_eq!(s.lines.len(), 1);
        let l = &s.lines[0];
        assert_eq!((l.axis, l.at), (1, 0.5));
        assert_eq!(l.weight.to_string(), "0.5*z + 0.5");
        // Sums inside products are expanded first.
        let e = (z() + v()) * (delta(z()) + n(1.0));
        let s = sift(&e, &states()).unwrap();
        assert_eq!(s.regular.to_string(), "v + z");
        assert_eq!(s.lines[0].weight.to_string(), "v");
    }

    #[test]
    fn zero_weights_are_dropped() {
        let e = z() * delta(z()) + Expr::call(Func::Abs, z()) * delta(z());
        assert!(sift(&e, &states()).unwrap().lines.is_empty());
    }

    #[test]
    fn meaningless_products_are_refused() {
        let st = states();
        for e in [
            delta(z()) * Expr::call(Func::Sgn, z()),
            delta(z() - n(1.0)) * Expr::call(Func::Sgn, n(2.0) * z() - n(2.0)),
            delta(z()) * delta(z()),
            Expr::call(Func::Exp, delta(z())),
        ] {
            assert!(
                matches!(sift(&e, &st), Err(SymbolicError::MeaninglessProduct { .. })),
                "{e}"
            );
        }
        // sgn of a different line is fine: it is continuous across z = 0 except at one point.
        let e = delta(z()) * Expr::call(Func::Sgn, v() - z());
        assert_eq!(sift(&e, &st).unwrap().lines[0].weight.to_string(), "sgn(v)");
    }

    #[test]
    fn unsupported_deltas_are_refused() {
        let st = states();
        assert!(matches!(
            sift(&(delta(z()) * delta(v())), &st),
            Err(SymbolicError::PointMass { .. })
        ));
        for e in [
            delta(Expr::pow(z(), n(2.0))),
            delta(z() + v()),
            delta(Expr::sym("k")),
            delta(Expr::call(Func::Sin, z())),
        ] {
            assert!(
                matches!(sift(&e, &st), Err(SymbolicError::NonLinearDelta { .. })),
                "{e}"
            );
        }
        assert!(matches!(
            sift(&(delta(z()) / z()), &st),
            Err(SymbolicError::SiftFailed { .. })
        ));
    }
}
