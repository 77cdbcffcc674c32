//! Helpers shared by the command-line integration tests: run the binary, make scratch
//! directories, read what a run wrote.

#![allow(dead_code)] // each test file uses its own subset

pub mod exact;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `fpsolve args…` to completion.
pub fn fpsolve(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .expect("run fpsolve")
}

/// A path unique to this test process and `name`, removed if it exists and not created.
///
/// It lies under Cargo's scratch directory for integration tests (`target/tmp`), not the
/// system's temporary directory: what a run leaves for inspection goes with `target/`.
pub fn fresh_path(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("fpsolve-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// An empty directory unique to this test process and `name`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = fresh_path(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in a directory, sorted.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A JSON file's value.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The entries of `summary.json`'s `comparisons` list of `method` against `reference`
/// (`"mc"` or `"grid"`), in the list's order.
pub fn comparisons(
    summary: &serde_json::Value,
    method: &str,
    reference: &str,
) -> Vec<serde_json::Value> {
    summary["comparisons"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter(|c| c["method"] == method && c["reference"] == reference)
                .cloned()
                .collect()
        })
        .unwrap_or_default()
}

/// ∫ f over [a, b] by composite Simpson on `n` (even) intervals.
pub fn simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let sum: f64 = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * f(a + i as f64 * h)
        })
        .sum();
    sum * h / 3.0
}

/// Runs `fpsolve args… --out <scratch>/out` (unless the case sets its own) and checks the
/// refusal: exit 2, every `expected` fragment in stderr, no panic, nothing written.
pub fn refused(tag: &str, args: &[&str], expected: &[&str]) {
    refused_with_env(tag, &[], args, expected)
}

/// [`refused`] with environment variables `env` set for the run.
pub fn refused_with_env(tag: &str, env: &[(&str, &str)], args: &[&str], expected: &[&str]) {
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

/// What a run under a deadline gave ([`run_within`]).
pub struct Ended {
    /// The exit code (`None`: killed by a signal).
    pub code: Option<i32>,
    /// Its standard error.
    pub stderr: String,
    /// Wall time to its end.
    pub elapsed: Duration,
}

/// Runs `fpsolve args…`, killed after `limit` (then the test fails: a hang ends in a
/// failure, not a stuck test run); stdout discarded, stderr read on its own thread so that a
/// full pipe never blocks the child. A panic message in stderr fails the test.
pub fn run_within(limit: Duration, args: &[&str]) -> Ended {
    let start = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run fpsolve");
    let mut pipe = child.stderr.take().expect("stderr piped");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut pipe, &mut s).expect("read stderr");
        s
    });
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for fpsolve") {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} still running after {limit:?} (a hang)");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let elapsed = start.elapsed();
    let stderr = reader.join().expect("stderr reader");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("RUST_BACKTRACE"),
        "{args:?}: panic\n{stderr}"
    );
    Ended {
        code: status.code(),
        stderr,
        elapsed,
    }
}

/// [`refused`] for a case that used to hang or exhaust memory: `fpsolve args… --out
/// <scratch tag>/out` must be refused (exit 2, every `expected` fragment in stderr, nothing
/// added beside `--out`) within a second; past ten it is killed and the test fails. Returns
/// stderr.
pub fn refused_at_once(tag: &str, args: &[&str], expected: &[&str]) -> String {
    const DEADLINE: Duration = Duration::from_secs(1);
    let root = scratch(tag);
    let out = root.join("out");
    let out = out.to_str().expect("a UTF-8 scratch path");
    let full: Vec<&str> = args.iter().copied().chain(["--out", out]).collect();
    let before = names(&root);
    let r = run_within(10 * DEADLINE, &full);
    assert_eq!(r.code, Some(2), "{full:?}: {}", r.stderr);
    assert!(
        r.elapsed < DEADLINE,
        "{full:?}: refused after {:?}",
        r.elapsed
    );
    for e in expected {
        assert!(
            r.stderr.contains(e),
            "{full:?}: stderr lacks {e:?}\n{}",
            r.stderr
        );
    }
    assert_eq!(names(&root), before, "{full:?}: wrote beside --out");
    let _ = std::fs::remove_dir_all(&root);
    r.stderr
}
