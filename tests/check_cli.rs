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
