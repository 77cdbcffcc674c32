//! Every malformed input must make `fpsolve check` exit with status 2 and a located, readable
//! message: never a panic, a backtrace or a stack overflow.
//!
//! The corpus in `tests/malformed/` holds one mistake per file; each file's first line says
//! what is expected: `# expect: LINE:COL message substring`. Files that are not UTF-8 cannot
//! carry that line and are listed in [`NOT_UTF8`] instead.

use std::path::{Path, PathBuf};
use std::process::Command;

/// (file, `line:col`, message substring) for the corpus files that are not UTF-8 text.
const NOT_UTF8: [(&str, &str, &str); 3] = [
    ("latin1.sde", "1:26", "not valid UTF-8 (byte 0xE4)"),
    ("utf16.sde", "1:1", "not valid UTF-8 (byte 0xFF)"),
    ("binary_garbage.sde", "1:1", "not valid UTF-8 (byte 0x89)"),
];

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed")
}

/// Runs `fpsolve check` with `args` and returns (status, stderr).
fn check(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .arg("check")
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the fpsolve binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Asserts a clean failure: status 2, `what` in stderr, no panic or backtrace.
fn assert_fails_cleanly(args: &[&str], what: &[&str]) {
    let (status, stderr) = check(args);
    assert_eq!(status, Some(2), "{args:?}: status {status:?}\n{stderr}");
    for w in what {
        assert!(stderr.contains(w), "{args:?}: `{w}` not in\n{stderr}");
    }
    for bad in ["panicked", "backtrace", "stack overflow"] {
        assert!(!stderr.contains(bad), "{args:?}: `{bad}` in\n{stderr}");
    }
    assert!(stderr.starts_with("error: "), "{args:?}:\n{stderr}");
    assert!(
        stderr.len() < 4000,
        "{args:?}: {} bytes of stderr",
        stderr.len()
    );
}

#[test]
fn every_corpus_file_fails_where_its_header_says() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sde"))
        .collect();
    files.sort();
    assert!(files.len() >= 45, "only {} corpus files", files.len());
    let mut checked = 0;
    for path in &files {
        let name = path.file_name().unwrap().to_str().unwrap();
        let shown = path.to_str().unwrap();
        let (location, message) = match NOT_UTF8.iter().find(|(f, ..)| *f == name) {
            Some((_, location, message)) => (location.to_string(), message.to_string()),
            None => {
                let text = std::fs::read_to_string(path).unwrap();
                let header = text.lines().next().unwrap_or_default();
                let rest = header
                    .strip_prefix("# expect: ")
                    .unwrap_or_else(|| panic!("{name}: no `# expect:` header"));
                let (location, message) = rest.split_once(' ').unwrap();
                (location.to_string(), message.to_string())
            }
        };
        assert_fails_cleanly(&[shown], &[&format!("{shown}:{location}"), &message]);
        checked += 1;
    }
    assert_eq!(checked, files.len());
}

/// A scratch directory for generated inputs, unique to this test process.
fn scratch(name: &str) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("fpsolve-malformed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn ten_thousand_nested_parentheses() {
    let src = format!(
        "model m\nparam a = {}1{}\n",
        "(".repeat(10_000),
        ")".repeat(10_000)
    );
    let path = write("nested.sde", src.as_bytes());
    let p = path.to_str().unwrap();
    // "param a = " is 10 columns; the 200th `(` opens the 201st level.
    assert_fails_cleanly(&[p], &[&format!("{p}:2:210"), "nested too deeply"]);
}

#[test]
fn long_lines() {
    let mut src = b"model m\nparam a = 1".to_vec();
    src.extend(std::iter::repeat_n(b'+', 10 << 20));
    let path = write("ten_mb_line.sde", &src);
    assert_fails_cleanly(&[path.to_str().unwrap()], &["larger than"]);

    let mut src = b"model m\n# ".to_vec();
    src.extend(std::iter::repeat_n(b'x', 512 << 10));
    let path = write("long_line.sde", &src);
    let p = path.to_str().unwrap();
    assert_fails_cleanly(&[p], &[&format!("{p}:2:1"), "line is too long"]);
}

#[test]
fn a_megabyte_of_random_bytes() {
    // A fixed xorshift stream: the same bytes on every run.
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let bytes: Vec<u8> = (0..1 << 20)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 56) as u8
        })
        .collect();
    let path = write("random.sde", &bytes);
    let p = path.to_str().unwrap();
    assert_fails_cleanly(&[p], &[p, "not valid UTF-8"]);
}

#[test]
fn nul_bytes() {
    let path = write("nul.sde", b"model m\0\0\nstate z, v\n");
    let p = path.to_str().unwrap();
    assert_fails_cleanly(&[p], &[&format!("{p}:1:8")]);
    let (_, stderr) = check(&[p]);
    assert!(!stderr.contains('\0'), "NUL echoed to the terminal");

    let path = write("all_nul.sde", &[0u8; 4096]);
    assert_fails_cleanly(&[path.to_str().unwrap()], &["expected a statement"]);
}

#[test]
fn an_empty_file() {
    let path = write("empty.sde", b"");
    let p = path.to_str().unwrap();
    assert_fails_cleanly(&[p], &[&format!("{p}:1:1"), "no `model` line"]);
}

#[test]
fn a_missing_file() {
    assert_fails_cleanly(
        &["/no/such/model.sde"],
        &["cannot read", "/no/such/model.sde"],
    );
}

#[test]
fn bad_set_flags() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
    let m = model.to_str().unwrap();
    assert_fails_cleanly(&[m, "--set", "nope=1"], &["unknown parameter `nope`"]);
    assert_fails_cleanly(
        &[m, "--set", "mu="],
        &["--set mu=", "expected an expression"],
    );
    assert_fails_cleanly(
        &[m, "--set", "mu=1+"],
        &["--set mu=1+", "1:3", "expected an expression"],
    );
    assert_fails_cleanly(&[m, "--set", "mu"], &["expected NAME=VALUE"]);
    assert_fails_cleanly(&[m, "--set", "mu=sinh(1)"], &["unknown function `sinh`"]);
    assert_fails_cleanly(&[m, "--set", "K=-1"], &["intensity"]);
}
