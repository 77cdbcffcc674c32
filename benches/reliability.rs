//! Issue 35, item 7: the reliability statistics' speed targets, each group timing the target
//! beside a peer in the same run, so that the ratio does not depend on the machine's load:
//!
//! * `reliability_statistics`: crossing and impact statistics "add ≤ 10 % to a stationary
//!   solve". The grid's stationary solve of the paper's case 1 with its wall
//!   (`models/vibro_impact_duffing.sde`) at 200×400 cells with its error estimate (the main
//!   job's solve), against the same followed by what the main job derives from it: the
//!   up-crossing rates of `y` at 201 levels ([`crossing_rate`]) and the impact statistics at
//!   the wall with the speed PDF at 201 points ([`impact_statistics`]), each with its error
//!   from the half-cells solve ([`GridSolution::estimate_of_each`]).
//! * `reliability_mean_passage`: "the mean first-passage time at 200×400 ≤ 1 s whole
//!   process". [`GridPassage`]'s mean times (no R(t)) at 200×400 with its half-cells
//!   estimate on the lightly damped linear oscillator (ζ = 0.05, |z| < 2.5σ, from rest) and
//!   on case 1 (`y < 3` from y = 1e−6 at rest), each beside the stationary solve of the same
//!   model at the same cells: what `fpsolve reliability --mean-only` solves (no output
//!   times, no slowest decay). (The whole process, reading the model and writing
//!   `summary.json`, is timed with the command: without `--mean-only` the command also
//!   steps R(t) to 5 mean times, finds the slowest decay and makes the stationary study of
//!   the crossing tables.)
//! * `reliability_r_of_t`: "R(t) to a horizon of 5× the mean time at 1e−4 ≤ 3 s". Case 1's
//!   R(t) at 51 times from 0 to 5 mean times (150) at the stepper's tolerance 1e−4, beside
//!   the mean times alone, at 100×200 cells: at 200×400 one run takes about a minute (the
//!   closing note's tables time it as a whole process), too long for criterion's ten
//!   samples.
//! * `reliability_mc_rate`: "first-passage Monte Carlo at the stationary kernel's rate".
//!   Path-steps per second (criterion's elements/s) of [`McPassage`] on case 1 (`y < 3`,
//!   dt 0.01, 2048 paths and its 2·dt bias run) against the stationary [`Simulation`] of the
//!   same model and scheme (1024 trajectories × 6000 steps, no burn-in, no bias run), on
//!   rayon's default pool. The passage run's step count is E[T]/dt per path at dt plus the
//!   bias paths' E[T]/(2 dt), from a first run of the same seed (the located exit ends a
//!   path within its last step, so the count is exact to a step per path).
//!
//! Measured on 2 shared cores under a load of 6–10 from other builds (medians of 10): the
//! statistics add 5 % (0.587 against 0.558 s); the mean times took 0.51 s (linear) and
//! 0.55 s (case 1) against the stationary solve's 0.31 and 0.40 s (load 2.3–3.9, medians of
//! four runs), and without the slowest decay (as `--mean-only`) 0.68 s and 0.84 s against
//! 0.70 and 0.73 s in the same run (load 6.5, criterion's medians of 10); `fpsolve reliability --method grid` at 200×400 without `--times` takes 10.6 s
//! (linear) and 4.6 s (case 1 as `vibro_duffing.sde`, |z| < 2.5) as a whole process, R(t)
//! on the fine cells most of it (load 3.8–4.9, medians of 5), and with `--mean-only`
//! 1.24 s and 0.73 s against 17.5 s and 7.6 s for the full run in the same alternated
//! runs (load 6.5–7.1, medians of 5; single runs at a load of about 5: 0.62 and 0.49 s),
//! the fine cells' stationary solve for the stationary start's average the longest part
//! (the killed generator's factorisation and the half cells' solves run beside it); R(t) to 5 means at
//! 100×200 3.9 s against 0.14 s for the mean times. Measured again
//! (`fpsolve reliability models/vibro_duffing.sde --safe 'abs(z) < 2.5' --method grid`,
//! 200×400): 4.5 s wall, 4.0 s user at a load of 4.2, 8.2–8.8 s at 5–6; R(t)'s fine run
//! takes 158 steps on the 20 000 safe cells from the one-cell start (75 before t = 1: each
//! step size is held 5 to 9 steps while the error falls from about 0.5 to 0.09 of the
//! allowance, when the step doubles), the stepping 63 % of the process and the stationary
//! solve for the crossing tables 21 % (`perf`). The passage Monte Carlo, first 8.7 M
//! path-steps/s against the stationary kernel's 1.0 G steps/s (116 times slower), now runs
//! 541–547 M/s against 1.46–1.50 G/s in the same runs (2.7 times slower; load 7.5–15): its
//! kernel takes two half flights per step where the stationary one takes one, the screen
//! of the safe set reads every step's state, and a lane idles once the queue is empty and
//! its path has ended.
//!
//! `cargo bench --bench reliability` (or `-- reliability_mc_rate` for one group)

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use fpsolve::grid::{GridPassage, GridSolution, GridSolver};
use fpsolve::mc::{BurnIn, Grid, McConfig, McPassage, Simulation};
use fpsolve::model::{load_model, BoundModel, BoundSafe, Model, Override};
use fpsolve::observe::{crossing_rate, impact_statistics, LevelRate};

const CELLS: [usize; 2] = [200, 400];

/// Ten samples of one iteration each (criterion's least), after a short warm-up: an
/// iteration here takes 0.1 to 10 s, and the whole file should run in a few minutes.
fn flat(g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(1));
}

fn model(file: &str, safe: &str) -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    load_model(&path)
        .expect("model")
        .with_safe(safe)
        .expect("safe set")
}

fn bound(model: &Model, set: &[Override]) -> (BoundModel, BoundSafe) {
    let b = model.bind(set).expect("binds");
    let s = model.safe().expect("a safe set").bind(&b).expect("binds");
    (b, s)
}

/// Case 1 with its wall, safe `y < 3`.
fn case1() -> (BoundModel, BoundSafe) {
    bound(&model("models/vibro_impact_duffing.sde", "y < 3"), &[])
}

/// ζ = 0.05, |z| < 2.5σ (σ² = 5).
fn linear() -> (BoundModel, BoundSafe) {
    let safe = format!("abs(z) < {}", 2.5 * 5f64.sqrt());
    bound(
        &model("models/linear.sde", &safe),
        &[Override::number("c", 0.1)],
    )
}

const CASE1_START: [f64; 2] = [1e-6, 0.0];

fn stationary(b: &BoundModel) -> GridSolution {
    GridSolver::new(b)
        .cells(CELLS[0], CELLS[1])
        .solve()
        .expect("solves")
}

/// What the main job derives from a solve of a walled model: the crossing rates of the
/// position at 201 levels and the wall's impact statistics with the speed PDF at 201
/// points, each with its error from the half-cells solve.
fn statistics(b: &BoundModel, sol: &GridSolution) -> (Vec<f64>, Vec<f64>) {
    let top = sol.report.domain.x[1];
    let levels: Vec<f64> = (0..201).map(|k| top * k as f64 / 200.0).collect();
    let rate = LevelRate::of_state(b, 0).expect("a position rate");
    let curve = crossing_rate(sol, &rate, &levels).expect("rates");
    let curve_errors = sol
        .estimate_of_each(&curve.rate, |s| {
            crossing_rate(s, &rate, &levels).expect("rates").rate
        })
        .expect("an estimate");
    let vmax = sol.report.domain.v[1];
    let speeds: Vec<f64> = (0..201).map(|k| vmax * k as f64 / 200.0).collect();
    let impact = &b.impacts()[0];
    let s = impact_statistics(sol, b, impact, &speeds).expect("impact statistics");
    let scalars = |s: &fpsolve::observe::ImpactStatistics| vec![s.rate, s.mean_speed, s.mean_power];
    let impact_errors = sol
        .estimate_of_each(&scalars(&s), |h| {
            scalars(&impact_statistics(h, b, impact, &[]).expect("impact statistics"))
        })
        .expect("an estimate");
    (curve_errors, impact_errors)
}

fn bench_statistics(c: &mut Criterion) {
    let (b, _) = case1();
    let mut g = c.benchmark_group("reliability_statistics");
    flat(&mut g);
    g.bench_function("case1_stationary_200x400", |i| i.iter(|| stationary(&b)));
    g.bench_function("case1_stationary_200x400_plus_crossings_and_impacts", |i| {
        i.iter(|| {
            let sol = stationary(&b);
            statistics(&b, &sol)
        })
    });
    g.finish();
}

/// The mean times as `fpsolve reliability --mean-only` solves them: no output times, no
/// slowest decay, the half-cells estimate.
fn mean_passage(b: &BoundModel, s: &BoundSafe, start: [f64; 2]) -> f64 {
    GridPassage::new(b, s)
        .cells(CELLS[0], CELLS[1])
        .start(start)
        .decay(false)
        .run()
        .expect("solves")
        .mean_at_start
}

fn bench_mean_passage(c: &mut Criterion) {
    let mut g = c.benchmark_group("reliability_mean_passage");
    flat(&mut g);
    for (name, (b, s), start) in [
        ("linear", linear(), [0.0, 0.0]),
        ("case1", case1(), CASE1_START),
    ] {
        g.bench_function(format!("{name}_stationary_200x400"), |i| {
            i.iter(|| stationary(&b))
        });
        g.bench_function(format!("{name}_mean_passage_200x400"), |i| {
            i.iter(|| mean_passage(&b, &s, start))
        });
    }
    g.finish();
}

/// The cells of the R(t) group.
const CELLS_R: [usize; 2] = [100, 200];

fn bench_reliability(c: &mut Criterion) {
    let (b, s) = case1();
    let [nx, nv] = CELLS_R;
    let mean_at = |cells: [usize; 2]| {
        GridPassage::new(&b, &s)
            .cells(cells[0], cells[1])
            .start(CASE1_START)
            .run()
            .expect("solves")
            .mean_at_start
    };
    let mean = mean_at(CELLS_R);
    let times: Vec<f64> = (0..=50).map(|k| 5.0 * mean * k as f64 / 50.0).collect();
    let mut g = c.benchmark_group("reliability_r_of_t");
    flat(&mut g);
    g.bench_function("case1_mean_passage_100x200", |i| {
        i.iter(|| mean_at(CELLS_R))
    });
    g.bench_function("case1_r_to_5_means_tol_1e-4_100x200", |i| {
        i.iter(|| {
            GridPassage::new(&b, &s)
                .cells(nx, nv)
                .start(CASE1_START)
                .times(times.clone())
                .tolerance(1e-4)
                .run()
                .expect("solves")
        })
    });
    g.finish();
}

fn bench_mc_rate(c: &mut Criterion) {
    let (b, s) = case1();
    let dt = 0.01;
    let passage = McPassage::new(&b, &s)
        .start(CASE1_START)
        .dt(dt)
        .paths(2048)
        .horizon(1000.0)
        .seed(1);
    let first = passage.run().expect("runs");
    let mean = first.mean_lower_bound.value;
    let passage_steps =
        first.paths as f64 * mean / dt + first.bias.paths as f64 * mean / (2.0 * dt);
    let (trajectories, samples, per_sample) = (1024u64, 600u64, 10u64);
    let config = McConfig {
        dt,
        spacing: dt * per_sample as f64,
        trajectories,
        samples,
        burn_in: BurnIn::Time(0.0),
        bias_fraction: 0.0,
        grids: vec![
            ("y".into(), Grid::new(0.0, 8.0, 100).expect("grid")),
            ("ydot".into(), Grid::new(-8.0, 8.0, 100).expect("grid")),
        ],
        ..McConfig::default()
    };
    let simulation = Simulation::new(&b, &config).expect("a simulation");
    let mut g = c.benchmark_group("reliability_mc_rate");
    flat(&mut g);
    g.throughput(Throughput::Elements(trajectories * samples * per_sample));
    g.bench_function("case1_stationary_kernel", |i| {
        i.iter(|| simulation.run().expect("runs"))
    });
    g.throughput(Throughput::Elements(passage_steps.round() as u64));
    g.bench_function("case1_first_passage", |i| {
        i.iter(|| passage.run().expect("runs"))
    });
    g.finish();
}

criterion_group!(
    benches,
    bench_statistics,
    bench_mean_passage,
    bench_reliability,
    bench_mc_rate
);
criterion_main!(benches);
