//! The PDFs of the original oscillator's displacement and velocity (Eqs. 25 and 28), computed
//! from an EPC solution, against direct 2-D integration of the same joint PDF.
//!
//! For bins [a, b]: ∫_a^b p_Y(y) dy must equal P(a < |z| < b) = ∬ p over {a < |z| < b}, and
//! ∫_a^b p_Ẏ(u) du must equal P(a < v·sgn(z) < b) = ∬_{z>0, a<v<b} p + ∬_{z<0, −b<v<−a} p.

use std::path::Path;

use fpsolve::epc::{Epc, EpcSolution};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, Override};
use fpsolve::observe::{integrate, observable_pdf, JointDensity, ObservableMap};

fn solve(mu: f64, eps: f64) -> (EpcSolution, Vec<ObservableMap>) {
    let model = load_model(Path::new("models/vibro_duffing.sde")).unwrap();
    let bound = model
        .bind(&[Override::number("mu", mu), Override::number("eps", eps)])
        .unwrap();
    let fpk = FpkOperator::derive(&bound).unwrap();
    let sol = Epc::new(&fpk, bound.delta_treatment())
        .degree(4)
        .solve()
        .unwrap();
    let maps = bound
        .observables()
        .iter()
        .map(|o| ObservableMap::classify(&o.expr, bound.states()))
        .collect();
    (sol, maps)
}

/// ∬ p over the rectangle [z0, z1] × [v0, v1] by nested adaptive quadrature.
fn rect(sol: &EpcSolution, z: [f64; 2], v: [f64; 2]) -> f64 {
    let inner = |zz: f64| integrate(&|vv: f64| sol.pdf(zz, vv), v[0], v[1], 1e-9);
    integrate(&inner, z[0], z[1], 1e-9)
}

fn check_case(mu: f64, eps: f64) {
    let (sol, maps) = solve(mu, eps);
    let [[z_lo, z_hi], [v_lo, v_hi]] = JointDensity::extent(&sol);
    let (y_map, ydot_map) = (&maps[0], &maps[1]);
    assert!(matches!(y_map, ObservableMap::SignedState { state: 0, .. }));
    assert!(matches!(
        ydot_map,
        ObservableMap::SignedState { state: 1, .. }
    ));
    let sz = sol.moments[0].variance.sqrt();
    let sv = sol.moments[1].variance.sqrt();
    for k in 0..6 {
        // Eq. 25: bins of y from the barrier out to the tail.
        let (a, b) = (k as f64 * 0.7 * sz, (k + 1) as f64 * 0.7 * sz);
        let by_eq25 = integrate(&|y: f64| observable_pdf(&sol, y_map, &[y])[0], a, b, 1e-10);
        let direct = rect(&sol, [a, b], [v_lo, v_hi]) + rect(&sol, [-b, -a], [v_lo, v_hi]);
        assert!(
            (by_eq25 - direct).abs() <= 1e-6 * direct,
            "mu={mu} eps={eps} y in [{a:.2}, {b:.2}]: Eq. 25 gives {by_eq25:e}, 2-D {direct:e}"
        );
        // Eq. 28: bins of ydot on both sides.
        for sign in [-1.0, 1.0] {
            let (a, b) = if sign > 0.0 {
                (a * sv / sz, b * sv / sz)
            } else {
                (-b * sv / sz, -a * sv / sz)
            };
            let by_eq28 = integrate(
                &|u: f64| observable_pdf(&sol, ydot_map, &[u])[0],
                a,
                b,
                1e-10,
            );
            let direct = rect(&sol, [0.0, z_hi], [a, b]) + rect(&sol, [z_lo, 0.0], [-b, -a]);
            assert!(
                (by_eq28 - direct).abs() <= 1e-6 * direct,
                "mu={mu} eps={eps} ydot in [{a:.2}, {b:.2}]: Eq. 28 gives {by_eq28:e}, 2-D {direct:e}"
            );
        }
    }
    // Both observable densities integrate to one.
    let total_y = integrate(
        &|y: f64| observable_pdf(&sol, y_map, &[y])[0],
        0.0,
        z_hi.max(-z_lo),
        1e-10,
    );
    assert!((total_y - 1.0).abs() < 1e-6, "∫p_Y = {total_y}");
}

#[test]
fn eqs_25_and_28_agree_with_direct_integration_case_2() {
    // Case 2 of Table 1: degree 4 is normalisable on the whole plane.
    check_case(0.1, -0.1);
}

#[test]
fn eqs_25_and_28_agree_with_direct_integration_case_1() {
    // Case 1: degree 4 is normalised inside its ridge; the density is cut there.
    check_case(0.1, 0.1);
}
