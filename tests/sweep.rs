//! Parameter sweeps: parsing `--set` ranges and lists, a sweep of the linear oscillator
//! against its exact variances and Gaussian tails, a failing point kept among the others,
//! determinism; several methods per point (columns per method, a failure recorded per
//! method), the vibro-impact sweep EPC fails at 4 of 13 points answered at all 13 by the grid
//! solver, and `--method` / `--cells` refused before any work.

use std::path::Path;

use approx::assert_relative_eq;
use fpsolve::grid::{Cells, CellsError};
use fpsolve::model::{load_model, Model, SetError};
use fpsolve::report::OutputDir;
use fpsolve::solve::{MethodName, MethodNameError, MethodSet, NotApplicable};
use fpsolve::sweep::{
    MethodRefusal, PointFailure, PointOutcome, PointSolution, Sweep, SweepError, SweepPoint,
    SweepSpec,
};

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| s.to_string()).collect()
}

fn linear() -> Model {
    load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde")).unwrap()
}

/// The outcome of the one method of an EPC sweep.
fn point_outcome(point: &SweepPoint) -> &PointOutcome {
    assert_eq!(point.outcomes.len(), 1);
    point.outcome(MethodName::Epc).expect("an EPC sweep")
}

fn solution(outcome: &PointOutcome) -> &PointSolution {
    match outcome {
        PointOutcome::Converged(s) => s,
        PointOutcome::Failed(f) => panic!("point failed ({}): {f}", f.stage()),
        PointOutcome::Refused(r) => panic!("point refused: {r}"),
    }
}

#[test]
fn parses_ranges_lists_and_fixed_values() {
    let spec = SweepSpec::parse(&args(&["c=0.1:0.3:5", "k=1, 2 ,1/(2*pi)", "K=2*c"])).unwrap();
    assert_eq!(spec.swept[0].name, "c");
    let c = &spec.swept[0].values;
    assert_eq!(c.len(), 5);
    assert_eq!((c[0], c[4]), (0.1, 0.3));
    assert_relative_eq!(c[1], 0.15, max_relative = 1e-15);
    assert_relative_eq!(spec.swept[1].values[2], 1.0 / (2.0 * std::f64::consts::PI));
    assert_eq!(spec.fixed.len(), 1);
    assert_eq!(spec.fixed[0].value.to_string(), "2*c");
    assert_eq!(spec.len(), 15);
    let points = spec.points();
    // The first parameter varies fastest.
    assert_eq!(points[1], vec![c[1], 1.0]);
    assert_eq!(points[5], vec![c[0], 2.0]);
    // A descending range is kept in the order given.
    let down = SweepSpec::parse(&args(&["c=1:0:3"])).unwrap();
    assert_eq!(down.swept[0].values, vec![1.0, 0.5, 0.0]);
}

#[test]
fn parse_errors_name_the_argument() {
    let err = |list: &[&str]| SweepSpec::parse(&args(list)).unwrap_err();
    assert!(matches!(err(&["c"]), SweepError::MissingEquals { arg } if arg == "c"));
    assert!(matches!(
        err(&["=1,2"]),
        SweepError::Set(SetError::MissingName { .. })
    ));
    assert!(matches!(err(&["c=0:1"]), SweepError::BadRange { arg, .. } if arg == "c=0:1"));
    assert!(matches!(err(&["c=0:1:1"]), SweepError::BadRange { .. }));
    assert!(matches!(err(&["c=0:1:2.5"]), SweepError::BadRange { .. }));
    assert!(matches!(err(&["c=1:1:4"]), SweepError::BadRange { .. }));
    assert!(matches!(
        err(&["c=0:1:99999999"]),
        SweepError::TooManyPoints { .. }
    ));
    assert!(
        matches!(err(&["c=0:k:3"]), SweepError::NotANumber { arg, item, .. } if arg == "c=0:k:3" && item == "k")
    );
    assert!(matches!(err(&["c=1,1/0"]), SweepError::NotANumber { .. }));
    assert!(matches!(
        err(&["c=1,,2"]),
        SweepError::EmptyListItem { index: 2, .. }
    ));
    assert!(matches!(
        err(&["c=1,2*"]),
        SweepError::Set(SetError::BadExpression { arg, .. }) if arg == "c=1,2*"
    ));
    assert!(matches!(err(&["k=2"]), SweepError::NothingSwept));
    assert!(matches!(err(&["c=1,2", "c=3"]), SweepError::Duplicate { name } if name == "c"));
    let three = err(&["c=1,2", "k=1,2", "K=1,2"]);
    assert!(matches!(three, SweepError::TooManySwept { count: 3, .. }));
    assert!(three.to_string().contains("c, k, K"));
    // Names are checked against the model before any work.
    let spec = SweepSpec::parse(&args(&["cc=1,2"])).unwrap();
    assert!(matches!(
        spec.validate(&linear()),
        Err(SweepError::UnknownParameter { name, .. }) if name == "cc"
    ));
}

/// P(|g| > a) for g ~ N(0, σ²), by Simpson's rule.
fn normal_tail(a: f64, sigma: f64) -> f64 {
    let (lo, hi, n) = (a / sigma, a / sigma + 14.0, 20_000);
    let h = (hi - lo) / n as f64;
    let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut s = phi(lo) + phi(hi);
    for i in 1..n {
        s += phi(lo + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    2.0 * s * h / 3.0
}

#[test]
fn linear_oscillator_matches_exact_variances_and_tails() {
    let model = linear();
    let spec = SweepSpec::parse(&args(&["c=0.05,0.2", "k=1,3", "K=0.2"])).unwrap();
    let result = Sweep::new(&model, &spec).degree(4).run();
    assert_eq!(result.parameters, vec!["c", "k"]);
    assert_eq!(result.points.len(), 4);
    assert_eq!(result.converged(), 4);
    assert_eq!(result.threshold_point, Some(0));
    // Thresholds: 2, 3, 4 × σ of z at the first point, σ² = πK/(ck) with c = 0.05, k = 1.
    let pi_k = std::f64::consts::PI * 0.2;
    let sigma0 = (pi_k / 0.05).sqrt();
    let tz = &result.tail_thresholds[0];
    assert_eq!(tz.name, "z");
    assert_relative_eq!(tz.rms, sigma0, max_relative = 1e-6);
    for point in &result.points {
        let (c, k) = (point.values[0], point.values[1]);
        let sol = solution(point.outcome(MethodName::Epc).unwrap());
        let exact = [pi_k / (c * k), pi_k / c]; // Var z, Var v
        for (stats, var) in sol.stats.iter().zip(exact) {
            assert_relative_eq!(stats.moments.variance, var, max_relative = 1e-4);
            assert!(
                stats.moments.mean.abs() < 1e-6 * var.sqrt(),
                "{}",
                stats.moments.mean
            );
            assert_relative_eq!(stats.moments.kurtosis, 3.0, max_relative = 1e-3);
        }
        // Tails of z at the fixed thresholds, against the Gaussian of this point.
        let z = &sol.stats[0];
        for (p, a) in z.tail.iter().zip(&tz.thresholds) {
            let expected = normal_tail(*a, exact[0].sqrt());
            match p {
                // Near the end of the tabulated curve (P ≲ 1e-7) the tail beyond the grid is
                // an exponential continuation: a few per cent, not per mille.
                Some(p) if expected > 1e-7 => {
                    assert_relative_eq!(*p, expected, max_relative = 5e-3)
                }
                Some(p) => assert_relative_eq!(*p, expected, max_relative = 5e-2),
                // Unresolved only where the tail is far below the tabulated 1e-8 of the peak.
                None => assert!(expected < 1e-9, "P = {expected} not resolved"),
            }
        }
        // The observable y = z has the statistics of z.
        assert_relative_eq!(
            sol.stats[2].moments.variance,
            z.moments.variance,
            max_relative = 1e-6
        );
    }
}

#[test]
fn a_failing_point_is_reported_and_the_others_kept() {
    let model = linear();
    // K < 0 makes the intensity 2πK negative: that point cannot be bound.
    let spec = SweepSpec::parse(&args(&["K=-0.1,0.1,0.2"])).unwrap();
    let result = Sweep::new(&model, &spec).degree(2).run();
    assert_eq!(result.converged(), 2);
    match point_outcome(&result.points[0]) {
        PointOutcome::Failed(f) => {
            assert!(matches!(f, PointFailure::Bind(_)), "{f}");
            assert_eq!(f.stage(), "bind");
        }
        other => panic!("expected a failure, got {other:?}"),
    }
    // Thresholds come from the first point that was solved.
    assert_eq!(result.threshold_point, Some(1));
    for point in &result.points[1..] {
        let var = std::f64::consts::PI * point.values[0] / 0.1;
        let z = &solution(point_outcome(point)).stats[0];
        assert_relative_eq!(z.moments.variance, var, max_relative = 1e-4);
    }

    let csv = result.to_csv();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(
        &header[..4],
        &["K", "epc_status", "epc_stage", "epc_message"]
    );
    assert!(lines[1].starts_with("-0.1,failed,bind,\""), "{}", lines[1]);
    assert!(
        lines[1].ends_with(",,,"),
        "a failed row has empty statistics"
    );
    assert!(lines[2].starts_with("0.1,converged,,,"), "{}", lines[2]);
    assert_eq!(lines[2].split(',').count(), header.len());

    let tmp = std::env::temp_dir().join(format!("fpsolve-sweep-test-{}", std::process::id()));
    let out = OutputDir::create(&tmp).unwrap();
    let files = result.write(&out).unwrap();
    for name in [
        "sweep.csv",
        "sweep.json",
        "sweep_std_dev.png",
        "sweep_tail_y.svg",
    ] {
        assert!(
            files.contains(&tmp.join(name)),
            "{name} missing from {files:?}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["methods"], serde_json::json!(["epc"]));
    let outcome = |i: usize| &json["points"][i]["outcomes"][0];
    assert_eq!(outcome(0)["method"], "epc");
    assert_eq!(outcome(0)["status"], "failed");
    assert_eq!(outcome(0)["stage"], "bind");
    assert_eq!(outcome(1)["status"], "converged");
    std::fs::remove_dir_all(&tmp).unwrap();
}

#[test]
fn a_failing_degree_is_reported_per_point() {
    let model = linear();
    let spec = SweepSpec::parse(&args(&["c=0.1,0.2"])).unwrap();
    // A degree beyond what EPC supports: every point fails at the EPC stage, none panics.
    let result = Sweep::new(&model, &spec).degree(99).run();
    assert_eq!(result.converged(), 0);
    for point in &result.points {
        match point_outcome(point) {
            PointOutcome::Failed(f) => {
                assert!(
                    matches!(
                        f,
                        PointFailure::Method { error, .. } if matches!(
                            error.as_ref(),
                            fpsolve::solve::SolveError::Epc(fpsolve::epc::EpcError::Degree { .. })
                        )
                    ),
                    "{f}"
                );
                assert_eq!(f.stage(), "epc");
            }
            other => panic!("expected a failure, got {other:?}"),
        }
    }
    // No point succeeded, so none sets tail thresholds (degree 2 converging at a point
    // whose target degree failed does not make it a reference): no tail columns.
    assert_eq!(result.threshold_point, None);
    assert!(result.tail_thresholds.is_empty());
    assert!(!result.to_csv().contains("p_gt"));
}

#[test]
fn same_result_twice() {
    let model = linear();
    let spec = SweepSpec::parse(&args(&["c=0.05:0.2:3"])).unwrap();
    let a = Sweep::new(&model, &spec).degree(4).run();
    let b = Sweep::new(&model, &spec).degree(4).run();
    assert_eq!(a.points.len(), 3);
    for (p, q) in a.points.iter().zip(&b.points) {
        assert_eq!(p.values, q.values);
        // Outcomes as data: the same solution, or the same failure at the same stage.
        assert_eq!(
            serde_json::to_value(point_outcome(p)).unwrap(),
            serde_json::to_value(point_outcome(q)).unwrap()
        );
    }
    assert_eq!(a.tail_thresholds, b.tail_thresholds);
    assert_eq!(a.to_csv(), b.to_csv());
}

fn vibro() -> Model {
    load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde")).unwrap()
}

/// The columns of an EPC sweep are those it always had; with another method every block of
/// columns carries its method, and each method's numbers are its own: EPC exact for the
/// linear oscillator, the grid solver within its own error estimate of the exact variances.
#[test]
fn each_method_has_its_own_columns() {
    let model = linear();
    let spec = SweepSpec::parse(&args(&["c=0.2,0.4", "K=0.2"])).unwrap();
    let epc = Sweep::new(&model, &spec).degree(2).run();
    let header = |csv: &str| -> Vec<String> {
        csv.lines()
            .next()
            .unwrap()
            .split(',')
            .map(String::from)
            .collect()
    };
    let epc_header = header(&epc.to_csv());
    assert_eq!(
        epc_header[..9],
        [
            "c",
            "epc_status",
            "epc_stage",
            "epc_message",
            "epc_iterations",
            "epc_residual",
            "epc_residual_threshold",
            "epc_fpk_residual",
            "epc_normalisation"
        ]
    );
    assert_eq!(
        epc_header[9..12],
        ["epc_z_mean", "epc_z_std_dev", "epc_z_kurtosis"]
    );

    let both = Sweep::new(&model, &spec)
        .methods("grid,epc".parse().unwrap())
        .degree(2)
        .cells(fpsolve::grid::Cells([48, 64]))
        .run();
    assert_eq!(both.converged(), 2);
    assert_eq!(both.cells, Some([48, 64]));
    let csv = both.to_csv();
    let h = header(&csv);
    // The EPC block is the EPC sweep's columns, named the same; the grid block follows.
    assert_eq!(h[1..epc_header.len()], epc_header[1..]);
    let g = epc_header.len();
    assert_eq!(
        h[g..g + 9],
        [
            "grid_status",
            "grid_stage",
            "grid_message",
            "grid_negative_mass",
            "grid_estimate_x",
            "grid_estimate_v",
            "grid_z_mean",
            "grid_z_std_dev",
            "grid_z_kurtosis"
        ]
    );
    assert_eq!(
        h.len(),
        1 + 2 * (epc_header.len() - 1) - EPC_ONLY + GRID_ONLY
    );
    let pi_k = std::f64::consts::PI * 0.2;
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    for (point, row) in both.points.iter().zip(&rows) {
        assert_eq!(row.len(), h.len());
        let c = point.values[0];
        let exact_var_v = pi_k / c;
        let epc_v = point
            .solution(MethodName::Epc)
            .unwrap()
            .stats_of("v")
            .unwrap();
        let grid = point.solution(MethodName::Grid).unwrap();
        let grid_v = grid.stats_of("v").unwrap();
        assert_relative_eq!(epc_v.moments.variance, exact_var_v, max_relative = 1e-6);
        // 48×64 cells: the velocity marginal's L1 error is estimated by the solver itself.
        let estimate = grid.grid().unwrap().discretisation_estimate.unwrap();
        assert!(estimate.v < 6e-2, "{estimate:?}");
        let rel = (grid_v.moments.variance / exact_var_v - 1.0).abs();
        assert!(rel < 2e-2 && rel > 0.0, "grid Var v off by {rel:e}");
        // The CSV carries each method's own number in its own column.
        let column = |name: &str| h.iter().position(|c| c == name).unwrap();
        let read = |name: &str| row[column(name)].parse::<f64>().unwrap();
        assert_relative_eq!(
            read("epc_v_std_dev"),
            epc_v.moments.std_dev(),
            max_relative = 1e-12
        );
        assert_relative_eq!(
            read("grid_v_std_dev"),
            grid_v.moments.std_dev(),
            max_relative = 1e-12
        );
        assert_eq!(row[column("grid_status")], "converged");
    }
    // One series per quantity and method, named by the method.
    let figures = both.figures();
    let (_, std_dev) = figures
        .iter()
        .find(|(stem, _)| stem == "sweep_std_dev")
        .unwrap();
    let labels: Vec<&str> = std_dev.series.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "y, EPC n = 2",
            "y, grid 48×64",
            "ydot, EPC n = 2",
            "ydot, grid 48×64"
        ]
    );
    assert!(
        std_dev.title.contains("EPC n = 2, grid 48×64"),
        "{}",
        std_dev.title
    );
}

/// Columns only EPC has (iterations, residual, threshold, FPK residual, normalisation) and
/// only the grid has (negative mass, two error estimates).
const EPC_ONLY: usize = 5;
const GRID_ONLY: usize = 3;

/// A method that fails at a point keeps the other method's answer there, and the failure is
/// data: the method, the stage, the typed error, in the JSON and the CSV.
#[test]
fn a_failure_is_recorded_per_method() {
    let model = linear();
    // K < 0: no method can bind the first point; degree 99: EPC fails everywhere else, the
    // grid solver does not.
    let spec = SweepSpec::parse(&args(&["K=-0.1,0.2"])).unwrap();
    let result = Sweep::new(&model, &spec)
        .methods("epc,grid".parse().unwrap())
        .degree(99)
        .cells(fpsolve::grid::Cells([32, 32]))
        .run();
    assert_eq!(result.converged(), 0);
    assert_eq!(result.converged_by(MethodName::Grid), 1);
    assert_eq!(result.converged_by(MethodName::Epc), 0);
    for o in &result.points[0].outcomes {
        let PointOutcome::Failed(f) = &o.outcome else {
            panic!("{:?} solved an unbindable point", o.method)
        };
        assert!(matches!(f, PointFailure::Bind(_)), "{f}");
    }
    let second = &result.points[1];
    assert_eq!(second.outcomes[0].method, MethodName::Epc);
    assert!(matches!(
        second.outcome(MethodName::Epc),
        Some(PointOutcome::Failed(PointFailure::Method {
            method: fpsolve::solve::Method::Epc { degree: 99 },
            error
        })) if matches!(
            error.as_ref(),
            fpsolve::solve::SolveError::Epc(fpsolve::epc::EpcError::Degree { .. })
        )
    ));
    let grid = second
        .solution(MethodName::Grid)
        .expect("the grid solves K = 0.2");
    // EPC, the first method, solved no point: the thresholds come from the next method that
    // solved one, the grid, at the second point.
    assert_eq!(result.threshold_method, MethodName::Grid);
    assert_eq!(result.threshold_point, Some(1));
    assert!(grid.stats_of("z").unwrap().tail.iter().all(Option::is_some));

    let json = serde_json::to_value(&result).unwrap();
    let outcomes = &json["points"][1]["outcomes"];
    assert_eq!(outcomes[0]["method"], "epc");
    assert_eq!(outcomes[0]["status"], "failed");
    assert_eq!(outcomes[0]["stage"], "epc");
    assert_eq!(outcomes[1]["method"], "grid");
    assert_eq!(outcomes[1]["status"], "converged");
    assert_eq!(outcomes[1]["cells"], serde_json::json!([32, 32]));

    let csv = result.to_csv();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = csv.lines().nth(2).unwrap().split(',').collect();
    let at = |name: &str| row[header.iter().position(|c| *c == name).unwrap()];
    assert_eq!((at("epc_status"), at("epc_stage")), ("failed", "epc"));
    assert_eq!(at("epc_z_mean"), "");
    assert_eq!((at("grid_status"), at("grid_stage")), ("converged", ""));
    assert!(at("grid_z_std_dev").parse::<f64>().unwrap() > 0.0);
}

/// A method that does not apply is recorded at every point by a `run` that skipped
/// [`Sweep::check`] (which refuses it before any work: `refusals_are_typed_and_exit_2_…`).
#[test]
fn a_run_that_skipped_the_check_records_the_refusal_at_every_point() {
    let model = fpsolve::model::parse_model(GRID_REFUSED, None).unwrap();
    let spec = SweepSpec::parse(&args(&["c=0.5,1"])).unwrap();
    let result = Sweep::new(&model, &spec)
        .methods("epc,grid".parse().unwrap())
        .degree(2)
        .run();
    assert_eq!(result.converged_by(MethodName::Epc), 2);
    for point in &result.points {
        let Some(PointOutcome::Failed(f)) = point.outcome(MethodName::Grid) else {
            panic!("the grid solved a model it does not handle");
        };
        assert_eq!(f.stage(), "grid");
    }
}

/// The headline: the vibro-impact Duffing oscillator at μ = 0.1 (the paper's Table 1 model)
/// over ε = −0.3 … 0.3. The degree-4 EPC density is not normalisable for ε ≥ 0.15 (4 of 13
/// points fail); the grid solver answers all 13, within its own error estimate, and agrees
/// with EPC where EPC has an answer to the accuracy of the δ-term closure.
#[test]
fn the_grid_answers_the_vibro_impact_sweep_epc_cannot() {
    let model = vibro();
    let spec = SweepSpec::parse(&args(&["eps=-0.3:0.3:13"])).unwrap();
    let sweep = Sweep::new(&model, &spec)
        .methods("epc,grid".parse().unwrap())
        .cells(fpsolve::grid::Cells([70, 140]));
    sweep.check().unwrap();
    let result = sweep.run();
    assert_eq!(result.converged_by(MethodName::Epc), 9);
    assert_eq!(result.converged_by(MethodName::Grid), 13);
    for point in &result.points {
        let eps = point.values[0];
        let epc = point.solution(MethodName::Epc);
        assert_eq!(epc.is_none(), eps > 0.125, "eps = {eps}");
        let grid = point.solution(MethodName::Grid).unwrap();
        let report = grid.grid().unwrap();
        let estimate = report.discretisation_estimate.unwrap();
        // The estimate of the written curves at 70×140 cells (reconstruction from cell
        // averages included, with Roache's safety factor): up to 3.4e-2.
        assert!(
            estimate.x < 5e-2 && estimate.v < 5e-2,
            "eps = {eps}: {estimate:?}"
        );
        assert!(
            report.negative_mass < 1e-3,
            "eps = {eps}: {}",
            report.negative_mass
        );
        let y = grid.stats_of("y").unwrap();
        assert!(
            y.moments.mean > 0.0 && y.moments.variance > 0.0,
            "eps = {eps}"
        );
        if let Some(epc) = epc {
            for q in ["y", "ydot"] {
                let (a, b) = (epc.stats_of(q).unwrap(), grid.stats_of(q).unwrap());
                let rel = b.moments.std_dev() / a.moments.std_dev() - 1.0;
                assert!(
                    rel.abs() < 0.05,
                    "eps = {eps}, {q}: σ grid/EPC − 1 = {rel:.3}"
                );
            }
        }
    }
}

fn fpsolve_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

/// The paper's δ-term impact damping without an impact law: EPC solves it, the grid (which
/// treats impacts exactly, by an `impact` statement) refuses it.
const GRID_REFUSED: &str = "model odd\nparam c = 1\nstate x, v\ndrift x: v\n\
    drift v: -c*v - x - 0.1*v*abs(v)*delta(x)\nnoise xi: intensity 1\ndiffusion v: xi\n";

/// What the library says of a sweep's `--method` and `--cells` texts, taken in the command
/// line's order: the method set, the cells, then [`Sweep::check`] against the model.
#[derive(Debug)]
enum Verdict {
    Methods(MethodNameError),
    Cells(CellsError),
    Check(SweepError),
    Accepted,
}

fn verdict(model: &Model, spec: &SweepSpec, method: &str, cells: Option<&str>) -> Verdict {
    let methods = match method.parse::<MethodSet>() {
        Ok(m) => m,
        Err(e) => return Verdict::Methods(e),
    };
    let mut sweep = Sweep::new(model, spec).methods(methods);
    match cells.map(str::parse::<Cells>).transpose() {
        Ok(Some(c)) => sweep = sweep.cells(c),
        Ok(None) => {}
        Err(e) => return Verdict::Cells(e),
    }
    match sweep.check() {
        Err(e) => Verdict::Check(e),
        Ok(()) => Verdict::Accepted,
    }
}

/// A refused sweep: its model and flags, the library's typed verdict on them, and words the
/// command line's message must hold (the flag or method it names).
struct Refusal<'a> {
    tag: &'a str,
    model: &'a str,
    set: &'a str,
    method: &'a str,
    cells: Option<&'a str>,
    typed: fn(&Verdict) -> bool,
    names: &'a [&'a str],
}

fn not_applicable(v: &Verdict, method: MethodName) -> Option<&NotApplicable> {
    match v {
        Verdict::Check(SweepError::Method {
            method: m, reason, ..
        }) if *m == method => match &**reason {
            MethodRefusal::NotApplicable(why) => Some(why),
            MethodRefusal::Cells(_) | MethodRefusal::Domain { .. } => None,
        },
        _ => None,
    }
}

/// Every refusal before any work, one table: the library's typed error for the flags
/// (`Accepted` where only the command line has the rule), and `fpsolve sweep` exiting 2
/// without creating its output directory, its message naming the flag or the method.
#[test]
fn refusals_are_typed_and_exit_2_before_any_work() {
    let root = std::env::temp_dir().join(format!("fpsolve-sweep-cli-{}", std::process::id()));
    std::fs::create_dir_all(&root).unwrap();
    let odd = root.join("odd.sde");
    std::fs::write(&odd, GRID_REFUSED).unwrap();
    let odd = odd.to_str().unwrap();
    let (linear_sde, vibro_sde) = ("models/linear.sde", "models/vibro_duffing.sde");
    let cases = [
        Refusal {
            tag: "unknown",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "epc,mc",
            cells: None,
            typed: |v| matches!(v, Verdict::Methods(MethodNameError::Unknown { name }) if name == "mc"),
            names: &["--method", "`mc` is not a method"],
        },
        Refusal {
            tag: "empty",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "",
            cells: None,
            typed: |v| matches!(v, Verdict::Methods(MethodNameError::Empty)),
            names: &["--method", "no method"],
        },
        Refusal {
            tag: "repeated",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "grid,grid",
            cells: None,
            typed: |v| matches!(v, Verdict::Methods(MethodNameError::Repeated { name }) if name == "grid"),
            names: &["--method", "twice"],
        },
        Refusal {
            tag: "odd-cells",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "grid",
            cells: Some("41,40"),
            typed: |v| matches!(v, Verdict::Cells(CellsError::Invalid { nx: 41, nv: 40 })),
            names: &["--cells", "even"],
        },
        Refusal {
            tag: "one-cell",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "grid",
            cells: Some("140"),
            typed: |v| matches!(v, Verdict::Cells(CellsError::Syntax { text }) if text == "140"),
            names: &["--cells", "NX,NV"],
        },
        Refusal {
            // Cells without the grid method: a rule of the command line alone.
            tag: "cells-no-grid",
            model: linear_sde,
            set: "c=0.1,0.2",
            method: "epc",
            cells: Some("140,280"),
            typed: |v| matches!(v, Verdict::Accepted),
            names: &["--cells", "grid"],
        },
        Refusal {
            tag: "grid-refused",
            model: odd,
            set: "c=0.5,1",
            method: "epc,grid",
            cells: None,
            typed: |v| {
                matches!(
                    not_applicable(v, MethodName::Grid),
                    Some(NotApplicable::Grid { .. })
                )
            },
            names: &["--method grid", "delta(...) terms"],
        },
        Refusal {
            // EPC with the exact impact condition takes the impact law itself: the
            // Zhuravlev form (δ terms, a pass-through law) is refused.
            tag: "impact",
            model: vibro_sde,
            set: "eps=0.1,0.2",
            method: "epc-impact",
            cells: None,
            typed: |v| {
                matches!(
                    not_applicable(v, MethodName::EpcImpact),
                    Some(NotApplicable::EpcImpact { .. })
                )
            },
            names: &["epc-impact", "original coordinates"],
        },
    ];
    for case in &cases {
        let tag = case.tag;
        let model = load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join(case.model)).unwrap();
        let spec = SweepSpec::parse(&args(&[case.set])).unwrap();
        let v = verdict(&model, &spec, case.method, case.cells);
        assert!((case.typed)(&v), "{tag}: {v:?}");
        let out = root.join(tag);
        let mut a = vec!["sweep", case.model, "--set", case.set, "--quiet"];
        a.extend(["--method", case.method]);
        if let Some(cells) = case.cells {
            a.extend(["--cells", cells]);
        }
        a.extend(["--out", out.to_str().unwrap()]);
        let o = fpsolve_cli(&a);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{tag}: {stderr}");
        assert!(!out.exists(), "{tag}: the output directory was created");
        for e in case.names {
            assert!(stderr.contains(e), "{tag}: `{e}` not in {stderr}");
        }
    }
    // Cells given to the library directly, past the text's own check, are refused by
    // `check`, whatever the model.
    let spec = SweepSpec::parse(&args(&["c=0.1,0.2"])).unwrap();
    let bad = Sweep::new(&linear(), &spec)
        .methods("grid".parse().unwrap())
        .cells(Cells([30, 7]))
        .check()
        .unwrap_err();
    assert!(
        matches!(
            &bad,
            SweepError::Method {
                method: MethodName::Grid,
                reason,
                ..
            } if matches!(**reason, MethodRefusal::Cells(_))
        ),
        "{bad}"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// `sweep --domain`: the box `solve --domain` takes, used at every point (each point's grid
/// report says it was given), and refused before any work when it does not fit the model's
/// wall at a point or when the grid is not among the methods.
#[test]
fn a_domain_is_used_at_every_point_and_checked_before_work() {
    let root = std::env::temp_dir().join(format!("fpsolve-sweep-domain-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let out = root.join("out");
    let out_s = out.to_str().unwrap();
    let run = fpsolve_cli(&[
        "sweep",
        "models/linear.sde",
        "--set",
        "c=0.2,0.4",
        "--method",
        "grid",
        "--cells",
        "40,80",
        "--domain",
        "z=-9:9,v=-8:9",
        "--out",
        out_s,
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    let points = json["points"].as_array().unwrap();
    assert_eq!(points.len(), 2);
    for p in points {
        let grid = &p["outcomes"][0];
        let report = serde_json::to_string(grid).unwrap();
        // The velocity range made symmetric, as `solve` does.
        assert!(report.contains("\"domain_given\":true"), "{report}");
        assert!(report.contains("[-9.0,9.0]"), "{report}");
    }
    // The library: the same box through the builder, Var v = S/(2c) = 0.5/c to the grid's
    // accuracy at each point.
    let model = linear();
    let spec = SweepSpec::parse(&args(&["c=0.2,0.4"])).unwrap();
    let d = fpsolve::grid::Domain {
        x: [-9.0, 9.0],
        v: [-9.0, 9.0],
    };
    let result = Sweep::new(&model, &spec)
        .methods("grid".parse().unwrap())
        .cells(Cells([40, 80]))
        .grid_domain(d)
        .run();
    for point in &result.points {
        let s = point.solution(MethodName::Grid).unwrap();
        assert_eq!(s.grid().unwrap().domain, d);
        let var = s.stats_of("v").unwrap().moments.variance;
        assert_relative_eq!(var, 0.5 / point.values[0], max_relative = 2e-2);
    }
    // A wall at y = 0 (domain y >= 0): the box's lower end must be on it, at every point.
    let wall =
        load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde"))
            .unwrap();
    let spec = SweepSpec::parse(&args(&["eps=0.1,0.2"])).unwrap();
    let off_wall = fpsolve::grid::Domain {
        x: [-1.0, 6.0],
        v: [-10.0, 10.0],
    };
    let err = Sweep::new(&wall, &spec)
        .methods("grid".parse().unwrap())
        .grid_domain(off_wall)
        .check()
        .unwrap_err();
    assert!(
        matches!(
            &err,
            SweepError::Method { method: MethodName::Grid, reason, .. }
                if matches!(**reason, MethodRefusal::Domain { .. })
        ),
        "{err}"
    );
    for (tag, extra, words) in [
        (
            "wall",
            vec!["--method", "grid", "--domain", "y=-1:6,ydot=-10:10"],
            vec!["the box at eps=0.1", "lower"],
        ),
        (
            "no-grid",
            vec!["--domain", "y=0:6,ydot=-10:10"],
            vec!["--domain", "not among the methods"],
        ),
    ] {
        let out = root.join(tag);
        let mut a = vec![
            "sweep",
            "models/vibro_impact_duffing.sde",
            "--set",
            "eps=0.1,0.2",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(extra);
        let run = fpsolve_cli(&a);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{tag}: {stderr}");
        for w in words {
            assert!(stderr.contains(w), "{tag}: {stderr}");
        }
        assert!(!out.exists(), "{tag}: output written");
    }
    let _ = std::fs::remove_dir_all(&root);
}
