use super::*;
use crate::epc::{Epc, EpcError};
use crate::fpk::{FpkError, FpkOperator};
use crate::mc::{BurnIn, Grid, McConfig, Simulation};
use crate::model::{load_model, parse_model, BoundModel, Model, Override};
use std::path::Path;

/// How many times each model (by name) was read, for tests that a run reads its model once.
static READS: std::sync::Mutex<Vec<(String, usize)>> = std::sync::Mutex::new(Vec::new());

/// Counts one [`Dynamics::read`] of `model`.
pub(super) fn count_read(model: &BoundModel) {
    let mut reads = READS.lock().unwrap_or_else(|e| e.into_inner());
    match reads.iter_mut().find(|(n, _)| *n == model.name) {
        Some((_, k)) => *k += 1,
        None => reads.push((model.name.clone(), 1)),
    }
}

/// How many times a model named `name` was read so far (give each test its own name).
pub(crate) fn reads_of(name: &str) -> usize {
    let reads = READS.lock().unwrap_or_else(|e| e.into_inner());
    reads.iter().find(|(n, _)| n == name).map_or(0, |(_, k)| *k)
}

fn model_file(name: &str) -> Model {
    load_model(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(name),
    )
    .unwrap()
}

fn bind(model: &Model, set: &[(&str, f64)]) -> BoundModel {
    let o: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    model.bind(&o).unwrap()
}

fn text(drift_v: &str, diffusion: &str, extra: &str) -> Model {
    let src = format!(
        "model m\nparam c = 0.1, k = 1, S = 1\nstate z, v\ndrift z: v\ndrift v: {drift_v}\n\
         noise xi: intensity S\ndiffusion v: {diffusion}\n{extra}"
    );
    parse_model(&src, None).unwrap()
}

/// The model in its original coordinates: x ≥ 0, reflecting law, no δ term.
const ORIGINAL: &str = "model orig
param c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95
param K = 1/(2*pi)
state x, v
drift x: v
drift v: -c*v - k*x - mu*x^3
noise xi: intensity 2*pi*K
diffusion v: (1 + eps*x) * xi
impact x = 0: v -> -r*v
domain x >= 0
";

#[test]
fn every_bundled_model_and_the_table_1_cases_are_admissible() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let bound = load_model(&path).unwrap().bind(&[]).unwrap();
        assert_eq!(check(&bound), Ok(()), "{}", path.display());
        let form = impact_form(&bound);
        // The models in their own coordinates: one reflecting barrier (EPC solves its
        // Zhuravlev transform), or two bounding a strip (EPC's δ form has none).
        let own_coordinates = matches!(
            &form,
            Some(ImpactForm::Unsupported {
                reason: UnsupportedImpact::Reflecting { .. }
                    | UnsupportedImpact::TwoBarriers { .. },
                ..
            })
        );
        assert!(
            matches!(form, None | Some(ImpactForm::Zhuravlev { .. })) || own_coordinates,
            "{}: {form:?}",
            path.display()
        );
        n += 1;
    }
    assert_eq!(n, 10);
    let vibro = model_file("vibro_duffing.sde");
    for (mu, eps) in [(0.1, 0.1), (0.1, -0.1), (1.0, 0.1), (1.0, -0.1)] {
        let b = bind(&vibro, &[("mu", mu), ("eps", eps)]);
        assert_eq!(check(&b), Ok(()), "mu = {mu}, eps = {eps}");
        assert_eq!(
            impact_form(&b),
            Some(ImpactForm::Zhuravlev { restitution: 0.95 })
        );
    }
    // Impact losses alone confine the motion: no viscous damping is needed.
    assert_eq!(check(&bind(&vibro, &[("c", 0.0)])), Ok(()));
    // Van der Pol: negative linear damping, contained by z^2 v; still accepted at any α.
    let vdp = model_file("van_der_pol.sde");
    assert_eq!(check(&bind(&vdp, &[("alpha", 0.5)])), Ok(()));
    // The original coordinates are physically fine: only EPC refuses them.
    let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
    assert_eq!(check(&orig), Ok(()));
}

#[test]
fn an_impact_that_adds_energy_is_refused_in_plain_words() {
    let vibro = model_file("vibro_duffing.sde");
    let err = check(&bind(&vibro, &[("r", 1.001)])).unwrap_err();
    assert_eq!(
        err,
        Inadmissible::EnergyAddingImpact {
            law: "v -> 1.001*v".into(),
            restitution: 1.001
        }
    );
    assert_eq!(
        err.to_string(),
        "no stationary density: the impact law `v -> 1.001*v` adds energy at every impact \
         (|r| = 1.001 > 1), so the response grows without bound"
    );
    // Reflecting form in the original coordinates, r = 1.1.
    let orig = parse_model(ORIGINAL, None).unwrap();
    assert!(matches!(
        check(&bind(&orig, &[("r", 1.1)])),
        Err(Inadmissible::EnergyAddingImpact { restitution, .. }) if (restitution - 1.1).abs() < 1e-12
    ));
    // The δ term alone (no impact line), standing for r = 1.1.
    let m = text("-c*v - k*z + 0.1*v*abs(v)*delta(z)", "xi", "");
    match check(&m.bind(&[]).unwrap()) {
        Err(Inadmissible::EnergyAddingImpactTerm {
            restitution,
            velocity,
            ..
        }) => {
            assert!((restitution - 1.1).abs() < 1e-12);
            assert_eq!(velocity, "v");
        }
        other => panic!("{other:?}"),
    }
    // r = 1 exactly is elastic, and fine with damping.
    assert_eq!(check(&bind(&vibro, &[("r", 1.0)])), Ok(()));
}

#[test]
fn no_damping_and_negative_damping() {
    let vibro = model_file("vibro_duffing.sde");
    let none = bind(&vibro, &[("c", 0.0), ("r", 1.0), ("eps", 0.0)]);
    assert_eq!(
        check(&none),
        Err(Inadmissible::NoDamping {
            velocity: "v".into()
        })
    );
    // Parametric noise does not change that.
    let none = bind(&vibro, &[("c", 0.0), ("r", 1.0)]);
    assert!(matches!(check(&none), Err(Inadmissible::NoDamping { .. })));
    let duffing = model_file("duffing.sde");
    match check(&bind(&duffing, &[("c", -0.1)])) {
        Err(Inadmissible::NegativeDamping {
            linear_damping,
            velocity,
        }) => {
            assert!((linear_damping + 0.1).abs() < 1e-8, "{linear_damping}");
            assert_eq!(velocity, "v");
        }
        other => panic!("{other:?}"),
    }
    // Negative linear damping contained by a cubic one is accepted.
    let m = text("0.1*v - 0.05*v^3 - k*z", "xi", "");
    assert_eq!(check(&m.bind(&[]).unwrap()), Ok(()));
    // Stratonovich velocity noise adds drift ½ S v: with c = 0 that is negative damping.
    let m = text("-c*v - k*z", "xi + v*xi", "");
    assert!(matches!(
        check(&bind(&m, &[("c", 0.0)])),
        Err(Inadmissible::NegativeDamping { .. })
    ));
}

/// A softening spring (the force at rest outwards far out) or none at all, on a side no wall
/// closes, has no stationary density; a wall on that side, a strip, or a weak restoring force
/// leaves one. The grid solver once searched for a domain for minutes on these.
#[test]
fn softening_and_missing_springs_escape_unless_a_wall_closes_the_side() {
    let vibro = model_file("vibro_duffing.sde");
    for mu in [-1.0, -0.01] {
        match check(&bind(&vibro, &[("mu", mu)])) {
            Err(Inadmissible::Escapes {
                position,
                side,
                at,
                force,
            }) => {
                assert_eq!((position.as_str(), side), ("z", "upper"));
                assert!(at > 0.0 && force > 0.0, "{at} {force}");
            }
            other => panic!("mu = {mu}: {other:?}"),
        }
    }
    assert!(matches!(
        check(&bind(&vibro, &[("k", 0.0), ("mu", 0.0)])),
        Err(Inadmissible::NoRestoringForce { .. })
    ));
    let parametric = model_file("parametric.sde");
    assert!(matches!(
        check(&bind(&parametric, &[("mu", -0.5)])),
        Err(Inadmissible::Escapes { .. })
    ));
    // A weak restoring force is a wide density, not none.
    assert_eq!(check(&bind(&vibro, &[("k", 1e-8), ("mu", 0.0)])), Ok(()));
    // Softening towards a wall: the lower side is open and escapes.
    let soft = "-c*v - k*z + 0.02*z^3";
    let wall_above = text(soft, "xi", "impact z = 0: v -> -0.9*v\ndomain z <= 0\n");
    assert!(matches!(
        check(&wall_above.bind(&[]).unwrap()),
        Err(Inadmissible::Escapes { side: "lower", .. })
    ));
    // Between two walls nothing escapes, nor does a free particle wander off.
    let strip = "impact z = -1: v -> -0.9*v\nimpact z = 1: v -> -0.9*v\ndomain -1 <= z <= 1\n";
    assert_eq!(check(&text(soft, "xi", strip).bind(&[]).unwrap()), Ok(()));
    assert_eq!(check(&text("-c*v", "xi", strip).bind(&[]).unwrap()), Ok(()));
}

#[test]
fn no_noise_and_noise_vanishing_at_rest() {
    let m = text("-c*v - k*z", "c*xi", "");
    assert_eq!(check(&bind(&m, &[("S", 0.0)])), Err(Inadmissible::NoNoise));
    assert_eq!(check(&bind(&m, &[("c", 0.0)])), Err(Inadmissible::NoNoise));
    // Purely parametric noise z·ξ on a damped linear oscillator: the second moments decay
    // iff S < 2c k (here 0.2); below that every trajectory comes to rest at the origin.
    let m = text("-c*v - k*z", "z*xi", "");
    match check(&bind(&m, &[("S", 0.19)])) {
        Err(Inadmissible::VanishingDiffusionAtRest {
            point, decay_rate, ..
        }) => {
            assert_eq!(point, [0.0, 0.0]);
            assert!(decay_rate > 0.0 && decay_rate < 0.05, "{decay_rate}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(check(&bind(&m, &[("S", 0.21)])), Ok(()));
    // An external part keeps it away from rest.
    let m = text("-c*v - k*z", "xi + z*xi", "");
    assert_eq!(check(&m.bind(&[]).unwrap()), Ok(())); // Noise that does not vanish at rest, however fast it grows away from it, is not
                                                      // "purely parametric": (1 + z²)^40 is 1 at the origin and 2^80 at unit distance.
    for noise in ["(1 + z^2)^40*xi", "exp(10*z)*xi", "(1 + z^200)*xi"] {
        let m = text("-c*v - k*z", noise, "");
        assert!(
            !matches!(
                check(&m.bind(&[]).unwrap()),
                Err(Inadmissible::VanishingDiffusionAtRest { .. })
            ),
            "{noise}"
        );
    }
    // Noise vanishing quadratically at rest still is.
    let m = text("-c*v - k*z", "z^2*xi", "");
    assert!(matches!(
        check(&m.bind(&[]).unwrap()),
        Err(Inadmissible::VanishingDiffusionAtRest { .. })
    ));
}

#[test]
fn a_linear_drift_with_a_mode_that_does_not_decay() {
    let m = text("-c*v - k*z", "xi", "");
    let expected = -0.05 + (0.05f64 * 0.05 + 1.0).sqrt();
    match check(&bind(&m, &[("k", -1.0)])) {
        Err(Inadmissible::UnstableLinearDrift { real_part }) => {
            assert!((real_part - expected).abs() < 1e-6, "{real_part}")
        }
        other => panic!("{other:?}"),
    }
    // No restoring force: a zero eigenvalue, the position diffuses freely.
    assert!(matches!(
        check(&bind(&m, &[("k", 0.0)])),
        Err(Inadmissible::UnstableLinearDrift { .. })
    ));
    // A non-mechanical linear model.
    let src = "model m\nstate x, y\ndrift x: 0.1*x\ndrift y: -y\nnoise xi: intensity 1\n\
               diffusion x: xi\ndiffusion y: xi\n";
    let m = parse_model(src, None).unwrap();
    assert!(matches!(
        check(&m.bind(&[]).unwrap()),
        Err(Inadmissible::UnstableLinearDrift { real_part }) if (real_part - 0.1).abs() < 1e-8
    ));
}

#[test]
fn refusals_stop_the_fpk_derivation_and_monte_carlo() {
    let vibro = model_file("vibro_duffing.sde");
    let b = bind(&vibro, &[("r", 1.001)]);
    assert!(matches!(
        FpkOperator::derive(&b),
        Err(FpkError::Inadmissible(
            Inadmissible::EnergyAddingImpact { .. }
        ))
    ));
    assert!(matches!(
        Simulation::new(&b, &McConfig::default()),
        Err(crate::mc::McError::Inadmissible(_))
    ));
}

#[test]
fn epc_refuses_an_impact_in_original_coordinates_before_any_work() {
    let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
    let fpk = FpkOperator::derive(&orig).unwrap();
    assert_eq!(
        fpk.impact,
        Some(ImpactForm::Unsupported {
            law: "impact x = 0: v -> -0.95*v".into(),
            reason: UnsupportedImpact::Reflecting { restitution: 0.95 },
        })
    );
    // An invalid weight would fail in the first step of the work: the refusal comes first.
    let epc = Epc::new(&fpk).degree(2).weights([Some(-1.0), None]);
    let err = epc.solve().unwrap_err();
    assert!(matches!(err, EpcError::UnsupportedImpact { .. }), "{err}");
    let text = err.to_string();
    for part in [
        "EPC cannot use the impact law `impact x = 0: v -> -0.95*v`",
        "it reflects the velocity",
        "Zhuravlev",
        "Monte Carlo",
    ] {
        assert!(text.contains(part), "`{part}` not in {text}");
    }
    let all = Epc::new(&fpk).solve_degrees(&[2, 4]);
    assert!(all
        .iter()
        .all(|r| matches!(r, Err(EpcError::UnsupportedImpact { .. }))));
}

#[test]
fn zhuravlev_jumps_need_the_matching_delta_term() {
    let jump = "impact z = 0: v -> 0.9*v";
    let m = text("-c*v - k*z", "xi", jump);
    assert!(matches!(
        impact_form(&m.bind(&[]).unwrap()),
        Some(ImpactForm::Unsupported {
            reason: UnsupportedImpact::MissingImpactTerm { .. },
            ..
        })
    ));
    let m = text("-c*v - k*z - 0.2*v*abs(v)*delta(z)", "xi", jump);
    assert!(matches!(
        impact_form(&m.bind(&[]).unwrap()),
        Some(ImpactForm::Unsupported {
            reason: UnsupportedImpact::MismatchedImpactTerm { .. },
            ..
        })
    ));
    let m = text("-c*v - k*z - 0.1*v*abs(v)*delta(z)", "xi", jump);
    assert_eq!(
        impact_form(&m.bind(&[]).unwrap()),
        Some(ImpactForm::Zhuravlev { restitution: 0.9 })
    );
    let m = text("-c*v - k*z", "xi", "impact z = 0: v -> 0.9*v - 0.01*v^3");
    assert!(matches!(
        impact_form(&m.bind(&[]).unwrap()),
        Some(ImpactForm::Unsupported {
            reason: UnsupportedImpact::NotLinear { .. },
            ..
        })
    ));
    let m = text("-c*v - k*z", "xi", "impact z = 0: v -> 0*v");
    assert!(matches!(
        impact_form(&m.bind(&[]).unwrap()),
        Some(ImpactForm::Unsupported {
            reason: UnsupportedImpact::Plastic,
            ..
        })
    ));
}

#[test]
fn monte_carlo_still_simulates_the_original_coordinates() {
    // A short run must see the barrier: x never negative, and a mean far from the 0 that
    // a barrier-free solve gives (the displacement's spread is about 1.7 here).
    let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
    let config = McConfig {
        trajectories: 256,
        samples: 100,
        seed: 3,
        burn_in: BurnIn::Time(50.0),
        grids: vec![
            ("x".into(), Grid::new(0.0, 8.0, 16).unwrap()),
            ("v".into(), Grid::new(-8.0, 8.0, 16).unwrap()),
        ],
        ..McConfig::default()
    };
    let result = Simulation::new(&orig, &config).unwrap().run().unwrap();
    let x = result.quantity("x").unwrap();
    assert_eq!(x.underflow, 0);
    assert!(x.moments.mean.value > 0.8, "E[x] = {:?}", x.moments.mean);
}

#[test]
fn an_impact_term_on_a_position_driven_by_noise_is_no_impact() {
    let drift = "-c*v - k*z - (1 - 0.9)*v*abs(v)*delta(z)";
    let jump = "impact z = 0: v -> 0.9*v";
    let clean = text(drift, "xi", jump);
    assert!(matches!(
        impact_form(&clean.bind(&[]).unwrap()),
        Some(ImpactForm::Zhuravlev { .. })
    ));
    let noisy = text(drift, "xi", &format!("diffusion z: 0.1*xi\n{jump}"));
    assert_eq!(
        impact_form(&noisy.bind(&[]).unwrap()).map(|f| match f {
            ImpactForm::Unsupported { reason, .. } => Some(reason),
            _ => None,
        }),
        Some(Some(UnsupportedImpact::NoiseInPosition {
            position: "z".into(),
            noise: "xi".into(),
        }))
    );
}

/// The one reading: a strip's walls lower first with their sides, a Zhuravlev law passing
/// through, the diffusion the FPK operator uses, and the form's typed refusal.
#[test]
fn dynamics_reads_barriers_diffusion_and_form() {
    let strip = text(
        "-c*v - k*z",
        "xi",
        "impact z = 1: v -> -0.8*v\nimpact z = -1: v -> -0.8*v\n",
    );
    let d = Dynamics::read(&bind(&strip, &[]));
    let Barriers::Strip { lo, hi } = d.barriers().unwrap() else {
        panic!("two walls read as {:?}", d.barriers().unwrap());
    };
    assert_eq!((lo.at(), hi.at()), (-1.0, 1.0));
    assert_eq!(
        lo.kind(),
        BarrierKind::Reflecting(crate::model::BarrierSide::Above)
    );
    assert_eq!(
        hi.kind(),
        BarrierKind::Reflecting(crate::model::BarrierSide::Below)
    );
    assert_eq!(lo.jump(-2.0), 1.6);
    assert_eq!(d.barriers().unwrap().len(), 2);

    let zhuravlev = bind(&model_file("vibro_duffing.sde"), &[]);
    let d = Dynamics::read(&zhuravlev);
    let Barriers::One(b) = d.barriers().unwrap() else {
        panic!("one law read as {:?}", d.barriers().unwrap());
    };
    assert_eq!(b.kind(), BarrierKind::PassThrough);
    assert_eq!(b.side(), None);
    let fpk = FpkOperator::derive(&zhuravlev).unwrap();
    assert_eq!(d.diffusion(), &fpk.diffusion);
    assert_eq!(d.ito_drift().unwrap(), &fpk.drift);
    assert_eq!(d.form(), &Form::Mechanical);

    let src = "model m\nstate x, y\ndrift x: -x + y\ndrift y: -y\nnoise xi: intensity 1\n\
               diffusion x: xi\n";
    let general = parse_model(src, None).unwrap().bind(&[]).unwrap();
    let d = Dynamics::read(&general);
    assert!(matches!(
        d.form(),
        Form::General { why: NotMechanical::Rate { position, .. } } if position == "x"
    ));
    assert!(d.barriers().unwrap().is_empty());
}
