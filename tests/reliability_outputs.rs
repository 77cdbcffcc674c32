//! What `fpsolve reliability` writes beside the first passage (issue 35, item 5): the
//! stationary crossing tables and impact statistics against their exact values, the
//! distances between the grid's and Monte Carlo's first-passage numbers, and `--domain` for a
//! model without a stationary density (the randomly accelerated particle against its
//! independent reference).

mod common;

use std::f64::consts::PI;
use std::path::Path;

use common::{fpsolve, json, names, scratch, simpson};

/// `crossings_<q>.csv`: the header and the columns (an empty field is NaN).
fn columns(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols = vec![Vec::new(); header.len()];
    for line in lines {
        for (k, field) in line.split(',').enumerate() {
            cols[k].push(if field.is_empty() {
                f64::NAN
            } else {
                field.parse().unwrap()
            });
        }
    }
    (header, cols)
}

/// The separable stationary density p_x(x)·N(0, σ_v²) of `y'' + c y' + y + μ y³ = ξ` (2πK =
/// 1, so f = c/(πK) = 2c and σ_v² = 1/f), restricted to y > `wall`: ν⁺(u) = p_x(u)·σ_v/√(2π).
fn exact_rate(c: f64, mu: f64, wall: f64) -> impl Fn(f64) -> f64 {
    let f = 2.0 * c;
    let potential = move |x: f64| (-f * (x * x / 2.0 + mu * x.powi(4) / 4.0)).exp();
    let norm = simpson(&potential, wall.max(-30.0), 30.0, 40000);
    let sv = (1.0 / f).sqrt();
    move |u| potential(u) / norm * sv / (2.0 * PI).sqrt()
}

/// The grid's and Monte Carlo's columns of a crossing table against the exact rate: the grid
/// within its stated error wherever it states one (and stating one on most levels), Monte
/// Carlo within 4 standard errors plus its stated bias. Returns the worst of each, in their
/// error units.
fn check_crossings(path: &Path, exact: &dyn Fn(f64) -> f64, with_mc: bool) -> (f64, f64) {
    let (header, cols) = columns(path);
    let mut expected = vec!["u", "grid", "grid_error"];
    if with_mc {
        expected.extend(["mc", "mc_se", "mc_bias"]);
    }
    assert_eq!(header, expected, "{}", path.display());
    let (u, grid, error) = (&cols[0], &cols[1], &cols[2]);
    let stated = error.iter().filter(|e| e.is_finite()).count();
    assert!(stated * 2 > u.len(), "{stated} of {} levels", u.len());
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..u.len() {
        let e = exact(u[k]);
        if error[k].is_finite() {
            worst.0 = worst.0.max((grid[k] - e).abs() / error[k]);
        }
        if with_mc {
            let (m, se, bias) = (cols[3][k], cols[4][k], cols[5][k]);
            if se > 0.0 {
                worst.1 = worst.1.max((m - e).abs() / (4.0 * se + bias.abs()));
            }
        }
    }
    assert!(worst.0 <= 1.0, "grid: {} error bounds", worst.0);
    assert!(worst.1 <= 1.0, "Monte Carlo: {} of 4 SE + bias", worst.1);
    worst
}

/// The elastic wall (grid_impact_linear, r = 1, c = 1): the impact rate
/// ∫_{v<0} |v| p(y_b, v) dv = p_x(y_b)·σ_v/√(2π) and the mean impact speed σ_v·√(π/2) of the
/// barrier-free Gaussian restricted to y > y_b, and the crossing rate of y (a separable
/// density), by the grid within its stated error and by Monte Carlo within 4 standard
/// errors; the files, the figures and `summary.json`'s keys; the method distances as
/// defined, and the worst on the console.
#[test]
fn the_elastic_wall_by_both_methods() {
    let dir = scratch("elastic");
    let out = dir.join("out");
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/models/grid_impact_linear.sde"
    );
    let o = fpsolve(&[
        "reliability",
        model,
        "--set",
        "c=1",
        "--safe",
        "y < 1.5",
        "--cells",
        "60,120",
        "--times",
        "0:20:6",
        "--paths",
        "2000",
        "--horizon",
        "500",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    println!("{stdout}");
    for file in [
        "crossings_y.csv",
        "crossings_y.png",
        "crossings_y.svg",
        "impact_speeds_y_lower.csv",
    ] {
        assert!(names(&out).contains(&file.to_string()), "{file}");
    }
    // The velocity's crossings have no finite rate: no table, the reason in the summary.
    assert!(!out.join("crossings_v.csv").exists());
    let (g, m) = check_crossings(
        &out.join("crossings_y.csv"),
        &exact_rate(1.0, 0.0, -0.5),
        true,
    );
    println!("crossings of y: grid within {g:.2} of its error, MC within {m:.2} of 4 SE + bias");

    let s = json(&out.join("summary.json"));
    assert_eq!(s["stationary"]["status"], "computed");
    assert_eq!(s["stationary"]["mc"]["trajectories"], 4096);
    assert_eq!(s["crossings"][0]["file"], "crossings_y.csv");
    let no: Vec<&str> = s["no_crossings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["quantity"].as_str().unwrap())
        .collect();
    assert_eq!(no, ["v", "ydot"]);
    // σ_v² = 1/2 and the Gaussian restricted to y > −0.5.
    let sv = 0.5f64.sqrt();
    let rate = exact_rate(1.0, 0.0, -0.5)(-0.5);
    let speed = sv * (PI / 2.0).sqrt();
    let impacts = s["impacts"].as_array().unwrap();
    assert_eq!(impacts.len(), 2);
    for i in impacts {
        let (r, w) = (
            i["rate"].as_f64().unwrap(),
            i["mean_speed"].as_f64().unwrap(),
        );
        let (er, ew) = match i["method"].as_str().unwrap() {
            "grid" => (
                i["rate_error"].as_f64().unwrap(),
                i["mean_speed_error"].as_f64().unwrap(),
            ),
            "mc" => (
                4.0 * i["stderr"][0].as_f64().unwrap(),
                4.0 * i["stderr"][1].as_f64().unwrap(),
            ),
            other => panic!("{other}"),
        };
        println!(
            "{}: impact rate {r:.6} ± {er:.1e} (exact {rate:.6}), mean speed {w:.6} ± {ew:.1e} \
             (exact {speed:.6})",
            i["method"]
        );
        assert!((r - rate).abs() <= er && (w - speed).abs() <= ew, "{i}");
        assert_eq!(i["mean_power"], 0.0);
    }

    // The distances: |grid − MC| / (MC SE + grid error), as the summary's numbers give them.
    let d = &s["method_distances"];
    assert_eq!(d["flag_above_se"], 3.0);
    let r = d["reliability"].as_array().unwrap();
    assert_eq!(r.len(), 6);
    let mut all: Vec<&serde_json::Value> = r.iter().collect();
    all.push(&d["mean_at_start"]);
    assert_eq!(d["mean_at_start"]["number"], "mean_at_start");
    assert_eq!(
        d["mean_at_start"]["mc"], s["mc"]["mean"]["value"],
        "{}",
        d["mean_at_start"]
    );
    let mut worst = 0.0f64;
    for e in &all {
        let f = |k: &str| e[k].as_f64().unwrap();
        if e["distance"].is_null() {
            // R(0) = 1 by both, neither with an error (Monte Carlo's on the grid's side,
            // above 1, is none).
            assert!(f("grid") == f("mc") && f("mc_stderr") == 0.0, "{e}");
            continue;
        }
        let expected = (f("grid") - f("mc")).abs() / (f("mc_stderr") + f("grid_error"));
        assert!(
            (f("distance") - expected).abs() <= 1e-12 * expected.max(1.0),
            "{e}"
        );
        worst = worst.max(f("distance"));
    }
    for (k, e) in r.iter().enumerate() {
        assert_eq!(e["t"], s["grid"]["times"][k]);
        assert_eq!(e["grid"], s["grid"]["reliability"][k]);
        assert_eq!(e["mc"], s["mc"]["reliability"][k]);
    }
    assert_eq!(d["worst"]["distance"].as_f64().unwrap(), worst);
    assert!(
        stdout.contains(&format!(
            "method distance |grid - MC| / (MC SE + grid error): worst {worst:.2}"
        )),
        "{stdout}"
    );
    // The run is consistent: no number flagged.
    assert!(worst <= 1.0 && !stdout.contains("flagged"), "{stdout}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A separable density without a wall (the Duffing oscillator, μ = 0.1, c = 1), the grid
/// alone: the crossing rates of the state and of the observable y = z are the exact
/// p_x(u)·σ_v/√(2π) within the grid's stated error; no Monte Carlo columns, no distances.
#[test]
fn the_duffing_crossing_rates_from_the_grid_alone() {
    let dir = scratch("duffing");
    let out = dir.join("out");
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/duffing.sde");
    let o = fpsolve(&[
        "reliability",
        model,
        "--set",
        "c=1",
        "--safe",
        "abs(z) < 2",
        "--cells",
        "60,120",
        "--method",
        "grid",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let exact = exact_rate(1.0, 0.1, f64::NEG_INFINITY);
    for q in ["z", "y"] {
        let (g, _) = check_crossings(&out.join(format!("crossings_{q}.csv")), &exact, false);
        println!("crossings of {q}: grid within {g:.2} of its error");
    }
    let s = json(&out.join("summary.json"));
    assert!(s.get("method_distances").is_none() && s.get("impacts").is_none());
    assert!(s["stationary"].get("mc").is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The randomly accelerated particle (no stationary density) from the command line: refused
/// without `--domain` (exit 2, naming the flag), and with it the mean exit time within the
/// grid's stated error plus 3 standard errors of the independent reference 2.312577 ±
/// 0.002819 (tests/passage.rs, `RA_MEAN`); no crossing tables, and why in the summary.
#[test]
fn the_randomly_accelerated_particle_from_the_command_line() {
    let dir = scratch("free");
    let out = dir.join("out");
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/models/random_acceleration.sde"
    );
    let o = fpsolve(&[
        "reliability",
        model,
        "--method",
        "grid",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--domain x=LO:HI,v=LO:HI"), "{stderr}");
    assert!(!out.exists());
    let o = fpsolve(&[
        "reliability",
        model,
        "--method",
        "grid",
        "--domain",
        "x=-1.05:1.05,v=-8:8",
        "--cells",
        "100,200",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let s = json(&out.join("summary.json"));
    let (mean, stated) = (
        s["grid"]["mean_at_start"].as_f64().unwrap(),
        s["grid"]["errors"]["mean_at_start"].as_f64().unwrap(),
    );
    let (reference, se) = (2.312577, 0.002819);
    println!("T {mean:.6} ± {stated:.1e} (reference {reference} ± {se})");
    assert!((mean - reference).abs() <= stated + 3.0 * se);
    // The box given, moved along x by less than a cell to put the set's ends on faces.
    let d = &s["grid"]["report"]["domain"];
    let cell = 2.1 / 100.0;
    for (k, given) in [-1.05, 1.05].into_iter().enumerate() {
        assert!((d["x"][k].as_f64().unwrap() - given).abs() < cell, "{d}");
    }
    assert_eq!(d["v"], serde_json::json!([-8.0, 8.0]));
    assert_eq!(s["stationary"]["status"], "not_computed");
    assert!(s.get("crossings").is_none());
    assert!(!names(&out).iter().any(|n| n.starts_with("crossings_")));
    assert!(
        stdout.contains("impacts: not computed (no stationary density"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
