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
