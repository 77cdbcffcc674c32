//! Unit tests of the trust layer: weak order, the bias estimate, stationarity, blow-up
//! verdicts and the pre-flight.

use super::*;
use crate::base::limits::MEMORY_LIMIT_BYTES;
use crate::model::load_model;
use crate::model::BoundModel;
use crate::stats::Estimate;

fn bundled(name: &str, set: &[(&str, f64)]) -> BoundModel {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    let overrides: Vec<crate::model::Override> = set
        .iter()
        .map(|(n, v)| crate::model::Override {
            name: n.to_string(),
            value: crate::symbolic::Expr::num(*v),
        })
        .collect();
    load_model(&path).unwrap().bind(&overrides).unwrap()
}

fn grids(names: &[&str], half: f64) -> Vec<(String, Grid)> {
    names
        .iter()
        .map(|n| (n.to_string(), Grid::new(-half, half, 20).unwrap()))
        .collect()
}

/// E[v²] of `cubic_damping_two_noises.sde` (exactly 1: Var v = 1, mean 0).
fn cubic_second_moment(choice: SchemeChoice, dt: f64, bias_fraction: f64) -> (Estimate, McResult) {
    cubic_second_moment_of(choice, dt, bias_fraction, 4096)
}

/// [`cubic_second_moment`] from `trajectories` trajectories.
fn cubic_second_moment_of(
    choice: SchemeChoice,
    dt: f64,
    bias_fraction: f64,
    trajectories: u64,
) -> (Estimate, McResult) {
    let model = bundled("cubic_damping_two_noises.sde", &[]);
    let config = McConfig {
        dt,
        spacing: 1.0,
        trajectories,
        lanes: 64,
        samples: 200,
        burn_in: BurnIn::Time(30.0),
        seed: 3,
        scheme: choice,
        grids: grids(&["z", "v", "y", "ydot"], 6.0),
        bias_fraction,
        ..McConfig::default()
    };
    let r = Simulation::new(&model, &config).unwrap().run().unwrap();
    let v = r.quantity("v").unwrap();
    let m2 = Estimate {
        value: v.moments.variance.value + v.moments.mean.value * v.moments.mean.value,
        stderr: v.moments.variance.stderr,
    };
    (m2, r)
}

/// `v' = −v − z + ξ₀ + ½ v ξ₁` read as Itô: E[v²] = 1/(2 − ¼) exactly.
fn multiplicative_ito() -> BoundModel {
    reference::linear_with_velocity_noise(1.0, 1.0, 1.0, crate::model::Interpretation::Ito)
        .bind(&[])
        .unwrap()
}

fn linear_variance(choice: SchemeChoice, dt: f64, bias_fraction: f64) -> McResult {
    let config = McConfig {
        dt,
        spacing: 0.8,
        trajectories: 4096,
        lanes: 64,
        samples: 200,
        burn_in: BurnIn::Time(20.0),
        seed: 3,
        scheme: choice,
        grids: grids(&["z", "v"], 8.0),
        bias_fraction,
        ..McConfig::default()
    };
    Simulation::new(&multiplicative_ito(), &config)
        .unwrap()
        .run()
        .unwrap()
}

/// The weak order p of `bias(dt) ≈ C·dtᵖ` by weighted least squares of ln|bias| on ln dt over
/// several step sizes, and its standard error from the points' standard errors
/// (σ(ln|b|) = σ_b/|b|). Every bias must be resolved (|b| > 4σ_b) and of one sign, so that
/// the logarithms are meaningful: the step sizes are chosen for that.
fn weak_order(points: &[(f64, Estimate)], exact: f64) -> (f64, f64) {
    let rows: Vec<(f64, f64, f64)> = points
        .iter()
        .map(|(dt, e)| {
            let b = e.value - exact;
            assert!(
                b.abs() > 4.0 * e.stderr,
                "bias {b} ± {} at dt {dt}",
                e.stderr
            );
            (dt.ln(), b.abs().ln(), (b.abs() / e.stderr).powi(2))
        })
        .collect();
    let sign = points[0].1.value - exact;
    assert!(points.iter().all(|(_, e)| (e.value - exact) * sign > 0.0));
    let sw: f64 = rows.iter().map(|r| r.2).sum();
    let xm = rows.iter().map(|r| r.2 * r.0).sum::<f64>() / sw;
    let ym = rows.iter().map(|r| r.2 * r.1).sum::<f64>() / sw;
    let sxx: f64 = rows.iter().map(|r| r.2 * (r.0 - xm).powi(2)).sum();
    let sxy: f64 = rows.iter().map(|r| r.2 * (r.0 - xm) * (r.1 - ym)).sum();
    (sxy / sxx, 1.0 / sxx.sqrt())
}

/// Whether a measured order `p ± se` is consistent with weak order 2: within 4 standard
/// errors (a chance failure about once in 10⁴ runs) plus 0.35 for the higher-order terms at
/// the step sizes used (Platen's biases of E[v²] below fall by 3.2, not 4, from dt = 0.25 to
/// 0.125: a fitted slope of 1.6 ± 0.12 with seed 3; exactly 1.55 on a linear model, 2 below: `platen::order_tests`). The Euler–Maruyama contrast, whose
/// se is 0.05, lies outside the band: the test fails for an order-1 scheme.
fn consistent_with_order_two(p: f64, se: f64) -> bool {
    (p - 2.0).abs() < 4.0 * se + 0.35
}

#[test]
fn the_general_path_has_weak_order_two() {
    // Bundled model with an exact stationary law, two sources, one multiplicative in v,
    // read as Stratonovich (so the Wong–Zakai drift is exercised): E[v²] = 1. Four step
    // sizes where the bias is resolved, each from 16384 trajectories.
    let platen: Vec<(f64, Estimate)> = [0.25, 0.2, 1.0 / 6.0, 0.125]
        .iter()
        .map(|&dt| {
            let (m2, res) = cubic_second_moment_of(SchemeChoice::General, dt, 0.0, 16384);
            assert_eq!(res.settings.scheme, SchemeKind::PlatenWeak2);
            (dt, m2)
        })
        .collect();
    let (p, se) = weak_order(&platen, 1.0);
    eprintln!("Platen: E v² at dt 0.25..0.125 {platen:?}: order {p:.2} ± {se:.2}");
    assert!(
        se < 0.15,
        "order {p} ± {se}: too imprecise to tell order 1 from 2"
    );
    assert!(consistent_with_order_two(p, se), "order {p} ± {se}");
    // The weak order-1 scheme (Euler–Maruyama) on an Itô model with multiplicative noise,
    // by the same fit: order 1, and refused by the same band.
    let exact = 1.0 / 1.75;
    let em: Vec<(f64, Estimate)> = [0.1, 0.08, 0.8 / 12.0, 0.05]
        .iter()
        .map(|&dt| {
            let r = linear_variance(SchemeChoice::GeneralOrder1, dt, 0.0);
            assert_eq!(r.settings.scheme, SchemeKind::EulerMaruyama);
            (dt, r.quantity("v").unwrap().moments.variance)
        })
        .collect();
    let (p1, se1) = weak_order(&em, exact);
    eprintln!("Euler-Maruyama: order {p1:.2} ± {se1:.2}");
    assert!((p1 - 1.0).abs() < 4.0 * se1 + 0.35, "order {p1} ± {se1}");
    assert!(!consistent_with_order_two(p1, se1), "order {p1} ± {se1}");
    // Platen's scheme on the same model at dt = 0.1, where Euler–Maruyama is 19 % off:
    // exact within the error bars.
    let pl = linear_variance(SchemeChoice::General, 0.1, 0.0);
    let var = pl.quantity("v").unwrap().moments.variance;
    eprintln!(
        "Platen (Itô model) dt 0.1: {} ± {} vs {exact}",
        var.value, var.stderr
    );
    assert!((var.value - exact).abs() < 4.5 * var.stderr);
}

#[test]
fn the_bias_estimate_covers_the_true_bias_of_euler_maruyama() {
    let exact = 1.0 / 1.75;
    let r = linear_variance(SchemeChoice::GeneralOrder1, 0.05, 0.25);
    let v = r.quantity("v").unwrap();
    let b = v.time_step_bias.as_ref().unwrap();
    let truth = v.moments.variance.value - exact;
    eprintln!(
        "EM dt 0.05: Var v = {:.5} ± {:.5}, true bias {truth:.5}, estimate {:.5} ± {:.5} from {} pairs",
        v.moments.variance.value, v.moments.variance.stderr, b.moments.variance.value, b.moments.variance.stderr, b.pairs
    );
    assert_eq!((b.order, b.pairs, b.coarse_dt), (1, 16, 0.1));
    assert!(b.moments.variance.resolved());
    // Richardson's own error is O(dt²) here (about a fifth of the bias at dt = 0.05).
    assert!(
        (b.moments.variance.value - truth).abs()
            < 3.0 * b.moments.variance.stderr + 0.3 * truth.abs(),
        "estimate {} ± {} vs true {truth}",
        b.moments.variance.value,
        b.moments.variance.stderr
    );
    assert!(r.warnings.iter().any(|w| matches!(
        w,
        McWarning::BiasExceedsError { quantity, statistic: Statistic::Variance, .. } if quantity == "v"
    )));
    // The weak order-2 scheme at dt = 0.01 on the bundled exact model: no resolved bias
    // of E[v²], and a bound below 1 %.
    let (m2, res) = cubic_second_moment(SchemeChoice::Auto, 0.01, 0.25);
    let b = res.quantity("v").unwrap().time_step_bias.clone().unwrap();
    eprintln!(
        "Platen dt 0.01: E v² = {:.5} ± {:.5}; bias of Var v {:.2e} ± {:.1e}; warnings {:?}",
        m2.value, m2.stderr, b.moments.variance.value, b.moments.variance.stderr, res.warnings
    );
    assert!((m2.value - 1.0).abs() < 4.5 * m2.stderr);
    assert!(
        b.moments.variance.bound() < 0.01,
        "{:?}",
        b.moments.variance
    );
    assert!(res.warnings.is_empty(), "{:?}", res.warnings);
}

fn vibro(set: &[(&str, f64)], burn_in: BurnIn, trajectories: u64, samples: u64) -> McResult {
    let model = bundled("vibro_duffing.sde", set);
    let config = McConfig {
        trajectories,
        lanes: 32,
        samples,
        burn_in,
        seed: 1,
        ..McConfig::default()
    };
    Simulation::new(&model, &config).unwrap().run().unwrap()
}

#[test]
fn platen_runs_are_bit_identical_across_threads_and_shards() {
    // Two correlated sources, both multiplicative, and an impact law: every branch of
    // the general path (pair signs, supporting values, events) in one run.
    use crate::symbolic::Expr;
    let mut m = reference::vibro_impact(reference::VibroImpact {
        c: 0.3,
        k: 1.0,
        mu: 0.5,
        eps: 0.4,
        r: 0.7,
        big_k: 0.08,
    });
    m.noises.push(crate::model::NoiseSource {
        name: "eta".into(),
        intensity: Expr::num(0.05),
    });
    m.correlations.push(crate::model::Correlation {
        a: 0,
        b: 1,
        coefficient: Expr::num(0.4),
    });
    m.noise_matrix[0].push(Expr::num(0.0));
    m.noise_matrix[1].push(Expr::sym("v"));
    let model = m.bind(&[]).unwrap();
    let config = McConfig {
        trajectories: 8 * 16,
        lanes: 16,
        samples: 50,
        seed: 9,
        ..McConfig::default()
    };
    let sim = Simulation::new(&model, &config).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| sim.run().unwrap())
    };
    let one = run_with(1);
    assert_eq!(one, run_with(2));
    assert!(one.impacts.as_ref().unwrap().count > 0);
    let shards: Vec<ShardOutput> = (0..3)
        .map(|k| {
            let out = sim.run_shard(Shard::new(k, 3).unwrap()).unwrap();
            serde_json::from_str(&serde_json::to_string(&out).unwrap()).unwrap()
        })
        .collect();
    let merged = merge_shards(&shards).unwrap();
    assert_eq!(
        serde_json::to_string(&merged).unwrap(),
        serde_json::to_string(&one).unwrap()
    );
}

#[test]
fn healthy_bundled_models_pass_the_stationarity_test() {
    let r = vibro(&[], BurnIn::DecayTimes(10.0), 1024, 400);
    eprintln!("vibro_duffing: {}", r.stationarity);
    assert!(matches!(r.stationarity, Stationarity::Stationary { .. }));
    assert_eq!(r.verdict(), Ok(()));
    let model = bundled("linear.sde", &[]);
    let config = McConfig {
        trajectories: 1024,
        lanes: 32,
        samples: 400,
        ..McConfig::default()
    };
    let r = Simulation::new(&model, &config).unwrap().run().unwrap();
    eprintln!("linear: {}", r.stationarity);
    assert!(matches!(r.stationarity, Stationarity::Stationary { .. }));
    assert_eq!(r.verdict(), Ok(()));
}

/// A test fixture from `tests/models/` (models the admissibility check accepts but whose
/// Monte Carlo verdict must fail).
fn fixture(name: &str, trajectories: u64, samples: u64, config: McConfig) -> McResult {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/models")
        .join(name);
    let model = load_model(&path).unwrap().bind(&[]).unwrap();
    let config = McConfig {
        trajectories,
        lanes: 32,
        samples,
        seed: 1,
        ..config
    };
    Simulation::new(&model, &config).unwrap().run().unwrap()
}

#[test]
fn a_run_that_keeps_growing_is_not_stationary_and_keeps_its_histograms() {
    let r = fixture(
        "fading_damping.sde",
        1024,
        400,
        McConfig {
            burn_in: BurnIn::Time(50.0),
            ..McConfig::default()
        },
    );
    eprintln!("fading damping: {}", r.stationarity);
    let Stationarity::NotStationary { largest } = &r.stationarity else {
        panic!("{}", r.stationarity)
    };
    assert!(largest.t.abs() > largest.threshold);
    assert!(largest.last_quarter > largest.first_quarter);
    assert!(matches!(r.verdict(), Err(McError::NotStationary { .. })));
    // The histograms are there to be written, flagged.
    assert!(r.quantity("v").unwrap().samples > 0);
}

#[test]
fn mass_blow_ups_fail_the_verdict() {
    // Runs away where the damping turns negative.
    let grid = Grid::new(-10.0, 10.0, 50).unwrap();
    let r = fixture(
        "runaway_damping.sde",
        256,
        200,
        McConfig {
            grids: vec![("z".into(), grid), ("v".into(), grid)],
            ..McConfig::default()
        },
    );
    eprintln!("runaway damping: {}", r.blowup_verdict);
    let BlowUps::TooMany {
        count,
        trajectories,
    } = r.blowup_verdict
    else {
        panic!("{}", r.blowup_verdict)
    };
    assert_eq!(trajectories, 256);
    assert!(count > 100, "{count}");
    assert!(matches!(r.verdict(), Err(McError::TooManyBlowUps { .. })));
}

#[test]
fn preflight_refuses_what_cannot_finish() {
    let model = bundled("vibro_duffing.sde", &[]);
    let ok = McConfig::default().preflight(&model).unwrap();
    eprintln!("default: {ok:?}");
    assert!(ok.seconds < 600.0 && ok.memory_bytes < 1e8);
    let long = |c: McConfig| match c.preflight(&model) {
        Err(McError::TooLong { seconds, .. }) => seconds,
        other => panic!("{other:?}"),
    };
    assert!(
        long(McConfig {
            dt: 1e-300,
            ..McConfig::default()
        }) > 1e290
    );
    assert!(
        long(McConfig {
            spacing: 1e6,
            ..McConfig::default()
        }) > 1e6
    );
    assert!(
        long(McConfig {
            burn_in: BurnIn::Time(1e300),
            ..McConfig::default()
        }) > 1e290
    );
    let setting = |c: McConfig| match c.preflight(&model) {
        Err(McError::BadSetting { name, .. }) => name,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        setting(McConfig {
            trajectories: u64::MAX,
            ..McConfig::default()
        }),
        "trajectories"
    );
    let grid = |bins| McConfig {
        grids: vec![(
            "y".into(),
            Grid {
                lo: 0.0,
                hi: 8.0,
                bins,
            },
        )],
        ..McConfig::default()
    };
    assert_eq!(setting(grid(4_294_967_297)), "grid");
    assert_eq!(setting(grid(100_000_000)), "grid");
    let big = McConfig {
        trajectories: 16384,
        ..grid(5_000_000)
    };
    assert!(matches!(
        big.preflight(&model),
        Err(McError::TooMuchMemory { .. })
    ));
    // Simulation::new makes the same checks before any work.
    assert!(matches!(
        Simulation::new(
            &model,
            &McConfig {
                dt: 1e-300,
                ..McConfig::default()
            }
        ),
        Err(McError::TooLong { .. })
    ));
    let message = long_message(&model);
    assert!(
        message.len() < 400 && message.contains("years"),
        "{message}"
    );
}

fn long_message(model: &BoundModel) -> String {
    McConfig {
        burn_in: BurnIn::Time(1e300),
        ..McConfig::default()
    }
    .preflight(model)
    .unwrap_err()
    .to_string()
}

/// The impact rate carries its time-step bias like a moment. A linear oscillator with an
/// elastic barrier at z = 0 (vibro_duffing with ε = μ = 0, r = 1) has the stationary density
/// of the free oscillator folded onto z > 0, so its impacts per unit time are the flux
/// ∫_{v<0} |v| p(0, v) dv = σ_v/(π σ_z) = √k/π = 1/π exactly. At dt = 0.2 the rate is
/// resolved above 1/π and the estimate covers that bias (Richardson's own error is O(dt³)
/// here); at dt = 0.01 the rate is 1/π within its error and its bias bound.
#[test]
fn the_impact_rate_bias_estimate_covers_the_true_bias() {
    let exact = 1.0 / std::f64::consts::PI;
    let run = |dt: f64| {
        let model = bundled(
            "vibro_duffing.sde",
            &[("eps", 0.0), ("mu", 0.0), ("r", 1.0)],
        );
        let config = McConfig {
            dt,
            spacing: 0.2,
            trajectories: 2048,
            lanes: 64,
            samples: 8000,
            seed: 3,
            ..McConfig::default()
        };
        Simulation::new(&model, &config).unwrap().run().unwrap()
    };
    let coarse = run(0.2);
    let i = coarse.impacts.as_ref().unwrap();
    let b = i.time_step_bias.unwrap();
    let truth = i.rate.value - exact;
    eprintln!(
        "dt 0.2: rate {:.5} ± {:.1e} (1/π {exact:.5}), bias estimate {:.2e} ± {:.1e}; {:?}",
        i.rate.value, i.rate.stderr, b.value, b.stderr, coarse.warnings
    );
    assert!(b.resolved(), "{b:?}");
    assert!(
        (b.value - truth).abs() < 3.0 * (b.stderr + i.rate.stderr) + 0.3 * truth.abs(),
        "estimate {b:?} vs true {truth}"
    );
    assert!(coarse.warnings.iter().any(|w| matches!(
        w,
        McWarning::BiasExceedsError { quantity, statistic: Statistic::Rate, .. } if quantity == "impacts"
    )));
    let fine = run(0.01);
    let i = fine.impacts.as_ref().unwrap();
    let b = i.time_step_bias.unwrap();
    eprintln!(
        "dt 0.01: rate {:.5} ± {:.1e}, bias {:.2e} ± {:.1e}",
        i.rate.value, i.rate.stderr, b.value, b.stderr
    );
    assert!(!b.resolved(), "{b:?}");
    assert!((i.rate.value - exact).abs() < 4.5 * i.rate.stderr + b.bound());
}

/// Damping c = 1e6 at dt = 0.01 blew every trajectory up in a run that looked like a hang;
/// the explicit step is stable while c·dt ≤ 2 (seen: c = 190 runs, c = 210 blows up at
/// dt = 0.01), on the splitting as on the general schemes.
#[test]
fn preflight_refuses_a_step_the_damping_makes_unstable() {
    let run = |c: f64, scheme: SchemeChoice| {
        let model = bundled("vibro_duffing.sde", &[("c", c)]);
        McConfig {
            scheme,
            burn_in: BurnIn::Time(10.0),
            ..McConfig::default()
        }
        .preflight(&model)
    };
    for scheme in [
        SchemeChoice::Auto,
        SchemeChoice::General,
        SchemeChoice::GeneralOrder1,
    ] {
        for c in [1e6, 210.0] {
            match run(c, scheme) {
                Err(McError::UnstableStep { dt, limit }) => {
                    assert_eq!(dt, 0.01);
                    assert_eq!(limit.state, "v");
                    assert!((limit.rate / c - 1.0).abs() < 1e-6, "{limit:?}");
                    assert!((limit.largest_dt * c / 2.0 - 1.0).abs() < 1e-6, "{limit:?}");
                }
                other => panic!("c = {c}, {scheme:?}: {other:?}"),
            }
        }
        assert!(run(190.0, scheme).is_ok(), "{scheme:?}");
        assert!(run(0.1, scheme).is_ok(), "{scheme:?}");
    }
    // The run's own set-up makes the same check.
    let model = bundled("vibro_duffing.sde", &[("c", 1e6)]);
    assert!(matches!(
        Simulation::new(&model, &McConfig::default()),
        Err(McError::UnstableStep { .. })
    ));
    let message = run(1e6, SchemeChoice::Auto).unwrap_err().to_string();
    assert!(
        message.contains("dt = 0.01 is too large") && message.contains("largest stable dt is"),
        "{message}"
    );
}

/// Survivors of a run that lost trajectories to infinity looked stationary (parametric at
/// dt = 0.4: 19 of 1024 blew up beside "stationarity: stationary"), and at dt = 0.48 their
/// mean of 5.9e52 was printed in 53 digits; the run is not stationary, and its numbers read.
#[test]
fn a_run_with_too_many_blow_ups_is_never_called_stationary() {
    let model = bundled("parametric.sde", &[]);
    for dt in [0.4, 0.48] {
        let config = McConfig {
            dt,
            spacing: dt,
            trajectories: 1024,
            samples: 98,
            ..McConfig::default()
        };
        let r = Simulation::new(&model, &config).unwrap().run().unwrap();
        assert!(
            matches!(r.blowup_verdict, BlowUps::TooMany { .. }),
            "{}",
            r.blowup_verdict
        );
        assert!(
            !matches!(r.stationarity, Stationarity::Stationary { .. }),
            "dt = {dt}: {}",
            r.stationarity
        );
        let table = r.to_string();
        assert!(table.contains("stationarity: not stationary"), "{table}");
        // The moment rows (the first line's dt and burn-in are printed to round-trip).
        let longest_digit_run = table
            .lines()
            .filter(|l| l.contains(" mc "))
            .flat_map(|l| l.split(|c: char| !c.is_ascii_digit()))
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest_digit_run < 12, "dt = {dt}: {table}");
    }
}

/// The documented maximum of bins, 10⁷ in one quantity, peaked at 12.5 GB (every part of
/// every batch held to the end) while the estimate said 3.6 GB, under the limit; the estimate
/// now counts the accumulators, the parts and the result, and the run is refused before any
/// allocation, while a run with fewer batches fits.
#[test]
fn histograms_over_the_memory_limit_are_refused_before_allocation() {
    let model = bundled("vibro_duffing.sde", &[]);
    let grid = |trajectories| McConfig {
        trajectories,
        grids: vec![("y".into(), Grid::new(0.0, 8.0, MAX_BINS).unwrap())],
        ..McConfig::default()
    };
    match grid(4096).preflight(&model) {
        Err(McError::TooMuchMemory { bytes, .. }) => {
            // 40 batches of 8e7 bytes, and per thread 6 such copies, and the outputs.
            assert!(bytes > 40.0 * 8e7 + 6.0 * 8e7, "{bytes:e}");
        }
        other => panic!("{other:?}"),
    }
    let few = grid(256).preflight(&model).unwrap();
    assert!(few.memory_bytes < MEMORY_LIMIT_BYTES, "{few:?}");
}

/// The run records which evaluator ran it: the vectorised kernel for a polynomial mechanical
/// model, the tape otherwise (an energy-dependent damping, several noises on Platen's scheme).
#[test]
fn the_run_says_which_evaluator_it_gets() {
    let evaluator = |name: &str| {
        let model = bundled(name, &[]);
        let dynamics = crate::dynamics::Dynamics::read(&model);
        let walls = compile::scheme::walls(&dynamics).unwrap();
        let resolved = McConfig::default()
            .resolve_with(&model, &dynamics, walls)
            .unwrap();
        compile::scheme::Evaluator::of(&resolved.plan, McConfig::default().increments)
    };
    assert_eq!(
        evaluator("vibro_duffing.sde"),
        compile::scheme::Evaluator::PolynomialKernel
    );
    assert_eq!(
        evaluator("cubic_damping_two_noises.sde"),
        compile::scheme::Evaluator::Tape
    );
    let model = bundled("linear.sde", &[]);
    let config = McConfig {
        trajectories: 256,
        samples: 50,
        ..McConfig::default()
    };
    let r = Simulation::new(&model, &config).unwrap().run().unwrap();
    assert_eq!(
        r.settings.evaluator,
        Some(compile::scheme::Evaluator::PolynomialKernel)
    );
    assert!(
        r.to_string()
            .contains("evaluator: the vectorised polynomial mechanical kernel"),
        "{r}"
    );
}

/// Energy-dependent damping `(c₀ + c₁H)·v` with additive noise has the exact stationary
/// density `p ∝ exp(−(c₀H + c₁H²/2)/(πS))` (Caughey's class, intensity 2πS), with cross
/// terms in z and v; its force is cubic in v, which runs on the polynomial kernel's
/// two-evaluation Heun step. The variances of x and v agree with the exact ones (2-D
/// quadrature) to 4.5 standard errors.
#[test]
fn energy_dependent_damping_on_the_kernel_matches_its_exact_density() {
    let (c0, c1, s) = (0.05, 0.01, 0.05);
    let source = crate::mc::compile::mech_form::tests::POLYNOMIAL_IN_V[0].1;
    let model = crate::model::parse_model(source, None)
        .unwrap()
        .bind(&[])
        .unwrap();
    // The exact variances by the midpoint rule on [−4, 4] × [−10, 10] (the density there
    // is below 1e-40 of its peak at the edges).
    let d = std::f64::consts::PI * s;
    let n = 1000;
    let (mut z, mut x2, mut v2) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let x = -4.0 + 8.0 * (i as f64 + 0.5) / n as f64;
        for j in 0..n {
            let v = -10.0 + 20.0 * (j as f64 + 0.5) / n as f64;
            let h = v * v / 2.0 + x * x / 2.0 + x.powi(4) / 4.0;
            let w = (-(c0 * h + c1 * h * h / 2.0) / d).exp();
            z += w;
            x2 += w * x * x;
            v2 += w * v * v;
        }
    }
    let (exact_x, exact_v) = (x2 / z, v2 / z);
    let config = McConfig {
        dt: 0.01,
        spacing: 1.0,
        trajectories: 4096,
        samples: 200,
        burn_in: BurnIn::Time(100.0),
        seed: 7,
        ..McConfig::default()
    };
    let r = Simulation::new(&model, &config).unwrap().run().unwrap();
    assert_eq!(
        r.settings.evaluator,
        Some(compile::scheme::Evaluator::PolynomialKernel)
    );
    for (q, exact) in [("x", exact_x), ("v", exact_v)] {
        let var = r.quantity(q).unwrap().moments.variance;
        assert!(
            (var.value - exact).abs() < 4.5 * var.stderr,
            "Var {q}: {} ± {} against the exact {exact}",
            var.value,
            var.stderr
        );
    }
}
