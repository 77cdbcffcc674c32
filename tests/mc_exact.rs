//! Monte Carlo against exact stationary solutions, with tolerances from the run's own
//! standard errors.

use fpsolve::mc::reference::{
    linear_oscillator, reflecting_vibro_impact, vibro_impact, VibroImpact,
};
use fpsolve::mc::{
    merge_shards, Grid, McConfig, McResult, QuantityHistogram, SchemeChoice, Shard, ShardOutput,
    Simulation,
};
use fpsolve::model::BoundModel;

mod common;
use common::exact::{cases, ExactCase, McTolerance};

/// Simpson's rule with `n` (even) panels.
fn simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// Checks a histogram against the exact density's bin averages on every bin whose exact
/// value is above 1e-3 of the peak: |mc − exact| < `tol` standard errors. Returns the largest
/// deviation in standard errors.
fn check_density(q: &QuantityHistogram, exact: &dyn Fn(f64) -> f64, tol: &McTolerance) -> f64 {
    let g = q.grid;
    let w = g.width();
    let exact_bins: Vec<f64> = (0..g.bins)
        .map(|j| {
            let a = g.lo + j as f64 * w;
            simpson(exact, a, a + w, 16) / w
        })
        .collect();
    let peak = exact_bins.iter().cloned().fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for (j, &exact_j) in exact_bins.iter().enumerate() {
        if exact_j < 1e-3 * peak {
            continue;
        }
        checked += 1;
        assert!(q.stderr[j] > 0.0, "{} bin {j} has no spread", q.name);
        let z = (q.density[j] - exact_j) / q.stderr[j];
        assert!(
            z.abs() < tol.standard_errors,
            "{} bin {j} at {:.3}: mc {:.5} ± {:.5}, exact {:.5} ({z:.1} se)",
            q.name,
            g.lo + (j as f64 + 0.5) * w,
            q.density[j],
            q.stderr[j],
            exact_j
        );
        worst = worst.max(z.abs());
    }
    assert!(checked > g.bins / 2, "only {checked} bins checked");
    worst
}

fn bind(m: fpsolve::model::Model) -> BoundModel {
    m.bind(&[]).unwrap()
}

/// The registry's cases that carry a Monte Carlo tolerance.
fn mc_cases() -> Vec<(ExactCase, McTolerance)> {
    let all: Vec<_> = cases()
        .into_iter()
        .filter_map(|c| c.mc.clone().map(|t| (c, t)))
        .collect();
    assert!(
        all.len() >= 4,
        "the registry checks Monte Carlo on {} cases",
        all.len()
    );
    all
}

/// A run of `case` whose states' grids cover ±5 exact standard deviations.
fn run_case(case: &ExactCase, scheme: SchemeChoice, seed: u64) -> (BoundModel, McResult) {
    let model = case.bind();
    let grids = (0..2)
        .map(|axis| {
            let half = 5.0 * case.variance(axis).sqrt();
            let name = model.states()[axis].to_string();
            (name, Grid::new(-half, half, 40).unwrap())
        })
        .collect();
    let config = McConfig {
        trajectories: 1024,
        lanes: 32,
        samples: 400,
        spacing: 0.5,
        seed,
        scheme,
        grids,
        ..McConfig::default()
    };
    let res = Simulation::new(&model, &config).unwrap().run().unwrap();
    (model, res)
}

/// Every exact case with a Monte Carlo tolerance, by the automatic scheme and by the general
/// one (Platen): each state's histogram against the exact marginal's bin averages, its
/// variance and mean (0: every case is symmetric) within the tolerance in standard errors.
#[test]
fn monte_carlo_reproduces_the_exact_cases() {
    for (case, tol) in mc_cases() {
        for scheme in [SchemeChoice::Auto, SchemeChoice::General] {
            let (model, res) = run_case(&case, scheme, 5);
            assert!(res.blowups.is_empty(), "{}", case.name);
            for axis in 0..2 {
                let name = model.states()[axis].to_string();
                let q = res.quantity(&name).unwrap();
                let worst = check_density(q, &|x| case.marginal(axis, x), &tol);
                let (var, mean) = (q.moments.variance, q.moments.mean);
                let exact = case.variance(axis);
                eprintln!(
                    "{} ({:?}, {name}): worst bin {worst:.2} se, Var {:.5} ± {:.5} vs {exact:.5}",
                    case.name, res.settings.scheme, var.value, var.stderr
                );
                assert!(
                    (var.value - exact).abs() < tol.standard_errors * var.stderr,
                    "{} {name}: Var {} ± {} vs {exact}",
                    case.name,
                    var.value,
                    var.stderr
                );
                assert!(
                    var.stderr < 0.03 * exact,
                    "error bar too wide: {}",
                    var.stderr
                );
                assert!(mean.value.abs() < tol.standard_errors * mean.stderr);
            }
        }
    }
}

/// The vibro-impact case with elastic impacts (r = 1) and no parametric noise: y = |z| has
/// p_Y(y) = 2 p_Z(y), and ydot = v·sgn(z) has v's law (z and v are independent).
#[test]
fn elastic_impacts_fold_the_displacement_density() {
    let (case, tol) = mc_cases()
        .into_iter()
        .find(|(c, _)| c.name == "vibro-impact r = 1, eps = 0")
        .expect("the registry's elastic vibro-impact case");
    let model = case.bind();
    let half = 5.0 * case.variance(0).sqrt();
    let vhalf = 5.0 * case.variance(1).sqrt();
    let config = McConfig {
        trajectories: 2048,
        lanes: 64,
        samples: 400,
        spacing: 0.5,
        seed: 11,
        grids: vec![
            ("y".into(), Grid::new(0.0, half, 40).unwrap()),
            ("ydot".into(), Grid::new(-vhalf, vhalf, 40).unwrap()),
        ],
        ..McConfig::default()
    };
    let res = Simulation::new(&model, &config).unwrap().run().unwrap();
    assert!(res.blowups.is_empty());
    let worst_y = check_density(
        res.quantity("y").unwrap(),
        &|y| 2.0 * case.marginal(0, y),
        &tol,
    );
    let worst_v = check_density(
        res.quantity("ydot").unwrap(),
        &|v| case.marginal(1, v),
        &tol,
    );
    eprintln!("worst deviations: y {worst_y:.2} se, ydot {worst_v:.2} se");
    // r = 1 maps v to itself, yet every crossing is an event.
    assert!(res.impacts.as_ref().unwrap().rate.value > 0.0);
}

/// The stationary E[v²] of the linear oscillator is S/(2c); the splitting's weak error in
/// it is O(dt²) (O(dt⁴)-exact in E[z²], so v² is the informative moment).
#[test]
fn weak_error_shrinks_at_second_order_when_dt_halves() {
    let (c, k, s) = (0.5, 1.0, 1.0);
    let exact = s / (2.0 * c);
    let model = bind(linear_oscillator(c, k, s));
    let run = |dt: f64| {
        let config = McConfig {
            dt,
            spacing: 1.0,
            trajectories: 1024,
            lanes: 32,
            samples: 1500,
            seed: 3,
            ..McConfig::default()
        };
        let v = Simulation::new(&model, &config).unwrap().run().unwrap();
        v.quantity("v").unwrap().moments.variance
    };
    let (coarse, fine) = (run(0.5), run(0.25));
    let (e1, e2) = (coarse.value - exact, fine.value - exact);
    let order = (e1 / e2).log2();
    // Propagated standard error of log2(e1/e2).
    let se =
        ((coarse.stderr / e1).powi(2) + (fine.stderr / e2).powi(2)).sqrt() / std::f64::consts::LN_2;
    eprintln!(
        "errors {e1:.5} ± {:.5}, {e2:.5} ± {:.5}: order {order:.2} ± {se:.2}",
        coarse.stderr, fine.stderr
    );
    assert!(se < 0.25, "too noisy to tell the order: ±{se}");
    assert!(
        (order - 2.0).abs() < 4.0 * se,
        "observed order {order} ± {se}"
    );
    assert!(
        (order - 1.0).abs() > 4.0 * se,
        "cannot tell order 2 from order 1"
    );
}

fn small_vibro_run() -> (Simulation, McConfig) {
    let p = VibroImpact {
        c: 0.2,
        k: 1.0,
        mu: 0.5,
        eps: 0.3,
        r: 0.8,
        big_k: 0.05,
    };
    let model = bind(vibro_impact(p));
    let config = McConfig {
        trajectories: 8 * 16,
        lanes: 16,
        samples: 50,
        seed: 99,
        ..McConfig::default()
    };
    (Simulation::new(&model, &config).unwrap(), config)
}

#[test]
fn results_are_bit_identical_across_thread_counts() {
    let (sim, _) = small_vibro_run();
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| sim.run().unwrap())
    };
    let one = run_with(1);
    let two = run_with(2);
    assert_eq!(
        serde_json::to_string(&one).unwrap(),
        serde_json::to_string(&two).unwrap()
    );
    assert_eq!(one, two);
    assert!(one.impacts.unwrap().count > 0);
}

#[test]
fn merged_shards_equal_the_unsharded_run_bit_for_bit() {
    let (sim, _) = small_vibro_run();
    let whole = sim.run().unwrap();
    for count in [2, 3, 8] {
        // Shards go through JSON, as on a cluster, and arrive in any order.
        let mut shards: Vec<ShardOutput> = (0..count)
            .rev()
            .map(|k| {
                let out = sim.run_shard(Shard::new(k, count).unwrap()).unwrap();
                serde_json::from_str(&serde_json::to_string(&out).unwrap()).unwrap()
            })
            .collect();
        let merged = merge_shards(&shards).unwrap();
        assert_eq!(
            serde_json::to_string(&merged).unwrap(),
            serde_json::to_string(&whole).unwrap()
        );
        assert_eq!(merged, whole);
        shards.pop();
        assert!(
            merge_shards(&shards).is_err(),
            "a missing shard must be an error"
        );
    }
}

#[test]
fn a_different_seed_gives_different_numbers() {
    let (sim, mut config) = small_vibro_run();
    let a = sim.run().unwrap();
    config.seed += 1;
    config.grids = a
        .quantities
        .iter()
        .map(|q| (q.name.clone(), q.grid))
        .collect();
    let model = bind(vibro_impact(VibroImpact {
        c: 0.2,
        k: 1.0,
        mu: 0.5,
        eps: 0.3,
        r: 0.8,
        big_k: 0.05,
    }));
    let b = Simulation::new(&model, &config).unwrap().run().unwrap();
    assert_ne!(
        a.quantities[0].moments.mean.value,
        b.quantities[0].moments.mean.value
    );
}

/// Checks that two runs estimate the same law: every histogram bin of `names` above 1% of
/// the peak, and the impact rate, agree within 4.5 combined standard errors. Returns the
/// worst bin deviation, both impact rates and their deviation, in standard errors.
fn same_law(
    a: &McResult,
    b: &McResult,
    names: &[&str],
) -> (f64, fpsolve::stats::Estimate, fpsolve::stats::Estimate, f64) {
    let mut worst: f64 = 0.0;
    for &name in names {
        let (qa, qb) = (a.quantity(name).unwrap(), b.quantity(name).unwrap());
        let peak = qa.density.iter().cloned().fold(0.0, f64::max);
        for j in 0..qa.grid.bins {
            if qa.density[j] < 1e-2 * peak {
                continue;
            }
            let se = (qa.stderr[j].powi(2) + qb.stderr[j].powi(2)).sqrt();
            let z = (qa.density[j] - qb.density[j]) / se;
            assert!(
                z.abs() < 4.5,
                "{name} bin {j}: {} vs {} ({z:.1} se)",
                qa.density[j],
                qb.density[j]
            );
            worst = worst.max(z.abs());
        }
    }
    let (ra, rb) = (
        a.impacts.as_ref().unwrap().rate,
        b.impacts.as_ref().unwrap().rate,
    );
    let z = (ra.value - rb.value) / (ra.stderr.powi(2) + rb.stderr.powi(2)).sqrt();
    (worst, ra, rb, z)
}

/// The Zhuravlev form (pass-through, v → r·v) and the original coordinates (reflection,
/// ẏ → −r·ẏ) are the same process for trajectories: their y and ẏ histograms must agree
/// within the two runs' combined error bars, for inelastic impacts and parametric noise.
#[test]
fn zhuravlev_and_reflecting_forms_agree_for_inelastic_impacts() {
    let p = VibroImpact {
        c: 0.3,
        k: 1.0,
        mu: 0.5,
        eps: 0.4,
        r: 0.6,
        big_k: 0.08,
    };
    let grids = || {
        vec![
            ("y".to_string(), Grid::new(0.0, 1.5, 30).unwrap()),
            ("ydot".to_string(), Grid::new(-1.5, 1.5, 30).unwrap()),
        ]
    };
    let config = |seed: u64| McConfig {
        trajectories: 2048,
        lanes: 64,
        samples: 300,
        spacing: 0.5,
        seed,
        grids: grids(),
        ..McConfig::default()
    };
    let zh = Simulation::new(&bind(vibro_impact(p)), &config(1))
        .unwrap()
        .run()
        .unwrap();
    let re = Simulation::new(&bind(reflecting_vibro_impact(p)), &config(2))
        .unwrap()
        .run()
        .unwrap();
    assert_eq!(
        re.quantity("y").unwrap().underflow,
        0,
        "the reflecting form left y ≥ 0"
    );
    let (worst, ra, rb, z) = same_law(&zh, &re, &["y", "ydot"]);
    eprintln!(
        "worst bin {worst:.2} se; impact rates {:.4} vs {:.4} ({z:.1} se)",
        ra.value, rb.value
    );
    assert!(z.abs() < 4.5);
}

#[test]
fn general_scheme_with_events_matches_the_splitting() {
    let p = VibroImpact {
        c: 0.3,
        k: 1.0,
        mu: 0.5,
        eps: 0.4,
        r: 0.6,
        big_k: 0.08,
    };
    let config = |seed: u64, scheme| McConfig {
        trajectories: 2048,
        lanes: 64,
        samples: 300,
        spacing: 0.5,
        seed,
        scheme,
        grids: vec![
            ("y".to_string(), Grid::new(0.0, 1.5, 30).unwrap()),
            ("ydot".to_string(), Grid::new(-1.5, 1.5, 30).unwrap()),
        ],
        ..McConfig::default()
    };
    let model = bind(vibro_impact(p));
    let a = Simulation::new(&model, &config(1, SchemeChoice::Auto))
        .unwrap()
        .run()
        .unwrap();
    let b = Simulation::new(&model, &config(2, SchemeChoice::General))
        .unwrap()
        .run()
        .unwrap();
    assert_eq!(b.settings.scheme, fpsolve::mc::SchemeKind::PlatenWeak2);
    let (worst, ra, rb, z) = same_law(&a, &b, &["y", "ydot"]);
    eprintln!(
        "general vs splitting: worst bin {worst:.2} se; impact rates {:.4} vs {:.4} ({z:.1} se)",
        ra.value, rb.value
    );
    assert!(z.abs() < 4.5);
}
