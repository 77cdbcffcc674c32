//! Properties of the symbolic layer on random expressions: derivatives against central finite
//! differences, simplification and expansion keep values, the tape agrees with the tree walk,
//! and sifting evaluates on the line.

use fpsolve::symbolic::{diff, expand, sift, simplify, DeltaPolicy, Expr, Func, Symbol, Tape};
use proptest::prelude::*;

fn n(v: f64) -> Expr {
    Expr::num(v)
}

fn call(f: Func, u: Expr) -> Expr {
    Expr::call(f, u)
}

/// `abs(u) + 0.5`: a base that keeps log, sqrt, negative and real powers in their domains.
fn positive(u: Expr) -> Expr {
    call(Func::Abs, u) + n(0.5)
}

/// Random expressions over x and y, all functions included, every domain guarded so that the
/// value is finite wherever the arguments are.
fn expr() -> impl Strategy<Value = Expr> {
    let leaf = prop_oneof![
        Just(Expr::sym("x")),
        Just(Expr::sym("y")),
        (-2.0f64..2.0).prop_map(|v| n((v * 100.0).round() / 100.0)),
    ];
    leaf.prop_recursive(4, 24, 2, |inner| {
        prop_oneof![
            (inner.clone(), inner.clone()).prop_map(|(a, b)| a + b),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| a - b),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| a * b),
            (inner.clone(), 2u8..4).prop_map(|(a, k)| Expr::pow(a, n(k as f64))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| a / (Expr::pow(b, n(2.0)) + n(0.5))),
            inner.clone().prop_map(|a| Expr::pow(positive(a), n(-1.5))),
            (inner.clone(), inner.clone())
                .prop_map(|(a, b)| Expr::pow(positive(a), call(Func::Sin, b))),
            inner
                .clone()
                .prop_map(|a| call(Func::Exp, call(Func::Tanh, a))),
            inner.clone().prop_map(|a| call(Func::Log, positive(a))),
            inner.clone().prop_map(|a| call(Func::Sqrt, positive(a))),
            inner.clone().prop_map(|a| call(Func::Sin, a)),
            inner.clone().prop_map(|a| call(Func::Cos, a)),
            inner.clone().prop_map(|a| call(Func::Tanh, a)),
            inner.clone().prop_map(|a| call(Func::Abs, a)),
            inner.clone().prop_map(|a| call(Func::Sgn, a)),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Expr::Call(Func::Min, vec![a, b])),
            (inner.clone(), inner).prop_map(|(a, b)| Expr::Call(Func::Max, vec![a, b])),
        ]
    })
}

fn point() -> impl Strategy<Value = (f64, f64)> {
    (-2.0f64..2.0, -2.0f64..2.0)
}

fn at(e: &Expr, x: f64, y: f64) -> f64 {
    e.eval_with(&|s| Some(if s == "x" { x } else { y }), DeltaPolicy::Zero)
        .expect("only x and y")
}

/// The smallest |argument| of a non-smooth function in `e` at (x, y): how far the point is
/// from a kink or jump.
fn kink_distance(e: &Expr, x: f64, y: f64) -> f64 {
    let mut d = f64::INFINITY;
    e.walk(&mut |s| match s {
        Expr::Call(Func::Abs | Func::Sgn, a) => d = d.min(at(&a[0], x, y).abs()),
        Expr::Call(Func::Min | Func::Max, a) => {
            d = d.min((at(&a[0], x, y) - at(&a[1], x, y)).abs())
        }
        _ => {}
    });
    d
}

/// A bound on the size of the intermediate values of `e` at (x, y): sums of absolute values,
/// so that tolerances allow for the cancellation a reordered sum may expose.
fn magnitude(e: &Expr, x: f64, y: f64) -> f64 {
    match e {
        Expr::Add(ts) => ts.iter().map(|t| magnitude(t, x, y)).sum(),
        Expr::Mul(fs) => fs.iter().map(|f| magnitude(f, x, y)).product(),
        _ => at(e, x, y).abs(),
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    a.is_finite() && b.is_finite() && (a - b).abs() <= tol
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn derivative_matches_central_differences(e in expr(), (x, y) in point(), wrt_y in any::<bool>()) {
        let var = if wrt_y { "y" } else { "x" };
        let h = 1e-5;
        let shifted = |t: f64| if wrt_y { at(&e, x, y + t) } else { at(&e, x + t, y) };
        // Away from kinks only, including those of points the difference quotient uses.
        for t in [-h, 0.0, h] {
            let (px, py) = if wrt_y { (x, y + t) } else { (x + t, y) };
            prop_assume!(kink_distance(&e, px, py) > 1e-3);
        }
        let d = diff(&e, var).expect("no delta in e");
        let exact = at(&d, x, y);
        let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
        let scale = 1.0 + exact.abs() + magnitude(&e, x, y) * 1e-4;
        prop_assert!(
            close(exact, fd, 1e-5 * scale),
            "d/d{var} {e} = {d}: {exact} vs finite difference {fd} at ({x}, {y})"
        );
    }

    #[test]
    fn simplify_and_expand_keep_the_value(e in expr(), (x, y) in point()) {
        prop_assume!(kink_distance(&e, x, y) > 1e-9);
        let v = at(&e, x, y);
        for (name, f) in [("simplify", simplify(&e)), ("expand", expand(&e))] {
            let w = at(&f, x, y);
            let tol = 1e-9 * (1.0 + magnitude(&e, x, y) + magnitude(&f, x, y));
            prop_assert!(close(v, w, tol), "{name}({e}) = {f}: {v} vs {w} at ({x}, {y})");
        }
    }

    #[test]
    fn simplify_is_idempotent(e in expr()) {
        let once = simplify(&e);
        prop_assert_eq!(simplify(&once), once);
    }

    #[test]
    fn tape_agrees_with_tree_walk(es in prop::collection::vec(expr(), 1..4), (x, y) in point()) {
        let tape = Tape::compile(&es, &["x", "y"], DeltaPolicy::Reject).expect("compiles");
        let mut out = vec![0.0; es.len()];
        tape.eval(&[x, y], &mut Vec::new(), &mut out);
        for (e, &t) in es.iter().zip(&out) {
            let v = at(e, x, y);
            let tol = 1e-12 * (v.abs() + magnitude(e, x, y)).max(1e-300);
            prop_assert!(close(v, t, tol) || v == t, "{e}: tree {v} vs tape {t}");
        }
    }

    #[test]
    fn sift_evaluates_on_the_line(g in expr(), y in -2.0f64..2.0) {
        let e = g.clone() * call(Func::Delta, Expr::sym("x") - n(0.3));
        let states: [Symbol; 2] = ["x".into(), "y".into()];
        // g may jump on the line x = 0.3 (a sgn whose argument vanishes there): refused.
        let split = match sift(&e, &states) {
            Ok(s) => s,
            Err(err) => {
                let jumps = format!("{err}").contains("meaningless");
                prop_assert!(jumps, "unexpected error {err} for {e}");
                return Ok(());
            }
        };
        prop_assert_eq!(&split.regular, &n(0.0));
        let expected = at(&g, 0.3, y);
        let got = match split.lines.as_slice() {
            [] => 0.0,
            [l] => {
                prop_assert_eq!((l.axis, l.at), (0, 0.3));
                at(&l.weight, 0.0, y)
            }
            more => return Err(TestCaseError::fail(format!("{} lines", more.len()))),
        };
        prop_assume!(kink_distance(&g, 0.3, y) > 1e-9);
        let tol = 1e-9 * (1.0 + magnitude(&g, 0.3, y));
        prop_assert!(close(expected, got, tol), "{g} on x = 0.3: {expected} vs {got}");
    }
}
