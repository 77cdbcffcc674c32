//! Accuracy on request (`GridSolver::tolerance`) against exact stationary densities: the
//! true L1 error of both marginal curves is below the tolerance asked and below the estimate
//! the solution reports, on the exact cases of `tests/common/exact.rs`.

mod common;

use common::exact::{cases, ExactCase};
use fpsolve::density::JointDensity;
use fpsolve::grid::{Domain, GridError, GridSolution, GridSolver, Shortfall};

/// The L1 distance of the solution's marginal curve of `axis` (the line integrals of its
/// interpolant, what it writes) from the exact one, by the midpoint rule at eight points per
/// cell, plus the exact mass outside the box on that axis (out to three box widths).
fn curve_l1(sol: &GridSolution, case: &ExactCase, axis: usize) -> f64 {
    let d = sol.domain();
    let [lo, hi] = if axis == 0 { d.x } else { d.v };
    let n = 8 * sol.report.cells[axis];
    let h = (hi - lo) / n as f64;
    let whole = [f64::NEG_INFINITY, f64::INFINITY];
    let inside: f64 = (0..n)
        .map(|k| {
            let u = lo + (k as f64 + 0.5) * h;
            let p = JointDensity::line_integral(sol, axis, u, whole).unwrap();
            (p - case.marginal(axis, u)).abs()
        })
        .sum::<f64>()
        * h;
    let w = hi - lo;
    let tails: f64 = [(lo - 3.0 * w, lo), (hi, hi + 3.0 * w)]
        .iter()
        .map(|&(a, b)| {
            let m = 4000;
            let t = (b - a) / m as f64;
            (0..m)
                .map(|k| case.marginal(axis, a + (k as f64 + 0.5) * t))
                .sum::<f64>()
                * t
        })
        .sum();
    inside + tails
}

/// Solves `case` to `tol` and checks: reached, the true L1 of each marginal below the
/// tolerance and below its own reported estimate (the failure said when not).
fn check(case: &ExactCase, tol: f64) -> Result<(), String> {
    check_within(case, tol, false)
}

/// [`check`], where `cell_limit` also accepts a tolerance not reached at this machine's cell
/// limit, flagged as such (`Shortfall::CellLimit`), its estimate still above the true L1.
fn check_within(case: &ExactCase, tol: f64, cell_limit: bool) -> Result<(), String> {
    let bound = case.bind();
    let start = std::time::Instant::now();
    let sol = GridSolver::new(&bound).tolerance(tol).solve().unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let outcome = sol.report.tolerance.clone().unwrap();
    let e = sol.report.discretisation_estimate.unwrap();
    let l1 = [curve_l1(&sol, case, 0), curve_l1(&sol, case, 1)];
    let t = &sol.report.timings;
    println!(
        "{} tol {tol:.0e}: cells {:?}, estimate {:.2e} {:.2e}, true L1 {:.2e} {:.2e}, \
         solves {:?}, {seconds:.2} s (last solve: main {:.0} ms, half {:.0} ms, {} box passes)",
        case.name,
        sol.report.cells,
        e.x,
        e.v,
        l1[0],
        l1[1],
        outcome.solves,
        t.solve_ms + t.assemble_ms,
        t.estimate_ms,
        sol.report.domain_passes
    );
    // Measured: every case reaches 1e-3 and 1e-4, the estimate 1.2-1.6 times the true L1
    // (the order the half and quarter solves show). With the order-1 estimate, four of the
    // cases stopped at 720x1440 at 1e-4 with the true L1 at a third of the tolerance.
    let flagged = cell_limit && matches!(outcome.shortfall, Some(Shortfall::CellLimit { .. }));
    if outcome.reached != (outcome.achieved <= tol) || !(outcome.reached || flagged) {
        return Err(format!("{} tol {tol:e}: {outcome:?}", case.name));
    }
    if outcome.reached && !(l1[0] < tol && l1[1] < tol) {
        return Err(format!("{} tol {tol:e}: true L1 {l1:?}", case.name));
    }
    if !(l1[0] < e.x && l1[1] < e.v) {
        return Err(format!(
            "{} tol {tol:e}: true L1 {l1:?} vs estimate {e:?}",
            case.name
        ));
    }
    Ok(())
}

fn case(name: &str) -> ExactCase {
    cases().into_iter().find(|c| c.name == name).unwrap()
}

#[test]
fn tolerance_1e3_holds_on_the_linear_and_duffing_oscillators() {
    for name in ["linear", "duffing"] {
        check(&case(name), 1e-3).unwrap();
    }
}

/// Every exact case at 1e-3 and 1e-4 (100 s in a release build on two busy cores):
/// `cargo test --release --test grid_tolerance -- --ignored --nocapture` prints per case the
/// cells, estimate, true L1 and time.
#[test]
#[ignore]
fn tolerance_holds_on_every_exact_case() {
    let mut failures = Vec::new();
    for case in cases() {
        if GridSolver::new(&case.bind()).check().is_err() {
            println!("{}: the grid refuses it", case.name);
            continue;
        }
        for tol in [1e-3, 1e-4] {
            if let Err(e) = check(&case, tol) {
                failures.push(e);
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Every exact case at 1e-5 (the target for smooth cases: L1 ≤ 1e-5):
/// `cargo test --release --test grid_tolerance -- --ignored --nocapture tolerance_1e5`.
/// Measured (2 shared cores, a plan of 4 GiB: at most 689 591 cells): ten of the eleven
/// reach it at 448x892 to 588x1172 in 4.7–11.8 s, true L1 at most 4.1e−6; Duffing with
/// μ = 1 stops at the cell limit, 584x1172, its estimate 1.03e−5 (velocity) for a true L1 of
/// 5.4e−6, and says so. Each estimate is above the true L1.
#[test]
#[ignore]
fn tolerance_1e5_holds_on_every_exact_case() {
    let mut failures = Vec::new();
    for case in cases() {
        if GridSolver::new(&case.bind()).check().is_err() {
            println!("{}: the grid refuses it", case.name);
            continue;
        }
        if let Err(e) = check_within(&case, 1e-5, true) {
            println!("{e}");
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn a_tolerance_is_positive_and_excludes_cells() {
    let bound = case("linear").bind();
    for bad in [0.0, -1e-3, f64::NAN] {
        let err = GridSolver::new(&bound).tolerance(bad).check().unwrap_err();
        assert!(
            matches!(
                err,
                GridError::Setting {
                    setting: "tolerance",
                    ..
                }
            ),
            "{err}"
        );
    }
    let err = GridSolver::new(&bound)
        .cells(40, 80)
        .tolerance(1e-3)
        .check()
        .unwrap_err();
    assert!(
        matches!(
            err,
            GridError::Setting {
                setting: "tolerance",
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn an_unreachable_tolerance_is_flagged_not_silent() {
    // A given box that cuts the velocity density (sd 2.2) at ±2: no cells bring that mass back.
    let bound = case("linear").bind();
    let cut = Domain {
        x: [-12.0, 12.0],
        v: [-2.0, 2.0],
    };
    let sol = GridSolver::new(&bound)
        .domain(cut)
        .tolerance(1e-3)
        .solve()
        .unwrap();
    let outcome = sol.report.tolerance.clone().unwrap();
    assert!(
        !outcome.reached && outcome.shortfall.is_some(),
        "{outcome:?}"
    );
    assert!(outcome.achieved > 1e-3);
    assert!(
        matches!(outcome.shortfall, Some(Shortfall::BoxCuts { .. })),
        "{outcome:?}"
    );
    assert!(sol
        .report
        .to_string()
        .contains("warning: the grid did not reach"));
}
