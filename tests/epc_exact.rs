//! EPC against exact stationary densities and on the paper's vibro-impact model (Eq. 13), all
//! through the real pipeline: model file → `Model::bind` (with `--set`-style overrides) →
//! `FpkOperator::derive` → `Epc`.

mod common;

use std::path::Path;

use approx::assert_relative_eq;
use common::exact::{self, EpcTolerance, ExactCase};
use fpsolve::epc::{
    AttemptEnd, BestPointKind, BranchEnd, Epc, EpcError, EpcSolution, HomotopyEnd,
    NormalisationKind, SolverMethod,
};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, DeltaTreatment, Override};

/// The operator of `models/<file>` with parameters overridden.
fn operator(file: &str, set: &[(&str, f64)]) -> FpkOperator {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(file);
    let model = load_model(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    let overrides: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    let bound = model.bind(&overrides).unwrap();
    FpkOperator::derive(&bound).unwrap()
}

/// Checks an EPC solution against a case's exact density: every coefficient, ln C, the
/// density on the case's check points, the variances and the FPK residual, each to the
/// case's EPC tolerances.
fn check_exact(case: &ExactCase, tol: &EpcTolerance, sol: &EpcSolution) {
    let label = format!("{} degree {}", case.name, sol.degree);
    for (&(i, j), a) in sol.exponents.iter().zip(&sol.coefficients) {
        let want = case.coefficient(i, j);
        assert!(
            (a - want).abs() <= tol.coefficient * (1.0 + want.abs()),
            "{label}: coefficient {:?} = {a}, exact {want}",
            (i, j)
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
        sol.fpk_residual < tol.fpk_residual,
        "{label}: ∫|F|p = {}",
        sol.fpk_residual
    );
    let log_z = case.log_normaliser();
    assert_relative_eq!(sol.log_c(), -log_z, epsilon = tol.log_c);
    for (z, v) in case.check_points() {
        let want = (case.log_density(z, v) - log_z).exp();
        assert_relative_eq!(sol.pdf(z, v), want, max_relative = tol.pdf);
    }
    for axis in 0..2 {
        assert_relative_eq!(
            sol.moments[axis].variance,
            case.variance(axis),
            max_relative = tol.variance
        );
    }
}

#[test]
fn exact_densities_are_reproduced() {
    let mut checked = 0;
    for case in exact::cases() {
        let Some(tol) = &case.epc else { continue };
        let bound = case.bind();
        let fpk = FpkOperator::derive(&bound).unwrap();
        let mut degrees = vec![2];
        degrees.extend(tol.degrees.iter().copied().filter(|d| *d > 2));
        let res = Epc::new(&fpk).solve_degrees(&degrees);
        for (d, r) in degrees.iter().zip(res) {
            let sol = r.unwrap_or_else(|e| panic!("{} degree {d}: {e}", case.name));
            if tol.degrees.contains(d) {
                check_exact(&case, tol, &sol);
                checked += 1;
            }
        }
    }
    assert!(checked >= 20, "{checked} solutions checked");
}

#[test]
fn linear_oscillator_closure_is_exact() {
    let (c, k) = (0.3, 2.0);
    let fpk = operator("linear.sde", &[("c", c), ("k", k)]);
    let sol = Epc::new(&fpk).degree(2).solve().unwrap();
    let cl = sol.closure.as_ref().unwrap();
    assert_relative_eq!(cl.covariance[0][0], 0.5 / (c * k), max_relative = 1e-10);
    assert_relative_eq!(cl.covariance[1][1], 0.5 / c, max_relative = 1e-10);
    assert!(cl.covariance[0][1].abs() < 1e-10);
}

#[test]
fn vibro_impact_degree_2_is_the_closure_and_degree_4_improves() {
    let fpk = operator("vibro_duffing.sde", &[]);
    let res = Epc::new(&fpk).solve_degrees(&[2, 4]);
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
    let fpk = operator("vibro_duffing.sde", &[]);
    let exact = Epc::new(&fpk.clone().with_delta_treatment(DeltaTreatment::Exact))
        .degree(2)
        .solve()
        .unwrap();
    let mut last = f64::INFINITY;
    for w in [0.3, 0.1, 0.03, 0.01] {
        let s = Epc::new(
            &fpk.clone()
                .with_delta_treatment(DeltaTreatment::Gaussian { width: w }),
        )
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
    let fpk = operator("vibro_duffing.sde", &[]);
    assert!(matches!(
        Epc::new(&fpk).degree(1).solve(),
        Err(EpcError::Degree { .. })
    ));
    assert!(matches!(
        Epc::new(&fpk).weights([Some(-1.0), None]).solve(),
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
    let epc = Epc::new(&target).degree(6);
    let err = epc.solve().unwrap_err();
    let EpcError::NoConvergence { attempts, best, .. } = &err else {
        panic!("expected no convergence: {err}")
    };
    // The error claims only what was shown: the operator homotopy from the Gaussian-exact
    // operator folds before the model, the best point is a local minimum (no more).
    let operator_path = attempts
        .iter()
        .find_map(|a| match &a.end {
            AttemptEnd::Homotopy(p) if p.method == SolverMethod::OperatorHomotopy => Some(p),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no operator homotopy in {attempts:?}"));
    assert_ne!(operator_path.end, HomotopyEnd::Reached, "{operator_path:?}");
    let first_fold = operator_path.folds.first().copied();
    assert!(
        first_fold.is_some_and(|l| (0.4..0.5).contains(&l)),
        "folds at {:?}",
        operator_path.folds
    );
    assert_eq!(best.kind, BestPointKind::LocalMinimum);
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
