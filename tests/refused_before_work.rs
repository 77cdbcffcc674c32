//! Runs that cannot give a trustworthy answer are refused before any work (exit 2, nothing
//! written), from every command they reach:
//! - models without a stationary density (a softening spring, or none at all, on a side no
//!   wall closes), which once ran past a minute with no output (the grid solver searching for
//!   a domain, Monte Carlo simulating escapes);
//! - cell counts whose factorisation degenerates: 8 by 65536 cells once aborted allocating
//!   34.8 GB, and 8 by 32768 took 59 s and 1.8 GB to give a velocity sd four times the true one.

mod common;

use common::refused;

fn model(name: &str) -> String {
    format!("{}/models/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn softening_and_missing_springs_are_refused_by_every_command() {
    let (vibro, original) = (
        model("vibro_duffing.sde"),
        model("vibro_impact_duffing.sde"),
    );
    let words = ["no stationary density"];
    for set in [["mu=-1", "k=1"], ["mu=-0.01", "k=1"], ["mu=0", "k=0"]] {
        let sets = ["--set", set[0], "--set", set[1]];
        for m in [&vibro, &original] {
            for method in ["grid", "epc", "epc-impact"] {
                if method == "epc-impact" && m == &vibro {
                    continue; // a pass-through law: epc-impact does not apply
                }
                let mut args = vec!["solve", m.as_str(), "--method", method];
                args.extend(sets);
                refused("escape", &args, &words);
            }
            let mut job = vec![m.as_str()];
            job.extend(sets);
            refused("escape", &job, &words);
            let mut sim = vec!["simulate", m.as_str()];
            sim.extend(sets);
            refused("escape", &sim, &words);
        }
    }
    let parametric = model("parametric.sde");
    refused(
        "refused",
        &["solve", &parametric, "--method", "grid", "--set", "mu=-0.5"],
        &words,
    );
}

#[test]
fn thin_meshes_are_refused_by_every_command_that_takes_cells() {
    let m = model("vibro_duffing.sde");
    let words = ["--cells", "64 times"];
    for cells in ["8,65536", "8,16384", "16384,16", "8,520"] {
        let m = m.as_str();
        refused(
            "refused",
            &["solve", m, "--method", "grid", "--cells", cells],
            &words,
        );
        refused(
            "refused",
            &[m, "--method", "grid", "--cells", cells],
            &words,
        );
        refused(
            "refused",
            &[
                "sweep",
                m,
                "--set",
                "eps=0:0.1:2",
                "--method",
                "grid",
                "--cells",
                cells,
            ],
            &words,
        );
    }
}

/// `--tol` asks the grid for an accuracy: a model the grid cannot solve (δ-term impact damping
/// without an impact law: the main job's methods are EPC alone) refuses it before any work,
/// as does a tolerance outside (0, 0.5].
#[test]
fn a_tolerance_the_grid_cannot_serve_is_refused_before_work() {
    let dir = common::scratch("tol-refused-model");
    let plain = dir.join("plain.sde");
    std::fs::write(
        &plain,
        "model plain\nstate x, y\ndrift x: y\ndrift y: -0.2*y - x - 0.1*y*abs(y)*delta(x)\n\
         noise xi: intensity 1\ndiffusion y: xi\n",
    )
    .unwrap();
    let plain = plain.to_str().unwrap();
    refused("tol-delta", &[plain, "--tol", "1e-3"], &["--tol", "grid"]);
    refused(
        "tol-delta-solve",
        &["solve", plain, "--method", "grid", "--tol", "1e-3"],
        &["--method grid", "delta(...) terms"],
    );
    let vibro = model("vibro_duffing.sde");
    refused(
        "tol-range",
        &[&vibro, "--tol", "0.75"],
        &["--tol", "at most 0.5"],
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn monte_carlo_from_a_start_held_still_is_refused_by_every_command() {
    // Rest in the Zhuravlev form: drift and noise vanish (sgn(0) = 0), every path would stay.
    let m = model("vibro_duffing.sde");
    let words = ["every path would stay at its start", "start beside it"];
    refused("held", &["reliability", &m, "--safe", "y < 3"], &words);
    refused(
        "held",
        &[
            "reliability",
            &m,
            "--safe",
            "y < 3",
            "--method",
            "mc",
            "--horizon",
            "10",
        ],
        &words,
    );
    refused(
        "held",
        &[
            "transient",
            &m,
            "--times",
            "0:1:2",
            "--method",
            "mc",
            "--domain",
            "z=-8:8,v=-12:12",
        ],
        &words,
    );
    refused(
        "held",
        &[
            "transient",
            &m,
            "--times",
            "0:1:2",
            "--method",
            "grid,mc",
            "--initial",
            "point z = 0, v = 0",
        ],
        &words,
    );
}
