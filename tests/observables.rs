//! The PDFs of the original oscillator's displacement and velocity (Eqs. 25 and 28), computed
//! from an EPC solution, against direct 2-D integration of the same joint PDF.
//!
//! For bins [a, b]: ∫_a^b p_Y(y) dy must equal P(a < |z| < b) = ∬ p over {a < |z| < b}, and
//! ∫_a^b p_Ẏ(u) du must equal P(a < v·sgn(z) < b) = ∬_{z>0, a<v<b} p + ∬_{z<0, −b<v<−a} p.

use std::path::Path;

use fpsolve::density::JointDensity;
use fpsolve::epc::{Epc, EpcSolution};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, Override};
use fpsolve::observe::{integrate_adaptive as integrate, observable_pdf, ObservableMap};

fn solve(mu: f64, eps: f64) -> (EpcSolution, Vec<ObservableMap>) {
    let model = load_model(Path::new("models/vibro_duffing.sde")).unwrap();
    let bound = model
        .bind(&[Override::number("mu", mu), Override::number("eps", eps)])
        .unwrap();
    let fpk = FpkOperator::derive(&bound).unwrap();
    let sol = Epc::new(&fpk).degree(4).solve().unwrap();
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

// ---------------------------------------------------------------------------------------------
// General observables through the real pipeline (model text → bind → FPK → EPC → observable),
// against exact answers. These failed with the Gaussian-kernel method (energy mean 5.40,
// p(0) = 0.086; E[v²] = 5.94; E[z⁴/4 + v²/2] = 112.6).

use fpsolve::model::parse_model;
use fpsolve::observe::{moments, ObservableDensity};
use fpsolve::study::Study;
use std::f64::consts::PI;

const LINEAR: &str = "model linear
param c = 0.1, k = 1
param K = 1/(2*pi)
state z, v
drift z: v
drift v: -c*v - k*z
noise xi: intensity 2*pi*K
diffusion v: xi
observe energy = v^2/2 + k*z^2/2, vsq = v^2, quart = z^4/4 + v^2/2, zv = z*v, para = z^2 - v
";

const BISTABLE: &str = "model bistable
param c = 1, alpha = 1, beta = 1
param K = 1/(4*pi)
state z, v
drift z: v
drift v: -c*v + alpha*z - beta*z^3
noise xi: intensity 2*pi*K
diffusion v: xi
observe energy = v^2/2 - alpha*z^2/2 + beta*z^4/4
";

/// The EPC solution of degree `n` of a model given as text, and its observables' maps by name.
fn pipeline(text: &str, n: usize) -> (EpcSolution, Vec<(String, ObservableMap)>) {
    let model = parse_model(text, None).unwrap();
    let bound = model.bind(&[]).unwrap();
    let fpk = FpkOperator::derive(&bound).unwrap();
    let sol = Epc::new(&fpk).degree(n).solve().unwrap();
    (sol, maps_by_name(&bound))
}

/// A bound model's observables' maps by name.
fn maps_by_name(bound: &fpsolve::model::BoundModel) -> Vec<(String, ObservableMap)> {
    bound
        .observables()
        .iter()
        .map(|o| {
            (
                o.name.to_string(),
                ObservableMap::classify(&o.expr, bound.states()),
            )
        })
        .collect()
}

fn map<'a>(maps: &'a [(String, ObservableMap)], name: &str) -> &'a ObservableMap {
    &maps.iter().find(|(n, _)| n == name).unwrap().1
}

fn assert_rel(what: &str, got: f64, exact: f64, tol: f64) {
    assert!(
        (got - exact).abs() <= tol * exact.abs(),
        "{what}: {got:e} vs exact {exact:e} (rel {:e})",
        (got - exact).abs() / exact.abs()
    );
}

/// Composite Simpson on [a, b] with n (even) panels.
fn simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn linear_oscillator_energy_is_exponential_with_mean_5() {
    // Var z = Var v = πK/c = 5, independent: energy = v²/2 + z²/2 ~ Exp(mean 5).
    let (sol, maps) = pipeline(LINEAR, 2);
    let energy = map(&maps, "energy");
    assert!(matches!(energy, ObservableMap::General { .. }));
    let u = [0.0, 1e-9, 0.5, 2.0, 5.0, 10.0, 20.0, 40.0];
    let start = std::time::Instant::now();
    let p = ObservableDensity::new(&sol, energy).pdf(&u);
    eprintln!("energy pdf at {} points: {:?}", u.len(), start.elapsed());
    for (u, p) in u.iter().zip(&p) {
        assert_rel(&format!("p_energy({u})"), *p, 0.2 * (-u / 5.0).exp(), 1e-6);
    }
    let m = moments(&sol, energy);
    assert_rel("E[energy]", m.moments.mean, 5.0, 1e-9);
    assert_rel("std energy", m.moments.std_dev(), 5.0, 1e-9);
    assert_rel("kurtosis energy", m.moments.kurtosis, 9.0, 1e-8);
    assert_eq!(m.undefined_mass, 0.0);
}

#[test]
fn linear_oscillator_velocity_squared_is_a_scaled_chi_square() {
    // v ~ N(0, 5): p_{v²}(u) = exp(−u/10)/√(2π·5·u), infinite at 0.
    let (sol, maps) = pipeline(LINEAR, 2);
    let vsq = map(&maps, "vsq");
    let u = [0.01, 0.5, 3.0, 10.0, 40.0];
    let p = ObservableDensity::new(&sol, vsq).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = (-u / 10.0).exp() / (2.0 * PI * 5.0 * u).sqrt();
        assert_rel(&format!("p_vsq({u})"), *p, exact, 1e-6);
    }
    assert_eq!(
        ObservableDensity::new(&sol, vsq).pdf(&[0.0])[0],
        f64::INFINITY
    );
    let m = moments(&sol, vsq);
    assert_rel("E[v²]", m.moments.mean, 5.0, 1e-9);
    assert_rel("E[v⁴]", m.moments.raw[1], 75.0, 1e-9);
}

#[test]
fn linear_oscillator_product_z_v_is_a_bessel_k0_density() {
    // z, v independent N(0, s²), s² = 5: p_{zv}(u) = K0(|u|/s²)/(π s²); two branches.
    let (sol, maps) = pipeline(LINEAR, 2);
    let zv = map(&maps, "zv");
    let k0 = |x: f64| simpson(&|t: f64| (-x * t.cosh()).exp(), 0.0, 12.0, 40000);
    let u = [-20.0, -3.0, 0.5, 2.0, 10.0];
    let p = ObservableDensity::new(&sol, zv).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = k0(u.abs() / 5.0) / (PI * 5.0);
        assert_rel(&format!("p_zv({u})"), *p, exact, 1e-6);
    }
    // The saddle of z·v at the origin: the density is infinite at 0.
    assert_eq!(
        ObservableDensity::new(&sol, zv).pdf(&[0.0])[0],
        f64::INFINITY
    );
}

#[test]
fn linear_oscillator_parabola_z2_minus_v_matches_a_one_dimensional_integral() {
    // p(u) = ∫ p_z(z) p_v(z² − u) dz; the level set v = z² − u has two branches in z.
    let (sol, maps) = pipeline(LINEAR, 2);
    let para = map(&maps, "para");
    let normal = |x: f64| (-x * x / 10.0).exp() / (10.0 * PI).sqrt();
    let u = [-12.0, -2.0, 0.0, 3.0, 10.0, 25.0];
    let p = ObservableDensity::new(&sol, para).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = simpson(
            &|z: f64| normal(z) * normal(z * z - u),
            -25.0,
            25.0,
            200_000,
        );
        assert_rel(&format!("p_para({u})"), *p, exact, 1e-6);
    }
    let m = moments(&sol, para);
    assert_rel("E[z² − v]", m.moments.mean, 5.0, 1e-9);
}

#[test]
fn linear_oscillator_means_through_the_study() {
    let model = parse_model(LINEAR, None).unwrap();
    let study = Study::run(&model, &[], &[2]).unwrap();
    let stats = &study.runs[0].stats;
    let get = |n: &str| stats.iter().find(|s| s.name == n).unwrap();
    assert_rel("E[energy]", get("energy").moments.mean, 5.0, 1e-9);
    assert_rel("E[v²]", get("vsq").moments.mean, 5.0, 1e-9);
    assert_rel("E[z⁴/4 + v²/2]", get("quart").moments.mean, 21.25, 1e-9);
    assert_rel("E[z²]", get("z").moments.raw[1], 5.0, 1e-9);
    assert_rel("E[z⁴]", get("z").moments.raw[3], 75.0, 1e-9);
    // The energy curve starts at 0 with p = 0.2 and integrates to one on its grid.
    let c = study.curves.iter().find(|c| c.name == "energy").unwrap();
    let p = &c.columns[0].pdf;
    assert!(c.x[0].abs() < 1e-9, "energy grid starts at {}", c.x[0]);
    assert_rel(
        "p_energy(0) on the curve",
        p[0],
        0.2 * (-c.x[0] / 5.0).exp(),
        1e-6,
    );
}

/// ∫_{U(z) < u} dz / √(u − U(z)) for U = −z²/2 + z⁴/4, by the substitution that removes the
/// inverse square roots at the turning points (u − U = (z² − r1)(r2 − z²)/4).
fn period_integral(u: f64) -> f64 {
    let s = (1.0 + 4.0 * u).sqrt();
    let (r1, r2) = (1.0 - s, 1.0 + s);
    let n = 4000;
    if u > 0.0 {
        // One interval [−Z, Z]; (Z − z)(Z + z) = Z² sin²θ.
        let zz = r2.sqrt();
        simpson(
            &|t: f64| {
                let z = -zz * t.cos();
                2.0 / (z * z - r1).sqrt()
            },
            0.0,
            PI,
            n,
        )
    } else {
        // Two wells; on [z1, z2]: (z − z1)(z2 − z) = half² sin²θ.
        let (z1, z2) = (r1.sqrt(), r2.sqrt());
        let (mid, half) = (0.5 * (z1 + z2), 0.5 * (z2 - z1));
        2.0 * simpson(
            &|t: f64| {
                let z = mid - half * t.cos();
                2.0 / ((z + z1) * (z + z2)).sqrt()
            },
            0.0,
            PI,
            n,
        )
    }
}

#[test]
fn bistable_duffing_energy_matches_the_period_integral() {
    // p(z, v) = C exp(−4H), H = v²/2 + U(z): p_H(u) = e^{−4u} T(u) / (Z_z σ_v √π), with
    // σ_v = 1/2, Z_z = ∫ e^{−4U} dz, T the period integral ∮ ds/|∇H| written in z.
    let (sol, maps) = pipeline(BISTABLE, 4);
    let energy = map(&maps, "energy");
    let zz = simpson(
        &|z: f64| (-4.0 * (-z * z / 2.0 + z.powi(4) / 4.0)).exp(),
        -5.0,
        5.0,
        20000,
    );
    let exact = |u: f64| (-4.0 * u).exp() * period_integral(u) / (zz * 0.5 * PI.sqrt());
    let u = [-0.24, -0.2, -0.1, -0.02, 0.05, 0.3, 1.0, 3.0];
    let p = ObservableDensity::new(&sol, energy).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        assert_rel(&format!("p_H({u})"), *p, exact(*u), 1e-6);
    }
    // At the wells' value −1/4: the one-sided limit, two wells × p(x*)·2π/√det H, det H = 2.
    let p_star = (1.0f64).exp() / (zz * (PI / 2.0).sqrt());
    let limit = 2.0 * p_star * 2.0 * PI / 2.0f64.sqrt();
    let p0 = ObservableDensity::new(&sol, energy).pdf(&[-0.25])[0];
    assert_rel("p_H(-1/4)", p0, limit, 1e-6);
    // The barrier (saddle) value 0: the density is infinite there.
    assert_eq!(
        ObservableDensity::new(&sol, energy).pdf(&[0.0])[0],
        f64::INFINITY
    );
}

/// The linear model with one extra observable line.
fn linear_with(observe: &str) -> String {
    LINEAR.replace(
        "observe energy = v^2/2 + k*z^2/2, vsq = v^2, quart = z^4/4 + v^2/2, zv = z*v, para = z^2 - v\n",
        &format!("{observe}\n"),
    )
}

#[test]
fn observables_without_a_density_are_refused_at_load_time() {
    for (line, what) in [
        ("observe s = sgn(z)", "takes only discrete values"),
        (
            "observe s = sgn(z)*sgn(v) + 2",
            "takes only discrete values",
        ),
        (
            "observe s = sgn(z) - 3*sgn(v)",
            "takes only discrete values",
        ),
        ("observe q = k*pi", "does not depend on the states"),
        ("observe q = z - z", "does not depend on the states"),
        ("observe d = exp(delta(z))", "contains `delta(...)`"),
    ] {
        let err = parse_model(&linear_with(line), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains(what), "{line}: {err}");
    }
    // Continuous maps with kinks or jumps on a line are fine, and so is log(z) (flagged, below).
    for line in [
        "observe s = sgn(z) + 0.01*z",
        "observe s = abs(z)*sgn(v)",
        "observe l = log(z)",
    ] {
        parse_model(&linear_with(line), None).unwrap_or_else(|e| panic!("{line}: {e}"));
    }
}

#[test]
fn log_of_a_state_reports_its_missing_mass_instead_of_renormalising() {
    // log(z) is undefined for z ≤ 0, half the mass: the PDF integrates to 1/2 and the
    // moments say so; E[log z | z > 0] for z ~ N(0, 5) is ln√5 − (γ + ln 2)/2.
    let (sol, maps) = pipeline(&linear_with("observe l = log(z)"), 2);
    let l = map(&maps, "l");
    let m = moments(&sol, l);
    assert_rel("undefined mass", m.undefined_mass, 0.5, 1e-9);
    let euler_gamma = 0.577_215_664_901_532_9;
    let exact_mean = 0.5 * 5.0f64.ln() - 0.5 * (euler_gamma + 2.0f64.ln());
    assert_rel("E[log z | z > 0]", m.moments.mean, exact_mean, 1e-6);
    // p_l(u) = e^u p_z(e^u): the defective density, not doubled.
    let pz = |z: f64| (-z * z / 10.0).exp() / (10.0 * PI).sqrt();
    let u = [-6.0, -1.0, 0.0, 1.0, 2.0];
    let p = ObservableDensity::new(&sol, l).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        assert_rel(&format!("p_log({u})"), *p, u.exp() * pz(u.exp()), 1e-6);
    }
    let total = integrate(
        &|u: f64| ObservableDensity::new(&sol, l).pdf(&[u])[0],
        -30.0,
        3.5,
        1e-9,
    );
    assert_rel("∫ p_log", total, 0.5, 1e-5);
}

#[test]
fn kinked_and_discontinuous_maps_match_one_dimensional_integrals() {
    // z, v independent N(0, 5). |z| + v: a kink along z = 0, p(u) = ∫_0^∞ 2 φ(y) φ(u − y) dy.
    // v + sgn(z): a jump across z = 0 that is not a root, p(u) = (φ(u − 1) + φ(u + 1))/2.
    let (sol, maps) = pipeline(
        &linear_with("observe kink = abs(z) + v, jump = v + sgn(z)"),
        2,
    );
    let normal = |x: f64| (-x * x / 10.0).exp() / (10.0 * PI).sqrt();
    let (kink, jump) = (map(&maps, "kink"), map(&maps, "jump"));
    assert!(matches!(kink, ObservableMap::General { .. }));
    assert!(matches!(jump, ObservableMap::General { .. }));
    let u = [-8.0, -1.0, 0.0, 0.7, 3.0, 12.0];
    let p = ObservableDensity::new(&sol, kink).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = simpson(
            &|y: f64| 2.0 * normal(y) * normal(u - y),
            0.0,
            30.0,
            100_000,
        );
        assert_rel(&format!("p_kink({u})"), *p, exact, 1e-6);
    }
    let p = ObservableDensity::new(&sol, jump).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = 0.5 * (normal(u - 1.0) + normal(u + 1.0));
        assert_rel(&format!("p_jump({u})"), *p, exact, 1e-6);
    }
    let m = moments(&sol, kink);
    assert_rel("E[|z| + v]", m.moments.mean, (2.0 * 5.0 / PI).sqrt(), 1e-9);
    // A kink off the axes, along z = v: |z − v| + v = u has the roots z = u and z = 2v − u
    // for v < u, so p(u) = ∫_{v<u} φ(v) (φ(u) + φ(2v − u)) dv.
    let (sol, maps) = pipeline(&linear_with("observe diag = abs(z - v) + v"), 2);
    let diag = map(&maps, "diag");
    let u = [-8.0, -2.0, 0.0, 0.7, 3.0, 10.0];
    let p = ObservableDensity::new(&sol, diag).pdf(&u);
    for (u, p) in u.iter().zip(&p) {
        let exact = simpson(
            &|v: f64| normal(v) * (normal(*u) + normal(2.0 * v - u)),
            -40.0,
            *u,
            200_000,
        );
        assert_rel(&format!("p_diag({u})"), *p, exact, 1e-6);
    }
}

/// Moments that do not exist are NaN and counted, never a finite number the quadrature
/// happened to give. Before: `1/z` on the linear oscillator printed mean 1e-13 (a cancellation
/// of a divergent integral), std 8.8e7, kurtosis 6.5e15.
#[test]
fn moments_that_diverge_are_undefined_not_numbers() {
    // The linear oscillator above, with other observables.
    let text = format!(
        "{}observe energy = v^2/2 + k*z^2/2, inv = 1/z, isq = 1/sqrt(abs(z))\n",
        &LINEAR[..LINEAR.find("observe").unwrap()]
    );
    let text = text.as_str();
    let (sol, maps) = pipeline(text, 2);
    // Bounded-tail observables: every moment exists.
    let energy = moments(&sol, map(&maps, "energy"));
    assert_eq!(energy.existing, 4);
    // E|1/z| = ∞ (p(0, v) > 0): nothing exists.
    let inv = moments(&sol, map(&maps, "inv"));
    assert_eq!(inv.existing, 0);
    assert!(
        inv.moments.mean.is_nan()
            && inv.moments.std_dev().is_nan()
            && inv.moments.raw.iter().all(|m| m.is_nan())
    );
    // |z|^(-1/2): the mean exists, E|z|^-1 does not. For z ~ N(0, 5):
    // E|z|^(-1/2) = 5^(-1/4) 2^(-1/4) Γ(1/4)/√π.
    let isq = moments(&sol, map(&maps, "isq"));
    assert_eq!(isq.existing, 1);
    let gamma_quarter = 3.625_609_908_221_908;
    let exact = 5f64.powf(-0.25) * 2f64.powf(-0.25) * gamma_quarter / PI.sqrt();
    assert_rel("E|z|^-1/2", isq.moments.mean, exact, 1e-4);
    assert!(isq.moments.std_dev().is_nan() && isq.moments.kurtosis.is_nan());
    // The study says so in words.
    let study = Study::run(&parse_model(text, None).unwrap(), &[], &[2]).unwrap();
    let stats = &study.runs[0].stats;
    let note = stats
        .iter()
        .find(|s| s.name == "inv")
        .unwrap()
        .note()
        .unwrap();
    assert!(
        note.contains("E[|inv|^1] is not established as finite"),
        "{note}"
    );
    assert!(stats
        .iter()
        .find(|s| s.name == "energy")
        .unwrap()
        .note()
        .is_none());
}

/// The grid's PDFs of maps, from level-set quadrature of its piecewise-bilinear density cut at
/// its pieces and at the maps' kinks, against the exact PDFs of the linear oscillator (z, v
/// independent N(0, 5)): a smooth map with a minimum (the energy, Exp(mean 5)), a kinked one
/// (|z + v|, half-normal of variance 10), one with a point mass and a kinked level set
/// (max(z, 0) + v) and one singular at 0 (v², a scaled χ², compared away from 0). The L1
/// distance over each curve's levels stays below the grid's own estimated L1 error of its
/// marginals: the joint density's error, pushed forward, is of that size.
#[test]
fn the_grid_pdfs_of_smooth_kinked_and_singular_maps_are_exact_to_its_error() {
    let text = LINEAR.replace(
        "observe energy",
        "observe absum = abs(z + v), clip = max(z, 0) + v, energy",
    );
    let bound = parse_model(&text, None).unwrap().bind(&[]).unwrap();
    let grid = fpsolve::grid::GridSolver::new(&bound)
        .cells(100, 200)
        .solve()
        .unwrap();
    let estimate = grid.report.discretisation_estimate.unwrap();
    let bound_l1 = estimate.x.max(estimate.v);
    let maps = maps_by_name(&bound);
    let s2: f64 = 5.0;
    let normal = |u: f64, var: f64| (-u * u / (2.0 * var)).exp() / (2.0 * PI * var).sqrt();
    // Φ(x) for the clipped sum, by Simpson from far in the left tail.
    let cdf = |x: f64| simpson(&|t| normal(t, 1.0), -12.0, x, 4000);
    type Exact<'a> = Box<dyn Fn(f64) -> f64 + 'a>;
    let cases: [(&str, [f64; 2], Exact); 4] = [
        ("energy", [0.0, 60.0], Box::new(|u| (-u / 5.0).exp() / 5.0)),
        (
            "absum",
            [0.0, 25.0],
            Box::new(|u| 2.0 * normal(u, 2.0 * s2)),
        ),
        (
            "clip",
            [-15.0, 20.0],
            Box::new(|u| 0.5 * normal(u, s2) + normal(u, 2.0 * s2) * cdf(u / (2.0 * s2).sqrt())),
        ),
        (
            "vsq",
            [0.5, 100.0],
            Box::new(|u| (-u / 10.0).exp() / (2.0 * PI * 5.0 * u).sqrt()),
        ),
    ];
    for (name, [lo, hi], exact) in cases {
        let n = 400;
        let u: Vec<f64> = (0..=n)
            .map(|k| lo + (hi - lo) * k as f64 / n as f64)
            .collect();
        let p = ObservableDensity::new(&grid, map(&maps, name)).pdf(&u);
        let d: Vec<f64> = u
            .iter()
            .zip(&p)
            .map(|(&u, p)| (p - exact(u)).abs())
            .collect();
        assert!(d.iter().all(|d| d.is_finite()), "{name}: {p:?}");
        let h = (hi - lo) / n as f64;
        let l1 = h * (d.iter().sum::<f64>() - 0.5 * (d[0] + d[n]));
        eprintln!("{name}: L1 {l1:.2e} against the estimate {bound_l1:.2e}");
        assert!(
            l1 < bound_l1,
            "{name}: L1 {l1:e} above the estimate {bound_l1:e}"
        );
    }
}

/// |z + v| folds the plane along z + v = 0, where it takes its least value 0 on a whole line
/// with no critical point: no line of the quadrature crosses that level set, and p(0) once
/// came out 0. It is the one-sided limit, 2·φ(0) of the sum's variance 10 (EPC's degree 2 is
/// exact here).
#[test]
fn a_folded_map_has_its_limit_at_the_fold() {
    let text = LINEAR.replace("observe energy", "observe absum = abs(z + v), energy");
    let (sol, maps) = pipeline(&text, 2);
    let p = ObservableDensity::new(&sol, map(&maps, "absum")).pdf(&[0.0, 1.0, -1e-3]);
    let half_normal = |u: f64| 2.0 * (-u * u / 20.0).exp() / (2.0 * PI * 10.0).sqrt();
    assert_rel("p(0)", p[0], half_normal(0.0), 1e-6);
    assert_rel("p(1)", p[1], half_normal(1.0), 1e-6);
    assert_eq!(p[2], 0.0);
}
