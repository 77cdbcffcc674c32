//! The command line's jobs end to end: the main job, `solve`, `simulate` with shards and
//! `merge` (bit for bit), and their exit codes.

mod common;

use std::path::Path;

use common::{fpsolve, fresh_path, json};

fn header(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().next().unwrap().to_string()
}

#[test]
fn main_job_writes_observable_pdfs_summary_and_figures() {
    let dir = fresh_path("main");
    let out = fpsolve(&[
        "models/vibro_duffing.sde",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8(out.stdout).unwrap();
    assert!(table.contains("inside ridge"), "{table}");
    assert_eq!(header(&dir.join("pdf_y.csv")), "y,epc_n2,epc_n4");
    assert_eq!(header(&dir.join("pdf_ydot.csv")), "ydot,epc_n2,epc_n4");
    for f in ["pdf_y.png", "pdf_y.svg", "pdf_ydot.png", "pdf_ydot.svg"] {
        assert!(std::fs::metadata(dir.join(f)).unwrap().len() > 1000, "{f}");
    }
    let summary = json(&dir.join("summary.json"));
    assert_eq!(summary["all_converged"], true);
    let degrees = summary["degrees"].as_array().unwrap();
    assert_eq!(degrees.len(), 2);
    assert_eq!(degrees[1]["degree"], 4);
    assert!(
        degrees[1]["solution"]["coefficients"]
            .as_array()
            .unwrap()
            .len()
            == 14
    );
    // y = |z| starts at the barrier and the grid reaches 1e-8 of the peak.
    let text = std::fs::read_to_string(dir.join("pdf_y.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows[0][0], 0.0);
    let peak = rows.iter().map(|r| r[1]).fold(0.0, f64::max);
    assert!(rows.last().unwrap()[1] < 1e-7 * peak);
    // No temporary files are left behind: the only hidden file is the run's marker.
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(
            !name.starts_with('.') || name == fpsolve::report::MARKER,
            "left {name}"
        );
    }
}

#[test]
fn solve_keeps_the_degrees_that_converge_and_exits_non_zero_for_the_others() {
    let dir = fresh_path("solve");
    let out = fpsolve(&[
        "solve",
        "models/vibro_duffing.sde",
        "--degree",
        "2,4,6",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("degree 6"), "{stderr}");
    assert_eq!(header(&dir.join("pdf_z.csv")), "z,epc_n2,epc_n4");
    assert_eq!(header(&dir.join("pdf_v.csv")), "v,epc_n2,epc_n4");
    let summary = json(&dir.join("summary.json"));
    assert_eq!(summary["all_converged"], false);
    assert_eq!(summary["degrees"][2]["converged"], false);
    assert!(summary["degrees"][2]["error"].as_str().unwrap().len() > 20);
}

#[test]
fn bad_flags_exit_2_with_a_message() {
    for args in [
        vec!["models/vibro_duffing.sde", "--set", "nope=1"],
        vec!["solve", "models/vibro_duffing.sde", "--degree", "x"],
        vec!["models/missing.sde"],
        vec!["simulate", "models/vibro_duffing.sde", "--samples", "-5"],
        vec!["simulate", "models/vibro_duffing.sde", "--shard", "3/2"],
    ] {
        let out = fpsolve(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("error"), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

#[test]
fn shards_merge_to_exactly_the_unsplit_run() {
    let whole = fresh_path("whole");
    let parts = fresh_path("parts");
    let merged = fresh_path("merged");
    let common = [
        "--samples",
        "60000",
        "--trajectories",
        "384",
        "--seed",
        "7",
        "--dt",
        "0.02",
    ];
    let run = |extra: &[&str], dir: &Path| {
        let mut args = vec!["simulate", "models/vibro_duffing.sde"];
        args.extend_from_slice(&common);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", dir.to_str().unwrap()]);
        let out = fpsolve(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run(&[], &whole);
    run(&["--shard", "1/3"], &parts);
    run(&["--shard", "2/3"], &parts);
    run(&["--shard", "3/3"], &parts);
    let out = fpsolve(&[
        "merge",
        parts.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "mc_summary.json",
        "mc_z.csv",
        "mc_v.csv",
        "mc_y.csv",
        "mc_ydot.csv",
    ] {
        let a = std::fs::read(whole.join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(a == b, "{f} differs between the unsplit and the merged run");
    }
}

#[test]
fn main_job_with_monte_carlo_adds_columns_and_distances() {
    let dir = fresh_path("mc");
    let out = fpsolve(&[
        "models/vibro_duffing.sde",
        "--mc",
        "100000",
        "--trajectories",
        "256",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The EPC curves keep their own grid; the histogram sits beside the EPC bin averages.
    assert_eq!(header(&dir.join("pdf_y.csv")), "y,epc_n2,epc_n4");
    assert_eq!(
        header(&dir.join("mc_y.csv")),
        "y,mc,mc_stderr,mc_bias,mc_bias_stderr,epc_n2_bin_mean,epc_n4_bin_mean"
    );
    let summary = json(&dir.join("summary.json"));
    let distances = summary["epc_vs_mc"].as_array().unwrap();
    assert_eq!(distances.len(), 4);
    // Degree 4 is closer to the Monte Carlo than the Gaussian closure for y (paper, Fig. 1).
    let l1 = |d: u64| {
        distances
            .iter()
            .find(|c| c["quantity"] == "y" && c["degree"] == d)
            .unwrap()["l1"]
            .as_f64()
            .unwrap()
    };
    assert!(l1(4) < l1(2), "L1 n=4 {} vs n=2 {}", l1(4), l1(2));
}

#[test]
fn sweep_writes_its_table_and_figures_and_refuses_unknown_parameters() {
    let dir = fresh_path("sweep");
    let out = fpsolve(&[
        "sweep",
        "models/linear.sde",
        "--set",
        "c=0.1:0.3:3",
        "--set",
        "k=1,2",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    assert!(dir.join("sweep.json").exists());
    assert!(dir.join("sweep_std_dev.png").exists());
    let out = fpsolve(&["sweep", "models/linear.sde", "--set", "nope=1:2:3"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope"));
}
