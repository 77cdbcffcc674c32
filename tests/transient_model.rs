//! Time in the model language: `t` in drift and diffusion lines makes a model
//! time-dependent; `t` anywhere else, or declared as a name, is refused at file:line:col; and
//! every stationary command refuses a time-dependent model before any work (exit 2), with
//! the reason as data (`Inadmissible::TimeDependent`).

mod common;

use common::{refused, scratch};
use fpsolve::dynamics::{check, Inadmissible};
use fpsolve::model::{parse_model, SemanticError};

/// The linear oscillator under Shinozuka–Sato modulated white noise and a periodic force.
const MODULATED: &str = "\
model modulated \"linear oscillator, modulated noise and a periodic force\"
param c = 0.1, k = 2, a = 4, b1 = 0.1, b2 = 0.2, A = 0.5, w = 1.3
state z, v
drift z: v
drift v: -c*v - k*z + A*cos(w*t)
noise xi: intensity 1
diffusion v: a*(exp(-b1*t) - exp(-b2*t))*xi
";

fn with(line: &str) -> String {
    format!("model m\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n{line}\n")
}

#[test]
fn time_in_drift_and_diffusion_makes_the_model_time_dependent() {
    let model = parse_model(MODULATED, None).unwrap();
    assert!(model.time_dependent());
    let bound = model.bind(&[]).unwrap();
    assert!(bound.time_dependent());
    // The parameters are substituted, the time is kept.
    assert_eq!(
        bound.drift()[1].to_string(),
        "-0.1*v - 2*z + 0.5*cos(1.3*t)"
    );
    let err = check(&bound).unwrap_err();
    assert_eq!(
        err,
        Inadmissible::TimeDependent {
            line: "drift of `v`".into()
        }
    );
    // Only the diffusion depends on t.
    let noise_only = with("noise xi: intensity 1\ndiffusion v: exp(-t)*xi");
    let bound = parse_model(&noise_only, None).unwrap().bind(&[]).unwrap();
    assert_eq!(
        check(&bound),
        Err(Inadmissible::TimeDependent {
            line: "diffusion of `v`".into()
        })
    );
    // A model without t is not.
    let plain = with("noise xi: intensity 1\ndiffusion v: xi");
    assert!(!parse_model(&plain, None).unwrap().time_dependent());
}

#[test]
fn time_elsewhere_or_as_a_name_is_refused_where_it_is_written() {
    let cases: [(&str, usize, usize); 6] = [
        ("noise xi: intensity 1 + t\ndiffusion v: xi", 6, 25),
        (
            "noise xi: intensity 1\ndiffusion v: xi\nobserve y = z*t",
            8,
            15,
        ),
        ("noise xi: intensity 1\ndiffusion v: xi\nparam q = t", 8, 11),
        ("noise xi: intensity 1\ndiffusion v: xi\nparam t = 1", 8, 7),
        ("noise t: intensity 1\ndiffusion v: t", 6, 7),
        (
            "noise xi: intensity 1\ndiffusion v: xi\nobserve t = z",
            8,
            9,
        ),
    ];
    for (line, l, c) in cases {
        let text = with(line);
        let err = parse_model(&text, None).unwrap_err();
        let d = err.diagnostic().expect("located");
        assert_eq!((d.line(), d.column()), (l, c), "{line}: {err}");
        match err.semantic() {
            Some(SemanticError::TimeOutsideEquations { .. }) => {
                assert!(err.to_string().contains("only drift and diffusion lines"))
            }
            Some(SemanticError::ReservedName { what, .. }) => assert_eq!(*what, "the time"),
            other => panic!("{line}: {other:?}"),
        }
    }
}

#[test]
fn stationary_commands_refuse_a_time_dependent_model_before_any_work() {
    let dir = scratch("time_dependent_model");
    let path = dir.join("modulated.sde");
    std::fs::write(&path, MODULATED).unwrap();
    let m = path.to_str().unwrap();
    let words = ["no stationary density", "depend on the time `t`"];
    for method in ["grid", "epc", "epc-impact"] {
        refused("time", &["solve", m, "--method", method], &words);
    }
    refused("time", &[m], &words);
    refused("time", &["simulate", m], &words);
    refused("time", &["sweep", m, "--set", "c=0.1:0.2:2"], &words);
}

/// `fpsolve check` prints a time-dependent model (it is valid) with a note instead of the
/// stationary operator it does not have, and exits 0.
#[test]
fn check_prints_a_time_dependent_model() {
    let dir = scratch("time_dependent_check");
    let path = dir.join("modulated.sde");
    std::fs::write(&path, MODULATED).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("A*cos(w*t)"), "{text}");
    assert!(
        text.contains("the equations depend on the time `t`"),
        "{text}"
    );
    assert!(!text.contains("derived Fokker-Planck operator"), "{text}");
}

/// The `initial` line: rest, a point, a Gaussian (any order of the states, parameters
/// allowed), bound to numbers; the grid starts from it.
#[test]
fn initial_lines_are_read_and_bound() {
    use fpsolve::grid::Initial;
    use fpsolve::model::{InitialError, InitialSpec, InitialState, Override};
    let line = |l: &str| {
        format!(
            "{}param s = 0.5\n{l}\n",
            with("noise xi: intensity 1\ndiffusion v: xi")
        )
    };
    let start = |l: &str| {
        let model = parse_model(&line(l), None).unwrap();
        let bound = model.bind(&[]).unwrap();
        model.initial().map(|i| i.bind(&bound).unwrap())
    };
    assert_eq!(start("initial rest"), Some(InitialState::Rest));
    assert_eq!(
        start("initial point v = -1, z = 2*s"),
        Some(InitialState::Point([1.0, -1.0]))
    );
    let gaussian = start("initial gaussian mean z = 1, v = 0 cov s^2, 0.1, 0.1, 1");
    assert_eq!(
        gaussian,
        Some(InitialState::Gaussian {
            mean: [1.0, 0.0],
            covariance: [[0.25, 0.1], [0.1, 1.0]]
        })
    );
    assert_eq!(
        Initial::from(gaussian.unwrap()),
        Initial::Gaussian {
            mean: [1.0, 0.0],
            covariance: [[0.25, 0.1], [0.1, 1.0]]
        }
    );
    assert_eq!(start("# none"), None);
    // A covariance that depends on a parameter is checked when bound.
    let model = parse_model(
        &line("initial gaussian mean z = 0, v = 0 cov s, 0, 0, 1"),
        None,
    )
    .unwrap();
    let bound = model.bind(&[Override::number("s", -1.0)]).unwrap();
    let err = model.initial().unwrap().bind(&bound).unwrap_err();
    assert!(matches!(err, InitialError::Covariance { .. }), "{err}");
    assert!(err.to_string().contains("not positive definite"), "{err}");
    assert!(matches!(
        model.initial(),
        Some(InitialSpec::Gaussian { .. })
    ));
    // Twice is refused where the second is.
    let err = parse_model(&line("initial rest\ninitial rest"), None).unwrap_err();
    assert!(matches!(
        err.semantic(),
        Some(SemanticError::DuplicateStatement {
            keyword: "initial",
            ..
        })
    ));
}

/// The stationary methods ignore the `initial` line: the same stationary answer with it.
#[test]
fn the_stationary_checks_ignore_the_initial_line() {
    let plain = with("noise xi: intensity 1\ndiffusion v: xi");
    let started = format!("{plain}initial point z = 3, v = 0\n");
    let a = parse_model(&plain, None).unwrap().bind(&[]).unwrap();
    let b = parse_model(&started, None).unwrap().bind(&[]).unwrap();
    assert_eq!(check(&a), Ok(()));
    assert_eq!(check(&b), Ok(()));
    assert_eq!(a.drift(), b.drift());
}
