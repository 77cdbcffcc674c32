use super::scope::{closest, edit_distance};
use super::*;
use crate::model::{parse_model, DeltaTreatment, ModelError};

const BASE: &str = "\
model m \"test\"
param c = 0.1, k = 1
state z, v
drift z: v
drift v: -c*v - k*z
noise xi: intensity 1
diffusion v: xi
";

/// Parses `BASE` with `edit` applied and returns the semantic error and its position.
fn error(src: &str) -> (SemanticError, usize, usize) {
    match parse_model(src, None) {
        Err(ModelError::Semantic { error, diagnostic }) => {
            (*error, diagnostic.line(), diagnostic.column())
        }
        other => panic!("expected a semantic error for\n{src}\ngot {other:?}"),
    }
}

fn with(line: &str) -> String {
    format!("{BASE}{line}\n")
}

fn replaced(from: &str, to: &str) -> String {
    assert!(BASE.contains(from));
    BASE.replacen(from, to, 1)
}

#[test]
fn the_base_model_is_valid() {
    let m = parse_model(BASE, None).unwrap();
    assert_eq!(m.noise_matrix()[0][0], Expr::num(0.0));
    assert_eq!(m.noise_matrix()[1][0], Expr::num(1.0));
}

#[test]
fn unknown_identifiers_come_with_a_suggestion() {
    let (e, l, c) = error(&replaced("-c*v - k*z", "-c*v - kk*z"));
    assert_eq!(
        e,
        SemanticError::UnknownIdentifier {
            name: "kk".into(),
            suggestion: Some("k".into())
        }
    );
    assert_eq!((l, c), (5, 17));
    let (e, ..) = error(&replaced("-c*v - k*z", "-c*v - zeta"));
    assert!(matches!(
        e,
        SemanticError::UnknownIdentifier {
            suggestion: None,
            ..
        }
    ));
}

#[test]
fn unknown_functions_and_wrong_arity() {
    let (e, l, c) = error(&replaced("- k*z", "- k*sinh(z)"));
    assert_eq!(
        e,
        SemanticError::UnknownFunction {
            name: "sinh".into(),
            suggestion: Some("sin".into())
        }
    );
    assert_eq!((l, c), (5, 19));
    let (e, ..) = error(&replaced("- k*z", "- k*max(z)"));
    assert_eq!(
        e,
        SemanticError::WrongArity {
            func: "max",
            expected: 2,
            found: 1
        }
    );
    let (e, ..) = error(&replaced("- k*z", "- k*abs(z, v)"));
    assert!(matches!(e, SemanticError::WrongArity { found: 2, .. }));
}

#[test]
fn duplicate_and_reserved_names() {
    let (e, l, c) = error(&with("param c = 2"));
    assert_eq!(
        e,
        SemanticError::DuplicateDefinition {
            name: "c".into(),
            kind: "parameter",
            previous_kind: "parameter",
            previous_line: 2
        }
    );
    assert_eq!((l, c), (8, 7));
    let (e, ..) = error(&with("param z = 2"));
    assert!(matches!(
        e,
        SemanticError::DuplicateDefinition {
            kind: "parameter",
            previous_kind: "state",
            ..
        }
    ));
    let (e, ..) = error(&with("observe xi = z"));
    assert!(matches!(
        e,
        SemanticError::DuplicateDefinition {
            previous_kind: "noise source",
            ..
        }
    ));
    let (e, ..) = error(&with("drift v: 0"));
    assert!(matches!(
        e,
        SemanticError::DuplicateDefinition { kind: "drift", .. }
    ));
    let (e, ..) = error(&with("diffusion v: xi"));
    assert!(matches!(
        e,
        SemanticError::DuplicateDefinition {
            kind: "diffusion",
            ..
        }
    ));
    let (e, ..) = error(&with("param pi = 3"));
    assert!(matches!(e, SemanticError::ReservedName { .. }));
    let (e, ..) = error(&with("param abs = 3"));
    assert!(matches!(
        e,
        SemanticError::ReservedName {
            what: "a function",
            ..
        }
    ));
}

#[test]
fn statements_that_may_appear_once() {
    let (e, l, _) = error(&format!("{BASE}delta: exact\ndelta: exact\n"));
    assert_eq!(
        e,
        SemanticError::DuplicateStatement {
            keyword: "delta",
            previous_line: 8
        }
    );
    assert_eq!(l, 9);
    let (e, ..) = error(&with("model n"));
    assert_eq!(e, SemanticError::DuplicateModelLine { previous_line: 1 });
    let (e, l, c) = error(&format!("param a = 1\n{BASE}"));
    assert_eq!((e, l, c), (SemanticError::ModelNotFirst, 2, 1));
    let (e, ..) = error(&BASE.replacen("model m \"test\"\n", "", 1));
    assert_eq!(e, SemanticError::MissingModelLine);
}

#[test]
fn states_and_drifts() {
    let (e, l, _) = error(&replaced("state z, v", "state z, v, w"));
    assert_eq!((e, l), (SemanticError::StateCount { found: 3 }, 3));
    let (e, ..) = error(&replaced("state z, v", "state z"));
    assert_eq!(e, SemanticError::StateCount { found: 1 });
    let (e, l, c) = error(&replaced("drift z: v\n", ""));
    assert_eq!(e, SemanticError::MissingDrift { state: "z".into() });
    assert_eq!((l, c), (3, 7));
    let (e, ..) = error(&replaced("drift z: v", "drift zz: v"));
    assert_eq!(
        e,
        SemanticError::DriftForUnknownState {
            name: "zz".into(),
            suggestion: Some("z".into())
        }
    );
}

#[test]
fn impacts_diffusions_and_observables_need_states() {
    let (e, ..) = error(&with("impact w = 0: v -> -v"));
    assert!(matches!(
        e,
        SemanticError::UnknownState {
            context: "impact",
            ..
        }
    ));
    let (e, l, c) = error(&with("impact z = 0: z -> -v"));
    assert_eq!(e, SemanticError::ImpactOnItself { state: "z".into() });
    assert_eq!((l, c), (8, 15));
    let (e, ..) = error(&replaced("diffusion v: xi", "diffusion w: xi"));
    assert!(matches!(
        e,
        SemanticError::UnknownState {
            context: "diffusion",
            ..
        }
    ));
    let (e, ..) = error(&with("observe y = abs(w)"));
    assert!(matches!(e, SemanticError::UnknownIdentifier { .. }));
    let (e, ..) = error(&with("observe y = z\nobserve q = y"));
    assert!(matches!(e, SemanticError::ObservableInExpression { .. }));
}

#[test]
fn parameter_cycles_show_the_chain() {
    let (e, l, c) = error(&with("param a = 2*b, b = c + d, d = a"));
    assert_eq!(
        e,
        SemanticError::ParameterCycle {
            name: "a".into(),
            chain: "a -> b -> d -> a".into()
        }
    );
    assert_eq!((l, c), (8, 7));
    let (e, ..) = error(&with("param a = a"));
    assert!(matches!(e, SemanticError::ParameterCycle { .. }));
}

#[test]
fn long_parameter_chains_are_refused_without_recursion() {
    let n = MAX_PARAMETER_CHAIN + 5;
    let mut src = String::from(BASE);
    for i in 0..n {
        src.push_str(&format!("param p{i} = p{} + 1\n", i + 1));
    }
    src.push_str(&format!("param p{n} = 1\n"));
    let (e, ..) = error(&src);
    assert!(matches!(e, SemanticError::ParameterChainTooLong { .. }));
}

#[test]
fn noise_sources_declared_used_and_only_in_diffusion() {
    let (e, l, c) = error(&replaced("diffusion v: xi", "diffusion v: xi + eta"));
    assert_eq!(e, SemanticError::UndeclaredNoise { name: "eta".into() });
    assert_eq!((l, c), (7, 19));
    let (e, l, _) = error(&with("noise eta: intensity 1"));
    assert_eq!(
        (e, l),
        (SemanticError::UnusedNoise { name: "eta".into() }, 8)
    );
    let (e, ..) = error(&replaced("- k*z", "- k*z + xi"));
    assert_eq!(
        e,
        SemanticError::NoiseOutsideDiffusion {
            name: "xi".into(),
            context: "a drift"
        }
    );
    let (e, ..) = error(&with("observe y = xi"));
    assert!(matches!(e, SemanticError::NoiseOutsideDiffusion { .. }));
    let (e, ..) = error(&with("correlate xi, eta: 0.5"));
    assert_eq!(e, SemanticError::UndeclaredNoise { name: "eta".into() });
}

#[test]
fn states_are_not_allowed_in_constants() {
    for (line, context) in [
        ("param a = z", "a parameter default"),
        ("impact z = v: v -> -v", "a barrier position"),
    ] {
        let (e, ..) = error(&with(line));
        assert!(
            matches!(e, SemanticError::StateInConstant { context: c, .. } if c == context),
            "{line}: {e:?}"
        );
    }
    let (e, ..) = error(&replaced("intensity 1", "intensity z"));
    assert!(matches!(
        e,
        SemanticError::StateInConstant {
            context: "a noise intensity",
            ..
        }
    ));
    let src = format!("{BASE}noise eta: intensity 1\ndiffusion z: eta\ncorrelate xi, eta: v\n");
    let (e, ..) = error(&src);
    assert!(matches!(
        e,
        SemanticError::StateInConstant {
            context: "a correlation coefficient",
            ..
        }
    ));
}

#[test]
fn correlations_pair_two_distinct_sources_once() {
    let two = format!("{BASE}noise eta: intensity 1\ndiffusion z: eta\n");
    let (e, ..) = error(&format!("{two}correlate xi, xi: 0.5\n"));
    assert_eq!(e, SemanticError::SelfCorrelation { name: "xi".into() });
    let (e, l, _) = error(&format!(
        "{two}correlate xi, eta: 0.5\ncorrelate eta, xi: 0.1\n"
    ));
    assert!(matches!(
        e,
        SemanticError::DuplicateCorrelation {
            previous_line: 10,
            ..
        }
    ));
    assert_eq!(l, 11);
    let m = parse_model(&format!("{two}correlate eta, xi: 0.3\n"), None).unwrap();
    assert_eq!((m.correlations()[0].a, m.correlations()[0].b), (1, 0));
}

#[test]
fn gaussian_width_must_be_a_positive_number() {
    for w in ["0", "-1e-3", "c", "1/0"] {
        let (e, ..) = error(&with(&format!("delta: gaussian({w})")));
        assert!(
            matches!(e, SemanticError::BadGaussianWidth { .. }),
            "{w}: {e:?}"
        );
    }
    let m = parse_model(&with("delta: gaussian(1e-3)"), None).unwrap();
    assert_eq!(
        m.delta_treatment(),
        DeltaTreatment::Gaussian { width: 1e-3 }
    );
}

#[test]
fn noise_must_enter_linearly() {
    for (rhs, col) in [
        ("xi^2", 14),
        ("xi*z*xi", 19),
        ("z/xi", 16),
        ("sin(xi)", 14),
        ("2*abs(xi)", 16),
    ] {
        let (e, l, c) = error(&replaced("diffusion v: xi", &format!("diffusion v: {rhs}")));
        assert!(
            matches!(e, SemanticError::NonlinearNoise { .. }),
            "{rhs}: {e:?}"
        );
        assert_eq!((l, c), (7, col), "{rhs}");
    }
    let (e, l, c) = error(&replaced("diffusion v: xi", "diffusion v: xi + z"));
    assert_eq!(e, SemanticError::NoiseFreeTerm { state: "v".into() });
    assert_eq!((l, c), (7, 19));
    let (e, ..) = error(&replaced("diffusion v: xi", "diffusion v: c*z"));
    assert!(matches!(e, SemanticError::NoiseFreeTerm { .. }));
}

#[test]
fn noise_coefficients_are_extracted_term_by_term() {
    let src = "model m\nparam a = 1, b = 2\nstate x, v\ndrift x: v\ndrift v: -x\n\
                   noise xi: intensity 1\nnoise eta: intensity 1\n\
                   diffusion v: a*xi + b*eta - (a + b)*xi\ndiffusion x: -eta/2\n";
    let m = parse_model(src, None).unwrap();
    let at = |e: &Expr| {
        e.eval(&|s| match s {
            "a" => Some(1.0),
            "b" => Some(2.0),
            _ => None,
        })
    };
    let g = m.noise_matrix();
    assert_eq!(at(&g[1][0]).unwrap(), -2.0);
    assert_eq!(at(&g[1][1]).unwrap(), 2.0);
    assert_eq!(at(&g[0][0]).unwrap(), 0.0);
    assert_eq!(at(&g[0][1]).unwrap(), -0.5);
    // A coefficient that is a sum keeps its shape.
    let src = BASE.replacen("diffusion v: xi", "diffusion v: (1 + c*z)*xi", 1);
    let m = parse_model(&src, None).unwrap();
    assert_eq!(m.noise_matrix()[1][0].to_string(), "1 + c*z");
}

#[test]
fn malformed_numbers_are_syntax_errors() {
    for bad in ["1e", "2x", "1.2.3", "1e999"] {
        let src = replaced("intensity 1", &format!("intensity {bad}"));
        let err = parse_model(&src, None).unwrap_err();
        assert!(matches!(err, ModelError::Syntax(_)), "{bad}: {err}");
        assert!(err.to_string().contains("malformed number"), "{bad}: {err}");
        assert_eq!((err.line(), err.column()), (Some(6), Some(21)), "{bad}");
    }
}

#[test]
fn misplaced_deltas_are_named_where_they_are_written() {
    let misuse = |drift: &str| match error(&replaced("-c*v - k*z", drift)) {
        (SemanticError::MisplacedDelta { delta, misuse }, l, c) => (delta, misuse, l, c),
        other => panic!("{drift}: {other:?}"),
    };
    let abs = DeltaMisuse::InFunction { func: "abs".into() };
    assert_eq!(
        misuse("-c*v - k*z - abs(delta(z))"),
        ("delta(z)".into(), abs, 5, 27)
    );
    assert_eq!(misuse("-c*v - delta(z)^2").1, DeltaMisuse::InPower);
    assert_eq!(misuse("-c*v - 2^delta(z)").1, DeltaMisuse::InExponent);
    assert_eq!(misuse("-c*v - v/delta(z)").1, DeltaMisuse::InDenominator);
    assert_eq!(
        misuse("-c*v - delta(z)*v*delta(v)").1,
        DeltaMisuse::TimesDelta
    );
    assert_eq!(misuse("-c*v - delta(c)").1, DeltaMisuse::NoState);
    assert_eq!(misuse("-c*v - delta(z + v)").1, DeltaMisuse::BothStates);
    assert_eq!(
        misuse("-c*v - delta(z*z)").1,
        DeltaMisuse::NonlinearArgument { state: "z".into() }
    );
    assert_eq!(
        misuse("-c*v - delta(v)").1,
        DeltaMisuse::OwnDrift { state: "v".into() }
    );
    // The paper's term and its relatives are fine.
    for ok in [
        "-c*v - k*z - (1 - c)*v*abs(v)*delta(z)",
        "-c*v - (1 + delta(z - 1))*v",
        "-c*v - v*delta(2*z + c)",
    ] {
        assert!(
            parse_model(&replaced("-c*v - k*z", ok), None).is_ok(),
            "{ok}"
        );
    }
    let (e, l, c) = error(&with("impact z = 0: v -> delta(z)*v"));
    assert!(matches!(
        e,
        SemanticError::MisplacedDelta {
            misuse: DeltaMisuse::InImpactMap,
            ..
        }
    ));
    assert_eq!((l, c), (8, 20));
    let (e, ..) = error(&replaced("diffusion v: xi", "diffusion v: delta(z)*xi"));
    assert!(matches!(
        e,
        SemanticError::MisplacedDelta {
            misuse: DeltaMisuse::InDiffusion,
            ..
        }
    ));
    let (e, ..) = error(&replaced("intensity 1", "intensity delta(1)"));
    assert!(matches!(
        e,
        SemanticError::MisplacedDelta {
            misuse: DeltaMisuse::InConstant {
                context: "a noise intensity"
            },
            ..
        }
    ));
}

#[test]
fn edit_distance_counts_single_edits() {
    assert_eq!(edit_distance("mu", "mu"), 0);
    assert_eq!(edit_distance("mux", "mu"), 1);
    assert_eq!(edit_distance("kitten", "sitting"), 3);
    assert_eq!(
        closest("epss", ["eps", "c"].into_iter()),
        Some("eps".into())
    );
    assert_eq!(closest("q", ["eps", "c"].into_iter()), Some("c".into()));
    assert_eq!(closest("zeta", ["eps", "c"].into_iter()), None);
}
