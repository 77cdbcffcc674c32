//! Rice's up-crossing rates and the impact statistics at a wall, from EPC, EPC with the exact
//! impact condition and the grid, against exact answers: the linear oscillator's Gaussian,
//! the Duffing oscillator's separable density p_x(x)·N(0, σ_v²), and, for an elastic wall,
//! the barrier-free density restricted to the domain (beside Monte Carlo's impact count).

mod common;
use common::simpson;
use std::f64::consts::PI;
use std::path::Path;

use fpsolve::density::JointDensity;
use fpsolve::epc::Epc;
use fpsolve::epc_impact::EpcImpact;
use fpsolve::fpk::FpkOperator;
use fpsolve::grid::GridSolver;
use fpsolve::mc::{Grid, McConfig, Simulation};
use fpsolve::model::{load_model, BoundModel, Override};
use fpsolve::observe::{crossing_rate, impact_statistics, CrossingError, LevelRate};

fn bound(path: &str, set: &[(&str, f64)]) -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let model = load_model(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let overrides: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    model.bind(&overrides).unwrap()
}

/// The models' f = c/(πK) = 0.2: σ_v² = 1/f = 5 for both, σ_x² = 5 for the linear one.
const F: f64 = 0.2;

/// The Duffing oscillator's unnormalised p_x (μ = 0 for the linear one).
fn potential(x: f64, mu: f64) -> f64 {
    (-F * (x * x / 2.0 + mu * x.powi(4) / 4.0)).exp()
}

/// Exact ν⁺(u) = p_x(u)·σ_v/√(2π) for the separable energy density.
fn exact_rate(mu: f64) -> impl Fn(f64) -> f64 {
    let norm = simpson(&|x| potential(x, mu), -30.0, 30.0, 40000);
    let sv = (1.0 / F).sqrt();
    move |u| potential(u, mu) / norm * sv / (2.0 * PI).sqrt()
}

/// The largest relative error of `rates` at `levels` against `exact`.
fn worst(levels: &[f64], rates: &[f64], exact: &dyn Fn(f64) -> f64) -> f64 {
    levels
        .iter()
        .zip(rates)
        .map(|(&u, r)| (r - exact(u)).abs() / exact(u))
        .fold(0.0, f64::max)
}

const LEVELS: [f64; 7] = [-6.0, -3.0, -1.0, 0.0, 1.5, 3.0, 6.0];

#[test]
fn rice_rates_of_linear_and_duffing_from_epc_are_exact() {
    for (file, mu, degree) in [
        ("models/linear.sde", 0.0, 2),
        ("models/duffing.sde", 0.1, 4),
    ] {
        let b = bound(file, &[]);
        let sol = Epc::new(&FpkOperator::derive(&b).unwrap())
            .degree(degree)
            .solve()
            .unwrap();
        let exact = exact_rate(mu);
        for rate in [
            LevelRate::of_state(&b, 0).unwrap(),
            LevelRate::of_observable(&b, "y").unwrap(),
        ] {
            let curve = crossing_rate(&sol, &rate, &LEVELS).unwrap();
            let err = worst(&LEVELS, &curve.rate, &exact);
            println!(
                "{file} EPC-{degree}: {} worst relative error {err:.2e} (stated {:.0e})",
                curve.quantity, curve.accuracy
            );
            assert!(err < 1e-8, "{file}: {err:e}");
        }
        // The velocity is driven by the noise: no rate, a typed reason.
        assert!(matches!(
            LevelRate::of_observable(&b, "ydot"),
            Err(CrossingError::NoiseDriven { .. })
        ));
    }
}

#[test]
fn rice_rates_of_linear_and_duffing_from_the_grid() {
    for (file, mu) in [("models/linear.sde", 0.0), ("models/duffing.sde", 0.1)] {
        let b = bound(file, &[]);
        let sol = GridSolver::new(&b)
            .cells(160, 320)
            .estimate(false)
            .solve()
            .unwrap();
        let exact = exact_rate(mu);
        let curve = crossing_rate(&sol, &LevelRate::of_state(&b, 0).unwrap(), &LEVELS).unwrap();
        let err = worst(&LEVELS, &curve.rate, &exact);
        // Within |u| ≤ 3 (1.3σ of the linear oscillator), where the rates are large; the
        // grid's relative error grows in the far tail (u = ±6: p_x is e^−10 of its peak for
        // the Duffing oscillator), which its own estimate, not the curve's quadrature
        // accuracy, has to state.
        let near = worst(&LEVELS[1..6], &curve.rate[1..6], &exact);
        println!(
            "{file} grid 160x320: within |u| <= 3 worst relative error {near:.2e}, at ±6 {err:.2e}"
        );
        assert!(near < 2e-3 && err < 0.2, "{file}: {near:e} {err:e}");
    }
}

/// grid_impact_linear: σ_x = σ_v = √5, elastic wall at yb = −0.5, the Gaussian restricted to
/// y > yb: λ = p_x(yb)·σ_v/√(2π)/P(y > yb), E_q[w] = σ_v·√(π/2), no power dissipated.
fn elastic_wall_exact() -> (f64, f64) {
    let s = 5f64.sqrt();
    let yb = -0.5;
    let above = simpson(&|y| potential(y, 0.0), yb, 40.0, 40000);
    let px = potential(yb, 0.0) / above;
    (px * s / (2.0 * PI).sqrt(), s * (PI / 2.0).sqrt())
}

#[test]
fn elastic_wall_impact_rate_from_grid_and_epc_impact_is_the_free_flux() {
    let b = bound("tests/models/grid_impact_linear.sde", &[]);
    let (rate, speed) = elastic_wall_exact();
    let speeds = [0.0, 1.0, 3.0];
    let grid = GridSolver::new(&b)
        .cells(160, 320)
        .estimate(false)
        .solve()
        .unwrap();
    let epc = EpcImpact::new(&b).solve(2).unwrap();
    let sv = 5f64.sqrt();
    for (method, density, tol) in [
        ("grid 160x320", &grid as &dyn JointDensity, 3e-3),
        ("EPC-impact 2", &epc as &dyn JointDensity, 1e-8),
    ] {
        let s = impact_statistics(density, &b, &b.impacts()[0], &speeds).unwrap();
        let e_rate = (s.rate - rate) / rate;
        let e_speed = (s.mean_speed - speed) / speed;
        println!(
            "{method}: impact rate {:.6} (exact {rate:.6}, {e_rate:+.1e}), mean speed {:.6} \
             (exact {speed:.6}, {e_speed:+.1e}), power {:.1e}",
            s.rate, s.mean_speed, s.mean_power
        );
        assert!(e_rate.abs() < tol && e_speed.abs() < tol, "{method}");
        assert!(s.mean_power.abs() < 1e-12, "{method}: {}", s.mean_power);
        // The flux-weighted speed PDF is the Rayleigh law w/σ_v²·exp(−w²/(2σ_v²)).
        for (w, q) in speeds.iter().zip(&s.speed_pdf) {
            let exact = w / (sv * sv) * (-w * w / (2.0 * sv * sv)).exp();
            assert!(
                (q - exact).abs() < 10.0 * tol * (1.0 / sv),
                "{method} w={w}: {q}"
            );
        }
    }
}

/// Newton's law with r < 1: the power is (1 − r²)/2·E_q[w²]·λ from the same density, and the
/// grid and EPC-impact agree on the rate (no exact density is known).
#[test]
fn inelastic_wall_power_is_the_lost_kinetic_energy_per_unit_time() {
    let b = bound("tests/models/grid_impact_linear.sde", &[("r", 0.8)]);
    let grid = GridSolver::new(&b)
        .cells(160, 320)
        .estimate(false)
        .solve()
        .unwrap();
    let s = impact_statistics(&grid, &b, &b.impacts()[0], &[]).unwrap();
    // E_q[w²] = ∫ |v|³ p / λ along the wall, by Simpson on the grid's interpolant.
    let third = simpson(&|v| (-v).powi(3) * grid.pdf(-0.5, v), -40.0, 0.0, 40000);
    let power = 0.5 * (1.0 - 0.64) * third;
    println!(
        "grid r=0.8: rate {:.6}, mean speed {:.6}, power {:.6} (Simpson {power:.6})",
        s.rate, s.mean_speed, s.mean_power
    );
    assert!((s.mean_power - power).abs() < 1e-6 * power);
}

/// Monte Carlo's impact count, the judge: within 4 standard errors of the exact rate.
#[test]
fn elastic_wall_impact_rate_agrees_with_monte_carlo() {
    let b = bound("tests/models/grid_impact_linear.sde", &[]);
    let config = McConfig {
        trajectories: 1024,
        samples: 400,
        seed: 11,
        grids: vec![
            ("y".into(), Grid::new(-0.5, 8.0, 16).unwrap()),
            ("v".into(), Grid::new(-8.0, 8.0, 16).unwrap()),
        ],
        ..McConfig::default()
    };
    let res = Simulation::new(&b, &config).unwrap().run().unwrap();
    let impacts = res.impacts.as_ref().unwrap();
    let (rate, _) = elastic_wall_exact();
    let t = (impacts.rate.value - rate) / impacts.rate.stderr;
    println!(
        "Monte Carlo: impact rate {:.5} ± {:.5} (exact {rate:.5}, {t:+.1} se), bias {:?}",
        impacts.rate.value, impacts.rate.stderr, impacts.time_step_bias
    );
    assert!(t.abs() < 4.0, "{t:.1} standard errors");
}

/// The Zhuravlev form (vibro_duffing.sde with r = 1, ε = 0: the Duffing density in z, folded
/// by y = |z|): the up-crossings of the user's y at u are both branches of z,
/// 2·p_x(u)·σ_v/√(2π), and at u = 0 (the limit from above) the impact rate, every crossing of
/// z = 0 — in the user's coordinates though EPC solved the transformed model.
#[test]
fn folded_observable_of_the_zhuravlev_form_counts_both_branches() {
    let b = bound("models/vibro_duffing.sde", &[("r", 1.0), ("eps", 0.0)]);
    let sol = Epc::new(&FpkOperator::derive(&b).unwrap())
        .degree(4)
        .solve()
        .unwrap();
    let exact = exact_rate(0.1);
    let levels = [0.0, 0.5, 2.0, 5.0];
    let y = crossing_rate(&sol, &LevelRate::of_observable(&b, "y").unwrap(), &levels).unwrap();
    let err = worst(&levels, &y.rate, &|u| 2.0 * exact(u));
    println!(
        "vibro_duffing r=1 EPC-4: y up-crossing rate at 0+ {:.6} (the impact rate), worst \
         relative error {err:.2e}",
        y.rate[0]
    );
    assert!(err < 1e-8, "{err:e}");
    assert!(matches!(
        LevelRate::of_observable(&b, "ydot"),
        Err(CrossingError::NoiseDriven { .. })
    ));
}

/// Reads `crossings_<q>.csv`: the header and the rows.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.parse().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    (header, rows)
}

/// The main job writes every method's Rice rate curve with, for the grid, an error bound per
/// level that covers the exact rate at every level written (the linear oscillator:
/// ν⁺(u) = exp(−u²/10)/(2π)), lists the noise-driven velocity as having none, and states at
/// an elastic wall an impact rate and mean speed whose error bounds cover the exact ones.
#[test]
fn the_main_job_writes_crossing_rates_and_impacts_whose_errors_cover_the_exact_ones() {
    use fpsolve::job::{Job, JobSpec};
    use fpsolve::report::OutputDir;
    let dir = std::env::temp_dir().join(format!("fpsolve-crossing-job-{}", std::process::id()));
    let spec = JobSpec {
        degrees: vec![2],
        methods: "epc,grid".parse().unwrap(),
        methods_named: true,
        cells: [100, 200],
        figures: false,
        ..JobSpec::default()
    };
    let mut last = None;
    for (file, mu) in [("models/linear.sde", 0.0), ("models/duffing.sde", 0.1)] {
        let model = load_model(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file)).unwrap();
        let report = Job::new(&model, &spec)
            .run(&OutputDir::create(&dir).unwrap())
            .unwrap();
        let (header, rows) = read_csv(&dir.join("crossings_z.csv"));
        assert_eq!(header, ["u", "epc_n2", "grid", "grid_error"]);
        let exact = exact_rate(mu);
        let (mut worst, mut bounded) = (0.0f64, 0);
        let peak = rows.iter().map(|r| r[2]).fold(0.0, f64::max);
        for row in &rows {
            let (u, epc, grid, error) = (row[0], row[1], row[2], row[3]);
            if mu == 0.0 {
                // EPC at n = 2 is exact for the linear oscillator.
                assert!((epc - exact(u)).abs() <= 1e-8 * exact(u), "EPC at {u}");
            }
            // No bound below 1e−5 of the peak rate (the estimate's tail level): an empty
            // field.
            assert_eq!(error.is_nan(), grid < 1e-5 * peak, "{file} at {u}");
            if error.is_nan() {
                continue;
            }
            bounded += 1;
            assert!(
                (grid - exact(u)).abs() <= error,
                "{file}: grid at {u}: {grid} vs {} (error bound {error})",
                exact(u)
            );
            worst = worst.max((grid - exact(u)).abs() / error);
        }
        println!(
            "{file}: {} levels, {bounded} with a bound, worst grid error / bound {worst:.2}",
            rows.len()
        );
        assert!(bounded > rows.len() / 2);
        last = Some(report);
    }
    let report = last.unwrap();
    let reasons = &report.reliability.no_crossings;
    assert!(reasons.iter().any(|r| r.quantity == "v"), "{reasons:?}");

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_linear.sde");
    let model = load_model(&path).unwrap();
    let spec = JobSpec {
        degrees: vec![2],
        methods: "grid".parse().unwrap(),
        methods_named: true,
        cells: [100, 200],
        figures: false,
        ..JobSpec::default()
    };
    let walled = dir.join("wall");
    let report = Job::new(&model, &spec)
        .run(&OutputDir::create(&walled).unwrap())
        .unwrap();
    let (rate, speed) = elastic_wall_exact();
    let wall = &report.reliability.impacts[0];
    println!(
        "impact rate {} ± {:?} (exact {rate}), mean speed {} ± {:?} (exact {speed})",
        wall.rate, wall.rate_error, wall.mean_speed, wall.mean_speed_error
    );
    assert!((wall.rate - rate).abs() <= wall.rate_error.unwrap());
    assert!((wall.mean_speed - speed).abs() <= wall.mean_speed_error.unwrap());
    assert!(walled.join(&wall.speed_pdf_file).is_file());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_method_without_an_error_says_so_at_the_wall_and_is_measured_against_the_grid() {
    // EPC-impact's impact numbers carry no error bound: the row says so and gives its
    // distance from the grid's row.
    let model = format!(
        "{}/models/vibro_impact_duffing.sde",
        env!("CARGO_MANIFEST_DIR")
    );
    let out = std::env::temp_dir().join(format!("fpsolve-crossing-epc-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args([
            model.as_str(),
            "--method",
            "epc-impact,grid",
            "--cells",
            "64,128",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let rows = summary["impacts"].as_array().unwrap();
    let grid = rows.iter().find(|r| r["method"] == "grid").unwrap();
    assert!(grid.get("no_error_bound").is_none() && grid["rate_error"].as_f64().unwrap() > 0.0);
    let epc: Vec<_> = rows
        .iter()
        .filter(|r| r["method"].as_str().unwrap().starts_with("epc_impact"))
        .collect();
    assert!(!epc.is_empty());
    for r in epc {
        assert!(r["no_error_bound"]
            .as_str()
            .unwrap()
            .contains("states no error"));
        assert!(r.get("rate_error").is_none());
        let d = r["minus_grid"][0].as_f64().unwrap();
        let want = r["rate"].as_f64().unwrap() - grid["rate"].as_f64().unwrap();
        assert_eq!(d, want);
    }
    let _ = std::fs::remove_dir_all(&out);
}
