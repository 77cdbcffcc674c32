//! A corpus of bad invocations: every flag, range, output directory and shard file that is
//! wrong must be refused before anything is computed or written — exit 2, a message naming the
//! flag (or file), no panic, and no output directory (nor staging leftovers) created.

mod common;

use std::process::Command;

use common::{names, refused, refused_at_once, refused_with_env, scratch};

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
        &[
            "--out",
            "thesis.tex",
            "not a file of one earlier fpsolve run",
        ],
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
    // δ terms and no impact law: EPC applies (its δ-term form), the grid does not.
    std::fs::write(
        &plain,
        "model plain\nstate x, y\ndrift x: y\ndrift y: -0.2*y - x - 0.1*y*abs(y)*delta(x)\nnoise xi: intensity 1\n\
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
            "delta(...) terms",
        ],
    );
    refused(
        "method-grid-solve",
        &["solve", plain, "--method", "epc,grid"],
        &["--method grid", "delta(...) terms"],
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

/// `--tol` (the grid's L1 tolerance) out of range, with `--cells`, or without the grid among
/// the methods, on `solve` and the main job; `sweep --domain` malformed or without the grid.
#[test]
fn tolerances_and_sweep_boxes() {
    for (tag, tol, msg) in [
        ("tol-zero", "0", "above 0 and at most 0.5"),
        ("tol-neg", "-1e-3", "above 0 and at most 0.5"),
        ("tol-nan", "NaN", "above 0 and at most 0.5"),
        ("tol-inf", "inf", "above 0 and at most 0.5"),
        ("tol-big", "0.6", "above 0 and at most 0.5"),
        ("tol-text", "tight", "invalid value 'tight'"),
    ] {
        refused(tag, &[LINEAR, "--tol", tol], &["--tol", msg]);
        refused(
            &format!("{tag}-solve"),
            &["solve", LINEAR, "--method", "grid", "--tol", tol],
            &["--tol", msg],
        );
    }
    refused(
        "tol-cells",
        &[LINEAR, "--tol", "1e-3", "--cells", "40,80"],
        &["--tol", "--cells", "give one"],
    );
    refused(
        "tol-cells-solve",
        &[
            "solve", LINEAR, "--method", "grid", "--tol", "1e-3", "--cells", "40,80",
        ],
        &["--tol", "--cells", "give one"],
    );
    refused(
        "tol-no-grid",
        &[LINEAR, "--method", "epc", "--tol", "1e-3"],
        &["--tol", "not among the methods"],
    );
    refused(
        "tol-no-grid-solve",
        &["solve", LINEAR, "--tol", "1e-3"],
        &["--tol", "not among the methods (epc)"],
    );
    let sweep = ["sweep", LINEAR, "--set", "c=0.1,0.2"];
    for (tag, extra, msg) in [
        (
            "sweep-domain-no-grid",
            vec!["--domain", "z=-9:9,v=-9:9"],
            vec!["--domain", "not among the methods"],
        ),
        (
            "sweep-domain-syntax",
            vec!["--method", "grid", "--domain", "z=-9..9"],
            vec!["--domain"],
        ),
        (
            "sweep-domain-name",
            vec!["--method", "grid", "--domain", "q=-9:9,v=-9:9"],
            vec!["--domain"],
        ),
        (
            "sweep-domain-empty",
            vec!["--method", "grid", "--domain", "z=9:-9,v=-9:9"],
            vec!["--domain"],
        ),
    ] {
        let mut args = sweep.to_vec();
        args.extend(extra);
        refused(tag, &args, &msg);
    }
}

/// `reliability --domain` malformed, reversed, naming another state, without the grid,
/// leaving the start outside, without 0 in the velocity's range, or with the safe set
/// reaching the box's end along x for a model without a stationary density; and that model
/// without the flag: each refused before any work, naming the flag.
#[test]
fn reliability_boxes() {
    const FREE: &str = "tests/models/random_acceleration.sde";
    let linear = [
        "reliability",
        LINEAR,
        "--safe",
        "abs(z) < 2",
        "--cells",
        "40,40",
    ];
    let free = ["reliability", FREE, "--method", "grid", "--cells", "40,40"];
    for (tag, base, extra, msg) in [
        (
            "rel-domain-syntax",
            &linear,
            vec!["--domain", "z=-9..9"],
            vec!["--domain", "is not x=LO:HI,v=LO:HI"],
        ),
        (
            "rel-domain-reversed",
            &linear,
            vec!["--domain", "z=9:-9,v=-9:9"],
            vec!["--domain", "lower end must be below"],
        ),
        (
            "rel-domain-name",
            &linear,
            vec!["--domain", "q=-9:9,v=-9:9"],
            vec!["--domain", "`q`"],
        ),
        (
            "rel-domain-nan",
            &linear,
            vec!["--domain", "z=nan:9,v=-9:9"],
            vec!["--domain"],
        ),
        (
            "rel-domain-mc",
            &linear,
            vec![
                "--method",
                "mc",
                "--horizon",
                "5",
                "--domain",
                "z=-9:9,v=-9:9",
            ],
            vec!["--domain", "only the grid"],
        ),
        (
            "rel-domain-start",
            &linear,
            vec!["--domain", "z=1:9,v=-9:9"],
            vec!["--domain", "start (0, 0) is outside"],
        ),
        (
            "rel-domain-v",
            &linear,
            vec!["--domain", "z=-9:9,v=1:9"],
            vec!["--domain", "v_lo < 0 < v_hi"],
        ),
        (
            "rel-free-nobox",
            &free,
            vec![],
            vec!["no stationary density", "--domain"],
        ),
        (
            "rel-free-open",
            &free,
            vec!["--domain", "x=-0.5:1.05,v=-8:8", "--start", "-0.2,0"],
            vec!["--domain", "reaches the grid's box at x = -0.5"],
        ),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        refused(tag, &args, &msg);
    }
}

/// `reliability --mean-only` with output times (which it would not compute), and with
/// Monte Carlo alone but no horizon (no grid mean to set it from, no times allowed): refused
/// before any work, naming the flags.
#[test]
fn reliability_mean_only() {
    let base = [
        "reliability",
        LINEAR,
        "--safe",
        "abs(z) < 2",
        "--cells",
        "40,40",
        "--mean-only",
    ];
    for (tag, extra, msg) in [
        (
            "rel-mean-only-times",
            vec!["--times", "0:10:11"],
            vec!["--mean-only", "--times", "cannot be used with"],
        ),
        (
            "rel-mean-only-mc",
            vec!["--method", "mc"],
            vec!["--method mc --mean-only", "give --horizon"],
        ),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        refused(tag, &args, &msg);
    }
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

/// The entries of `dir` with their contents, to compare before and after a refusal.
fn snapshot(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    names(dir)
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap_or_default();
            (n, bytes)
        })
        .collect()
}

/// Runs `fpsolve args…` (OS strings, so not necessarily UTF-8) to completion and checks the
/// refusal: exit 2 within a second, no panic, `expected` in stderr.
fn refused_os(args: &[&std::ffi::OsStr], expected: &[&str]) -> String {
    let t = std::time::Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .expect("run fpsolve");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(
        t.elapsed() < std::time::Duration::from_secs(1),
        "{args:?}: slow refusal"
    );
    assert!(!stderr.contains("panicked"), "{args:?}: panic\n{stderr}");
    for e in expected {
        assert!(stderr.contains(e), "{args:?}: stderr lacks {e:?}\n{stderr}");
    }
    stderr
}

/// `--out` never replaces what is not exactly one earlier run of fpsolve's: the shard files
/// of `simulate --shard`, the inputs of `merge` and `--mc-from`, a run beside a note or a
/// repository. Each is refused (exit 2) and left as it was.
#[test]
fn output_directories_that_hold_more_than_one_earlier_run() {
    let root = scratch("out-inputs");
    let shards = root.join("S");
    let s = shards.as_os_str();
    for k in 1..=3 {
        let part = format!("{k}/3");
        let o = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
            .args([
                "simulate",
                LINEAR,
                "--samples",
                "1e5",
                "--quiet",
                "--shard",
                &part,
            ])
            .arg("--out")
            .arg(s)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let before = snapshot(&shards);
    let os = |v: &[&str]| -> Vec<std::ffi::OsString> { v.iter().map(Into::into).collect() };
    for args in [
        os(&["solve", LINEAR, "--degree", "2", "--out"]),
        os(&[LINEAR, "--method", "epc", "--out"]),
        os(&["simulate", LINEAR, "--samples", "1e5", "--out"]),
    ] {
        let mut args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_os_str()).collect();
        args.push(s);
        refused_os(&args, &["--out", "shard_1_of_3.json"]);
        assert_eq!(snapshot(&shards), before, "{args:?}: the shards changed");
    }
    refused_os(
        &["merge".as_ref(), s, "--out".as_ref(), s],
        &["--out", "an input of this command"],
    );
    assert_eq!(
        snapshot(&shards),
        before,
        "merge S --out S changed the shards"
    );
    // A finished Monte Carlo run, read by --mc-from.
    let mc = root.join("M");
    let o = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(["merge", shards.to_str().unwrap(), "--quiet", "--out"])
        .arg(&mc)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let before_mc = snapshot(&mc);
    let m = mc.as_os_str();
    refused_os(
        &[
            LINEAR.as_ref(),
            "--method".as_ref(),
            "epc".as_ref(),
            "--mc-from".as_ref(),
            m,
            "--out".as_ref(),
            m,
        ],
        &["--out", "an input of this command"],
    );
    assert_eq!(snapshot(&mc), before_mc, "--mc-from M --out M changed M");
    // One run's files beside a note, or beside a repository.
    for extra in ["notes.txt", ".git"] {
        let path = mc.join(extra);
        std::fs::write(&path, b"keep").unwrap();
        refused_os(
            &["solve".as_ref(), LINEAR.as_ref(), "--out".as_ref(), m],
            &["--out", extra],
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"keep");
        std::fs::remove_file(&path).unwrap();
    }
    assert_eq!(
        names(&root),
        vec![".M.fpsolve-lock".to_string(), "M".into(), "S".into()]
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Standard output closed by its reader (`fpsolve … | head -1`): every command that prints
/// ends quietly (exit 0, the pipe convention), its files committed.
#[test]
#[cfg(unix)]
fn a_closed_stdout_ends_quietly_with_the_files_written() {
    let root = scratch("closed-stdout");
    let shards = root.join("shards");
    let shards_arg = shards.to_str().unwrap();
    std::fs::create_dir(&shards).unwrap();
    let cases: [(&str, Vec<&str>); 6] = [
        ("solve", vec!["solve", LINEAR, "--degree", "2"]),
        ("main", vec![LINEAR, "--method", "epc", "--degree", "2"]),
        ("simulate", vec!["simulate", LINEAR, "--samples", "1e5"]),
        (
            "shard",
            vec!["simulate", LINEAR, "--samples", "1e5", "--shard", "1/1"],
        ),
        ("sweep", vec!["sweep", LINEAR, "--set", "c=0.1,0.2"]),
        ("merge", vec!["merge", shards_arg]),
    ];
    for (tag, args) in cases {
        let out = if tag == "shard" {
            shards.clone()
        } else {
            root.join(tag)
        };
        // A pipe whose reading end is closed before the run starts: every write fails.
        let mut fds = [0; 2];
        // SAFETY: pipe(2) fills two descriptors, which are ours to close or own.
        assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
        unsafe { libc::close(fds[0]) };
        let write_end =
            unsafe { <std::os::fd::OwnedFd as std::os::fd::FromRawFd>::from_raw_fd(fds[1]) };
        let t = std::time::Instant::now();
        let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
            .args(&args)
            .args(["--quiet", "--out"])
            .arg(&out)
            .stdout(std::process::Stdio::from(write_end))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            matches!(output.status.code(), Some(0) | Some(141)),
            "{tag}: exit {:?}\n{stderr}",
            output.status.code()
        );
        assert!(!stderr.contains("panicked"), "{tag}: {stderr}");
        assert!(
            !stderr.contains("stdout"),
            "{tag}: a closed pipe reported\n{stderr}"
        );
        assert!(
            t.elapsed() < std::time::Duration::from_secs(30),
            "{tag}: slow"
        );
        assert!(!names(&out).is_empty(), "{tag}: nothing written");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Standard output on a full disk: the failed write is reported once, the run's files are
/// written, and the exit status says something went wrong (1).
#[test]
#[cfg(unix)]
fn a_failing_stdout_is_reported_once() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return;
    };
    let root = scratch("full-stdout");
    let out = root.join("out");
    let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(["simulate", LINEAR, "--samples", "1e5", "--quiet", "--out"])
        .arg(&out)
        .stdout(full)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.matches("writing to stdout").count(), 1, "{stderr}");
    assert!(names(&out).contains(&"mc_summary.json".to_string()));
    let _ = std::fs::remove_dir_all(&root);
}

/// Arguments that are not UTF-8: a model path is refused with exit 2 (it does not exist),
/// an output path is used as given, a `--set` is refused; none panics.
#[test]
#[cfg(unix)]
fn arguments_that_are_not_utf8() {
    use std::os::unix::ffi::OsStrExt;
    let root = scratch("not-utf8");
    let bad_model = std::ffi::OsStr::from_bytes(b"m\xff.sde");
    refused_os(&["solve".as_ref(), bad_model], &["m\u{fffd}.sde"]);
    refused_os(&[bad_model], &["m\u{fffd}.sde"]);
    refused_os(
        &[
            "solve".as_ref(),
            LINEAR.as_ref(),
            "--set".as_ref(),
            std::ffi::OsStr::from_bytes(b"c=\xff"),
        ],
        &["invalid UTF-8"],
    );
    let out = root.join(std::ffi::OsStr::from_bytes(b"o\xff"));
    for args in [
        vec!["solve", LINEAR, "--degree", "2"],
        vec!["simulate", LINEAR, "--samples", "1e5"],
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
            .args(&args)
            .args(["--quiet", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(out.join(fpsolve::report::MARKER).is_file());
    }
    let _ = std::fs::remove_dir_all(&root);
}

// issue 39 item 10: sweeps
/// Sweeps into the unrepresentable: values further apart than the largest float (their
/// figures' axis searched for ticks forever) are refused at once, in ranges and lists; a
/// point that does not bind names its values in short form, not in 57 digits.
#[test]
fn sweeps_into_the_unrepresentable_are_refused_at_once() {
    for (tag, set) in [
        ("sweep-span-range", "eps=-1e308:1e308:3"),
        ("sweep-span-list", "eps=-1e308,0,1e308"),
        ("sweep-span-mu", "mu=-1.5e308,1e308"),
    ] {
        refused_at_once(
            tag,
            &["sweep", MODEL, "--set", set],
            &[set, "largest floating-point number"],
        );
    }
    let stderr = refused_at_once(
        "sweep-bind-digits",
        &["sweep", MODEL, "--set", "K=-1e56,1"],
        &["at the sweep point K = -1e56", "intensity"],
    );
    let longest = stderr
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    assert!(longest < 20, "a {longest}-digit number in: {stderr}");
}

// issue 39 items 7/8: Monte Carlo and file readers

/// A FIFO at `path` (no writer ever opens it: a reader that opens it blocking hangs).
fn fifo(path: &std::path::Path) {
    let status = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(status.success());
}

/// Damping c = 1e6 at dt = 0.01 (c·dt = 1e4, the explicit step stable to 2): every
/// trajectory blew up, in a run that printed nothing for minutes.
#[test]
fn a_time_step_the_damping_makes_unstable() {
    let expected = ["dt = 0.01 is too large", "largest stable dt is"];
    refused_at_once(
        "mc-stiff-simulate",
        &["simulate", MODEL, "--set", "c=1e6", "--samples", "1e5"],
        &expected,
    );
    refused_at_once(
        "mc-stiff-job",
        &[MODEL, "--set", "c=1e6", "--mc", "1e5"],
        &expected,
    );
    refused_at_once(
        "mc-stiff-210",
        &["simulate", MODEL, "--set", "c=210", "--samples", "1e5"],
        &["dt = 0.01 is too large", "largest stable dt is 9.52e-3"],
    );
}

/// The histograms of the documented maximum of bins (10⁷) took 12.5 GB.
#[test]
fn histograms_over_the_memory_limit() {
    refused_at_once(
        "mc-grid-max",
        &[
            "simulate",
            MODEL,
            "--grid",
            "y=0:8:10000000",
            "--samples",
            "1e6",
        ],
        &["memory", "10000300 bins"],
    );
}

/// Every reader of a named file refuses what is not a regular file of bounded size: a
/// symbolic link to `/dev/zero` was read until the kernel killed the process, a FIFO waited
/// forever.
#[test]
fn input_files_that_are_not_regular_files() {
    let root = scratch("readers-src");
    let zero = |p: &std::path::Path| std::os::unix::fs::symlink("/dev/zero", p).unwrap();
    // Model files.
    let fifo_model = root.join("fifo.sde");
    fifo(&fifo_model);
    let zero_model = root.join("zero.sde");
    zero(&zero_model);
    for (tag, path, why) in [
        ("model-fifo", &fifo_model, "not a regular file (a FIFO)"),
        (
            "model-zero",
            &zero_model,
            "not a regular file (a character device)",
        ),
        ("model-dir", &root, "not a regular file (a directory)"),
    ] {
        let path = path.to_str().unwrap();
        refused_at_once(tag, &[path], &[path, why]);
        refused_at_once(
            &format!("{tag}-simulate"),
            &["simulate", path, "--samples", "1e4"],
            &[path, why],
        );
    }
    // `--mc-from`: the summary a link to /dev/zero, a FIFO, a directory, a huge file.
    let mc = |name: &str, make: &dyn Fn(&std::path::Path)| {
        let dir = root.join(name);
        std::fs::create_dir(&dir).unwrap();
        make(&dir.join("mc_summary.json"));
        dir
    };
    let huge = |p: &std::path::Path| {
        // Sparse: 17 GiB claimed, nothing written.
        std::fs::File::create(p).unwrap().set_len(17 << 30).unwrap();
    };
    for (tag, dir, why) in [
        (
            "mc-from-zero",
            mc("mc-zero", &|p| zero(p)),
            "not a regular file (a character device)",
        ),
        (
            "mc-from-fifo",
            mc("mc-fifo", &fifo),
            "not a regular file (a FIFO)",
        ),
        (
            "mc-from-dir",
            mc("mc-dir", &|p| std::fs::create_dir(p).unwrap()),
            "not a regular file (a directory)",
        ),
        (
            "mc-from-huge",
            mc("mc-huge", &huge),
            "18253611008 bytes, more than the 17179869184",
        ),
    ] {
        let d = dir.to_str().unwrap();
        refused_at_once(
            tag,
            &[MODEL, "--method", "epc", "--mc-from", d],
            &["--mc-from", "mc_summary.json", why],
        );
    }
    refused_at_once(
        "mc-from-dev-zero",
        &[MODEL, "--method", "epc", "--mc-from", "/dev/zero"],
        &["--mc-from", "/dev/zero"],
    );
    // Shard files of `merge`, Monte Carlo and sweep.
    let shards = |name: &str, file: &str, make: &dyn Fn(&std::path::Path)| {
        let dir = root.join(name);
        std::fs::create_dir(&dir).unwrap();
        make(&dir.join(file));
        dir
    };
    for (tag, dir, why) in [
        (
            "merge-zero",
            shards("sh-zero", "shard_1_of_2.json", &|p| zero(p)),
            "not a regular file (a character device)",
        ),
        (
            "merge-fifo",
            shards("sh-fifo", "shard_1_of_2.json", &fifo),
            "not a regular file (a FIFO)",
        ),
        (
            "merge-huge",
            shards("sh-huge", "shard_1_of_2.json", &huge),
            "more than the 17179869184",
        ),
        (
            "merge-sweep-fifo",
            shards("sw-fifo", "sweep_shard_1_of_2.json", &fifo),
            "not a regular file (a FIFO)",
        ),
        (
            "merge-sweep-zero",
            shards("sw-zero", "sweep_shard_1_of_2.json", &|p| zero(p)),
            "not a regular file (a character device)",
        ),
    ] {
        let d = dir.to_str().unwrap();
        refused_at_once(tag, &["merge", d], &[d, why]);
    }
    let _ = std::fs::remove_dir_all(&root);
}
