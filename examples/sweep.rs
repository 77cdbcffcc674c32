//! A parameter sweep through the library: the vibro-impact Duffing oscillator of
//! `models/vibro_duffing.sde` (paper Eq. 10) with the parametric-noise factor ε from −0.3 to
//! 0.3 in 13 steps, for a weak and a strong nonlinearity μ = 0.1 and μ = 1: 26 EPC solutions
//! at degree 4, in parallel. Prints a table and writes `out/sweep_example/` (`sweep.csv`,
//! `sweep.json`, figures).
//!
//! `cargo run --release --example sweep`
//!
//! The same sweep from the command line would be
//! `--set eps=-0.3:0.3:13 --set mu=0.1,1`.

use std::path::Path;

use fpsolve::model::load_model;
use fpsolve::report::OutputDir;
use fpsolve::solve::MethodName;
use fpsolve::sweep::{PointOutcome, Sweep, SweepSpec};

/// The EPC degree of every point (continued from degree 2 within each point).
const DEGREE: usize = 4;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = load_model(&root.join("models/vibro_duffing.sde"))?;
    let args = ["eps=-0.3:0.3:13", "mu=0.1,1"].map(String::from);
    let spec = SweepSpec::parse(&args)?;
    // A misspelt name fails here, once, instead of at all 26 points.
    spec.validate(&model)?;

    let result = Sweep::new(&model, &spec).degree(DEGREE).run();

    println!(
        "{} points, {} converged, {:.2} s wall time (EPC n = {DEGREE}, {} threads)",
        result.points.len(),
        result.converged(),
        result.wall_ms / 1e3,
        rayon::current_num_threads(),
    );
    for t in &result.tail_thresholds {
        println!(
            "tail thresholds of {}: a = {:.3}, {:.3}, {:.3} (2, 3, 4 × rms {:.3} at the first point)",
            t.name, t.thresholds[0], t.thresholds[1], t.thresholds[2], t.rms
        );
    }
    println!();
    println!(
        "{:>6} {:>5} {:>10} {:>5} {:>10} {:>9} {:>9} {:>9} {:>10} {:>9} {:>9}",
        "eps",
        "mu",
        "status",
        "iter",
        "norm",
        "mean y",
        "std y",
        "kurt y",
        "P(y>3rms)",
        "std ydot",
        "kurt ydot"
    );
    for point in &result.points {
        let (eps, mu) = (point.values[0], point.values[1]);
        match point.outcome(MethodName::Epc).expect("an EPC sweep") {
            PointOutcome::Converged(sol) => {
                let find = |name: &str| sol.stats.iter().find(|s| s.name == name);
                let (Some(y), Some(ydot)) = (find("y"), find("ydot")) else {
                    return Err("the model has no observables y and ydot".into());
                };
                println!(
                    "{eps:>6.2} {mu:>5} {:>10} {:>5} {:>10} {:>9.4} {:>9.4} {:>9.3} {:>10.3e} {:>9.4} {:>9.3}",
                    "converged",
                    sol.epc().map_or(0, |e| e.iterations),
                    sol.epc().map_or(String::new(), |e| e.normalisation.to_string()),
                    y.moments.mean,
                    y.moments.std_dev(),
                    y.moments.kurtosis,
                    y.tail.get(1).copied().flatten().unwrap_or(f64::NAN),
                    ydot.moments.std_dev(),
                    ydot.moments.kurtosis,
                );
            }
            PointOutcome::Failed(failure) => {
                let stage = failure.stage();
                println!("{eps:>6.2} {mu:>5} {:>10} ({stage}) {failure}", "failed");
            }
            PointOutcome::Refused(refusal) => {
                println!("{eps:>6.2} {mu:>5} {:>10} {refusal}", "refused");
            }
        }
    }

    let out = OutputDir::create(root.join("out/sweep_example"))?;
    let files = result.write(&out)?;
    println!(
        "\nwrote {} files into {}",
        files.len(),
        out.path().display()
    );
    Ok(())
}
