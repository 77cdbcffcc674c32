//! Monte Carlo's reliability statistics against exact values, with honest error bars: each
//! within 4 standard errors plus its stated bias (the time-step bias from the 2·dt run, and
//! for crossing rates the sample spacing's bias).
//! - an elastic wall on the linear oscillator: the density is the barrier-free Gaussian
//!   restricted to the domain, so the impact rate, the mean impact speed, the flux-weighted
//!   (Rayleigh) speed density and the up-crossing rates are known;
//! - the Duffing oscillator with additive noise: p = p_x(x)·N(0, σ_v²), ν⁺(u) = p_x(u)·σ_v/√(2π);
//! - a wall with restitution 0.8 in the main job: Monte Carlo's dissipated power against the
//!   grid's within the grid's stated error plus Monte Carlo's.

use std::f64::consts::PI;
use std::path::Path;

use fpsolve::job::{Job, JobSpec};
use fpsolve::mc::{CrossingRates, Grid, McConfig, Simulation};
use fpsolve::model::{load_model, BoundModel, Override};
use fpsolve::report::OutputDir;
use fpsolve::stats::Estimate;

fn bound(path: &str, set: &[(&str, f64)]) -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let model = load_model(&path).unwrap();
    let overrides: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    model.bind(&overrides).unwrap()
}

fn simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for k in 1..n {
        s += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// |estimate − exact| within 4 standard errors plus the stated bias; prints the comparison.
fn check(what: &str, e: Estimate, bias: f64, exact: f64) {
    let t = (e.value - exact) / e.stderr;
    println!(
        "{what}: mc {:.6} ± {:.2e} (bias {bias:+.2e}), exact {exact:.6}, {t:+.2} se",
        e.value, e.stderr
    );
    assert!(
        (e.value - exact).abs() <= 4.0 * e.stderr + bias.abs(),
        "{what}: {} vs {exact}",
        e.value
    );
}

/// The crossing rates of `c` at every level against `exact`.
fn check_crossings(c: &CrossingRates, exact: &dyn Fn(f64) -> f64) {
    for (k, &u) in c.levels.iter().enumerate() {
        let bias = c.spacing_bias[k].value + c.time_step_bias.as_ref().map_or(0.0, |b| b[k].value);
        check(
            &format!("{} crossings at u = {u}", c.quantity),
            c.rate[k],
            bias,
            exact(u),
        );
    }
}

/// The models' f = c/(πK) = 0.2: σ_v² = 5.
const F: f64 = 0.2;

/// Elastic wall at y = −0.5 (grid_impact_linear, σ_y = σ_v = √5): the Gaussian restricted
/// to y > −0.5. Impact rate p_y(yb)·σ_v/√(2π), mean speed σ_v·√(π/2), no power, the speeds
/// Rayleigh w/σ_v²·exp(−w²/(2σ_v²)), ν⁺(u) = p_y(u)·σ_v/√(2π) at and above the wall.
#[test]
fn elastic_wall_impacts_and_crossings_are_the_restricted_gaussians() {
    let b = bound("tests/models/grid_impact_linear.sde", &[]);
    // The wall's own level (up-crossed once per impact, Rice's flux leaving the wall) and
    // levels near it, where paths folded by an impact between samples cross twice.
    let levels = vec![-0.5, -0.45, -0.3, 0.0, 1.0, 2.5, 4.0];
    let speeds = Grid::new(0.0, 10.0, 10).unwrap();
    let config = McConfig {
        trajectories: 2048,
        samples: 2000,
        seed: 21,
        grids: vec![
            ("y".into(), Grid::new(-0.5, 10.0, 21).unwrap()),
            ("v".into(), Grid::new(-10.0, 10.0, 20).unwrap()),
        ],
        levels: vec![("y".into(), levels.clone())],
        impact_speeds: Some(speeds),
        ..McConfig::default()
    };
    let res = Simulation::new(&b, &config).unwrap().run().unwrap();
    let yb = -0.5;
    let sv = (1.0 / F).sqrt();
    let potential = |y: f64| (-F * y * y / 2.0).exp();
    let norm = simpson(&potential, yb, 40.0, 40000);
    let flux = |u: f64| potential(u) / norm * sv / (2.0 * PI).sqrt();
    let w = &res.impacts.as_ref().unwrap().walls[0];
    let bias = w.time_step_bias.map_or([0.0; 3], |b| b.map(|e| e.value));
    check("impact rate", w.rate, bias[0], flux(yb));
    check(
        "mean impact speed",
        w.mean_speed,
        bias[1],
        sv * (PI / 2.0).sqrt(),
    );
    // r = 1: each impact keeps its energy exactly.
    assert_eq!(w.mean_power.value, 0.0);
    // The bin averages of the Rayleigh density, from its distribution function.
    let d = w.speeds.as_ref().unwrap();
    let cdf = |w: f64| 1.0 - (-w * w / (2.0 * sv * sv)).exp();
    for (k, (&q, &se)) in d.density.iter().zip(&d.stderr).enumerate() {
        let (lo, hi) = (k as f64, k as f64 + 1.0);
        let exact = (cdf(hi) - cdf(lo)) / (hi - lo);
        check(
            &format!("speed density on [{lo}, {hi})"),
            Estimate {
                value: q,
                stderr: se,
            },
            0.0,
            exact,
        );
    }
    check_crossings(&res.crossings[0], &flux);
}

/// The Duffing oscillator x'' + c x' + x + μx³ = ξ with additive noise (models/duffing.sde,
/// μ = 0.1): ν⁺(u) = p_x(u)·σ_v/√(2π), p_x ∝ exp(−f(x²/2 + μx⁴/4)).
#[test]
fn duffing_crossing_rates_are_rices() {
    let b = bound("models/duffing.sde", &[]);
    let levels = vec![-6.0, -3.0, -1.0, 0.0, 1.5, 3.0, 6.0];
    let config = McConfig {
        trajectories: 2048,
        samples: 2000,
        seed: 8,
        levels: vec![(b.states()[0].to_string(), levels)],
        ..McConfig::default()
    };
    let res = Simulation::new(&b, &config).unwrap().run().unwrap();
    let mu = 0.1;
    let potential = |x: f64| (-F * (x * x / 2.0 + mu * x.powi(4) / 4.0)).exp();
    let norm = simpson(&potential, -30.0, 30.0, 40000);
    let sv = (1.0 / F).sqrt();
    check_crossings(&res.crossings[0], &|u| {
        potential(u) / norm * sv / (2.0 * PI).sqrt()
    });
}

/// Restitution 0.8 in the main job: Monte Carlo's row in `impacts` and the grid's agree on
/// the rate, the mean speed and the power within the grid's stated error plus 4 of Monte
/// Carlo's standard errors and its time-step bias; the tables carry Monte Carlo's columns.
#[test]
fn inelastic_wall_power_by_monte_carlo_is_the_grids() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_linear.sde");
    let model = load_model(&path).unwrap();
    let spec = JobSpec {
        overrides: vec![Override::number("r", 0.8)],
        methods: "grid".parse().unwrap(),
        methods_named: true,
        cells: [80, 160],
        mc: Some(McConfig {
            trajectories: 2048,
            samples: 1000,
            seed: 4,
            ..McConfig::default()
        }),
        ..JobSpec::default()
    };
    let tmp = std::env::temp_dir().join(format!("fpsolve-mc-reliability-{}", std::process::id()));
    let report = Job::new(&model, &spec)
        .run(&OutputDir::create(&tmp).unwrap())
        .unwrap();
    let rows = &report.reliability.impacts;
    let grid = rows.iter().find(|r| r.method == "grid").unwrap();
    let mc = rows.iter().find(|r| r.method == "mc").unwrap();
    let se = mc.stderr.unwrap();
    let bias = mc.time_step_bias.unwrap_or([0.0; 3]);
    for (what, g, e, m, k) in [
        ("rate", grid.rate, grid.rate_error, mc.rate, 0),
        (
            "mean speed",
            grid.mean_speed,
            grid.mean_speed_error,
            mc.mean_speed,
            1,
        ),
        (
            "mean power",
            grid.mean_power,
            grid.mean_power_error,
            mc.mean_power,
            2,
        ),
    ] {
        let e = e.expect("the grid states its error");
        println!(
            "{what}: mc {m:.6} ± {:.2e} (bias {:+.2e}), grid {g:.6} ± {e:.2e}",
            se[k], bias[k]
        );
        assert!((m - g).abs() <= e + 4.0 * se[k] + bias[k].abs(), "{what}");
    }
    assert!(mc.mean_power > 0.0);
    let speeds = std::fs::read_to_string(tmp.join(&mc.speed_pdf_file)).unwrap();
    assert!(
        speeds.starts_with("speed,grid,mc,mc_se\n"),
        "{}",
        &speeds[..40]
    );
    let crossings = std::fs::read_to_string(tmp.join("crossings_y.csv")).unwrap();
    assert!(crossings
        .lines()
        .next()
        .unwrap()
        .ends_with(",mc,mc_se,mc_bias"));
    std::fs::remove_dir_all(&tmp).unwrap();
}
