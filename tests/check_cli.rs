//! `fpsolve check models/vibro_duffing.sde` prints the paper's Eq. 13 coefficients.
//!
//! Case 1 of Table 1 (c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95, 2πK = 1): Eq. 13 reads
//! A0 = c + 2(1−r)|v|δ(z) = 0.1 + 0.1|v|δ(z), A_z = −v,
//! A_v = c v + k z + μ z³ + (1−r) v|v|δ(z), B_vv = πK(1 + 2ε|z| + ε² z²).

use std::process::Command;

fn check(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .arg("check")
        .arg("models/vibro_duffing.sde")
        .args(args)
        .output()
        .expect("run fpsolve");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 output")
}

fn assert_lines(text: &str, expected: &[&str]) {
    for line in expected {
        assert!(
            text.lines()
                .any(|l| l.trim_start_matches('#').trim() == *line),
            "missing `{line}` in\n{text}"
        );
    }
}

#[test]
fn check_prints_eq_13_for_case_1() {
    let text = check(&[]);
    assert_lines(
        &text,
        &[
            "A0 = 0.1 + 0.1*abs(v)*delta(z)",
            "A_z = -v",
            "A_v = 0.1*v + z + 0.1*z^3 + 0.05*v*abs(v)*delta(z)",
            "B_vv = 0.005*z^2 + 0.1*abs(z) + 0.5",
            "(no Wong-Zakai correction)",
            "Impact law: Zhuravlev (r = 0.95), represented by the delta term of the drift",
        ],
    );
}

#[test]
fn check_prints_eq_13_for_case_4_with_overrides() {
    let text = check(&["--set", "mu=1", "--set", "eps=-0.1"]);
    assert_lines(
        &text,
        &[
            "A0 = 0.1 + 0.1*abs(v)*delta(z)",
            "A_v = 0.1*v + z + z^3 + 0.05*v*abs(v)*delta(z)",
            "B_vv = 0.005*z^2 - 0.1*abs(z) + 0.5",
        ],
    );
}

/// Runs the binary with `args`, returns (status, stdout, stderr).
fn run(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .expect("run fpsolve");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn scratch(name: &str) -> String {
    let dir = std::env::temp_dir().join(format!("fpsolve-check-cli-{}-{name}", std::process::id()));
    dir.to_str().unwrap().to_string()
}

/// Issue 9, item 13: an impact that adds energy used to give "a solution" (r = 1.001, exit 0
/// with degree 2) and no damping a numerical failure; both are now refused in plain words,
/// by `check`, the main job, `solve` and `simulate`, before any work.
#[test]
fn invalid_physics_is_refused_with_exit_2_and_plain_words() {
    let energy = "no stationary density: the impact law `v -> 1.001*v` adds energy at every impact";
    let out = scratch("r");
    for args in [
        vec!["check", "models/vibro_duffing.sde", "--set", "r=1.001"],
        vec![
            "models/vibro_duffing.sde",
            "--set",
            "r=1.001",
            "--quiet",
            "--out",
            &out,
        ],
        vec![
            "solve",
            "models/vibro_duffing.sde",
            "--set",
            "r=1.001",
            "--out",
            &out,
        ],
        vec![
            "simulate",
            "models/vibro_duffing.sde",
            "--set",
            "r=1.001",
            "--samples",
            "1000",
            "--out",
            &out,
        ],
    ] {
        let (status, _, stderr) = run(&args);
        assert_eq!(status, Some(2), "{args:?}\n{stderr}");
        assert!(stderr.contains(energy), "{args:?}\n{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let (status, _, stderr) = run(&[
        "models/vibro_duffing.sde",
        "--set",
        "c=0",
        "--set",
        "r=1",
        "--set",
        "eps=0",
        "--quiet",
        "--out",
        &out,
    ]);
    assert_eq!(status, Some(2), "{stderr}");
    assert!(
        stderr.contains("no stationary density: nothing takes energy out of the motion"),
        "{stderr}"
    );
    let (status, _, stderr) = run(&["check", "models/duffing.sde", "--set", "c=-0.1"]);
    assert_eq!(status, Some(2), "{stderr}");
    assert!(
        stderr.contains("no stationary density: the damping of `v` is negative"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Issue 9, item 5: a model in original coordinates (reflecting impact, no delta term) was
/// solved by EPC as if there were no barrier (E[x] = 0). Issue 11: EPC given that model
/// directly still refuses it; `check` prints its Zhuravlev transform and `solve` solves that
/// transform, answering for the original states (x >= 0, so E[x] > 0).
#[test]
fn a_model_in_original_coordinates_is_solved_through_its_zhuravlev_transform() {
    let dir = std::env::temp_dir().join(format!("fpsolve-check-cli-orig-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("orig.sde");
    std::fs::write(
        &model,
        "model orig\nparam c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95, K = 1/(2*pi)\n\
         state x, v\ndrift x: v\ndrift v: -c*v - k*x - mu*x^3\nnoise xi: intensity 2*pi*K\n\
         diffusion v: (1 + eps*x) * xi\nimpact x = 0: v -> -r*v\ndomain x >= 0\n",
    )
    .unwrap();
    let path = model.to_str().unwrap();
    let (status, stdout, stderr) = run(&["check", path]);
    assert_eq!(status, Some(0), "{stderr}");
    assert!(
        stdout.contains("Impact law `impact x = 0: v -> -0.95*v`: it reflects the velocity"),
        "{stdout}"
    );
    // The names z and v: v is taken by the model, so the new velocity is `v_`.
    for line in [
        "# Zhuravlev transform (Eqs. 5-10), the model EPC solves",
        "state z, v_",
        "drift v_: -c*v_ - k*z - mu*z^3 - (1 - r)*v_*abs(v_)*delta(z)",
        "impact z = 0: v_ -> r*v_",
        "observe x = abs(z), v = v_*sgn(z)",
    ] {
        assert!(stdout.contains(line), "`{line}` not in\n{stdout}");
    }
    let out = dir.join("out");
    let (status, stdout, stderr) = run(&[
        "solve",
        path,
        "--degree",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(status, Some(0), "{stdout}\n{stderr}");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(out.join("pdf_x.csv").exists() && out.join("pdf_v.csv").exists());
    // The displacement lives on x >= 0: its grid starts at the barrier.
    let csv = std::fs::read_to_string(out.join("pdf_x.csv")).unwrap();
    assert!(csv.lines().nth(1).unwrap().starts_with("0,"), "{csv}");
    assert!(summary.contains("\"x\""), "{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 11: `check` of the paper's Eqs. 1–2 prints their Zhuravlev transform, which is
/// `vibro_duffing.sde`'s model (the same equations, impact law, observables and δ treatment).
#[test]
fn check_prints_the_zhuravlev_transform_of_eqs_1_2() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let (status, stdout, stderr) = run(&[
        "check",
        dir.join("vibro_impact_duffing.sde").to_str().unwrap(),
    ]);
    assert_eq!(status, Some(0), "{stderr}");
    let (_, tail) = stdout
        .split_once("# Zhuravlev transform (Eqs. 5-10), the model EPC solves; the lines below are a model file\n")
        .unwrap_or_else(|| panic!("no transform in\n{stdout}"));
    let text: String = tail
        .lines()
        .take_while(|l| !l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    let transformed = fpsolve::model::parse_model(&text, None).unwrap();
    let paper = fpsolve::model::load_model(&dir.join("vibro_duffing.sde")).unwrap();
    assert_eq!(transformed.states(), paper.states());
    assert_eq!(transformed.drift(), paper.drift());
    assert_eq!(transformed.impacts(), paper.impacts());
    assert_eq!(transformed.observables(), paper.observables());
    assert_eq!(transformed.delta_treatment(), paper.delta_treatment());
    assert_eq!(transformed.interpretation(), paper.interpretation());
    // The noise: `(eps*z + sgn(z))*xi` against the file's `(sgn(z) + eps*z) * xi`.
    let b = |m: &fpsolve::model::Model| fpsolve::symbolic::simplify(&m.noise_matrix()[1][0]);
    assert_eq!(b(&transformed), b(&paper));
}
