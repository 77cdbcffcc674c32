//! The command line keeps its promises: one run owns its output directory, a finished result
//! is never lost, quality figures compare like with like, and an answer does not depend on how
//! the question was asked.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::{comparisons, fpsolve, json, names, scratch};

/// Rows of a CSV file as numbers, with its header.
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_run_replaces_the_previous_runs_files_as_a_whole() {
    let root = scratch("replace");
    let out = root.join("out");
    let o = fpsolve(&[
        "models/vibro_duffing.sde",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("pdf_y.png").exists());
    // `solve` into the main job's folder: the observables' files and figures go.
    let o = fpsolve(&[
        "solve",
        "models/linear.sde",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        names(&out),
        vec![
            fpsolve::report::MARKER.to_string(),
            "crossings_z.csv".into(),
            "pdf_v.csv".into(),
            "pdf_z.csv".into(),
            "summary.json".into()
        ]
    );
    assert_eq!(json(&out.join("summary.json"))["model"], "linear");
    // Nothing but the lock is left beside it.
    assert_eq!(
        names(&root),
        vec![".out.fpsolve-lock".to_string(), "out".into()]
    );
    // A run whose every degree fails still writes (and owns) the directory: its summary says
    // why, and no earlier CSV is left to be mistaken for its result.
    let o = fpsolve(&[
        "solve",
        "models/vibro_duffing.sde",
        "--degree",
        "6",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        names(&out),
        vec![fpsolve::report::MARKER.to_string(), "summary.json".into()]
    );
    let summary = json(&out.join("summary.json"));
    assert_eq!(summary["degrees"][0]["converged"], false);
    let _ = std::fs::remove_dir_all(&root);
}

/// Waits until `dir` holds an entry whose name starts with `prefix`.
fn wait_for(dir: &Path, prefix: &str, limit: Duration) -> bool {
    let t = Instant::now();
    while t.elapsed() < limit {
        if names(dir).iter().any(|n| n.starts_with(prefix)) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

#[test]
fn a_concurrent_run_is_refused_and_an_interrupted_run_leaves_the_old_results() {
    let root = scratch("lock");
    let out = root.join("out");
    let o = fpsolve(&[
        "solve",
        "models/linear.sde",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(out.join("summary.json")).unwrap();
    // A long Monte Carlo run into the same directory.
    let mut long = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args([
            "simulate",
            "models/linear.sde",
            "--samples",
            "1e11",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert!(
        wait_for(&root, ".out.fpsolve-partial-", Duration::from_secs(60)),
        "the long run never started"
    );
    let second = fpsolve(&[
        "solve",
        "models/linear.sde",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(second.status.code(), Some(2), "{}", stderr(&second));
    assert!(
        stderr(&second).contains("another fpsolve run is writing this directory"),
        "{}",
        stderr(&second)
    );
    // SIGINT: the run stops, removes its staging directory, leaves the old files as they were.
    let killed = Command::new("kill")
        .args(["-INT", &long.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = long.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert_eq!(std::fs::read(out.join("summary.json")).unwrap(), before);
    assert_eq!(
        names(&root),
        vec![".out.fpsolve-lock".to_string(), "out".into()]
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn the_answer_at_a_degree_does_not_depend_on_the_other_degrees_asked() {
    // Before: `--degree 6` alone landed on another root (ridge 12.9 e-folds) than `--degree 4,6`
    // (18.7), and `--degree 8` alone was refused as not normalisable while `6,8` converged.
    let root = scratch("degrees");
    let run = |degrees: &str| {
        let dir = root.join(degrees.replace(',', "_"));
        let o = fpsolve(&[
            "solve",
            "models/vdp_vibro_impact.sde",
            "--degree",
            degrees,
            "--quiet",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "--degree {degrees}: {}", stderr(&o));
        json(&dir.join("summary.json"))
    };
    let coefficients = |summary: &serde_json::Value, degree: u64| -> Vec<f64> {
        let d = summary["degrees"]
            .as_array()
            .unwrap()
            .iter()
            .find(|d| d["degree"] == degree)
            .unwrap();
        d["solution"]["coefficients"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap())
            .collect()
    };
    let alone = run("6");
    let with_four = run("4,6");
    let (a, b) = (coefficients(&alone, 6), coefficients(&with_four, 6));
    assert_eq!(a.len(), b.len());
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 1e-8 * scale, "{a:?}\n{b:?}");
    }
    let eight = run("8");
    assert_eq!(eight["degrees"][0]["converged"], true);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn epc_and_monte_carlo_are_compared_on_bin_averages_and_the_epc_curves_are_not_cut() {
    let root = scratch("bins");
    let out = root.join("out");
    let o = fpsolve(&[
        "models/vibro_duffing.sde",
        "--mc",
        "2e5",
        "--trajectories",
        "256",
        "--grid",
        "y=0:2:40",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    // A quarter of the samples of y lie beyond the histogram's [0, 2]: the run is written
    // and flagged, the missing mass named.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("samples of y fell below its histogram grid"),
        "{}",
        stderr(&o)
    );
    let table = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(table.contains("fpk resid"), "{table}");
    // The EPC curve reaches 1e-8 of its peak, far beyond the histogram's [0, 2].
    let (head, epc) = csv(&out.join("pdf_y.csv"));
    assert_eq!(head, ["y", "epc_n2", "epc_n4", "grid"]);
    assert!(epc.last().unwrap()[0] > 5.0);
    // Each bin's EPC value is the density's average over the bin: recompute it from the fine
    // EPC curve (trapezoid on its 401 points, linear interpolation at the bin edges).
    let (head, bins) = csv(&out.join("mc_y.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (mc_col, n4_col) = (col("mc"), col("epc_n4_bin_mean"));
    assert!(col("epc_n2_bin_mean") < n4_col);
    assert_eq!(bins.len(), 40);
    let interp = |x: f64, col: usize| {
        let i = epc.partition_point(|r| r[0] <= x).clamp(1, epc.len() - 1);
        let (a, b) = (&epc[i - 1], &epc[i]);
        a[col] + (b[col] - a[col]) * (x - a[0]) / (b[0] - a[0])
    };
    let average = |lo: f64, hi: f64, col: usize| {
        let n = 200;
        let h = (hi - lo) / n as f64;
        let mut s = 0.5 * (interp(lo, col) + interp(hi, col));
        for k in 1..n {
            s += interp(lo + k as f64 * h, col);
        }
        s * h / (hi - lo)
    };
    let width = 2.0 / 40.0;
    let mut l1 = 0.0;
    for row in &bins {
        let (lo, hi) = (row[0] - width / 2.0, row[0] + width / 2.0);
        let expected = average(lo, hi, 2);
        assert!(
            (row[n4_col] - expected).abs() <= 2e-4 * expected.abs().max(1e-3),
            "bin at {}: {} vs {expected}",
            row[0],
            row[n4_col]
        );
        l1 += (row[n4_col] - row[mc_col]).abs() * width;
    }
    let summary = json(&out.join("summary.json"));
    let c = comparisons(&summary, "epc", "mc")
        .into_iter()
        .find(|c| c["quantity"] == "y" && c["degree"] == 4)
        .unwrap();
    assert!((c["l1"].as_f64().unwrap() - l1).abs() < 1e-9, "{c}");
    assert_eq!(c["range"][1], 2.0);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn no_burn_in_still_writes_the_summary_and_the_table() {
    // Before: an infinite log-ratio (EPC is 0 beyond its ridge where the histogram is not) made
    // the run exit 2 after the CSVs and figures, with no summary and no table.
    let root = scratch("burnin");
    let out = root.join("out");
    let o = fpsolve(&[
        "models/vibro_duffing.sde",
        "--mc",
        "2e6",
        "--burn-in",
        "0",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let table = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(table.contains("EPC n = 4 vs MC"), "{table}\n{}", stderr(&o));
    assert!(out.join("summary.json").exists(), "{}", stderr(&o));
    let summary = json(&out.join("summary.json"));
    let zero_bins: u64 = comparisons(&summary, "epc", "mc")
        .iter()
        .map(|c| c["ratio_1e5"]["bins_epc_zero"].as_u64().unwrap())
        .sum();
    assert!(zero_bins > 0, "{summary}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn rounded_values_and_capped_threads_are_announced() {
    let root = scratch("notes");
    let o = fpsolve(&[
        "simulate",
        "models/linear.sde",
        "--samples",
        "1000",
        "--trajectories",
        "200",
        "--threads",
        "4096",
        "--quiet",
        "--out",
        root.join("out").to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert!(e.contains("--trajectories 200 rounded up to 256"), "{e}");
    assert!(
        e.contains("1000 Monte Carlo samples rounded up to 1024"),
        "{e}"
    );
    assert!(e.contains("--threads 4096 capped"), "{e}");
    assert!(o.status.success(), "{e}");
    let _ = std::fs::remove_dir_all(&root);
}

/// `--threads N` runs (it once failed whenever checking the plan had started rayon's global
/// pool) and changes nothing but the speed: the histograms are bit-identical.
#[test]
fn a_thread_count_changes_no_number() {
    let root = scratch("threads");
    let run = |threads: &str| {
        let out = root.join(format!("t{threads}"));
        let o = fpsolve(&[
            "simulate",
            "models/linear.sde",
            "--samples",
            "2e4",
            "--trajectories",
            "256",
            "--seed",
            "5",
            "--threads",
            threads,
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "--threads {threads}: {}", stderr(&o));
        std::fs::read_to_string(out.join("mc_v.csv")).unwrap()
    };
    assert_eq!(run("1"), run("2"));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn every_subcommand_accepts_quiet() {
    let root = scratch("quiet");
    let shards = root.join("shards");
    for args in [
        vec!["check", "models/linear.sde", "--quiet"],
        vec![
            "simulate",
            "models/linear.sde",
            "--samples",
            "2e4",
            "--trajectories",
            "256",
            "--shard",
            "1/1",
            "--quiet",
            "--out",
            shards.to_str().unwrap(),
        ],
    ] {
        let o = fpsolve(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    let merged = root.join("merged");
    let o = fpsolve(&[
        "merge",
        shards.to_str().unwrap(),
        "--quiet",
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = fpsolve(&[
        "sweep",
        "models/linear.sde",
        "--set",
        "c=0.1,0.2",
        "--quiet",
        "--out",
        root.join("sweep").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn an_undefined_statistic_is_written_as_null_with_the_run_kept() {
    // Before: the NaN kurtosis of 1/z made the run exit 2 after writing CSVs and figures, with
    // no summary.json and no table.
    let root = scratch("nan");
    let model = root.join("inv.sde");
    std::fs::write(
        &model,
        "model inv\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
         noise xi: intensity 1\ndiffusion v: xi\nobserve w = 1/z, y = abs(z)\n",
    )
    .unwrap();
    let out = root.join("out");
    let o = fpsolve(&[
        model.to_str().unwrap(),
        "--degree",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let table = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        table.contains("warning: E[|w|^1] is not established as finite"),
        "{table}"
    );
    let summary = json(&out.join("summary.json"));
    let stats = summary["degrees"][0]["stats"].as_array().unwrap();
    let w = stats.iter().find(|s| s["name"] == "w").unwrap();
    assert!(w["mean"].is_null() && w["kurtosis"].is_null(), "{w}");
    let undefined = summary["undefined"].as_array().unwrap();
    assert!(undefined
        .iter()
        .any(|u| u["field"].as_str().unwrap().ends_with(".kurtosis")));
    // Everything else was written.
    for f in ["pdf_w.csv", "pdf_y.csv", "pdf_y.png"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Issue 37, item 4: with stderr not a terminal (a batch log), a run prints plain status lines
/// at the interval asked (`FPSOLVE_PROGRESS_EVERY`, a minute by default), and none with
/// `--quiet`; the results are the same either way.
#[test]
fn a_batch_log_gets_plain_progress_lines() {
    let root = scratch("plain-progress");
    let run = |quiet: bool, out: &str| {
        let mut args = vec![
            "simulate",
            "models/vibro_duffing.sde",
            "--samples",
            "2e6",
            "--out",
        ];
        let dir = root.join(out);
        let dir = dir.to_str().unwrap().to_string();
        args.push(&dir);
        if quiet {
            args.push("--quiet");
        }
        Command::new(env!("CARGO_BIN_EXE_fpsolve"))
            .args(&args)
            .env("FPSOLVE_PROGRESS_EVERY", "0.05")
            .stderr(Stdio::piped())
            .stdout(Stdio::piped())
            .output()
            .unwrap()
    };
    let loud = run(false, "loud");
    let text = stderr(&loud);
    assert!(loud.status.success(), "{text}");
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("fpsolve ["))
        .collect();
    assert!(!lines.is_empty(), "no status line in: {text}");
    assert!(lines.iter().any(|l| l.contains(" parts")), "{lines:?}");
    let quiet = run(true, "quiet");
    assert!(!stderr(&quiet).contains("fpsolve ["), "{}", stderr(&quiet));
    let csv = |d: &str| std::fs::read_to_string(root.join(d).join("mc_y.csv")).unwrap();
    assert_eq!(csv("loud"), csv("quiet"));
    let _ = std::fs::remove_dir_all(&root);
}
