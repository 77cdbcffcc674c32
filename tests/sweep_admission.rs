//! Sweeps into a regime boundary (issue 39, item 10 and the sweep's part of item 17): every
//! point is checked for a stationary density before any is solved, and a point without one
//! is recorded as refused (typed, in sweep.csv, sweep.json and the library's outcome) while
//! the others are solved; the tail thresholds come from a point that succeeded, and a sweep
//! where none did has none.

mod common;

use std::path::Path;
use std::time::Duration;

use common::{json, run_within, scratch};
use fpsolve::base::cancel::Cancel;
use fpsolve::dynamics::Inadmissible;
use fpsolve::grid::Cells;
use fpsolve::mc::Shard;
use fpsolve::model::{load_model, parse_model, Model};
use fpsolve::solve::MethodName;
use fpsolve::sweep::{PointOutcome, Sweep, SweepSpec};

fn vibro() -> Model {
    load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde")).unwrap()
}

/// `fpsolve sweep models/vibro_duffing.sde --set mu=-1:1:5`: μ < 0 is a softening spring
/// whose trajectories escape. Those points are refused before any work — status `refused`,
/// stage `admissibility` and the reason in sweep.csv and sweep.json — and the others solved;
/// exit 1 with the files kept.
#[test]
fn a_mu_range_into_the_softening_regime_refuses_those_points_and_solves_the_others() {
    let root = scratch("sweep-softening");
    let out = root.join("out");
    let out_arg = out.to_str().unwrap();
    let ended = run_within(
        Duration::from_secs(120),
        &[
            "sweep",
            "models/vibro_duffing.sde",
            "--set",
            "mu=-1:1:5",
            "--out",
            out_arg,
        ],
    );
    let (code, stderr) = (ended.code, ended.stderr);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("2 points refused before any work (no stationary density)"),
        "{stderr}"
    );
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            // The message is quoted and holds commas: the first three fields suffice.
            let mut fields = l.splitn(4, ',').map(str::to_string).collect::<Vec<_>>();
            fields.truncate(3);
            fields
        })
        .collect();
    let head = |i: usize| {
        (
            rows[i][0].as_str(),
            rows[i][1].as_str(),
            rows[i][2].as_str(),
        )
    };
    assert_eq!(head(0), ("-1", "refused", "admissibility"));
    assert_eq!(head(1), ("-0.5", "refused", "admissibility"));
    assert_eq!((head(3).1, head(4).1), ("converged", "converged"));
    assert!(csv.contains("softening restoring force"), "{csv}");
    let sweep = json(&out.join("sweep.json"));
    let outcome = &sweep["points"][0]["outcomes"][0];
    assert_eq!(outcome["status"], "refused");
    assert_eq!(outcome["stage"], "admissibility");
    assert!(outcome["message"]
        .as_str()
        .unwrap()
        .starts_with("no stationary density"));
    // The thresholds come from a point that was solved.
    assert_eq!(sweep["threshold_point"], 3);
    let _ = std::fs::remove_dir_all(&root);
}

/// Refused points are refused for every method, without any method's work, with the typed
/// reason; the points with a density are solved by each method as before.
#[test]
fn a_refused_point_is_refused_for_every_method_before_any_work() {
    let model = parse_model(
        "model duffing\nparam c = 0.5, mu = 0.1\nstate z, v\ndrift z: v\n\
         drift v: -c*v - z - mu*z^3\nnoise xi: intensity 1\ndiffusion v: xi\n",
        None,
    )
    .unwrap();
    let spec = SweepSpec::parse(&["mu=-1,0.1".to_string()]).unwrap();
    let result = Sweep::new(&model, &spec)
        .methods("epc,grid".parse().unwrap())
        .degree(2)
        .cells(Cells([40, 80]))
        .run();
    let refused = &result.points[0];
    assert_eq!(refused.outcomes.len(), 2);
    for o in &refused.outcomes {
        let PointOutcome::Refused(why) = &o.outcome else {
            panic!("{}: {:?}", o.method, o.outcome)
        };
        assert!(
            matches!(why.0, Inadmissible::Escapes { side: "upper", .. }),
            "{why}"
        );
        assert_eq!(o.wall_ms, 0.0, "{}: some work was done", o.method);
    }
    assert_eq!(result.refused(), 1);
    for m in [MethodName::Epc, MethodName::Grid] {
        assert!(result.points[1].solution(m).is_some(), "{m}");
    }
    assert_eq!(result.threshold_point, Some(1));
}

/// At μ = 0 EPC's degree-2 solution converges and degree 4 does not: the point failed, so
/// it does not set the tail thresholds (it did, undocumented); the first point that
/// converged does, in every shard alike.
#[test]
fn the_tail_thresholds_come_from_the_first_point_that_succeeded() {
    let model = vibro();
    let spec = SweepSpec::parse(&["mu=0,0.5,1".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec);
    let result = sweep.run();
    assert!(matches!(
        result.points[0].outcome(MethodName::Epc),
        Some(PointOutcome::Failed(_))
    ));
    assert_eq!(result.threshold_point, Some(1));
    assert_eq!(result.threshold_method, MethodName::Epc);
    assert!(!result.tail_thresholds.is_empty());
    // Shard 3 of 3 (point 2 alone) walks to the same point and the same values.
    let shard = sweep
        .run_shard(Shard::new(2, 3).unwrap(), &Cancel::new())
        .unwrap();
    let merged_head: serde_json::Value = serde_json::to_value(&shard).unwrap();
    let head: serde_json::Value =
        serde_json::from_str(merged_head["json_head"].as_str().unwrap()).unwrap();
    assert_eq!(head["threshold_point"], 1);
    assert_eq!(
        head["tail_thresholds"],
        serde_json::to_value(&result.tail_thresholds).unwrap()
    );
}

/// No point converged: no thresholds, no tail columns, and `threshold_point` null.
#[test]
fn a_sweep_where_no_point_succeeded_has_no_tail_thresholds() {
    let model = vibro();
    let spec = SweepSpec::parse(&["mu=0,-1e-5".to_string()]).unwrap();
    let result = Sweep::new(&model, &spec).run();
    assert_eq!(result.converged(), 0);
    assert_eq!(result.threshold_point, None);
    assert!(result.tail_thresholds.is_empty());
    assert!(!result.to_csv().contains("p_gt"));
}

/// A shard records its refused points as a single run does, and the merge of the shards is
/// the single run's text.
#[test]
fn shards_record_refused_points_as_one_run_does() {
    let model = vibro();
    let spec = SweepSpec::parse(&["mu=-1,0.5,1".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec);
    let parts: Vec<_> = (0..2)
        .map(|k| {
            sweep
                .run_shard(Shard::new(k, 2).unwrap(), &Cancel::new())
                .unwrap()
        })
        .map(|s| (s.file_name(), s))
        .collect();
    let merged = fpsolve::sweep::merge_sweep_shards(&parts).unwrap();
    let whole = sweep.run();
    assert_eq!(merged.csv(), whole.to_csv());
    assert!(merged
        .csv()
        .lines()
        .nth(1)
        .unwrap()
        .starts_with("-1,refused,admissibility,"));
    assert_eq!(whole.threshold_point, Some(1));
    // The merge counts refused points as the run does (its exit message reads this).
    assert_eq!((merged.refused(), whole.refused()), (1, 1));
}
