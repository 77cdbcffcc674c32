//! The stepper against exact solutions: exp(At) of scalar and 2×2 systems, its order on a
//! fixed step, L-stability, the error control, mass, and a generator that depends on t.

use std::borrow::Cow;

use faer::sparse::{SparseColMat, Triplet};

use super::{Esdirk, Generator, Scheme, StepError, Tolerance};

fn matrix(n: usize, entries: &[(usize, usize, f64)]) -> SparseColMat<usize, f64> {
    let t: Vec<_> = entries
        .iter()
        .map(|&(r, c, v)| Triplet::new(r, c, v))
        .collect();
    SparseColMat::try_new_from_triplets(n, n, &t).unwrap()
}

fn tol(t: f64) -> Tolerance {
    Tolerance {
        relative: t,
        absolute: t,
    }
}

/// x' = v, v' = −ω² x − 2ζω v, and its exact solution from (x₀, v₀).
struct Oscillator {
    omega: f64,
    zeta: f64,
}

impl Oscillator {
    fn a(&self) -> SparseColMat<usize, f64> {
        let (w, z) = (self.omega, self.zeta);
        matrix(2, &[(0, 1, 1.0), (1, 0, -w * w), (1, 1, -2.0 * z * w)])
    }

    fn exact(&self, t: f64, [x0, v0]: [f64; 2]) -> [f64; 2] {
        let (w, z) = (self.omega, self.zeta);
        let wd = w * (1.0 - z * z).sqrt();
        let (c, s, e) = ((wd * t).cos(), (wd * t).sin(), (-z * w * t).exp());
        [
            e * (x0 * c + (v0 + z * w * x0) / wd * s),
            e * (v0 * c - (z * w * v0 + w * w * x0) / wd * s),
        ]
    }
}

const OSC: Oscillator = Oscillator {
    omega: 2.0,
    zeta: 0.1,
};

fn error_at(history: &super::History, exact: impl Fn(f64) -> [f64; 2]) -> f64 {
    history
        .outputs
        .iter()
        .map(|o| {
            let e = exact(o.t);
            (o.y[0] - e[0]).abs() + (o.y[1] - e[1]).abs()
        })
        .fold(0.0, f64::max)
}

/// One step of y' = λy: the filtered embedded estimate is the true local error
/// y₁ − e^{λh} to leading order (their ratio → 1: the estimate is the method minus the
/// third-order companion), and the local error is O(h³). Measured: ratio 1.035 at h = 0.4,
/// 1.0006 at h = 0.0125; error/h³ → −0.134 (the method's constant (−3γ² + 4γ − 2)/(12(2 − γ)) · λ³).
#[test]
fn the_estimate_is_the_local_error() {
    let lambda = -1.5;
    let a = matrix(1, &[(0, 0, lambda)]);
    let run = Esdirk::new(&a);
    let mut last = f64::INFINITY;
    for h in [0.4, 0.2, 0.1, 0.05, 0.025, 0.0125] {
        let (y1, est) = run.one_step(0.0, h, &[1.0]);
        let truth = y1[0] - (lambda * h).exp();
        let off = (est[0] / truth - 1.0).abs();
        assert!(off < 0.04 && off < last, "h {h}: ratio {}", est[0] / truth);
        last = off;
    }
    assert!(last < 1e-3, "{last}");
    let gamma = 2.0 - std::f64::consts::SQRT_2;
    let constant =
        (-3.0 * gamma * gamma + 4.0 * gamma - 2.0) / (12.0 * (2.0 - gamma)) * lambda.powi(3);
    let h = 1e-3;
    let (y1, _) = run.one_step(0.0, h, &[1.0]);
    let per_h3 = (y1[0] - (lambda * h).exp()) / h.powi(3);
    // The method's error y₁ − y(h) is minus the truncation error C h³ y‴.
    assert!(
        (per_h3 / -constant - 1.0).abs() < 1e-2,
        "{per_h3} vs {constant}"
    );
}

/// y' = −1.5y from 2 over 0..4 (outputs inside steps): with the default control (error per
/// unit time) the global error is proportional to the tolerance, about half of it at every
/// tolerance from 1e−6 to 1e−9 (measured 0.355 to 0.523, the steps no longer than the
/// outputs' intervals). A local tolerance per step does
/// not bound the global error by the same number: with `per_step` the error is about the
/// tolerance times the number of steps (measured 117·tol at 1e−9 over 1648 steps) and
/// falls as tol^(2/3) (5.5·tol at 1e−5): both are held below.
#[test]
fn scalar_decay_is_exp() {
    let a = matrix(1, &[(0, 0, -1.5)]);
    let times = [0.0, 0.3, 1.0, 2.5, 4.0];
    let error = |h: &super::History| {
        assert_eq!(h.outputs.len(), times.len());
        h.outputs
            .iter()
            .map(|o| (o.y[0] - 2.0 * (-1.5 * o.t).exp()).abs())
            .fold(0.0, f64::max)
    };
    for t in [1e-6, 1e-7, 1e-8, 1e-9] {
        let h = Esdirk::new(&a)
            .tolerance(tol(t))
            .run(&[2.0], 0.0, &times)
            .unwrap();
        let ratio = error(&h) / t;
        assert!((0.3..0.6).contains(&ratio), "tol {t:e}: error {ratio}·tol");
        let per_step = Esdirk::new(&a).tolerance(tol(t)).per_step();
        let h = per_step.run(&[2.0], 0.0, &times).unwrap();
        let err = error(&h);
        // The scale of the tolerance is 1 + |y| ≤ 3.
        let steps = h.stats.accepted as f64;
        assert!(
            err < 3.0 * t * steps && err > t,
            "tol {t:e}: {err:e}, {steps} steps"
        );
    }
}

/// Fixed steps h, h/2, h/4 on the 2×2 oscillator: errors fall by 4 each time.
#[test]
fn second_order_on_a_fixed_step() {
    let a = OSC.a();
    let errors: Vec<f64> = [0.1, 0.05, 0.025]
        .iter()
        .map(|&h| {
            let run = Esdirk::new(&a).first_step(h).fixed();
            let history = run.run(&[1.0, 0.0], 0.0, &[4.0]).unwrap();
            error_at(&history, |t| OSC.exact(t, [1.0, 0.0]))
        })
        .collect();
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!((1.9..2.1).contains(&order), "{errors:?}: order {order}");
    }
}

/// A two-state chain relaxing at rate 1e6, one step of 0.1: the trapezoidal rule would keep
/// the fast mode (|R(−∞)| = 1); TR-BDF2 damps it (R(z) ~ 1.41/(d z) → 0), and keeps the mass.
#[test]
fn l_stable_on_a_stiff_chain() {
    let (up, down) = (1e6, 1.0);
    let a = matrix(2, &[(0, 0, -up), (1, 0, up), (0, 1, down), (1, 1, -down)]);
    let h = Esdirk::new(&a).first_step(0.1).fixed();
    let out = h.run(&[1.0, 0.0], 0.0, &[0.1]).unwrap();
    let y = &out.outputs[0].y;
    let stationary = down / (up + down);
    let rate = up + down;
    let exact = stationary + (1.0 - stationary) * (-rate * 0.1f64).exp();
    assert!((y[0] - exact).abs() < 1e-4, "{} vs {exact}", y[0]);
    assert!((y[0] + y[1] - 1.0).abs() < 1e-15);
    // The stability function at z = −1e8: |R| < 1e-7.
    let stiff = matrix(1, &[(0, 0, -1e8)]);
    let r = Esdirk::new(&stiff)
        .first_step(1.0)
        .fixed()
        .run(&[1.0], 0.0, &[1.0])
        .unwrap();
    assert!(r.outputs[0].y[0].abs() < 1e-7, "{}", r.outputs[0].y[0]);
}

/// The controlled error over 0..10 (about three periods of a lightly damped oscillator that
/// does not contract the error), at 1001 outputs inside steps: proportional to the tolerance
/// and below tolerance × elapsed time (measured 4.12, 4.82, 4.87 × tol: a Hermite output
/// error, O(h⁴), would not scale with tol), with few factorisations.
#[test]
fn error_control_meets_the_tolerance() {
    let a = OSC.a();
    let times: Vec<f64> = (0..=20).map(|k| 0.5 * k as f64).collect();
    let mut ratios = Vec::new();
    for t in [1e-4, 1e-6, 1e-8] {
        let h = Esdirk::new(&a)
            .tolerance(tol(t))
            .run(&[1.0, 0.0], 0.0, &times)
            .unwrap();
        let err = error_at(&h, |s| OSC.exact(s, [1.0, 0.0]));
        assert!(err < 10.0 * t, "tol {t:e}: error {err:e}");
        ratios.push(err / t);
        assert!(h.stats.factorizations == h.stats.step_sizes);
        assert!(
            h.stats.factorizations * 100 < h.stats.accepted,
            "{:?}",
            h.stats
        );
    }
    let (lo, hi) = ratios
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), r| (l.min(*r), h.max(*r)));
    assert!(hi / lo < 1.2, "error/tol {ratios:?}");
}

/// A 40-state generator (columns sum to zero, rates spread over six decades) keeps its mass
/// to rounding over hundreds of steps.
#[test]
fn mass_is_conserved_to_rounding() {
    let n = 40;
    let mut entries = Vec::new();
    for c in 0..n {
        let mut out = 0.0;
        for (k, r) in [(c + 1) % n, (c + 7) % n, (c + 13) % n]
            .into_iter()
            .enumerate()
        {
            let rate = 10f64.powi(((c * 3 + k) % 7) as i32 - 3);
            entries.push((r, c, rate));
            out += rate;
        }
        entries.push((c, c, -out));
    }
    let a = matrix(n, &entries);
    let y0: Vec<f64> = (0..n).map(|k| if k < 5 { 0.2 } else { 0.0 }).collect();
    let times: Vec<f64> = (1..=50).map(|k| 0.2 * k as f64).collect();
    let h = Esdirk::new(&a).tolerance(tol(1e-7)).conserve_mass();
    let h = h.run(&y0, 0.0, &times).unwrap();
    assert!(h.stats.accepted > 100, "{:?}", h.stats);
    for o in &h.outputs {
        assert!((o.mass - 1.0).abs() < 2e-13, "t={}: mass {}", o.t, o.mass);
    }
    // A matrix whose columns do not sum to zero is refused.
    let leaky = matrix(2, &[(0, 0, -1.0), (1, 0, 0.5)]);
    let refused = Esdirk::new(&leaky)
        .conserve_mass()
        .run(&[1.0, 0.0], 0.0, &[1.0]);
    assert!(matches!(
        refused,
        Err(StepError::Setting {
            setting: "conserve_mass",
            ..
        })
    ));
}

/// y' = −t y, y = exp(−t²/2): a generator that depends on t, factorised per stage time.
#[test]
fn a_generator_that_depends_on_time() {
    struct Ramp;
    impl Generator for Ramp {
        fn dim(&self) -> usize {
            1
        }
        fn time_invariant(&self) -> bool {
            false
        }
        fn at(&self, t: f64) -> Result<Cow<'_, SparseColMat<usize, f64>>, StepError> {
            Ok(Cow::Owned(matrix(1, &[(0, 0, -t)])))
        }
    }
    let times = [0.5, 1.0, 2.0, 3.0];
    for scheme in [Scheme::TrBdf2, Scheme::Esdirk4] {
        let mut factorizations = Vec::new();
        for across in [false, true] {
            let stepper = Esdirk::new(&Ramp).scheme(scheme).tolerance(tol(1e-9));
            let stepper = if across {
                stepper.reuse_across_times()
            } else {
                stepper
            };
            let h = stepper.run(&[1.0], 0.0, &times).unwrap();
            for o in &h.outputs {
                let exact = (-o.t * o.t / 2.0).exp();
                assert!(
                    (o.y[0] - exact).abs() < 1e-8,
                    "{scheme:?} across {across} t={}: {} vs {exact}",
                    o.t,
                    o.y[0]
                );
            }
            assert_eq!(h.stats.sweeps > 0, across, "{scheme:?} {:?}", h.stats);
            factorizations.push(h.stats.factorizations);
        }
        // Another time's factor preconditions most stage solves.
        assert!(
            4 * factorizations[1] < factorizations[0],
            "{scheme:?}: {factorizations:?}"
        );
    }
}

/// ESDIRK4 on fixed steps h, h/2, h/4 of the 2×2 oscillator: errors fall by 16 each time;
/// and on y' = −t y (stage times in a generator that depends on t) by 16 too.
#[test]
fn esdirk4_is_fourth_order_on_a_fixed_step() {
    let a = OSC.a();
    let errors: Vec<f64> = [0.2, 0.1, 0.05]
        .iter()
        .map(|&h| {
            let run = Esdirk::new(&a)
                .scheme(Scheme::Esdirk4)
                .first_step(h)
                .fixed();
            let history = run.run(&[1.0, 0.0], 0.0, &[4.0]).unwrap();
            error_at(&history, |t| OSC.exact(t, [1.0, 0.0]))
        })
        .collect();
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!((3.8..4.3).contains(&order), "{errors:?}: order {order}");
    }
}

/// ESDIRK4 under error control: the error proportional to the tolerance and below 10 ×
/// tol on the lightly damped oscillator, in far fewer steps than TR-BDF2 at the same
/// tolerance; and L-stable on the stiff chain.
#[test]
fn esdirk4_meets_the_tolerance_in_fewer_steps() {
    let a = OSC.a();
    let times: Vec<f64> = (0..=20).map(|k| 0.5 * k as f64).collect();
    for t in [1e-4, 1e-6, 1e-8] {
        let run = |scheme| {
            Esdirk::new(&a)
                .scheme(scheme)
                .tolerance(tol(t))
                .run(&[1.0, 0.0], 0.0, &times)
                .unwrap()
        };
        let (four, two) = (run(Scheme::Esdirk4), run(Scheme::TrBdf2));
        let err = error_at(&four, |s| OSC.exact(s, [1.0, 0.0]));
        assert!(err < 10.0 * t, "tol {t:e}: error {err:e}");
        assert!(
            four.stats.accepted * 3 < two.stats.accepted,
            "tol {t:e}: {:?} vs {:?}",
            four.stats,
            two.stats
        );
    }
    let stiff = matrix(1, &[(0, 0, -1e8)]);
    let r = Esdirk::new(&stiff)
        .scheme(Scheme::Esdirk4)
        .first_step(1.0)
        .fixed()
        .run(&[1.0], 0.0, &[1.0])
        .unwrap();
    assert!(r.outputs[0].y[0].abs() < 1e-7, "{}", r.outputs[0].y[0]);
}

#[test]
fn settings_are_checked_before_any_step() {
    let a = OSC.a();
    let run = Esdirk::new(&a);
    let setting = |r: Result<super::History, StepError>| match r {
        Err(StepError::Setting { setting, .. }) => setting,
        other => panic!("{other:?}"),
    };
    assert_eq!(setting(run.run(&[1.0, 0.0], 0.0, &[2.0, 1.0])), "times");
    assert_eq!(setting(run.run(&[1.0, 0.0], 1.0, &[0.5])), "times");
    assert_eq!(setting(run.run(&[1.0], 0.0, &[1.0])), "initial");
    assert_eq!(setting(run.run(&[f64::NAN, 0.0], 0.0, &[1.0])), "initial");
    let bad = Esdirk::new(&a).tolerance(tol(-1.0));
    assert_eq!(setting(bad.run(&[1.0, 0.0], 0.0, &[1.0])), "tolerance");
    let few = Esdirk::new(&a).tolerance(tol(1e-10)).max_steps(5);
    assert!(matches!(
        few.run(&[1.0, 0.0], 0.0, &[10.0]),
        Err(StepError::TooManySteps { steps: 5, .. })
    ));
}
