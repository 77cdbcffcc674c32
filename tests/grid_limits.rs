//! Cell counts whose factorisation degenerates are refused before any work (exit 2), from
//! every command that takes `--cells`: a mesh of 8 by 65536 cells once aborted allocating
//! 34.8 GB, and 8 by 32768 took 59 s and 1.8 GB to give a velocity sd four times the true one.

use std::process::Command;

fn refused(args: &[&str]) {
    let out = std::env::temp_dir().join(format!("fpsolve-grid-limits-{}", std::process::id()));
    let output = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run fpsolve");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(
        stderr.contains("--cells") && stderr.contains("64 times"),
        "{args:?}: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(!out.exists(), "{args:?}: wrote {}", out.display());
}

#[test]
fn thin_meshes_are_refused_before_any_work() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/vibro_duffing.sde");
    for cells in ["8,65536", "8,16384", "16384,16", "8,520"] {
        refused(&["solve", model, "--method", "grid", "--cells", cells]);
        refused(&[model, "--method", "grid", "--cells", cells]);
        refused(&[
            "sweep",
            model,
            "--set",
            "eps=0:0.1:2",
            "--method",
            "grid",
            "--cells",
            cells,
        ]);
    }
}
