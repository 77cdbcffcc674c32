//! EPC against exact stationary densities and on the paper's vibro-impact model (Eq. 13), all
//! through the real pipeline: model file → `Model::bind` (with `--set`-style overrides) →
//! `FpkOperator::derive` → `Epc`.

use std::path::Path;

use approx::assert_relative_eq;
use fpsolve::epc::{BranchEnd, Epc, EpcError, EpcSolution, NormalisationKind};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, DeltaTreatment, Override};

/// The operator and delta treatment of `models/<file>` with parameters overridden.
fn operator(file: &str, set: &[(&str, f64)]) -> (FpkOperator, DeltaTreatment) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(file);
    let model = load_model(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    let overrides: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    let bound = model.bind(&overrides).unwrap();
    (
        FpkOperator::derive(&bound).unwrap(),
        model.delta_treatment(),
    )
}

/// A model with a known stationary density p ∝ exp(Σ q_ij z^i v^j) (original variables).
struct Exact {
    file: &'static str,
    set: Vec<(&'static str, f64)>,
    /// The exact Q's nonzero coefficients.
    q: Vec<((usize, usize), f64)>,
    /// Degrees at which EPC must reproduce Q (every degree ≥ deg Q).
    degrees: Vec<usize>,
}

/// Energy-type densities exp(−f (v²/2 + k z²/2 + μ z⁴/4)).
fn energy(f: f64, k: f64, mu: f64) -> Vec<((usize, usize), f64)> {
    let mut q = vec![((0, 2), -f / 2.0), ((2, 0), -f * k / 2.0)];
    if mu != 0.0 {
        q.push(((4, 0), -f * mu / 4.0));
    }
    q
}

fn registry() -> Vec<Exact> {
    // 2πK = 1 in every file: πK = 1/2.
    vec![
        Exact {
            file: "linear.sde",
            set: vec![("c", 0.3), ("k", 2.0)],
            q: energy(0.3 / 0.5, 2.0, 0.0),
            degrees: vec![2, 4],
        },
        Exact {
            file: "duffing.sde",
            set: vec![],
            q: energy(0.1 / 0.5, 1.0, 0.1),
            degrees: vec![4, 6],
        },
        Exact {
            file: "duffing.sde",
            set: vec![("mu", 1.0)],
            q: energy(0.1 / 0.5, 1.0, 1.0),
            degrees: vec![4],
        },
        // (1 + εx)² damping with (1 + εx) noise: β/(πK) = 0.4.
        Exact {
            file: "parametric.sde",
            set: vec![],
            q: energy(0.2 / 0.5, 1.0, 0.5),
            degrees: vec![4, 6],
        },
        // The vibro-impact model without impacts (r = 1) or parametric noise (ε = 0) is the
        // Duffing oscillator: the Stratonovich reading and sgn(z)² = 1 must both come out right.
        Exact {
            file: "vibro_duffing.sde",
            set: vec![("r", 1.0), ("eps", 0.0)],
            q: energy(0.1 / 0.5, 1.0, 0.1),
            degrees: vec![4, 6],
        },
    ]
}

/// ln ∫∫ exp(Q) dz dv for a Q without z–v cross terms, by trapezoid sums (spectrally accurate
/// here) over boxes reaching e^-60 of the peak.
fn log_z_exact(q: &[((usize, usize), f64)]) -> f64 {
    let part = |axis: usize| {
        let poly = |t: f64| -> f64 {
            q.iter()
                .filter(|((i, j), _)| if axis == 0 { *j == 0 } else { *i == 0 })
                .map(|((i, j), a)| a * t.powi((i + j) as i32))
                .sum()
        };
        let mut half = 1.0;
        while poly(half) > -60.0 {
            half *= 1.5;
        }
        let n = 4000;
        let h = 2.0 * half / n as f64;
        (0..=n)
            .map(|i| poly(-half + i as f64 * h).exp())
            .sum::<f64>()
            * h
    };
    (part(0) * part(1)).ln()
}

fn check_exact(case: &Exact, sol: &EpcSolution) {
    let label = format!("{} {:?} degree {}", case.file, case.set, sol.degree);
    for (e, a) in sol.exponents.iter().zip(&sol.coefficients) {
        let want = case.q.iter().find(|(f, _)| f == e).map_or(0.0, |(_, v)| *v);
        assert!(
            (a - want).abs() <= 1e-7 * (1.0 + want.abs()),
            "{label}: coefficient {e:?} = {a}, exact {want}"
        );
    }
    assert!(
        matches!(sol.normalisation.kind, NormalisationKind::Plane { .. }),
        "{label}: {:?}",
        sol.normalisation.kind
    );
    assert!(
        sol.solve.residual <= sol.solve.residual_threshold,
        "{label}"
    );
    assert!(
        sol.fpk_residual < 1e-6,
        "{label}: ∫|F|p = {}",
        sol.fpk_residual
    );
    // Normalisation: ln C against the exact normalising integral, and p at a few points.
    let log_z = log_z_exact(&case.q);
    assert_relative_eq!(sol.log_c(), -log_z, epsilon = 1e-6);
    for (z, v) in [(0.0, 0.0), (1.0, -0.5), (-2.0, 3.0)] {
        let q: f64 = case
            .q
            .iter()
            .map(|((i, j), a)| a * f64::powi(z, *i as i32) * f64::powi(v, *j as i32))
            .sum();
        assert_relative_eq!(sol.pdf(z, v), (q - log_z).exp(), max_relative = 1e-6);
    }
    // v is Gaussian in every case of the registry: Var v = −1/(2 q_02).
    let q02 = case.q.iter().find(|(e, _)| *e == (0, 2)).unwrap().1;
    assert_relative_eq!(sol.moments[1].variance, -0.5 / q02, max_relative = 1e-6);
}

#[test]
fn exact_densities_are_reproduced() {
    for case in registry() {
        let (fpk, treatment) = operator(case.file, &case.set);
        let mut degrees = vec![2];
        degrees.extend(case.degrees.iter().copied().filter(|d| *d > 2));
        let res = Epc::new(&fpk, treatment).solve_degrees(&degrees);
        for (d, r) in degrees.iter().zip(res) {
            let sol = r.unwrap_or_else(|e| panic!("{} degree {d}: {e}", case.file));
            if case.degrees.contains(d) {
                check_exact(&case, &sol);
            }
        }
    }
}

#[test]
fn linear_oscillator_closure_is_exact() {
    let (c, k) = (0.3, 2.0);
    let (fpk, treatment) = operator("linear.sde", &[("c", c), ("k", k)]);
    let sol = Epc::new(&fpk, treatment).degree(2).solve().unwrap();
    let cl = sol.closure.as_ref().unwrap();
    assert_relative_eq!(cl.covariance[0][0], 0.5 / (c * k), max_relative = 1e-10);
    assert_relative_eq!(cl.covariance[1][1], 0.5 / c, max_relative = 1e-10);
    assert!(cl.covariance[0][1].abs() < 1e-10);
    assert_relative_eq!(sol.tail_probability(1, 0.0), 1.0, max_relative = 1e-6);
}

#[test]
fn vibro_impact_degree_2_is_the_closure_and_degree_4_improves() {
    let (fpk, treatment) = operator("vibro_duffing.sde", &[]);
    let res = Epc::new(&fpk, treatment).solve_degrees(&[2, 4]);
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
    let (fpk, _) = operator("vibro_duffing.sde", &[]);
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
    let (fpk, treatment) = operator("vibro_duffing.sde", &[]);
    assert!(matches!(
        Epc::new(&fpk, treatment).degree(1).solve(),
        Err(EpcError::Degree { .. })
    ));
    assert!(matches!(
        Epc::new(&fpk, treatment)
            .weights([Some(-1.0), None])
            .solve(),
        Err(EpcError::Weight { .. })
    ));
}

/// Table 1 case 1 at degree 6: follow the degree-6 solution from the exactly solvable
/// r = 1, ε = 0 (where it is the Duffing density, top coefficients zero) along
/// r = 1 − 0.05λ, ε = 0.1λ to case 1 (λ = 1).
#[test]
fn table1_case1_degree6_branch_from_the_exact_case() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path).unwrap();
    let at = |l: f64| {
        let bound = model
            .bind(&[
                Override::number("r", 1.0 - 0.05 * l),
                Override::number("eps", 0.1 * l),
            ])
            .map_err(|e| e.to_string())?;
        FpkOperator::derive_unchecked(&bound).map_err(|e| e.to_string())
    };
    let target = at(1.0).unwrap();
    let epc = Epc::new(&target, model.delta_treatment()).degree(6);
    let err = epc.solve().unwrap_err();
    assert!(matches!(err, EpcError::NoConvergence { .. }), "{err}");
    // The message claims only what was shown: the operator homotopy from the Gaussian-exact
    // operator folds before the model, the best point is a local minimum (no more).
    let text = err.to_string();
    assert!(
        text.contains("the operator homotopy from the Gaussian-exact operator folded at λ = 0.4"),
        "{text}"
    );
    assert!(!text.contains("lies nearby"), "{text}");
    let branch = epc.branch(&at).unwrap();
    // Every point is a genuine solution of its system.
    assert!(
        branch.points.iter().all(|p| p.residual < 1e-9),
        "{branch:?}"
    );
    // The branch folds back at λ ≈ 0.257 (r ≈ 0.987, ε ≈ 0.026), long before case 1.
    let BranchEnd::Fold { lambda } = branch.end else {
        panic!("expected a fold: {branch:?}")
    };
    assert!((0.24..0.27).contains(&lambda), "fold at λ = {lambda}");
}
