//! `--tol L1` through the command line: the grid chooses its cells until its estimate is at
//! most the tolerance, `summary.json` says what it asked, achieved and chose, and the true
//! error of the written curves (the linear oscillator's exact Gaussian marginals) is below
//! both; a tolerance that cannot be reached writes the best solve and exits 1.

mod common;

use std::path::Path;

use common::{fpsolve, json, scratch};

const LINEAR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");

/// The (x, p) columns of a written `pdf_<name>.csv` (header, then `x,p` rows).
fn curve(path: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let mut it = l.split(',').map(|v| v.parse::<f64>().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        })
        .collect()
}

/// The L1 distance of a written curve from the N(0, var) density: the trapezoid rule on the
/// curve's points (400 across the box: its own error is far below the grid's), plus the
/// exact mass outside the curve's range.
fn l1_from_normal(points: &[(f64, f64)], var: f64) -> f64 {
    let exact = |x: f64| (-x * x / (2.0 * var)).exp() / (2.0 * std::f64::consts::PI * var).sqrt();
    let inside: f64 = points
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            0.5 * (b.0 - a.0) * ((a.1 - exact(a.0)).abs() + (b.1 - exact(b.0)).abs())
        })
        .sum();
    let (lo, hi) = (points[0].0, points[points.len() - 1].0);
    let outside = |from: f64, to: f64| {
        let n = 2000;
        let h = (to - from) / n as f64;
        (0..n)
            .map(|k| exact(from + (k as f64 + 0.5) * h))
            .sum::<f64>()
            * h
    };
    inside + outside(lo - 20.0, lo) + outside(hi, hi + 20.0)
}

#[test]
fn a_tolerance_is_reached_and_bounds_the_true_error_of_the_written_curves() {
    let root = scratch("tol-cli");
    let out = root.join("out");
    let run = fpsolve(&[
        "solve",
        LINEAR,
        "--method",
        "grid",
        "--tol",
        "0.005",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("cells chosen for L1 tolerance 5.0e-3"),
        "{stdout}"
    );
    let summary = json(&out.join("summary.json"));
    let grid = &summary["grid"];
    let t = &grid["report"]["tolerance"];
    assert_eq!(t["asked"], 0.005);
    assert_eq!(t["reached"], true);
    assert!(t["shortfall"].is_null());
    let achieved = t["achieved"].as_f64().unwrap();
    assert!(achieved <= 0.005);
    // The cells chosen are the last solve's, and the settings say them.
    let solves = t["solves"].as_array().unwrap();
    assert!(solves.len() >= 2, "{solves:?}");
    let last = &solves[solves.len() - 1];
    assert_eq!(last[0], grid["report"]["cells"]);
    assert_eq!(grid["cells"], grid["report"]["cells"]);
    assert_eq!(last[1].as_f64().unwrap(), achieved);
    assert!(grid["report"]["domain"]["x"].is_array());
    // Var z = πK/(ck) = 5, Var v = πK/c = 5 (K = 1/(2π), c = 0.1, k = 1).
    for name in ["z", "v"] {
        let l1 = l1_from_normal(&curve(&out.join(format!("pdf_{name}.csv"))), 5.0);
        println!("{name}: true L1 {l1:.2e}, estimate {achieved:.2e}");
        assert!(l1 < achieved, "{name}: true L1 {l1} vs achieved {achieved}");
    }
    let _ = std::fs::remove_dir_all(root);
}

#[test]
fn a_tolerance_not_reached_writes_the_best_solve_and_exits_1() {
    // A given box that cuts the velocity density (sd 2.2) at ±2: no cells bring that mass
    // back.
    let root = scratch("tol-cli-short");
    let out = root.join("out");
    let run = fpsolve(&[
        "solve",
        LINEAR,
        "--method",
        "grid",
        "--tol",
        "1e-3",
        "--domain",
        "z=-12:12,v=-2:2",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("the L1 tolerance 1.0e-3 was not reached"),
        "{stderr}"
    );
    assert!(stderr.contains("cuts the density"), "{stderr}");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.contains("warning: the grid did not reach"),
        "{stdout}"
    );
    let t = &json(&out.join("summary.json"))["grid"]["report"]["tolerance"];
    assert_eq!(t["reached"], false);
    assert_eq!(t["shortfall"]["kind"], "box_cuts");
    assert!(t["achieved"].as_f64().unwrap() > 1e-3);
    assert!(out.join("pdf_z.csv").exists());
    let _ = std::fs::remove_dir_all(root);
}
