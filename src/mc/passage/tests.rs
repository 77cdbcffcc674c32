//! The blocked, screened batch (`batch.rs`) against the plain one it replaced: every step
//! advanced by itself and tested at its four samples. The exit times must agree to the bit.

use super::batch::Queue;
use super::locate::{left_within, SUBSTEPS};
use super::screen::Spans;
use super::*;
use crate::mc::step::state::BatchState;
use crate::model::{load_model, parse_model, Model};

/// The plain batch: one [`BatchState::advance`] per step, every step tested.
fn plain(run: &McPassage<'_>, plan: &Plan, first: u64, lanes: usize, h: f64) -> Vec<f64> {
    let spread = plan.initial_spread();
    let mut b = BatchState::new(plan, &spread, run.seed, first, lanes, run.increments);
    b.x.fill(run.start[0]);
    b.v.fill(run.start[1]);
    let q0 = run.safe.quantity_at(run.start);
    let mut prev = vec![(run.start, q0); lanes];
    let mut exit = vec![f64::INFINITY; lanes];
    let mut scratch = Vec::new();
    let steps = (run.horizon / h).ceil() as u64;
    for n in 0..steps {
        b.advance(plan, 1, h);
        for i in 0..lanes {
            if exit[i] != f64::INFINITY {
                continue;
            }
            let end = [b.x[i], b.v[i]];
            let q1 = run.safe.quantity_at(end);
            if q1.is_nan() || !end[0].is_finite() || !end[1].is_finite() {
                exit[i] = f64::NAN;
                continue;
            }
            let Some(s) = left_within(run.safe, prev[i], (end, q1), h, &mut scratch) else {
                prev[i] = (end, q1);
                continue;
            };
            let t = (n as f64 + s) * h;
            exit[i] = if t <= run.horizon {
                t
            } else {
                f64::NEG_INFINITY
            };
        }
    }
    exit.iter_mut()
        .filter(|t| **t == f64::NEG_INFINITY)
        .for_each(|t| *t = f64::INFINITY);
    exit
}

fn file(name: &str) -> Model {
    let path = format!("{}/models/{name}", env!("CARGO_MANIFEST_DIR"));
    load_model(path.as_ref()).unwrap()
}

/// The models, safe sets, starts and increments of the comparison: the fast mechanical path
/// with a wall and without, and every fallback (Gaussian increments, two walls, two noises,
/// a force depending on the time); quantities through most of the tape's operations,
/// including ones the enclosure refuses (a variable power).
fn cases() -> Vec<(&'static str, Model, &'static str, [f64; 2], Increments)> {
    let forced = parse_model(
        "model forced\nstate x, v\ndrift x: v\ndrift v: -0.1*v - x + 0.5*cos(1.3*t)\n\
         noise xi: intensity 0.2\ndiffusion v: xi\n",
        None,
    )
    .unwrap();
    let three = Increments::ThreePoint;
    vec![
        (
            "case 1",
            file("vibro_impact_duffing.sde"),
            "y < 2",
            [1e-6, 0.0],
            three,
        ),
        (
            "case 1, Gaussian",
            file("vibro_impact_duffing.sde"),
            "y < 2",
            [1e-6, 0.0],
            Increments::Gaussian,
        ),
        (
            "linear",
            file("linear.sde"),
            "abs(z) < 1.5",
            [0.0, 0.0],
            three,
        ),
        (
            "energy",
            file("linear.sde"),
            "z^2 + v^2 < 3",
            [0.5, 0.0],
            three,
        ),
        (
            "two-sided",
            file("linear.sde"),
            "-1 < z + 0.3*v < 1.4",
            [0.0, 0.0],
            three,
        ),
        (
            "functions",
            file("duffing.sde"),
            "sqrt(z^2 + 0.5*v^2) + 0.1*tanh(v) - 0.05*sgn(z) < 1.2",
            [0.0, 0.0],
            three,
        ),
        (
            "logarithm",
            file("duffing.sde"),
            "log(1 + z^2) + exp(0.1*v) - min(z, v) < 2",
            [0.0, 0.0],
            three,
        ),
        (
            "quotient",
            file("linear.sde"),
            "z / (1 + v^2) + max(abs(v), 0.2)^1.5 < 1.5",
            [0.0, 0.0],
            three,
        ),
        (
            "periodic",
            file("linear.sde"),
            "sin(z) + cos(v) > 0.2",
            [0.0, 0.0],
            three,
        ),
        (
            "variable power",
            file("linear.sde"),
            "(1 + z^2)^(1 + 0.1*v^2) < 2.5",
            [0.0, 0.0],
            three,
        ),
        (
            "strip",
            file("vibro_impact_strip.sde"),
            "abs(ydot) < 1.5",
            [0.0, 0.0],
            three,
        ),
        (
            "two noises",
            file("cubic_damping_two_noises.sde"),
            "abs(z) < 1",
            [0.0, 0.0],
            three,
        ),
        ("forced", forced, "abs(x) < 1", [0.0, 0.0], three),
    ]
}

#[test]
fn the_screened_blocks_give_the_plain_exit_times_to_the_bit() {
    let mut censored = 0;
    for (name, model, safe, start, increments) in cases() {
        let model = model.with_safe(safe).unwrap();
        let bound = model.bind(&[]).unwrap();
        let safe = model.safe().unwrap().bind(&bound).unwrap();
        // 150 paths: two whole batches and a part of one; a horizon of 3000 steps of 0.01
        // (23 blocks and a part), short enough that some paths are censored.
        let run = McPassage::new(&bound, &safe)
            .start(start)
            .horizon(29.995)
            .paths(150)
            .seed(5)
            .increments(increments);
        let plan = run.plan(&crate::dynamics::Dynamics::read(&bound)).unwrap();
        let mut exits = 0;
        // At h = 0.1 an excursion out and back within a step, caught only by the samples
        // between its ends, is common.
        for h in [0.01, 0.1] {
            let want: Vec<f64> = [(0, 64), (64, 64), (128, 22)]
                .into_iter()
                .flat_map(|(first, lanes)| plain(&run, &plan, first, lanes, h))
                .collect();
            // All the paths in one task (on the fast path its lanes take them in turn), then
            // from the second batch on, then a batch of its own.
            for (first, count) in [(0, 150), (64, 86), (128, 22)] {
                let mut got = run
                    .exits()
                    .drain(&plan, &Queue::new(first..first + count), h);
                got.sort_by_key(|e| e.0);
                let indices: Vec<u64> = got.iter().map(|e| e.0).collect();
                assert_eq!(indices, (first..first + count).collect::<Vec<_>>());
                for (p, g) in got {
                    let p = p as usize;
                    let w = want[p];
                    assert_eq!(
                        w.to_bits(),
                        g.to_bits(),
                        "{name}, h = {h}: path {p}: {w} vs {g}"
                    );
                }
            }
            exits += want.iter().filter(|t| t.is_finite()).count();
            censored += want.iter().filter(|t| **t == f64::INFINITY).count();
        }
        assert!(exits > 10, "{name}: {exits} exits");
    }
    assert!(censored > 0, "nothing censored");
}

/// Steps near the boundary of `y < 1` (the fast path's states, shifted so that the set's
/// edge cuts through them): the screen clears a part of a block only when no step of it
/// leaves at any sample, whatever the step size.
#[test]
fn the_screen_clears_no_step_that_leaves() {
    let model = file("linear.sde").with_safe("z < 1").unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let run = McPassage::new(&bound, &safe);
    let plan = run.plan(&crate::dynamics::Dynamics::read(&bound)).unwrap();
    let lanes = 64;
    let (mut cleared, mut refused) = (0, 0);
    for h in [0.01, 0.1, 0.5] {
        let mut b = BatchState::new(
            &plan,
            &plan.initial_spread(),
            9,
            0,
            lanes,
            Increments::ThreePoint,
        );
        let steps = 64;
        let (mut xs, mut vs) = (vec![0.0; steps * lanes], vec![0.0; steps * lanes]);
        let (bx, bv) = (b.x.clone(), b.v.clone());
        assert!(b.advance_rows(&plan, steps as u64, 1, h, &mut xs, &mut vs));
        let mut spans = Spans::default();
        spans.fill(b.simd(), &bx, &bv, &xs, &vs, 4);
        let (mut enclosure, mut scratch) = (Vec::new(), Vec::new());
        for p in 0..spans.parts() {
            for i in 0..lanes {
                let state = |j: usize| -> [f64; 2] {
                    if j == 0 {
                        [bx[i], bv[i]]
                    } else {
                        [xs[(j - 1) * lanes + i], vs[(j - 1) * lanes + i]]
                    }
                };
                // Does some step of the part leave (a sample at or beyond the edge)?
                let leaves = (4 * p..4 * p + 4).any(|j| {
                    let (a, e) = (state(j), state(j + 1));
                    let q = |s: [f64; 2]| safe.quantity_at(s);
                    // Tested from inside: a start beyond the edge counts as leaving.
                    !safe.inside(q(a))
                        || left_within(&safe, (a, q(a)), (e, q(e)), h, &mut scratch).is_some()
                });
                if spans.get(p, i).inside(&safe, h, &mut enclosure) {
                    assert!(
                        !leaves,
                        "h = {h}, part {p}, lane {i}: cleared, yet it leaves"
                    );
                    cleared += 1;
                } else {
                    refused += 1;
                }
            }
        }
    }
    assert!(
        cleared > 100 && refused > 100,
        "{cleared} cleared, {refused} refused"
    );
    assert_eq!(SUBSTEPS, 4);
}
