//! Unit tests of the simulation driver: blow-ups, scheme selection, determinism, shards.

use super::*;
use crate::mc::reference::{linear_oscillator, vibro_impact, VibroImpact};

fn small(trajectories: u64) -> McConfig {
    McConfig {
        trajectories,
        lanes: 16,
        samples: 100,
        ..McConfig::default()
    }
}

/// `tests/models/runaway_damping.sde` with `g` set: damping −(c − g z²) v, negative beyond
/// |z| = √(c/g), where trajectories run off to infinity in finite time. (A softening spring
/// would do it too, but the admissibility check refuses those.)
fn runaway(g: f64) -> crate::model::BoundModel {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/runaway_damping.sde");
    crate::model::load_model(&path)
        .unwrap()
        .bind(&[crate::model::Override::number("g", g)])
        .unwrap()
}

#[test]
fn blown_up_trajectories_are_reported_and_left_out() {
    let model = runaway(0.006);
    let config = McConfig {
        grids: vec![
            ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
        ],
        ..small(64)
    };
    let sim = Simulation::new(&model, &config).unwrap();
    let res = sim.run().unwrap();
    let total = sim.settings().trajectories();
    let lost = res.blowups.len() as u64;
    assert!(lost > 0 && lost < total, "{lost} of {total} blew up");
    assert_eq!(res.trajectories, total - lost);
    let mut seen = std::collections::HashSet::new();
    for b in &res.blowups {
        assert!(b.trajectory < total && seen.insert(b.trajectory));
        assert_eq!(b.params.len(), 3);
        if let Some(last) = &b.last_finite {
            assert!(last.step < b.step && last.state.iter().all(|s| s.is_finite()));
        }
    }
    let z = res.quantity("z").unwrap();
    assert!(z.moments.mean.value.is_finite() && z.moments.variance.value.is_finite());
    assert_eq!(z.samples, res.trajectories * 100);
    assert_eq!(z.invalid, 0);
}

#[test]
fn a_run_where_every_trajectory_blows_up_is_an_error() {
    // Negative damping from |z| = 0.32 on: every trajectory runs off to infinity.
    let model = runaway(1.0);
    let config = McConfig {
        grids: vec![
            ("z".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
            ("v".into(), Grid::new(-1.5, 1.5, 30).unwrap()),
        ],
        ..small(32)
    };
    let sim = Simulation::new(&model, &config).unwrap();
    assert_eq!(sim.run(), Err(McError::AllBlewUp { blowups: 32 }));
}

#[test]
fn schemes_are_chosen_from_the_model_form() {
    let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
    let sim = Simulation::new(&lin, &small(32)).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::MechanicalStrang);
    let general = McConfig {
        scheme: SchemeChoice::General,
        ..small(32)
    };
    let sim = Simulation::new(&lin, &general).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
    // Noise in the x-equation: not mechanical.
    let mut m = linear_oscillator(0.5, 1.0, 1.0);
    m.noise_matrix[0] = vec![crate::symbolic::Expr::num(0.1)];
    let sim = Simulation::new(&m.bind(&[]).unwrap(), &small(32)).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::PlatenWeak2);
    let order1 = McConfig {
        scheme: SchemeChoice::GeneralOrder1,
        ..small(32)
    };
    let sim = Simulation::new(&m.bind(&[]).unwrap(), &order1).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::Heun);
    m.interpretation = crate::model::Interpretation::Ito;
    let sim = Simulation::new(&m.bind(&[]).unwrap(), &order1).unwrap();
    assert_eq!(sim.settings().scheme, SchemeKind::EulerMaruyama);
}

#[test]
fn burn_in_is_ten_decay_times_of_the_linearisation() {
    // z'' + 0.4 z' + z: eigenvalues −0.2 ± i·0.98, decay time 5.
    let lin = linear_oscillator(0.4, 1.0, 1.0).bind(&[]).unwrap();
    let sim = Simulation::new(&lin, &small(32)).unwrap();
    assert_eq!(sim.settings().burn_in_steps, 5000);
    // Overdamped z'' + 5 z' + 4 z: eigenvalues −1 and −4, the slow one decides.
    let od = linear_oscillator(5.0, 4.0, 1.0).bind(&[]).unwrap();
    let sim = Simulation::new(&od, &small(32)).unwrap();
    assert_eq!(sim.settings().burn_in_steps, 1000);
    // No damping: no stationary law at all, refused before the burn-in is estimated.
    let free = linear_oscillator(0.0, 1.0, 1.0).bind(&[]).unwrap();
    assert!(matches!(
        Simulation::new(&free, &small(32)),
        Err(McError::Inadmissible(
            crate::dynamics::Inadmissible::NoDamping { .. }
        ))
    ));
}

/// A time-dependent model has no stationary law to sample: the stationary run refuses it
/// before any work, though its kernels could now step it (the transient runs it).
#[test]
fn a_time_dependent_model_is_refused_by_the_stationary_run() {
    let m = crate::model::parse_model(
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z + cos(t)\n\
         noise xi: intensity 1\ndiffusion v: xi\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let err = Simulation::new(&m, &small(32)).err().unwrap();
    assert!(
        matches!(
            &err,
            McError::Inadmissible(crate::dynamics::Inadmissible::TimeDependent { line })
                if line == "drift of `v`"
        ),
        "{err}"
    );
    assert!(crate::mc::McConfig::default().preflight(&m).is_err());
}

#[test]
fn automatic_grids_cover_the_pilot_and_fold_at_zero() {
    let p = VibroImpact {
        c: 0.5,
        k: 1.0,
        mu: 1.0,
        eps: 0.0,
        r: 0.9,
        big_k: 0.1,
    };
    let m = vibro_impact(p).bind(&[]).unwrap();
    let sim = Simulation::new(&m, &small(32)).unwrap();
    let q = &sim.settings().quantities;
    let names: Vec<&str> = q.iter().map(|q| q.name.as_str()).collect();
    assert_eq!(names, ["z", "v", "y", "ydot"]);
    assert_eq!(q[2].grid.lo, 0.0, "y = |z| is never negative");
    assert!(q[0].grid.lo < -0.5 && q[0].grid.hi > 0.5);
    assert_eq!(q[0].grid.bins, 100);
}

#[test]
fn bad_settings_are_errors() {
    let lin = linear_oscillator(0.5, 1.0, 1.0).bind(&[]).unwrap();
    let bad = |c: McConfig| Simulation::new(&lin, &c).err().unwrap();
    assert!(matches!(
        bad(McConfig {
            dt: 0.0,
            ..small(32)
        }),
        McError::BadSetting { name: "dt", .. }
    ));
    assert!(matches!(
        bad(McConfig {
            spacing: 0.015,
            ..small(32)
        }),
        McError::BadSetting {
            name: "spacing",
            ..
        }
    ));
    assert!(matches!(
        bad(small(16)),
        McError::BadSetting {
            name: "trajectories",
            ..
        }
    ));
    let unknown = McConfig {
        grids: vec![("w".into(), Grid::new(0.0, 1.0, 2).unwrap())],
        ..small(32)
    };
    assert!(matches!(bad(unknown), McError::UnknownQuantity { .. }));
    // Crossing levels: of a quantity the model has, finite, ascending, not none.
    for (q, levels) in [
        ("w", vec![0.0]),
        ("x", vec![]),
        ("x", vec![1.0, 0.0]),
        ("x", vec![0.0, f64::NAN]),
    ] {
        let config = McConfig {
            levels: vec![(q.into(), levels)],
            ..small(32)
        };
        let err = bad(config);
        assert!(
            matches!(err, McError::BadSetting { name: "levels", .. }),
            "{err}"
        );
    }
}

#[test]
fn a_delta_term_without_an_impact_law_is_an_error() {
    let p = VibroImpact {
        c: 0.5,
        k: 1.0,
        mu: 1.0,
        eps: 0.0,
        r: 0.9,
        big_k: 0.1,
    };
    let mut m = vibro_impact(p);
    m.impacts.clear();
    assert!(matches!(
        Simulation::new(&m.bind(&[]).unwrap(), &small(32)),
        Err(McError::DeltaWithoutImpact { .. })
    ));
}

#[test]
fn an_impact_on_a_state_driven_by_noise_is_refused() {
    let text = |zeta: &str| {
        format!(
            "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\nnoise xi: intensity 1\n\
             noise zeta: intensity {zeta}\ndiffusion z: 0.1*zeta\ndiffusion v: xi\n\
             impact z = 0: v -> -0.9*v\ndomain z >= 0\n"
        )
    };
    let sim = |zeta: &str| {
        let model = crate::model::parse_model(&text(zeta), None).unwrap();
        Simulation::new(&model.bind(&[]).unwrap(), &small(32)).map(|_| ())
    };
    assert_eq!(
        sim("0.02"),
        Err(McError::Barriers {
            layout: BarrierLayout::NoisyState {
                state: "z".into(),
                noise: "zeta".into(),
            }
        })
    );
    // A source of no intensity moves nothing: the model is the noiseless-position one.
    assert_eq!(sim("0"), Ok(()));
}

/// `v' = −c v − k z + ξ₀ + σ v ξ₁` (independent sources of intensities s₀, s₁): the
/// stationary E[v²] is s₀/(2c − s₁σ²) read as Itô and s₀/(2c − 2s₁σ²) read as
/// Stratonovich (Wong–Zakai adds ½s₁σ²·v to the drift).
fn velocity_noise(
    interpretation: crate::model::Interpretation,
    scheme: SchemeChoice,
    seed: u64,
) -> McResult {
    let m = super::reference::linear_with_velocity_noise(0.5, 1.0, 1.0, interpretation);
    let config = McConfig {
        dt: 0.005,
        spacing: 0.5,
        trajectories: 512,
        lanes: 16,
        samples: 200,
        seed,
        scheme,
        grids: vec![
            ("z".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
            ("v".into(), Grid::new(-6.0, 6.0, 10).unwrap()),
        ],
        ..McConfig::default()
    };
    Simulation::new(&m.bind(&[]).unwrap(), &config)
        .unwrap()
        .run()
        .unwrap()
}

#[test]
fn ito_and_stratonovich_readings_reach_their_own_exact_variances() {
    use crate::model::Interpretation;
    for (interp, exact, scheme, kind) in [
        (
            Interpretation::Ito,
            1.0 / (1.0 - 0.25),
            SchemeChoice::GeneralOrder1,
            SchemeKind::EulerMaruyama,
        ),
        (
            Interpretation::Stratonovich,
            1.0 / (1.0 - 0.5),
            SchemeChoice::GeneralOrder1,
            SchemeKind::Heun,
        ),
        (
            Interpretation::Ito,
            1.0 / (1.0 - 0.25),
            SchemeChoice::Auto,
            SchemeKind::PlatenWeak2,
        ),
        (
            Interpretation::Stratonovich,
            1.0 / (1.0 - 0.5),
            SchemeChoice::Auto,
            SchemeKind::PlatenWeak2,
        ),
    ] {
        let res = velocity_noise(interp, scheme, 4);
        assert_eq!(res.settings.scheme, kind);
        let var = res.quantity("v").unwrap().moments.variance;
        eprintln!("{interp:?}: {} ± {} (exact {exact})", var.value, var.stderr);
        assert!(
            (var.value - exact).abs() < 4.5 * var.stderr,
            "{interp:?}: {} ± {} vs {exact}",
            var.value,
            var.stderr
        );
    }
}

#[test]
fn fully_correlated_sources_have_a_singular_square_root() {
    let l = compile::scheme::psd_sqrt(&[vec![4.0, 2.0], vec![2.0, 1.0]]).unwrap();
    assert_eq!(l, vec![2.0, 0.0, 1.0, 0.0]);
    assert!(matches!(
        compile::scheme::psd_sqrt(&[vec![1.0, 2.0], vec![2.0, 1.0]]),
        Err(McError::IntensityNotPsd { .. })
    ));
}
