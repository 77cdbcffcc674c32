//! Parameter sweeps: parsing `--set` ranges and lists, a sweep of the linear oscillator
//! against its exact variances and Gaussian tails, a failing point kept among the others, and
//! determinism.

use std::path::Path;

use approx::assert_relative_eq;
use fpsolve::model::{load_model, Model, SetError};
use fpsolve::report::OutputDir;
use fpsolve::sweep::{PointFailure, PointOutcome, PointSolution, Sweep, SweepError, SweepSpec};

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| s.to_string()).collect()
}

fn linear() -> Model {
    load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde")).unwrap()
}

fn solution(outcome: &PointOutcome) -> &PointSolution {
    match outcome {
        PointOutcome::Converged(s) => s,
        PointOutcome::Failed(f) => panic!("point failed ({}): {f}", f.stage()),
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
        let sol = solution(&point.outcome);
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
    match &result.points[0].outcome {
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
        let z = &solution(&point.outcome).stats[0];
        assert_relative_eq!(z.moments.variance, var, max_relative = 1e-4);
    }

    let csv = result.to_csv();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(&header[..4], &["K", "status", "stage", "message"]);
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
    assert_eq!(json["points"][0]["status"], "failed");
    assert_eq!(json["points"][1]["status"], "converged");
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
        match &point.outcome {
            PointOutcome::Failed(f) => {
                assert!(
                    matches!(
                        f,
                        PointFailure::Solve {
                            error: fpsolve::epc::EpcError::Degree { .. },
                            ..
                        }
                    ),
                    "{f}"
                );
                assert_eq!(f.stage(), "epc");
            }
            other => panic!("expected a failure, got {other:?}"),
        }
    }
    // An unsupported degree does not stop degree 2, whose solutions still set the tail
    // thresholds (from the first point).
    assert_eq!(result.threshold_point, Some(0));
    assert!(!result.tail_thresholds.is_empty());
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
            serde_json::to_value(&p.outcome).unwrap(),
            serde_json::to_value(&q.outcome).unwrap()
        );
    }
    assert_eq!(a.tail_thresholds, b.tail_thresholds);
    assert_eq!(a.to_csv(), b.to_csv());
}
