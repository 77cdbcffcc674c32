//! Issue 39 items 15 and 17 (messages and figures): the main job reports the states beside the
//! observables, runs the methods that apply by default, refuses every named method that does
//! not apply in one message, speaks of the user's own model, tells a plastic wall from a
//! pass-through, prints ridge depths a reader can use, and draws no two curves alike.

mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use common::{comparisons, fpsolve, json, refused, scratch};
use fpsolve::report::CurveStyle;

/// The first line of a CSV file.
fn header(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().next().unwrap().to_string()
}

/// Writes `text` as `<scratch>/<name>.sde` and gives its path.
fn model_file(tag: &str, name: &str, text: &str) -> PathBuf {
    let path = scratch(tag).join(format!("{name}.sde"));
    std::fs::write(&path, text).unwrap();
    path
}

/// The quantities a summary's comparison list `key` holds.
fn compared(summary: &serde_json::Value, method: &str, reference: &str) -> Vec<String> {
    comparisons(summary, method, reference)
        .iter()
        .map(|c| c["quantity"].as_str().unwrap().to_string())
        .collect()
}

/// A model with observables: the states are written and compared too (model-files.md says
/// they are always reported), in the files, the table and `summary.json`.
#[test]
fn the_main_job_writes_and_compares_the_states_beside_the_observables() {
    let dir = scratch("states").join("out");
    let out = fpsolve(&[
        "models/cubic_damping_two_noises.sde",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for q in ["z", "v", "y", "ydot"] {
        let csv = dir.join(format!("pdf_{q}.csv"));
        assert!(csv.is_file(), "no pdf_{q}.csv");
        assert_eq!(header(&csv), format!("{q},epc_n2,epc_n4,grid"));
        assert!(
            dir.join(format!("pdf_{q}.png")).is_file(),
            "no figure of {q}"
        );
        assert!(table.contains(&format!(", {q} on [")), "{table}");
    }
    let summary = json(&dir.join("summary.json"));
    let to_grid = compared(&summary, "epc", "grid");
    for q in ["z", "v", "y", "ydot"] {
        assert!(
            to_grid.iter().any(|c| c == q),
            "{q} not compared: {to_grid:?}"
        );
    }
}

/// The vibro-impact strip with an energy observable.
fn strip_with_energy() -> PathBuf {
    let text = std::fs::read_to_string("models/vibro_impact_strip.sde").unwrap();
    model_file(
        "strip-energy",
        "strip_energy",
        &format!("{text}observe E = ydot^2/2 + y^2/2 + y^4/4\n"),
    )
}

/// A strip with observables is not refused by default: epc-impact and the grid apply and run
/// (EPC, which has no form for two barriers, is named as not run with its reason); the grid's
/// PDF of the energy is computed and compared too; the job takes seconds.
#[test]
fn a_strip_with_observables_runs_the_methods_that_apply() {
    let model = strip_with_energy();
    let dir = model.parent().unwrap().join("out");
    let t = Instant::now();
    let out = fpsolve(&[
        model.to_str().unwrap(),
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let wall = t.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let table = String::from_utf8_lossy(&out.stdout);
    assert_ne!(out.status.code(), Some(2), "refused: {stderr}");
    assert!(wall < 120.0, "{wall} s");
    let summary = json(&dir.join("summary.json"));
    assert_eq!(
        summary["methods"],
        serde_json::json!(["epc-impact", "grid"])
    );
    let skipped = summary["skipped_methods"].as_array().unwrap();
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0]["method"], "epc");
    assert!(summary.get("skipped_curves").is_none(), "{summary}");
    assert!(table.contains("epc: not run:"), "{table}");
    // The grid's states and its energy curve are written and compared.
    assert_eq!(
        header(&dir.join("pdf_y.csv")),
        "y,epc_impact_n2,epc_impact_n4,grid"
    );
    assert_eq!(
        header(&dir.join("pdf_E.csv")),
        "E,epc_impact_n2,epc_impact_n4,grid"
    );
    let to_grid = compared(&summary, "epc-impact", "grid");
    assert!(to_grid.iter().any(|q| q == "y") && to_grid.iter().any(|q| q == "ydot"));
    assert!(to_grid.iter().any(|q| q == "E"), "{to_grid:?}");
    // The grid's moments of the energy are still reported.
    let grid_stats = summary["grid"]["stats"].as_array().unwrap();
    assert!(
        grid_stats.iter().any(|s| s["name"] == "E"),
        "{grid_stats:?}"
    );
}

/// Several named methods that do not apply to a model: one refusal names them all, each with
/// its reason (not one at a time, to be found by trial).
#[test]
fn every_named_method_that_does_not_apply_is_refused_in_one_message() {
    let model = model_file(
        "not-mechanical",
        "not_mechanical",
        "model nm\nstate x, y\ndrift x: y\ndrift y: -0.2*y - x - 0.1*y*abs(y)*delta(x)\nnoise xi: intensity 1\n\
         diffusion y: xi\n",
    );
    refused(
        "not-mechanical-run",
        &[model.to_str().unwrap(), "--method", "epc,epc-impact,grid"],
        &[
            "2 of the methods named do not apply (epc-impact, grid)",
            "epc-impact: EPC with the exact impact condition cannot solve model `nm`",
            "grid: the grid solver cannot solve model `nm`",
        ],
    );
}

/// `solve` of a model in its own coordinates whose impact adds energy: the refusal quotes the
/// user's law with the user's names, not the Zhuravlev transform's (`v_ -> 1.2*v_`).
#[test]
fn solve_refuses_in_the_users_own_names() {
    let model = model_file(
        "own-names",
        "own_names",
        "model oc\nparam c = 0.1\nstate y, v\ndrift y: v\ndrift v: -c*v - y\n\
         noise xi: intensity 1\ndiffusion v: xi\nimpact y = 0: v -> -1.2*v\ndomain y >= 0\n",
    );
    for method in ["epc", "grid"] {
        let root = scratch(&format!("own-names-{method}"));
        let out = fpsolve(&[
            "solve",
            model.to_str().unwrap(),
            "--method",
            method,
            "--out",
            root.join("out").to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains("the impact law `v -> -1.2*v` adds energy"),
            "{stderr}"
        );
        assert!(!stderr.contains("v_"), "{stderr}");
    }
}

/// A plastic law (`v -> 0*v`) with a `domain` line is a plastic wall, not a pass-through: the
/// refusal says so and what to write instead.
#[test]
fn a_plastic_wall_is_refused_as_plastic_not_as_passing_through() {
    let model = model_file(
        "plastic",
        "plastic",
        "model pl\nparam c = 0.1\nstate y, v\ndrift y: v\ndrift v: -c*v - y\n\
         noise xi: intensity 1\ndiffusion v: xi\nimpact y = 0: v -> 0*v\ndomain y >= 0\n",
    );
    for command in [&[][..], &["solve"][..], &["simulate"][..]] {
        let mut args: Vec<&str> = command.to_vec();
        args.push(model.to_str().unwrap());
        refused(
            "plastic-run",
            &args,
            &[
                "stops the velocity (`v -> 0*v`): a plastic impact (r = 0)",
                "v -> -0.05*v",
            ],
        );
        let out = fpsolve(&args);
        assert!(
            !String::from_utf8_lossy(&out.stderr).contains("passes through it"),
            "{args:?}"
        );
    }
}

/// A ridge depth is printed with the digits a reader can use: the Van der Pol oscillator at
/// degree 8 is normalised inside a ridge about 1400 e-folds deep, printed as "more than 1000"
/// (not as 1393.5); at degree 6 (about 960) as a whole number.
#[test]
fn ridge_depths_are_printed_with_usable_digits() {
    let dir = scratch("efolds").join("out");
    let out = fpsolve(&[
        "solve",
        "models/van_der_pol.sde",
        "--degree",
        "6,8",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    let depths: Vec<&str> = table
        .lines()
        .filter_map(|l| l.split("inside ridge, ").nth(1))
        .map(|rest| rest.trim_end_matches(" e-folds below the mode"))
        .collect();
    assert_eq!(depths.len(), 2, "{table}");
    assert!(
        depths[0].parse::<u32>().is_ok(),
        "degree 6: {:?}",
        depths[0]
    );
    assert_eq!(depths[1], "more than 1000", "{table}");
}

/// Every curve of a figure has its own (colour, dash) pair: the most a density figure draws is
/// 13 (6 degrees of two ladder methods and the grid), and the pairs run out only after 24.
#[test]
fn no_two_curves_of_a_figure_share_colour_and_dash() {
    let styles: Vec<CurveStyle> = (0..24).map(CurveStyle::of_curve).collect();
    for (i, a) in styles.iter().enumerate() {
        for (j, b) in styles[..i].iter().enumerate() {
            assert_ne!((a.colour, a.dash), (b.colour, b.dash), "curves {j} and {i}");
        }
    }
    // Beyond the pairs the line widens: still no two curves alike.
    let more: Vec<CurveStyle> = (0..60).map(CurveStyle::of_curve).collect();
    for (i, a) in more.iter().enumerate() {
        assert!(!more[..i].contains(a), "curve {i}");
    }
}
