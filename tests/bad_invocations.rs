//! A corpus of bad invocations: every flag, range, output directory and shard file that is
//! wrong must be refused before anything is computed or written — exit 2, a message naming the
//! flag (or file), no panic, and no output directory (nor staging leftovers) created.

mod common;

use std::process::Command;

use common::{names, scratch};

/// Runs `fpsolve args… --out <scratch>/out` (unless the case sets its own) and checks the
/// refusal: exit 2, every `expected` fragment in stderr, no panic, nothing written.
fn refused(tag: &str, args: &[&str], expected: &[&str]) {
    refused_with_env(tag, &[], args, expected)
}

/// [`refused`] with environment variables `env` set for the run.
fn refused_with_env(tag: &str, env: &[(&str, &str)], args: &[&str], expected: &[&str]) {
    let root = scratch(tag);
    let out = root.join("out");
    let mut full: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    let is_merge = args.first() == Some(&"merge");
    if !args.contains(&"--out") && args.first() != Some(&"check") && !is_merge {
        full.push("--out".into());
        full.push(out.to_string_lossy().into_owned());
    }
    if is_merge && !args.contains(&"--out") {
        full.push("--out".into());
        full.push(out.to_string_lossy().into_owned());
    }
    let before = names(&root);
    let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(&full)
        .envs(env.iter().copied())
        .output()
        .expect("run fpsolve");
    let stderr = String::from_utf8_lossy(&output.stderr);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert_eq!(
        output.status.code(),
        Some(2),
        "{full:?}: expected exit 2\nstdout: {stdout}\nstderr: {stderr}"
    );
    for e in expected {
        assert!(
            stderr.contains(e),
            "{full:?}: stderr lacks {e:?}\nstderr: {stderr}"
        );
    }
    assert!(
        !stderr.contains("panicked") && !stderr.contains("RUST_BACKTRACE"),
        "{full:?}: panic\n{stderr}"
    );
    assert!(
        !stdout.contains("wrote"),
        "{full:?}: claims to have written files\n{stdout}"
    );
    assert_eq!(
        names(&root),
        before,
        "{full:?}: something was written beside the output directory"
    );
    let _ = std::fs::remove_dir_all(&root);
}

const MODEL: &str = "models/vibro_duffing.sde";
const LINEAR: &str = "models/linear.sde";

#[test]
fn degrees() {
    for (tag, d, msg) in [
        ("deg-dup", "4,4", "degree 4 is given twice"),
        ("deg-0", "0", "outside the supported range"),
        ("deg-1", "1", "outside the supported range"),
        ("deg-odd", "3", "degree 3 is odd"),
        ("deg-odd2", "2,5", "degree 5 is odd"),
        ("deg-max", "14", "outside the supported range 2 to 12"),
        ("deg-text", "four", "`four` is not a whole number"),
        ("deg-empty", "", "no degree given"),
        ("deg-neg", "-2", "-2"),
    ] {
        refused(tag, &[MODEL, "--degree", d], &[msg]);
        refused(
            &format!("{tag}-solve"),
            &["solve", MODEL, "--degree", d],
            &[msg],
        );
    }
    refused(
        "sweep-deg-odd",
        &["sweep", MODEL, "--set", "eps=0,0.1", "--degree", "3"],
        &["--degree", "odd"],
    );
    refused(
        "sweep-deg-two",
        &["sweep", MODEL, "--set", "eps=0,0.1", "--degree", "2,4"],
        &["--degree", "one degree"],
    );
}

#[test]
fn monte_carlo_flags() {
    let mc = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec![MODEL, "--mc", "1e5"];
        v.extend_from_slice(extra);
        v
    };
    for (tag, extra, msg) in [
        ("dt-zero", vec!["--dt", "0"], "dt"),
        ("dt-neg", vec!["--dt=-0.01"], "dt"),
        ("dt-nan", vec!["--dt", "NaN"], "dt"),
        ("spacing-frac", vec!["--spacing", "0.015"], "spacing"),
        ("spacing-zero", vec!["--spacing", "0"], "spacing"),
        ("burn-neg", vec!["--burn-in=-1"], "burn"),
        ("burn-inf", vec!["--burn-in", "inf"], "burn"),
        ("traj-zero", vec!["--trajectories", "0"], "--trajectories"),
        (
            "traj-huge",
            vec!["--trajectories", "18446744073709551615"],
            "--trajectories",
        ),
        (
            "traj-text",
            vec!["--trajectories", "many"],
            "--trajectories",
        ),
        ("grid-shape", vec!["--grid", "y=0:8"], "--grid"),
        ("grid-float-bins", vec!["--grid", "y=0:8:1e8"], "--grid"),
        ("grid-order", vec!["--grid", "y=8:0:10"], "--grid"),
        ("grid-zero-bins", vec!["--grid", "y=0:8:0"], "--grid"),
        ("grid-noname", vec!["--grid", "=0:8:10"], "--grid"),
        (
            "grid-twice",
            vec!["--grid", "y=0:8:10", "--grid", "y=0:4:10"],
            "already given",
        ),
        ("threads-zero", vec!["--threads", "0"], "--threads"),
        ("seed-text", vec!["--seed", "x"], "--seed"),
    ] {
        refused(tag, &mc(&extra), &[msg]);
    }
    for (tag, n, msg) in [
        ("mc-zero", "0", "between 1 and 1e15"),
        ("mc-text", "lots", "is not a number"),
        ("mc-frac", "1.5", "not a whole number"),
        ("mc-huge", "1e16", "between 1 and 1e15"),
    ] {
        refused(tag, &[MODEL, "--mc", n], &[msg]);
        refused(
            &format!("{tag}-sim"),
            &["simulate", MODEL, "--samples", n],
            &[msg],
        );
    }
}

#[test]
fn overrides_and_models() {
    refused("set-unknown", &[MODEL, "--set", "nope=1"], &["nope"]);
    refused("set-syntax", &[MODEL, "--set", "mu=1+"], &["--set mu=1+"]);
    refused("set-noeq", &[MODEL, "--set", "mu"], &["--set mu"]);
    refused("set-noname", &[MODEL, "--set", "=1"], &["name is missing"]);
    refused(
        "sweep-set-text",
        &["sweep", MODEL, "--set", "eps=0,0.1", "--set", "mu=abc"],
        &["abc"],
    );
    refused(
        "sweep-nothing",
        &["sweep", MODEL, "--set", "mu=0.2"],
        &["nothing to sweep"],
    );
    refused("no-model-file", &["models/nope.sde"], &["models/nope.sde"]);
    refused("check-set", &["check", MODEL, "--set", "nope=1"], &["nope"]);
    refused("no-model", &[], &["no model file given"]);
}

#[test]
fn shards_and_merge() {
    for (tag, s) in [
        ("shard-zero", "0/3"),
        ("shard-over", "4/3"),
        ("shard-text", "a/b"),
        ("shard-shape", "3"),
    ] {
        refused(
            tag,
            &["simulate", LINEAR, "--samples", "1e5", "--shard", s],
            &["--shard"],
        );
    }
    let empty = scratch("merge-empty-src");
    refused(
        "merge-empty",
        &["merge", empty.to_str().unwrap()],
        &["no shard_*.json"],
    );
    refused(
        "merge-missing",
        &["merge", "/nonexistent/fpsolve/shards"],
        &["/nonexistent/fpsolve/shards"],
    );
    let bad = scratch("merge-garbage-src");
    std::fs::write(bad.join("shard_1_of_2.json"), b"{ not json").unwrap();
    refused(
        "merge-garbage",
        &["merge", bad.to_str().unwrap()],
        &["shard_1_of_2.json"],
    );
    let _ = std::fs::remove_dir_all(empty);
    let _ = std::fs::remove_dir_all(bad);
}

#[test]
fn output_directories() {
    // A regular file where a parent directory should be.
    let root = scratch("out-file-parent");
    let file = root.join("plain");
    std::fs::write(&file, b"x").unwrap();
    let under = file.join("out");
    refused(
        "out-under-file",
        &[MODEL, "--out", under.to_str().unwrap()],
        &["--out"],
    );
    // The output path is itself a file.
    refused(
        "out-is-file",
        &[MODEL, "--out", file.to_str().unwrap()],
        &["--out", "not a directory"],
    );
    // A directory with files fpsolve did not write is never replaced.
    let foreign = root.join("home");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("thesis.tex"), b"keep").unwrap();
    refused(
        "out-foreign",
        &[MODEL, "--out", foreign.to_str().unwrap()],
        &["--out", "thesis.tex", "fpsolve did not write"],
    );
    assert_eq!(std::fs::read(foreign.join("thesis.tex")).unwrap(), b"keep");
    assert_eq!(names(&root), vec!["home".to_string(), "plain".into()]);
    refused(
        "out-foreign-sweep",
        &[
            "sweep",
            MODEL,
            "--set",
            "eps=0,0.1",
            "--out",
            foreign.to_str().unwrap(),
        ],
        &["--out", "thesis.tex"],
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn methods_cells_and_monte_carlo_references() {
    let models = scratch("methods-models");
    let plain = models.join("plain.sde");
    // Not in mechanical form (x' is not the second state): EPC applies, the grid does not.
    std::fs::write(
        &plain,
        "model plain\nstate x, y\ndrift x: -x + y\ndrift y: -y\nnoise xi: intensity 1\n\
         diffusion y: xi\n",
    )
    .unwrap();
    let plain = plain.to_str().unwrap();
    refused(
        "method-unknown",
        &[MODEL, "--method", "mc"],
        &["`mc` is not a method"],
    );
    refused(
        "method-twice",
        &[MODEL, "--method", "grid,grid"],
        &["given twice"],
    );
    refused(
        "method-impact",
        &[MODEL, "--method", "epc,epc-impact"],
        &["--method epc-impact", "delta", "original coordinates"],
    );
    refused(
        "method-grid",
        &[plain, "--method", "grid"],
        &[
            "--method grid",
            "cannot solve model `plain`",
            "mechanical form",
        ],
    );
    refused(
        "method-grid-solve",
        &["solve", plain, "--method", "epc,grid"],
        &["--method grid", "mechanical form"],
    );
    refused(
        "cells-odd",
        &[MODEL, "--cells", "141,280"],
        &["--cells", "even"],
    );
    refused(
        "cells-few",
        &[MODEL, "--cells", "6,280"],
        &["--cells", "at least 8"],
    );
    refused(
        "cells-syntax",
        &[MODEL, "--cells", "140x280"],
        &["--cells", "NX,NV"],
    );
    refused(
        "cells-memory",
        &[MODEL, "--cells", "100000,100000"],
        &["--cells", "GiB"],
    );
    refused(
        "cells-no-grid",
        &[MODEL, "--method", "epc", "--cells", "40,40"],
        &["--cells", "not among the methods"],
    );
    refused(
        "mc-from-missing",
        &[MODEL, "--mc-from", "/nonexistent/fpsolve/mc"],
        &["--mc-from", "/nonexistent/fpsolve/mc/mc_summary.json"],
    );
    refused(
        "mc-from-and-mc",
        &[MODEL, "--mc", "1e5", "--mc-from", "/nonexistent"],
        &["--mc-from", "cannot be used with"],
    );
    let garbage = scratch("mc-from-garbage-src");
    std::fs::write(garbage.join("mc_summary.json"), b"{\"settings\": 1}").unwrap();
    refused(
        "mc-from-garbage",
        &[MODEL, "--mc-from", garbage.to_str().unwrap()],
        &["--mc-from", "mc_summary.json", "not a Monte Carlo summary"],
    );
    let _ = std::fs::remove_dir_all(garbage);
    let _ = std::fs::remove_dir_all(models);
}

/// A vector-extension cap (`FPSOLVE_SIMD`) that names no extension is refused before any
/// work, whatever the command.
#[test]
fn vector_extension_cap() {
    for (tag, args) in [
        ("simd-main", vec![MODEL, "--method", "epc"]),
        ("simd-simulate", vec!["simulate", MODEL, "--samples", "1e4"]),
    ] {
        refused_with_env(
            tag,
            &[("FPSOLVE_SIMD", "avx3")],
            &args,
            &["FPSOLVE_SIMD=avx3", "baseline, avx2, avx512"],
        );
    }
}
