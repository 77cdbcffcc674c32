use super::*;
use crate::symbolic::Func;
use approx::assert_relative_eq;

fn z() -> Expr {
    Expr::sym("z")
}
fn v() -> Expr {
    Expr::sym("v")
}
fn n(x: f64) -> Expr {
    Expr::num(x)
}
fn pow(b: Expr, e: f64) -> Expr {
    Expr::pow(b, n(e))
}

fn eval1(t: &Tape, x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; t.n_outputs()];
    t.eval(x, &mut Vec::new(), &mut out);
    out
}

#[test]
fn integer_powers_are_multiplications_exact_for_negative_bases() {
    let t = Tape::compile(
        &[pow(z(), 3.0), pow(z(), -2.0)],
        &["z"],
        DeltaPolicy::Reject,
    )
    .unwrap();
    assert!(!t
        .ops
        .iter()
        .any(|op| matches!(op, Op::Pow(..) | Op::PowC(..))));
    assert_eq!(eval1(&t, &[-2.0]), [-8.0, 0.25]);
    // 0^-2 is +inf, as in Expr::eval, not NaN.
    assert_eq!(eval1(&t, &[0.0])[1], f64::INFINITY);
}

#[test]
fn non_integer_powers_keep_powf_and_sqrt() {
    let t = Tape::compile(
        &[pow(z(), 0.5), pow(z(), 1.5), Expr::pow(z(), v())],
        &["z", "v"],
        DeltaPolicy::Reject,
    )
    .unwrap();
    let out = eval1(&t, &[4.0, 3.0]);
    assert_relative_eq!(out[0], 2.0);
    assert_relative_eq!(out[1], 8.0);
    assert_relative_eq!(out[2], 64.0);
    // A variable integer exponent on a negative base stays exact.
    assert_eq!(eval1(&t, &[-2.0, 3.0])[2], -8.0);
}

#[test]
fn constants_are_folded_and_subexpressions_shared() {
    // (2*3)*z + sin(z)*z + z*sin(z): one sin, one product, shared by both outputs.
    let s = Expr::call(Func::Sin, z());
    let e1 = n(2.0) * n(3.0) * z() + s.clone() * z() + z() * s.clone();
    let e2 = s.clone() * z();
    let t = Tape::compile(&[e1, e2], &["z"], DeltaPolicy::Reject).unwrap();
    let sins = t
        .ops
        .iter()
        .filter(|op| matches!(op, Op::Unary(Unary::Sin, _)))
        .count();
    assert_eq!(sins, 1);
    let muls = t.ops.iter().filter(|op| matches!(op, Op::Mul(..))).count();
    assert_eq!(muls, 1);
    assert!(t
        .ops
        .iter()
        .any(|op| matches!(op, Op::MulC(_, c) if *c == 6.0)));
    assert!(!t.ops.iter().any(|op| matches!(op, Op::Const(_))));
    let out = eval1(&t, &[0.7]);
    assert_relative_eq!(
        out[0],
        6.0 * 0.7 + 2.0 * 0.7 * 0.7f64.sin(),
        epsilon = 1e-15
    );
    assert_relative_eq!(out[1], 0.7 * 0.7f64.sin(), epsilon = 1e-15);
}

#[test]
fn sgn_of_zero_is_zero() {
    let t = Tape::compile(&[Expr::call(Func::Sgn, z())], &["z"], DeltaPolicy::Reject).unwrap();
    assert_eq!(eval1(&t, &[0.0]), [0.0]);
    assert_eq!(eval1(&t, &[-1e-300]), [-1.0]);
}

#[test]
fn delta_policies() {
    let e = Expr::call(Func::Delta, z() - n(0.5));
    assert!(matches!(
        Tape::compile(std::slice::from_ref(&e), &["z"], DeltaPolicy::Reject),
        Err(SymbolicError::DeltaRejected { .. })
    ));
    let t = Tape::compile(std::slice::from_ref(&e), &["z"], DeltaPolicy::Zero).unwrap();
    assert_eq!(eval1(&t, &[0.5]), [0.0]);
    assert_eq!(t.len(), 1);
    let w = 0.2;
    let t = Tape::compile(
        std::slice::from_ref(&e),
        &["z"],
        DeltaPolicy::Gaussian { width: w },
    )
    .unwrap();
    let expected =
        (-0.5f64 * (0.3 / w) * (0.3 / w)).exp() / (w * (2.0 * std::f64::consts::PI).sqrt());
    assert_relative_eq!(eval1(&t, &[0.8])[0], expected, max_relative = 1e-14);
    assert_eq!(
        Tape::compile(&[e], &["z"], DeltaPolicy::Gaussian { width: 0.0 }),
        Err(SymbolicError::BadDeltaWidth { width: 0.0 })
    );
}

#[test]
fn unbound_symbols_are_named() {
    let e = z() * Expr::sym("mu");
    assert_eq!(
        Tape::compile(&[e], &["z"], DeltaPolicy::Reject),
        Err(SymbolicError::Unbound("mu".into()))
    );
}

#[test]
fn non_finite_constants_are_errors() {
    let e = z() + Expr::call(Func::Log, n(-1.0));
    assert!(matches!(
        Tape::compile(&[e], &["z"], DeltaPolicy::Reject),
        Err(SymbolicError::NotFinite { .. })
    ));
}

#[test]
fn batch_matches_point_evaluation_across_blocks() {
    let drift = n(-0.1) * v() - z() - n(0.1) * pow(z(), 3.0);
    let coef = n(0.5) * pow(Expr::call(Func::Sgn, z()) + n(0.1) * z(), 2.0);
    let t = Tape::compile(&[drift, coef, n(4.0)], &["z", "v"], DeltaPolicy::Reject).unwrap();
    let npts = 3 * BLOCK + 17;
    let zs: Vec<f64> = (0..npts).map(|i| (i as f64 * 0.37).sin() * 3.0).collect();
    let vs: Vec<f64> = (0..npts).map(|i| (i as f64 * 0.11).cos() * 2.0).collect();
    let mut out = vec![vec![0.0; npts]; 3];
    t.eval_batch(&[&zs, &vs], &mut out, &mut TapeScratch::new());
    let mut scratch = Vec::new();
    let mut one = [0.0; 3];
    for p in 0..npts {
        t.eval(&[zs[p], vs[p]], &mut scratch, &mut one);
        for j in 0..3 {
            assert_eq!(out[j][p], one[j], "output {j}, point {p}");
        }
    }
    let mut slices: Vec<&mut [f64]> = out.iter_mut().map(|o| &mut o[..]).collect();
    t.eval_batch(&[&zs, &vs], &mut slices, &mut TapeScratch::new());
}

#[test]
fn agrees_with_tree_walk() {
    let e = n(0.3) * Expr::call(Func::Exp, -pow(z(), 2.0)) + Expr::Call(Func::Max, vec![z(), v()])
        - Expr::Call(Func::Min, vec![z(), n(0.2)]) / (n(1.0) + pow(v(), 2.0))
        + Expr::call(Func::Tanh, v()) * Expr::call(Func::Cos, z())
        + Expr::call(Func::Abs, v()) * Expr::call(Func::Sqrt, pow(z(), 2.0) + n(1.0));
    let t = Tape::compile(std::slice::from_ref(&e), &["z", "v"], DeltaPolicy::Reject).unwrap();
    for &(zv, vv) in &[(0.3, -1.2), (-2.0, 0.5), (1.7, 2.2)] {
        let tree = e.eval(&|s| Some(if s == "z" { zv } else { vv })).unwrap();
        assert_relative_eq!(eval1(&t, &[zv, vv])[0], tree, max_relative = 1e-14);
    }
}
