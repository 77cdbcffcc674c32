//! Helpers shared by the command-line integration tests: run the binary, make scratch
//! directories, read what a run wrote.

#![allow(dead_code)] // each test file uses its own subset

pub mod exact;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `fpsolve args…` to completion.
pub fn fpsolve(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .expect("run fpsolve")
}

/// A path unique to this test process and `name`, removed if it exists and not created.
pub fn fresh_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fpsolve-test-{}-{name}", std::process::id()));
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

/// Runs `fpsolve args… --out <fresh>` and checks a refusal before any work: exit 2, every
/// `expected` fragment in stderr, no panic, nothing written.
pub fn refused_before_work(args: &[&str], expected: &[&str]) {
    let out = fresh_path("refused");
    let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run fpsolve");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    for e in expected {
        assert!(stderr.contains(e), "{args:?}: stderr lacks {e:?}: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(!out.exists(), "{args:?}: wrote {}", out.display());
}
