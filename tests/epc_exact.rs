//! EPC against exact stationary densities, and the vibro-impact operator of the paper (Eq. 13).

use approx::assert_relative_eq;
use fpsolve::epc::{Epc, EpcError, NormalisationKind};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::DeltaTreatment;
use fpsolve::symbolic::{DeltaLine, DeltaSplit, Expr, Func};

fn n(v: f64) -> Expr {
    Expr::num(v)
}
fn z() -> Expr {
    Expr::sym("z")
}
fn v() -> Expr {
    Expr::sym("v")
}
fn reg(e: Expr) -> DeltaSplit {
    DeltaSplit {
        regular: e,
        lines: vec![],
    }
}
fn abs(e: Expr) -> Expr {
    Expr::call(Func::Abs, e)
}

/// The paper's Eq. 13 operator (states z, v): c, k, μ, 2πK, r, ε.
fn vibro_impact(c: f64, k: f64, mu: f64, two_pi_k: f64, r: f64, eps: f64) -> FpkOperator {
    let pk = 0.5 * two_pi_k;
    let z3 = Expr::pow(z(), n(3.0));
    let b_vv = n(pk) * (n(1.0) + n(2.0 * eps) * abs(z()) + n(eps * eps) * Expr::pow(z(), n(2.0)));
    let line = |w: Expr| DeltaLine {
        axis: 0,
        at: 0.0,
        weight: w,
    };
    let lines_a0 = if r < 1.0 {
        vec![line(n(2.0 * (1.0 - r)) * abs(v()))]
    } else {
        vec![]
    };
    let lines_av = if r < 1.0 {
        vec![line(n(1.0 - r) * v() * abs(v()))]
    } else {
        vec![]
    };
    FpkOperator {
        states: ["z".into(), "v".into()],
        drift: [v(), n(-c) * v() - n(k) * z() - n(mu) * z3.clone()],
        wong_zakai: [n(0.0), n(0.0)],
        diffusion: [[n(0.0), n(0.0)], [n(0.0), n(2.0) * b_vv.clone()]],
        a0: DeltaSplit {
            regular: n(c),
            lines: lines_a0,
        },
        a: [
            reg(-v()),
            DeltaSplit {
                regular: n(c) * v() + n(k) * z() + n(mu) * z3,
                lines: lines_av,
            },
        ],
        b: [[reg(n(0.0)), reg(n(0.0))], [reg(n(0.0)), reg(b_vv)]],
    }
}

/// ẍ + β(1+εx)²ẋ + x + μx³ = (1+εx)ξ (Itô form as given): m_v = −β(1+εx)²v − x − μx³,
/// b_vv = 2πK(1+εx)².
fn parametric(beta: f64, eps: f64, mu: f64, two_pi_k: f64) -> FpkOperator {
    let s2 = Expr::pow(n(1.0) + n(eps) * z(), n(2.0));
    let m_v = n(-beta) * s2.clone() * v() - z() - n(mu) * Expr::pow(z(), n(3.0));
    let b = n(two_pi_k) * s2.clone();
    // A0 = −∂_v m_v + ½∂_v²b = β(1+εx)², A_z = −v, A_v = −m_v, B_vv = b/2.
    FpkOperator {
        states: ["z".into(), "v".into()],
        drift: [v(), m_v.clone()],
        wong_zakai: [n(0.0), n(0.0)],
        diffusion: [[n(0.0), n(0.0)], [n(0.0), b.clone()]],
        a0: reg(n(beta) * s2.clone()),
        a: [reg(-v()), reg(-m_v)],
        b: [[reg(n(0.0)), reg(n(0.0))], [reg(n(0.0)), reg(n(0.5) * b)]],
    }
}

#[test]
fn duffing_degree_4_is_exact() {
    for mu in [0.1, 1.0] {
        let (c, k) = (0.1, 1.0);
        let fpk = vibro_impact(c, k, mu, 1.0, 1.0, 0.0);
        let sol = Epc::new(&fpk, DeltaTreatment::Exact)
            .degree(4)
            .solve()
            .unwrap();
        let f = c / 0.5; // c/(πK)
        assert_relative_eq!(sol.coefficient(0, 2), -f / 2.0, max_relative = 1e-8);
        assert_relative_eq!(sol.coefficient(2, 0), -f * k / 2.0, max_relative = 1e-8);
        assert_relative_eq!(sol.coefficient(4, 0), -f * mu / 4.0, max_relative = 1e-8);
        for (e, a) in sol.exponents.iter().zip(&sol.coefficients) {
            if ![(0, 2), (2, 0), (4, 0)].contains(e) {
                assert!(a.abs() < 1e-9, "{e:?}: {a}");
            }
        }
        assert!(matches!(
            sol.normalisation.kind,
            NormalisationKind::Plane { .. }
        ));
        assert!(sol.fpk_residual < 1e-8, "{}", sol.fpk_residual);
        // Velocity is exactly Gaussian with variance πK/c.
        assert_relative_eq!(sol.moments[1].variance, 5.0, max_relative = 1e-8);
    }
}

#[test]
fn parametric_class_is_exact_at_degrees_4_and_6() {
    let (beta, eps, mu, tpk) = (0.2, 0.3, 0.5, 1.0);
    let fpk = parametric(beta, eps, mu, tpk);
    let f = beta / (0.5 * tpk);
    for r in Epc::new(&fpk, DeltaTreatment::Exact)
        .solve_degrees(&[2, 4, 6])
        .into_iter()
        .skip(1)
    {
        let sol = r.unwrap();
        assert_relative_eq!(sol.coefficient(0, 2), -f / 2.0, max_relative = 1e-7);
        assert_relative_eq!(sol.coefficient(2, 0), -f / 2.0, max_relative = 1e-7);
        assert_relative_eq!(sol.coefficient(4, 0), -f * mu / 4.0, max_relative = 1e-7);
        assert!(sol.coefficient(1, 1).abs() < 1e-8);
        assert!(sol.coefficient(3, 0).abs() < 1e-8);
    }
}

#[test]
fn linear_oscillator_degree_2_is_the_exact_gaussian() {
    let (c, k) = (0.3, 2.0);
    let fpk = vibro_impact(c, k, 0.0, 1.0, 1.0, 0.0);
    let sol = Epc::new(&fpk, DeltaTreatment::Exact)
        .degree(2)
        .solve()
        .unwrap();
    assert_relative_eq!(sol.moments[0].variance, 0.5 / (c * k), max_relative = 1e-8);
    assert_relative_eq!(sol.moments[1].variance, 0.5 / c, max_relative = 1e-8);
    let cl = sol.closure.as_ref().unwrap();
    assert_relative_eq!(cl.covariance[0][0], 0.5 / (c * k), max_relative = 1e-10);
    assert!(cl.covariance[0][1].abs() < 1e-10);
    // Normalisation: the density at the mode is 1/(2π σ1 σ2).
    let s = [(0.5 / (c * k)).sqrt(), (0.5 / c).sqrt()];
    assert_relative_eq!(
        sol.pdf(0.0, 0.0),
        1.0 / (std::f64::consts::TAU * s[0] * s[1]),
        max_relative = 1e-8
    );
    assert_relative_eq!(sol.tail_probability(1, 0.0), 1.0, max_relative = 1e-6);
}

#[test]
fn vibro_impact_degree_2_is_the_closure_and_degree_4_improves() {
    let fpk = vibro_impact(0.1, 1.0, 0.1, 1.0, 0.95, 0.1);
    let res = Epc::new(&fpk, DeltaTreatment::Exact).solve_degrees(&[2, 4]);
    let s2 = res[0].as_ref().unwrap();
    let cl = s2.closure.as_ref().unwrap();
    // Zero mean, uncorrelated closure; EPC-2 with its weights is the closure Gaussian.
    assert!(cl.mean[0].abs() < 1e-10 && cl.mean[1].abs() < 1e-10);
    assert!(cl.covariance[0][1].abs() < 1e-10);
    assert_relative_eq!(
        s2.coefficient(2, 0),
        -0.5 / cl.covariance[0][0],
        max_relative = 1e-9
    );
    assert_relative_eq!(
        s2.coefficient(0, 2),
        -0.5 / cl.covariance[1][1],
        max_relative = 1e-9
    );
    assert!(s2.coefficient(1, 1).abs() < 1e-10);
    let s4 = res[1].as_ref().unwrap();
    assert!(
        s4.fpk_residual < 0.8 * s2.fpk_residual,
        "{} vs {}",
        s4.fpk_residual,
        s2.fpk_residual
    );
}

#[test]
fn regulariser_converges_to_the_exact_treatment() {
    let fpk = vibro_impact(0.1, 1.0, 0.1, 1.0, 0.95, 0.1);
    let exact = Epc::new(&fpk, DeltaTreatment::Exact)
        .degree(2)
        .solve()
        .unwrap();
    let mut last = f64::INFINITY;
    for w in [0.3, 0.1, 0.03, 0.01] {
        let s = Epc::new(&fpk, DeltaTreatment::Gaussian { width: w })
            .degree(2)
            .solve()
            .unwrap();
        let err = exact
            .coefficients
            .iter()
            .zip(&s.coefficients)
            .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(err < last, "width {w}: {err} !< {last}");
        last = err;
    }
    assert!(last < 1e-3, "{last}");
}

#[test]
fn bad_inputs_are_typed_errors() {
    let fpk = vibro_impact(0.1, 1.0, 0.1, 1.0, 0.95, 0.1);
    assert!(matches!(
        Epc::new(&fpk, DeltaTreatment::Exact).degree(1).solve(),
        Err(EpcError::Degree { .. })
    ));
    assert!(matches!(
        Epc::new(&fpk, DeltaTreatment::Exact)
            .weights([Some(-1.0), None])
            .solve(),
        Err(EpcError::Weight { .. })
    ));
}
