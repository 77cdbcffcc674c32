//! SIGINT at every millisecond of a run: the output directory holds exactly one whole run
//! at every instant (the earlier one or the new one, never nothing, never a mix), nothing is
//! left beside it but its lock file, and the sentence printed on the interrupt is true.
//!
//! `FPSOLVE_TEST_BIN=/path/to/fpsolve` runs these against another build (to see them fail
//! on an older one).
#![cfg(unix)]

mod common;

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{names, scratch};
use fpsolve::report::MARKER;

fn binary() -> OsString {
    std::env::var_os("FPSOLVE_TEST_BIN").unwrap_or_else(|| env!("CARGO_BIN_EXE_fpsolve").into())
}

/// What an interrupted run did: its exit code (`None` when the signal killed it before the
/// handler was installed) and stderr.
struct Interrupted {
    code: Option<i32>,
    stderr: String,
}

/// Runs `fpsolve args…`, sends SIGINT `after` its start, and waits (10 s at most).
fn interrupt(args: &[&str], after: Duration) -> Interrupted {
    let mut child = Command::new(binary())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run fpsolve");
    std::thread::sleep(after);
    // SAFETY: kill(2) on our own child's id.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let t = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            panic!("{args:?}: no exit 10 s after SIGINT at {after:?}");
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let output = child.wait_with_output().unwrap();
    Interrupted {
        code: output.status.code(),
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
    }
}

/// The command line in `dir`'s marker, after checking that `dir` holds exactly the files
/// the marker lists and the marker: one whole run.
fn whole_run(dir: &Path, context: &str) -> String {
    let marker = std::fs::read_to_string(dir.join(MARKER)).unwrap_or_else(|e| {
        panic!(
            "{context}: {} has no marker ({e}): {:?}",
            dir.display(),
            names(dir)
        )
    });
    let mut lines = marker.lines();
    let command = lines
        .find_map(|l| l.strip_prefix("command: "))
        .unwrap_or_else(|| panic!("{context}: marker without a command: {marker}"))
        .to_string();
    // (An older fpsolve's marker has no list: the callers compare the files themselves.)
    if lines.any(|l| l == "files:") {
        let mut listed: Vec<String> = lines.map(str::to_string).collect();
        listed.push(MARKER.to_string());
        listed.sort();
        assert!(listed.len() > 1, "{context}: a run without files");
        assert_eq!(names(dir), listed, "{context}: not the marker's files");
    }
    command
}

/// Checks what an interrupted first run on `root/out` left: nothing but `out` and its lock
/// beside it; `out` missing or one whole run; the message true.
fn check_first_run(root: &Path, run: &Interrupted, context: &str) {
    let out = root.join("out");
    for name in names(root) {
        assert!(
            name == "out" || name == ".out.fpsolve-lock",
            "{context}: left {name} beside --out\n{}",
            run.stderr
        );
    }
    assert!(
        matches!(run.code, None | Some(0) | Some(130)),
        "{context}: exit {:?}\n{}",
        run.code,
        run.stderr
    );
    assert!(
        !run.stderr.contains("panicked"),
        "{context}: {}",
        run.stderr
    );
    if out.exists() {
        whole_run(&out, context);
        assert!(
            !run.stderr.contains("untouched"),
            "{context}: says earlier results are untouched, but wrote\n{}",
            run.stderr
        );
    } else {
        assert_ne!(run.code, Some(0), "{context}: exit 0 and nothing written");
        assert!(
            !run.stderr.contains("already written"),
            "{context}: says the results were written, but none are\n{}",
            run.stderr
        );
    }
}

/// SIGINT at 1 ms steps over the first 200 ms of `args … --out root/out`.
fn first_200_ms(tag: &str, args: &[&str]) {
    let root = scratch(tag);
    let out = root.join("out");
    let mut full: Vec<&str> = args.to_vec();
    let out_arg = out.to_string_lossy().into_owned();
    full.extend(["--quiet", "--out", &out_arg]);
    let (mut written, mut removed) = (0, 0);
    for ms in 0..200 {
        let run = interrupt(&full, Duration::from_millis(ms));
        check_first_run(&root, &run, &format!("{tag} at {ms} ms"));
        if out.exists() {
            written += 1;
            std::fs::remove_dir_all(&out).unwrap();
        } else {
            removed += 1;
        }
    }
    eprintln!("{tag}: {written} runs had written their files, {removed} had not");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn solve_interrupted_in_its_first_200_ms_leaves_nothing_beside_out() {
    first_200_ms(
        "int-solve",
        &["solve", "models/linear.sde", "--degree", "2"],
    );
}

#[test]
fn sweep_interrupted_in_its_first_200_ms_leaves_nothing_beside_out() {
    first_200_ms(
        "int-sweep",
        &["sweep", "models/linear.sde", "--set", "c=0.1,0.2"],
    );
}

/// Copies the files of `from` into a new directory `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

#[test]
fn an_interrupt_anywhere_in_a_run_keeps_one_whole_run_in_place() {
    let root = scratch("int-replace");
    let out = root.join("out");
    let out_arg = out.to_string_lossy().into_owned();
    let earlier: [&str; 7] = [
        "solve",
        "models/linear.sde",
        "--degree",
        "2,4",
        "--quiet",
        "--out",
        &out_arg,
    ];
    let newer: [&str; 7] = [
        "solve",
        "models/linear.sde",
        "--degree",
        "2",
        "--quiet",
        "--out",
        &out_arg,
    ];
    // The earlier run, kept aside to put back before each try.
    let saved: PathBuf = root.join("saved");
    let status = Command::new(binary())
        .args(earlier)
        .output()
        .unwrap()
        .status;
    assert!(status.success());
    let earlier_command = whole_run(&out, "the earlier run");
    let earlier_files = names(&out);
    copy_dir(&out, &saved);
    // How long the newer run takes, uninterrupted (the longest of three).
    let mut span = Duration::ZERO;
    for _ in 0..3 {
        let t = Instant::now();
        assert!(Command::new(binary())
            .args(newer)
            .output()
            .unwrap()
            .status
            .success());
        span = span.max(t.elapsed());
    }
    let newer_command = whole_run(&out, "the newer run");
    let newer_files = names(&out);
    assert_ne!(earlier_command, newer_command);
    let steps = span.as_millis() as u64 + 10;
    let (mut kept, mut replaced) = (0, 0);
    for ms in 0..steps {
        let context = format!("SIGINT at {ms} ms of {steps}");
        std::fs::remove_dir_all(&out).unwrap();
        copy_dir(&saved, &out);
        let run = interrupt(&newer, Duration::from_millis(ms));
        for name in names(&root) {
            assert!(
                ["out", "saved", ".out.fpsolve-lock"].contains(&name.as_str()),
                "{context}: left {name} beside --out\n{}",
                run.stderr
            );
        }
        assert!(out.is_dir(), "{context}: --out is missing\n{}", run.stderr);
        let command = whole_run(&out, &context);
        assert!(
            !run.stderr.contains("panicked"),
            "{context}: {}",
            run.stderr
        );
        if command == earlier_command {
            assert_eq!(
                names(&out),
                earlier_files,
                "{context}: a part of the earlier run"
            );
            kept += 1;
            assert_ne!(
                run.code,
                Some(0),
                "{context}: exit 0 and the earlier run in place"
            );
            assert!(
                !run.stderr.contains("already written"),
                "{context}: {}",
                run.stderr
            );
        } else {
            assert_eq!(command, newer_command, "{context}");
            assert_eq!(
                names(&out),
                newer_files,
                "{context}: a part of the newer run"
            );
            replaced += 1;
            assert!(
                !run.stderr.contains("untouched"),
                "{context}: says earlier results are untouched, but they were replaced\n{}",
                run.stderr
            );
        }
    }
    eprintln!("{steps} tries: the earlier run kept {kept} times, replaced {replaced} times");
    assert!(kept > 0 && replaced > 0, "the tries missed the commit");
    let _ = std::fs::remove_dir_all(&root);
}
