//! The EPC job paths in process, for the paper's vibro-impact case 1
//! (models/vibro_duffing.sde):
//!
//! - `job/solve_degree_N`: what `fpsolve solve MODEL --degree N` does, files included (the
//!   states' PDFs and `summary.json`, into a temporary directory), N = 2, 4, 8.
//! - `job/main_epc`: the main job without Monte Carlo and without the grid solver
//!   (`fpsolve MODEL --method epc`: degrees 2 and 4, the observables' PDFs and moments, the
//!   files and the figures, PNG and SVG).
//! - `job/study_epc`: the same study without any file (what a sweep point costs).
//! - `job/solve_degree_4_run_dir_fresh` and `…_replacing`: `solve_degree_4` as the command
//!   runs it, through a staged, locked output directory put in place by its commit (the
//!   files' and directories' flushes to disk included): into a new directory each time, and
//!   replacing the previous iteration's directory (the commit then also removes it).
//!
//! Issue 12's targets: `fpsolve solve MODEL --degree 4` under 10 ms and `--method epc` under
//! 50 ms, as processes. The whole-process times (start, model, files) are measured with
//! `perf stat -r 20 -e task-clock target/release/fpsolve solve models/vibro_duffing.sde
//! --degree 4 --quiet --out /tmp/fpsolve-bench` (see the README's benchmark section).
//!
//! Run: `cargo bench --bench job`.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use fpsolve::job::{Job, JobSpec, Target};
use fpsolve::model::load_model;
use fpsolve::report::{OutputDir, RunDir};
use fpsolve::study::StudyRunner;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path).unwrap();
    let tmp = std::env::temp_dir().join(format!("fpsolve-bench-job-{}", std::process::id()));
    let out = OutputDir::create(&tmp).unwrap();
    let mut g = c.benchmark_group("job");
    g.sample_size(10);
    for n in [2, 4, 8] {
        let spec = JobSpec {
            degrees: vec![n],
            target: Target::States,
            ..JobSpec::default()
        };
        g.bench_function(format!("solve_degree_{n}"), |b| {
            b.iter(|| Job::new(&model, &spec).run(&out).unwrap())
        });
    }
    let spec = JobSpec {
        figures: true,
        ..JobSpec::default()
    };
    g.bench_function("main_epc", |b| {
        b.iter(|| Job::new(&model, &spec).run(&out).unwrap())
    });
    let spec = JobSpec {
        degrees: vec![4],
        target: Target::States,
        ..JobSpec::default()
    };
    let solve_into = |dest: &Path| {
        let run = RunDir::begin(dest, "bench").unwrap();
        Job::new(&model, &spec).run(run.out()).unwrap();
        run.commit().unwrap()
    };
    let mut fresh = 0_u64;
    g.bench_function("solve_degree_4_run_dir_fresh", |b| {
        b.iter(|| {
            fresh += 1;
            solve_into(&tmp.join(format!("fresh-{fresh}")))
        })
    });
    let replaced = tmp.join("replaced");
    g.bench_function("solve_degree_4_run_dir_replacing", |b| {
        b.iter(|| solve_into(&replaced))
    });
    let bound = model.bind(&[]).unwrap();
    g.bench_function("study_epc", |b| {
        b.iter(|| StudyRunner::new(&bound).degrees(&[2, 4]).run().unwrap())
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&tmp);
}

criterion_group!(benches, bench);
criterion_main!(benches);
