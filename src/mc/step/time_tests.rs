//! The times at which the mechanical splitting evaluates a time-dependent model, checked
//! without sampling error on both of its evaluators (the fast polynomial kernel and the lane
//! evaluator): the velocity update of a step takes the noise at the step's midpoint, and a
//! deterministic run (no noise) with a time-dependent force, damping and stiffness converges
//! at order 2 to the exact solution. (The general schemes' orders with time-dependent
//! coefficients are measured exactly in `platen/order_tests.rs`.)

use crate::mc::compile::mech_form::tests::plan_of;
use crate::mc::compile::scheme::{Dynamics, Plan};
use crate::mc::kernel::rng::Increments;
use crate::mc::step::state::fast_path_tests::assert_follows;
use crate::mc::step::state::BatchState;

/// The plan of `text` on the fast kernel (its coefficients depend on the time: a
/// [`crate::mc::compile::mech_form::TimedForm`]) and on the lane evaluator.
fn both_paths(text: &str) -> [(&'static str, Plan); 2] {
    let fast = plan_of(text).unwrap();
    assert!(matches!(
        fast.dynamics,
        Dynamics::Mechanical {
            form: None,
            timed: Some(_),
            ..
        }
    ));
    let mut slow = plan_of(text).unwrap();
    if let Dynamics::Mechanical { timed, .. } = &mut slow.dynamics {
        *timed = None;
    }
    [("fast", fast), ("lanes", slow)]
}

/// With no force, v after one step from rest is the step's noise increment
/// ±a·√h·σ(t*) or 0 (three-point variables, a ≈ √3): σ(t) = 1 + t makes the nonzero |v| of
/// a step from t₀ = 2 and one from t₀ = 0 stand in the ratio (3 + h/2)/(1 + h/2), the
/// midpoint's; the step's start would give 3, its end (3 + h)/(1 + h).
#[test]
fn the_velocity_update_takes_the_noise_at_the_step_midpoint() {
    let text = "model m\nstate z, v\ndrift z: v\ndrift v: 0\nnoise xi: intensity 1\n\
                diffusion v: (1 + t)*xi\n";
    let h = 0.1;
    for (path, plan) in both_paths(text) {
        let largest = |t0: f64| {
            let mut b = BatchState::new(&plan, &[[0.0; 2]; 2], 3, 0, 256, Increments::ThreePoint);
            b.x.fill(0.0);
            b.v.fill(0.0);
            b.t = t0;
            b.advance(&plan, 1, h);
            assert_eq!(b.t, t0 + h, "{path}");
            let top = b.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // Every lane's increment is 0 or ±top.
            assert!(b.v.iter().all(|v| *v == 0.0 || v.abs() == top), "{path}");
            top
        };
        let ratio = largest(2.0) / largest(0.0);
        let mid = (3.0 + h / 2.0) / (1.0 + h / 2.0);
        assert!(
            (ratio / mid - 1.0).abs() < 1e-14,
            "{path}: ratio {ratio}, midpoint's {mid}"
        );
    }
}

/// z'' + (0.2 + 0.1 sin t) z' + (1 + 0.5 cos 2t) z = cos(0.8t) from (1, 0), no noise: every
/// lane follows the scheme's deterministic path, whose error at t = 2 falls by 4 when the
/// step halves (orders between 1.9 and 2.1 from h = 0.1 to 0.025), on both evaluators.
#[test]
fn a_time_dependent_force_converges_at_order_two() {
    let text = "model m\nstate z, v\ndrift z: v\n\
                drift v: -(0.2 + 0.1*sin(t))*v - (1 + 0.5*cos(2*t))*z + cos(0.8*t)\n\
                noise xi: intensity 0\ndiffusion v: xi\n";
    let force = |t: f64, z: f64, v: f64| {
        -(0.2 + 0.1 * t.sin()) * v - (1.0 + 0.5 * (2.0 * t).cos()) * z + (0.8 * t).cos()
    };
    let horizon = 2.0;
    // The exact solution by RK4 at a step where its error is far below the scheme's.
    let exact = {
        let (mut y, n) = ([1.0f64, 0.0], 20_000);
        let dt = horizon / n as f64;
        let f = |t: f64, y: [f64; 2]| [y[1], force(t, y[0], y[1])];
        for i in 0..n {
            let t = i as f64 * dt;
            let k1 = f(t, y);
            let k2 = f(
                t + dt / 2.0,
                [y[0] + dt / 2.0 * k1[0], y[1] + dt / 2.0 * k1[1]],
            );
            let k3 = f(
                t + dt / 2.0,
                [y[0] + dt / 2.0 * k2[0], y[1] + dt / 2.0 * k2[1]],
            );
            let k4 = f(t + dt, [y[0] + dt * k3[0], y[1] + dt * k3[1]]);
            for j in 0..2 {
                y[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
        y
    };
    for (path, plan) in both_paths(text) {
        let errors: Vec<f64> = [20u64, 40, 80]
            .iter()
            .map(|&n| {
                let mut b =
                    BatchState::new(&plan, &[[0.0; 2]; 2], 1, 0, 70, Increments::ThreePoint);
                b.x.fill(1.0);
                b.v.fill(0.0);
                // Two calls, as an output time splits a run: the time carries over.
                b.advance(&plan, n / 2, horizon / n as f64);
                b.advance(&plan, n / 2, horizon / n as f64);
                assert!(b.x.iter().all(|x| *x == b.x[0]), "{path}: lanes differ");
                (b.x[0] - exact[0]).hypot(b.v[0] - exact[1])
            })
            .collect();
        let orders: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
        let shown: Vec<String> = errors.iter().map(|e| format!("{e:.3e}")).collect();
        eprintln!("{path}: errors {shown:?}, orders {orders:.3?}");
        assert!(
            orders.iter().all(|p| (1.9..2.1).contains(p)),
            "{path}: errors {errors:?}"
        );
    }
}

/// Models whose coefficients depend on the time in every part the fast kernel evaluates:
/// a modulated noise with a sign part at a Zhuravlev barrier, a periodic force and a
/// time-dependent stiffness on a Duffing oscillator, a time-dependent damping (the Heun
/// factor then changes with the time), Rayleigh damping (degree 3 in v) under a periodic
/// force, and a reflecting wall under a parametric noise.
const TIMED: [(&str, &str); 5] = [
    (
        "modulated_vibro",
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z - 0.1*z^3\nnoise xi: intensity 1\n\
         diffusion v: 2*(exp(-0.5*t) - exp(-t))*(sgn(z) + 0.1*z)*xi\nimpact z = 0: v -> 0.8*v\n",
    ),
    (
        "forced_duffing",
        "model m\nstate z, v\ndrift z: v\n\
         drift v: -0.1*v - (1 + 0.3*cos(2*t))*z - 0.2*z^3 + 0.5*cos(0.9*t)\n\
         noise xi: intensity 0.2\ndiffusion v: xi\n",
    ),
    (
        "time_damping",
        "model m\nstate z, v\ndrift z: v\ndrift v: -(0.1 + 0.05*sin(t))*(1 + z^2)*v - z\n\
         noise xi: intensity 0.2\ndiffusion v: (1 + 0.5*sin(3*t))*xi\n",
    ),
    (
        "rayleigh_forced",
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - 0.05*v^3 - z + 0.3*sin(t)*v^2\n\
         noise xi: intensity 0.2\ndiffusion v: exp(-0.1*t)*xi\n",
    ),
    (
        "wall",
        "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\nnoise xi: intensity 0.2\n\
         diffusion v: (1 + 0.2*z*cos(t))*xi\nimpact z = -1: v -> -0.7*v\ndomain z >= -1\n",
    ),
];

/// The fast kernel's time-dependent coefficients against the lane evaluator's, from the
/// same random states and streams at several times, 4 steps at a time
/// ([`assert_follows`]): the states agree to rounding (Horner's order is not the tape's: far
/// less than 1e-12·(1 + |z| + |v|)³ over four steps), the impacts exactly.
#[test]
fn the_fast_kernel_follows_the_lane_evaluator_with_the_time() {
    for (name, text) in TIMED {
        let [(_, fast), (_, slow)] = both_paths(text);
        assert_follows(name, &fast, &slow, 1e-12);
    }
}

/// Coefficients computed once for every batch (a [`SpanTable`]) give the bits each batch
/// computes for itself, across kernel calls ([`TABLE_STEPS`] steps each); a table made for
/// other steps is not used.
#[test]
fn a_shared_span_table_changes_no_bit() {
    use crate::mc::step::timed::{SpanTable, TABLE_STEPS};
    for (name, text) in TIMED {
        let plan = plan_of(text).unwrap();
        let (steps, h, t0) = (TABLE_STEPS + 300, 0.01, 1.5);
        let table = SpanTable::of(&plan, t0, steps, h, usize::MAX).expect("a timed form");
        let other = SpanTable::of(&plan, t0 + h, steps, h, usize::MAX).unwrap();
        let run = |span: Option<&SpanTable>| {
            let mut b = BatchState::new(&plan, &[[0.0; 2]; 2], 5, 0, 70, Increments::ThreePoint);
            b.x.fill(0.5);
            b.v.fill(0.1);
            b.t = t0;
            b.advance_with(&plan, steps, h, span);
            (b.x, b.v, b.impacts)
        };
        let own = run(None);
        assert_eq!(run(Some(&table)), own, "{name}");
        assert_eq!(run(Some(&other)), own, "{name}");
        assert!(SpanTable::of(&plan, t0, steps, h, 10).is_none());
    }
}
