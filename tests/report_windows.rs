//! The curves a job writes cover the domain of their quantity: with a wall, the curve starts
//! (or ends) exactly on it and holds the whole mass. A linear oscillator with an elastic wall
//! (r = 1) has the unconstrained Gaussian restricted to its domain as its exact stationary
//! density, so every written curve is checked against it: walls below and above the rest
//! position, on both sides, and an asymmetric strip; the grid solver and EPC-impact each
//! alone (the methods that solve the model as written), and with EPC (which solves the
//! Zhuravlev transform). The Monte Carlo histogram of a job uses the same window: no sample
//! falls outside it.

mod common;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use fpsolve::job::{Job, JobReport, JobSpec};
use fpsolve::mc::{McConfig, McWarning};
use fpsolve::model::parse_model;
use fpsolve::report::OutputDir;

/// Var y = Var ẏ = πK/(c·k) = 2.5 for c = 0.2, k = 1, 2πK = 1.
const VARIANCE: f64 = 2.5;

/// The oscillator with the `impact`/`domain` lines `walls`.
fn model(walls: &str) -> String {
    format!(
        "model wall\nparam c = 0.2, k = 1\nparam K = 1/(2*pi)\nstate y, ydot\n\
         drift y: ydot\ndrift ydot: -c*ydot - k*y\nnoise xi: intensity 2*pi*K\n\
         diffusion ydot: xi\ninterpretation: stratonovich\n{walls}"
    )
}

/// The position's domain and the model lines that make it.
fn cases() -> Vec<([f64; 2], String)> {
    let below = |b: f64| {
        (
            [b, f64::INFINITY],
            format!("impact y = {b}: ydot -> -ydot\ndomain y >= {b}\n"),
        )
    };
    let above = |b: f64| {
        (
            [f64::NEG_INFINITY, b],
            format!("impact y = {b}: ydot -> -ydot\ndomain y <= {b}\n"),
        )
    };
    vec![
        below(0.3),
        below(0.5),
        below(-0.3),
        above(-0.3),
        above(-0.5),
        above(0.3),
        (
            [-0.4, 1.0],
            "impact y = -0.4: ydot -> -ydot\nimpact y = 1: ydot -> -ydot\n".into(),
        ),
    ]
}

/// The exact density of y: N(0, VARIANCE) restricted to `domain`, renormalised.
fn exact(domain: [f64; 2]) -> impl Fn(f64) -> f64 {
    let s = VARIANCE.sqrt();
    let phi = move |t: f64| (-t * t / (2.0 * VARIANCE)).exp() / (s * (2.0 * PI).sqrt());
    let clip = |t: f64| t.clamp(-12.0 * s, 12.0 * s);
    let mass = fpsolve::observe::integrate_adaptive(&phi, clip(domain[0]), clip(domain[1]), 1e-12);
    move |t: f64| {
        if t >= domain[0] && t <= domain[1] {
            phi(t) / mass
        } else {
            0.0
        }
    }
}

/// A written CSV: its header and its columns.
fn columns(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols = vec![Vec::new(); header.len()];
    for l in lines {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse().unwrap_or(f64::NAN));
        }
    }
    (header, cols)
}

fn trapezoid(x: &[f64], p: &[f64]) -> f64 {
    x.windows(2)
        .zip(p.windows(2))
        .map(|(x, p)| 0.5 * (p[0] + p[1]) * (x[1] - x[0]))
        .sum()
}

/// Runs the main job of `text` by `methods` into a scratch directory: the directory and the
/// report.
fn job(text: &str, methods: &str, tag: &str, mc: Option<McConfig>) -> (PathBuf, JobReport) {
    let model = parse_model(text, None).unwrap();
    let spec = JobSpec {
        degrees: vec![2],
        methods: methods.parse().unwrap(),
        methods_named: true,
        mc,
        ..JobSpec::default()
    };
    let dir = common::scratch(tag);
    let report = Job::new(&model, &spec)
        .run(&OutputDir::create(&dir).unwrap())
        .unwrap();
    (dir, report)
}

#[test]
fn every_curve_covers_its_domain_and_holds_the_whole_mass() {
    let mut failures = Vec::new();
    for (k, (domain, walls)) in cases().into_iter().enumerate() {
        let text = model(&walls);
        let strip = domain[0].is_finite() && domain[1].is_finite();
        let mut methods = vec!["grid", "epc-impact"];
        if !strip {
            // EPC solves the Zhuravlev transform of a single wall: the union of its window
            // and the others'.
            methods.push("epc,grid");
        }
        let p = exact(domain);
        for methods in methods {
            let (dir, _) = job(&text, methods, &format!("window-{k}-{methods}"), None);
            let (header, cols) = columns(&dir.join("pdf_y.csv"));
            let x = &cols[0];
            let (first, last) = (x[0], x[x.len() - 1]);
            // The walls are the curve's end points, exactly.
            if domain[0].is_finite() && first != domain[0] {
                failures.push(format!("{walls:?} {methods}: starts at {first}"));
            }
            if domain[1].is_finite() && last != domain[1] {
                failures.push(format!("{walls:?} {methods}: ends at {last}"));
            }
            for (name, pdf) in header.iter().zip(&cols).skip(1) {
                let mass = trapezoid(x, pdf);
                let diff: Vec<f64> = x.iter().zip(pdf).map(|(&t, v)| (v - p(t)).abs()).collect();
                let l1 = trapezoid(x, &diff);
                eprintln!("{walls:?} {methods} {name}: [{first}, {last}], mass {mass:.6}, L1 to exact {l1:.2e}");
                // The grid's own error is about 1e-4 (its estimate), EPC-impact's at n = 2 that
                // of its quadrature (the Gaussian is exact for it); EPC's closure of the
                // Zhuravlev transform is not exact for a wall away from 0 (L1 0.03 to 0.06).
                let (mass_tol, l1_tol) = if name.starts_with("epc_n") {
                    (1e-2, 0.1)
                } else {
                    (2e-3, 2e-3)
                };
                if (mass - 1.0).abs() > mass_tol || l1 > l1_tol {
                    failures.push(format!(
                        "{walls:?} {methods} {name}: mass {mass}, L1 to exact {l1}"
                    ));
                }
            }
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn the_monte_carlo_histogram_of_a_job_starts_on_the_wall_and_misses_no_sample() {
    let text = model("impact y = 0.3: ydot -> -ydot\ndomain y >= 0.3\n");
    let mc = McConfig {
        trajectories: 256,
        samples: 200,
        seed: 11,
        ..McConfig::default()
    };
    let (dir, report) = job(&text, "grid", "window-mc", Some(mc));
    let mc = report.mc.as_ref().expect("a Monte Carlo result");
    let y = mc.quantity("y").unwrap();
    assert_eq!(y.grid.lo, 0.3, "{:?}", y.grid);
    assert_eq!((y.underflow, y.overflow), (0, 0));
    assert!(
        fpsolve::job::flags(&report).is_empty(),
        "{:?}",
        fpsolve::job::flags(&report)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn samples_outside_a_histogram_grid_are_a_flagged_warning() {
    let text = model("impact y = 0.3: ydot -> -ydot\ndomain y >= 0.3\n");
    // A grid for y that stops at 2 (the user's `--grid y=0.3:2:40`): about a quarter of the
    // samples lie above it.
    let mc = McConfig {
        trajectories: 256,
        samples: 200,
        seed: 11,
        grids: vec![("y".into(), fpsolve::mc::Grid::new(0.3, 2.0, 40).unwrap())],
        ..McConfig::default()
    };
    let (dir, report) = job(&text, "grid", "window-outside", Some(mc));
    let result = report.mc.as_ref().expect("a Monte Carlo result");
    let y = result.quantity("y").unwrap();
    assert!(
        y.overflow > y.samples / 10,
        "{} of {}",
        y.overflow,
        y.samples
    );
    let warning = result
        .warnings
        .iter()
        .find(|w| matches!(w, McWarning::OutsideGrid { quantity, .. } if quantity == "y"))
        .expect("an outside-grid warning");
    assert!(warning.flags_a_comparison());
    let flags = fpsolve::job::flags(&report);
    assert_eq!(flags.len(), 1, "{flags:?}");
    // In the table and in summary.json too.
    assert!(report.to_string().contains("above it"), "{report}");
    let summary = common::json(&dir.join("summary.json"));
    let warnings = summary["monte_carlo"]["warnings"].as_array().unwrap();
    assert!(
        warnings.iter().any(|w| w["warning"] == "outside-grid"),
        "{warnings:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
