//! Unit tests of the parts: the exact density is a root of the discrete equations, and
//! barrier sets given in code on a barrier-free model (a strip, an upper barrier at a
//! positive position read from a lower one).

use nalgebra::DVector;

use super::mechanics::{BarrierSide, Mechanics, Wall};
use super::rule::{System, Window};
use super::{EpcImpact, Normalisation};
use crate::model::{parse_model, BoundModel};

/// x'' + (c0 + c1·E) x' + x = ξ, E = v²/2 + x²/2, 2πK = 1: the exact density (elastic
/// impacts) is exp(−2(c0 E + c1 E²/2)) on any domain.
fn caughey_ma(impact: &str) -> BoundModel {
    let text = format!(
        "model cm\nparam c0 = 0.1, c1 = 0.05\nstate x, v\ndrift x: v\n\
         drift v: -(c0 + c1*(v^2/2 + x^2/2))*v - x\nnoise xi: intensity 1\n\
         diffusion v: xi\n{impact}\n"
    );
    parse_model(&text, None).unwrap().bind(&[]).unwrap()
}

/// The exact Q of [`caughey_ma`] (original variables) on the degree-4 basis.
fn exact_q(exps: &[(usize, usize)]) -> Vec<f64> {
    let (c0, c1) = (0.1, 0.05);
    exps.iter()
        .map(|e| match e {
            (2, 0) | (0, 2) => -c0,
            (4, 0) | (0, 4) => -c1 / 4.0,
            (2, 2) => -c1 / 2.0,
            _ => 0.0,
        })
        .collect()
}

/// The residual of the discrete equations at the exact coefficients is at rounding level,
/// for a lower barrier off 0, an upper barrier and a strip.
#[test]
fn the_exact_elastic_density_is_a_root() {
    let model = caughey_ma("impact x = -0.5: v -> -v\ndomain x >= -0.5");
    let base = Mechanics::new(&crate::dynamics::Dynamics::read(&model)).unwrap();
    let sigma = [2.0, 2.0];
    for (barriers, x) in [
        (
            vec![Wall::restitution(-0.5, BarrierSide::Above, 1.0)],
            [-0.5, 14.0],
        ),
        (
            vec![Wall::restitution(0.7, BarrierSide::Below, 1.0)],
            [-14.0, 0.7],
        ),
        (
            vec![
                Wall::restitution(-0.5, BarrierSide::Above, 1.0),
                Wall::restitution(0.8, BarrierSide::Below, 1.0),
            ],
            [-0.5, 0.8],
        ),
    ] {
        let mut mech = base.clone();
        mech.barriers = barriers;
        let window = Window {
            x,
            v: [-14.0, 14.0],
        };
        let sys = System::build(&mech, sigma, window, [24, 24], 4).unwrap();
        let q = exact_q(&sys.exps);
        let a = DVector::from_iterator(
            q.len(),
            sys.exps
                .iter()
                .zip(&q)
                .map(|(&(i, j), c)| c * sigma[0].powi(i as i32) * sigma[1].powi(j as i32)),
        );
        let r = sys.residual(&a).norm();
        assert!(r < 1e-12, "{x:?}: ‖R‖ = {r:e}");
        // The same equations with r = 0.9 are not solved by it: the boundary term matters.
        let mut inelastic = mech.clone();
        for b in &mut inelastic.barriers {
            *b = Wall::restitution(b.at(), b.side, 0.9);
        }
        let sys = System::build(&inelastic, sigma, window, [24, 24], 4).unwrap();
        assert!(sys.residual(&a).norm() > 1e-4, "{x:?}");
    }
}

/// The solver recovers the exact density on a strip (two elastic barriers), which the model
/// language cannot state yet.
#[test]
fn a_strip_is_solved_exactly() {
    let model = caughey_ma("impact x = -0.5: v -> -v\ndomain x >= -0.5");
    let strip = vec![
        Wall::restitution(-0.5, BarrierSide::Above, 1.0),
        Wall::restitution(0.8, BarrierSide::Below, 1.0),
    ];
    let sol = EpcImpact::new(&model).barriers(strip).solve(4).unwrap();
    let q = exact_q(&sol.exponents);
    for (k, (a, e)) in sol.coefficients.iter().zip(&q).enumerate() {
        assert!((a - e).abs() < 1e-8, "{:?}: {a} vs {e}", sol.exponents[k]);
    }
    assert_eq!(sol.report.normalisation, Normalisation::Domain);
    assert_eq!(sol.window.x, [-0.5, 0.8]);
    assert_eq!(sol.pdf(0.9, 0.0), 0.0);
    assert_eq!(sol.pdf(-0.6, 0.0), 0.0);
}

/// Two barriers with the state above the upper one do not bound a strip.
#[test]
fn barriers_that_do_not_bound_a_strip_are_refused() {
    let model = caughey_ma("impact x = -0.5: v -> -v\ndomain x >= -0.5");
    let crossed = vec![
        Wall::restitution(0.8, BarrierSide::Above, 1.0),
        Wall::restitution(-0.5, BarrierSide::Below, 1.0),
    ];
    let err = EpcImpact::new(&model)
        .barriers(crossed)
        .solve(2)
        .unwrap_err();
    assert!(matches!(
        err,
        super::EpcImpactError::Unsupported {
            reason: super::Unsupported::NotAStrip { .. },
            ..
        }
    ));
}
