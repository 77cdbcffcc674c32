//! The bundled models parse, print back to themselves, and pass `fpsolve check`.

use std::path::{Path, PathBuf};
use std::process::Command;

use approx::assert_relative_eq;
use fpsolve::model::{load_model, parse_model, Override};
use fpsolve::symbolic::Expr;

const MODELS: [&str; 2] = ["vibro_duffing.sde", "duffing.sde"];

fn model_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name)
}

#[test]
fn bundled_models_parse_and_print_back_to_themselves() {
    for name in MODELS {
        let model = load_model(&model_path(name)).unwrap();
        let printed = model.to_string();
        let again = parse_model(&printed, None)
            .unwrap_or_else(|e| panic!("{name} printed as\n{printed}\ndoes not parse:\n{e}"));
        assert_eq!(again, model, "{name}");
        assert_eq!(again.to_string(), printed, "{name}");
    }
}

#[test]
fn the_vibro_impact_model_is_the_papers_eq_10() {
    let model = load_model(&model_path("vibro_duffing.sde")).unwrap();
    let b = model.bind(&[]).unwrap();
    for (name, value) in [
        ("c", 0.1),
        ("k", 1.0),
        ("mu", 0.1),
        ("eps", 0.1),
        ("r", 0.95),
    ] {
        assert_eq!(b.param(name), Some(value), "{name}");
    }
    // 2*pi*K = 1 (Table 1, case 1).
    assert_relative_eq!(b.intensity()[0][0], 1.0, epsilon = 1e-15);
    // G = (0, sgn(z) + eps*z): the noise enters the velocity equation only.
    let g = b.noise_matrix();
    assert_eq!(g[0][0], Expr::num(0.0));
    let at = |z: f64| g[1][0].eval(&|s| (s == "z").then_some(z)).unwrap();
    assert_relative_eq!(at(2.0), 1.2, epsilon = 1e-15);
    assert_relative_eq!(at(-2.0), -1.2, epsilon = 1e-15);
    let [impact] = b.impacts() else {
        panic!("one impact law")
    };
    assert_eq!((impact.state, impact.at, impact.other), (0, 0.0, 1));
    assert_eq!(impact.side, None, "a pass-through law has no side");
    let names: Vec<&str> = model.observables().iter().map(|o| &*o.name).collect();
    assert_eq!(names, ["y", "ydot"]);
    assert!(model.drift()[1].contains_delta());
}

#[test]
fn overrides_reach_the_bound_model() {
    let model = load_model(&model_path("duffing.sde")).unwrap();
    let value = fpsolve::model::parse_expr("2*k").unwrap();
    let b = model
        .bind(&[Override {
            name: "mu".into(),
            value,
        }])
        .unwrap();
    assert_eq!(b.param("mu"), Some(2.0));
}

#[test]
fn check_exits_zero_on_the_bundled_models() {
    for name in MODELS {
        let out = Command::new(env!("CARGO_BIN_EXE_fpsolve"))
            .arg("check")
            .arg(model_path(name))
            .args(["--set", "c=0.2"])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(0), "{name}: {out:?}");
        assert!(stdout.contains("#   c = 0.2"), "{name}:\n{stdout}");
        assert!(stdout.starts_with("model "), "{name}:\n{stdout}");
    }
}

mod printing {
    use fpsolve::model::parse_expr;
    use proptest::prelude::*;

    /// Random expression text in the model language, with every operator and precedence
    /// level mixed.
    fn expression() -> impl Strategy<Value = String> {
        let leaf = prop_oneof![
            Just("x".to_string()),
            Just("y".to_string()),
            (1u32..40).prop_map(|n| format!("{}", n as f64 / 8.0)),
        ];
        leaf.prop_recursive(5, 40, 2, |inner| {
            prop_oneof![
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a} + {b}")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a} - {b}")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a}*{b}")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a}/({b})")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("({a})*({b})")),
                inner.clone().prop_map(|a| format!("-{a}")),
                inner.clone().prop_map(|a| format!("-({a})")),
                inner.clone().prop_map(|a| format!("({a})^2")),
                inner.clone().prop_map(|a| format!("{a}^-1")),
                inner.clone().prop_map(|a| format!("abs({a})")),
                (inner.clone(), inner).prop_map(|(a, b)| format!("max({a}, {b})")),
            ]
        })
    }

    fn value(e: &fpsolve::symbolic::Expr) -> f64 {
        e.eval(&|s| match s {
            "x" => Some(0.7),
            "y" => Some(-1.3),
            _ => None,
        })
        .unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Printing an expression and reading it back keeps its value. (Not always its
        /// shape: `Expr`'s printer writes `(-1)*2*x` as `-2*x`, which reads back as `(-2)*x`.)
        #[test]
        fn print_then_parse_keeps_the_value(text in expression()) {
            let first = parse_expr(&text).unwrap();
            let printed = first.to_string();
            let second = parse_expr(&printed).unwrap();
            let (a, b) = (value(&first), value(&second));
            if a.is_finite() || b.is_finite() {
                prop_assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{text} -> {printed}: {a} vs {b}");
            }
        }

        /// For expressions in the canonical form the symbolic layer works in (simplified),
        /// printing and reading back gives the same canonical tree:
        /// simplify(parse(print(e))) == e (the printer writes factors in reading order, so the
        /// raw parse can list them differently).
        #[test]
        fn simplified_expressions_print_and_parse_back_to_the_same_tree(text in expression()) {
            let e = fpsolve::symbolic::simplify(&parse_expr(&text).unwrap());
            // Singular expressions (a division by an expression that is identically 0) keep
            // their unfolded `0^-1` and have no canonical form to come back to.
            prop_assume!(value(&e).is_finite());
            let printed = e.to_string();
            let back = fpsolve::symbolic::simplify(&parse_expr(&printed).unwrap());
            prop_assert_eq!(&back, &e, "{} printed as {}", text, printed);
        }
    }
}
