//! Fuzz-style properties of the parser, the validator and the binder (issue 9): whatever the
//! input — random bytes, token sequences built from the grammar, mutations of the bundled
//! model files, random `--set` values — nothing panics, and every error of the model file
//! carries a line and column that lie inside the input.

use std::path::Path;

use fpsolve::fpk::FpkOperator;
use fpsolve::model::{parse_expr, parse_model, BindError, Model, ModelError, Override};
use proptest::prelude::*;

const BUNDLED: [&str; 8] = [
    "vibro_duffing.sde",
    "duffing.sde",
    "linear.sde",
    "parametric.sde",
    "bistable_duffing.sde",
    "cubic_damping_two_noises.sde",
    "van_der_pol.sde",
    "vdp_vibro_impact.sde",
];

fn bundled(i: usize) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(BUNDLED[i % BUNDLED.len()]);
    std::fs::read_to_string(path).unwrap()
}

/// Whether `line:col` (1-based, columns in characters) lies in `text`, one past the end of a
/// line (or of the text) included.
fn inside(text: &str, line: usize, col: usize) -> bool {
    let lines: Vec<&str> = text.split('\n').collect();
    line >= 1 && line <= lines.len() && col >= 1 && col <= lines[line - 1].chars().count() + 1
}

fn assert_located_model_error(text: &str, e: &ModelError) -> Result<(), TestCaseError> {
    match e {
        ModelError::TooLarge { .. } => return Ok(()),
        ModelError::Io { .. } => prop_assert!(false, "no I/O here: {e}"),
        _ => {}
    }
    let Some(d) = e.diagnostic() else {
        return Err(TestCaseError::fail(format!("unlocated: {e}")));
    };
    let (line, col) = (d.line(), d.column());
    prop_assert_eq!((e.line(), e.column()), (Some(line), Some(col)));
    prop_assert!(
        inside(text, line, col),
        "{line}:{col} outside the input\n{text:?}\n{e}"
    );
    let rendered = e.to_string();
    // The rendering leads with the message, then says where.
    prop_assert!(
        rendered.starts_with(&format!("error: {}\n", d.message())),
        "{rendered}"
    );
    prop_assert!(
        rendered.contains(&format!("--> {line}:{col}\n")),
        "{rendered}"
    );
    // It shows the offending line from the column on (control characters as U+FFFD).
    let shown: String = text
        .split('\n')
        .nth(line - 1)
        .unwrap_or_default()
        .chars()
        .skip(col - 1)
        .take(16)
        .take_while(|c| *c != '\r')
        .map(|c| {
            if c.is_control() && c != '\t' {
                '\u{fffd}'
            } else {
                c
            }
        })
        .collect();
    prop_assert!(
        rendered.contains(shown.trim_end()),
        "{shown:?} not shown in\n{rendered}"
    );
    match e {
        // A syntax error says what was expected there (or which limit was passed).
        ModelError::Syntax(d) => prop_assert!(
            d.message().starts_with("expected ")
                || d.message().starts_with("unexpected ")
                || d.message().starts_with("malformed number")
                || d.message().contains("the limit is")
                || d.message().contains("nested too deeply"),
            "{}",
            d.message()
        ),
        // A semantic error's message is the typed error's own.
        ModelError::Semantic { error, diagnostic } => {
            prop_assert_eq!(diagnostic.message(), error.to_string())
        }
        _ => {}
    }
    Ok(())
}

/// Binds with `overrides`; an error about the file must be located inside it, an error
/// about an override must name the overridden parameter.
fn bind_and_derive(text: &str, model: &Model, overrides: &[Override]) -> Result<(), TestCaseError> {
    match model.bind(overrides) {
        Ok(bound) => {
            // Deriving (with the admissibility check) must not panic; its errors are about
            // the model as a whole.
            let _ = FpkOperator::derive(&bound);
        }
        Err(e) => match e.diagnostic() {
            Some(d) => {
                prop_assert!(
                    inside(text, d.line(), d.column()),
                    "{}:{} outside the input\n{e}",
                    d.line(),
                    d.column()
                );
            }
            None => {
                let names: Vec<&str> = overrides.iter().map(|o| o.name.as_str()).collect();
                let text = e.to_string();
                prop_assert!(
                    !overrides.is_empty()
                        && (names.iter().any(|n| text.contains(&format!("`{n}`")))
                            || matches!(e.cause(), BindError::Cycle { .. })),
                    "an unlocated bind error that names no override: {e}"
                );
            }
        },
    }
    Ok(())
}

/// A model's printed form parses, and prints again to itself. (The trees may differ where
/// the input was not in printed form: `- - a` is printed `+ a`.)
fn assert_reprints(model: &Model) -> Result<(), TestCaseError> {
    let printed = model.to_string();
    match parse_model(&printed, None) {
        Ok(back) => prop_assert_eq!(back.to_string(), printed),
        Err(e) => prop_assert!(false, "printed as\n{printed}\ndoes not parse: {e}"),
    }
    Ok(())
}

fn check_text(text: &str) -> Result<(), TestCaseError> {
    match parse_model(text, None) {
        Ok(model) => {
            assert_reprints(&model)?;
            bind_and_derive(text, &model, &[])?
        }
        Err(e) => assert_located_model_error(text, &e)?,
    }
    Ok(())
}

/// Tokens of the language, with the numbers and functions that reach the binder's and the
/// delta checks' corners.
fn token() -> impl Strategy<Value = &'static str> {
    prop_oneof![
        Just("model m"),
        Just("param"),
        Just("state z, v"),
        Just("drift z: v"),
        Just("drift v:"),
        Just("noise xi: intensity"),
        Just("diffusion v:"),
        Just("correlate"),
        Just("impact z = 0: v ->"),
        Just("observe"),
        Just("delta: exact"),
        Just("interpretation: ito"),
        Just("delta"),
        Just("sgn"),
        Just("abs"),
        Just("exp"),
        Just("max"),
        Just("("),
        Just(")"),
        Just(","),
        Just("="),
        Just(":"),
        Just("+"),
        Just("-"),
        Just("*"),
        Just("/"),
        Just("^"),
        Just("z"),
        Just("v"),
        Just("xi"),
        Just("c"),
        Just("c = 0.1"),
        Just("0"),
        Just("1"),
        Just("1e308"),
        Just("1e-320"),
        Just("1/0"),
        Just("\n"),
        Just("#"),
    ]
}

/// Lines built from the language's own tokens, so that the parser gets deep into its
/// rules before it fails (random unicode rarely passes the first keyword).
fn token_soup() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("model m"),
        Just("param"),
        Just("state z, v"),
        Just("drift"),
        Just("noise"),
        Just("diffusion"),
        Just("correlate"),
        Just("impact"),
        Just("observe"),
        Just("delta"),
        Just(":"),
        Just(","),
        Just("="),
        Just("->"),
        Just("("),
        Just(")"),
        Just("+"),
        Just("-"),
        Just("*"),
        Just("/"),
        Just("^"),
        Just("z"),
        Just("v"),
        Just("xi"),
        Just("1e"),
        Just(".5"),
        Just("abs"),
        Just("max"),
        Just("intensity"),
        Just("\n"),
        Just("#"),
        Just("\""),
        Just("gaussian"),
        Just("exact"),
        Just("\0"),
        Just("é"),
    ];
    proptest::collection::vec(token, 0..60).prop_map(|t| t.join(" "))
}

fn token_text() -> impl Strategy<Value = String> {
    proptest::collection::vec(token(), 0..80).prop_map(|t| t.join(" "))
}

/// A bundled model with a few random edits: a byte range deleted, a token inserted, a line
/// duplicated or two lines swapped.
#[derive(Clone, Debug)]
enum Edit {
    Delete(usize, usize),
    Insert(usize, &'static str),
    DuplicateLine(usize),
    SwapLines(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 0usize..12).prop_map(|(a, n)| Edit::Delete(a, n)),
        (any::<usize>(), token()).prop_map(|(a, t)| Edit::Insert(a, t)),
        any::<usize>().prop_map(Edit::DuplicateLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
    ]
}

fn apply(text: &str, edit: &Edit) -> String {
    let boundary = |i: usize| {
        let mut i = i % (text.len() + 1);
        while !text.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    match edit {
        Edit::Delete(a, n) => {
            let a = boundary(*a);
            let b = boundary((a + n).min(text.len()));
            format!("{}{}", &text[..a], &text[b.max(a)..])
        }
        Edit::Insert(a, t) => {
            let a = boundary(*a);
            format!("{}{t}{}", &text[..a], &text[a..])
        }
        Edit::DuplicateLine(i) => {
            let mut lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let i = i % lines.len();
                lines.insert(i, lines[i]);
            }
            lines.join("\n")
        }
        Edit::SwapLines(a, b) => {
            let mut lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let n = lines.len();
                lines.swap(a % n, b % n);
            }
            lines.join("\n")
        }
    }
}

/// `--set` values: expressions from numbers, parameter names, operators and functions.
fn set_value() -> impl Strategy<Value = String> {
    let part = prop_oneof![
        Just("1"),
        Just("0"),
        Just("-1"),
        Just("1e308"),
        Just("1e-300"),
        Just("c"),
        Just("k"),
        Just("mu"),
        Just("r"),
        Just("eps"),
        Just("K"),
        Just("nope"),
        Just("pi"),
        Just("+"),
        Just("-"),
        Just("*"),
        Just("/"),
        Just("^"),
        Just("("),
        Just(")"),
        Just("abs("),
        Just("delta("),
        Just("sqrt("),
        Just("log("),
        Just(","),
    ];
    proptest::collection::vec(part, 1..12).prop_map(|p| p.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn random_bytes_give_a_model_or_a_located_error(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let text = String::from_utf8_lossy(&bytes);
        check_text(&text)?;
    }

    #[test]
    fn token_sequences_give_a_model_or_a_located_error(text in token_text()) {
        check_text(&text)?;
    }

    #[test]
    fn mutated_bundled_models_give_a_model_or_a_located_error(
        which in 0usize..8,
        edits in proptest::collection::vec(edit(), 1..4),
    ) {
        let mut text = bundled(which);
        for e in &edits {
            text = apply(&text, e);
        }
        check_text(&text)?;
    }

    #[test]
    fn random_set_values_give_a_model_or_an_error_naming_the_flag(
        which in 0usize..8,
        name in prop_oneof![Just("c"), Just("k"), Just("mu"), Just("r"), Just("eps"), Just("K"), Just("alpha")],
        value in set_value(),
    ) {
        let text = bundled(which);
        let model = parse_model(&text, None).unwrap();
        match parse_expr(&value) {
            Err(e) => assert_located_model_error(&value, &e)?,
            Ok(value) => {
                let o = Override { name: name.to_string(), value };
                bind_and_derive(&text, &model, &[o])?;
            }
        }
    }

    #[test]
    fn token_soup_gives_a_model_or_a_located_error(text in token_soup()) {
        check_text(&text)?;
    }

    #[test]
    fn any_unicode_gives_a_model_or_a_located_error(text in "\\PC{0,200}") {
        check_text(&text)?;
    }
}
