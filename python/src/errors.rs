//! The library's typed errors as Python exceptions: one class per kind of failure, each
//! instance carrying the error's data as attributes (`line`, `degree`, `residual`, …) and, as
//! its text, the message the command line prints.

use std::path::Path;

use fpsolve::epc::EpcError;
use fpsolve::epc_impact::EpcImpactError;
use fpsolve::fpk::FpkError;
use fpsolve::grid::{GridError, TransientError};
use fpsolve::mc::{McError, McTransientError};
use fpsolve::model::{BindError, Diagnostic, ModelError as LibModelError, SetError};
use fpsolve::solve::SolveError as LibSolveError;
use fpsolve::sweep::SweepError as LibSweepError;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::GILOnceCell;
use pyo3::types::{PyDict, PyTuple, PyType};
use pyo3::IntoPyObjectExt;

create_exception!(
    fpsolve,
    FpsolveError,
    PyException,
    "Base class of every error fpsolve raises; `kind` names the library's error variant."
);
create_exception!(
    fpsolve,
    ModelError,
    FpsolveError,
    "A model file or text that cannot be read, parsed or validated: `path`, `line`, `column`, \
     `message`, `help` (None where not known), and the CLI's file:line:col rendering as text."
);
create_exception!(
    fpsolve,
    ParameterError,
    ModelError,
    "A parameter override that is malformed, names no parameter, or gives a model without a \
     meaning (negative intensity, …); located in the model file when the cause is there."
);
create_exception!(
    fpsolve,
    SolveError,
    FpsolveError,
    "A method that gave no density: `method`, `degree` (None for the grid), `kind`."
);
create_exception!(
    fpsolve,
    NoConvergenceError,
    SolveError,
    "EPC found no root of its equations: `degree`, `residual` (best ‖R‖), `threshold`, \
     `gradient` (‖JᵀR‖ at the best point)."
);
create_exception!(
    fpsolve,
    NotNormalisableError,
    SolveError,
    "The solved exp(Q) has no finite mass: `degree`, `reason` (the library's reason in words)."
);
create_exception!(
    fpsolve,
    GridSolveError,
    SolveError,
    "The grid solver failed (singular system, no domain found, …): `kind` and the variant's \
     fields (`nx`, `nv`, …)."
);
create_exception!(
    fpsolve,
    NotApplicableError,
    SolveError,
    "The method does not apply to the model (an impact law it cannot represent, noise in the \
     position equation, no stationary density, …): `method`, `reason`."
);
create_exception!(
    fpsolve,
    UnknownQuantityError,
    SolveError,
    "A name that is neither a state nor an observable: `name`, `known`."
);
create_exception!(
    fpsolve,
    MonteCarloError,
    FpsolveError,
    "A Monte Carlo run refused or failed: `kind` and the variant's fields."
);
create_exception!(
    fpsolve,
    SweepError,
    FpsolveError,
    "A parameter sweep that cannot run: `kind`, `argument` (None when not about one)."
);
create_exception!(
    fpsolve,
    JobError,
    FpsolveError,
    "The main job failed as a whole (output directory taken, …): `kind`."
);

/// The classes Python sees for the errors that are also builtin exceptions, by name: each
/// derives from its Rust-made class above (so the hierarchy under `FpsolveError` holds) and
/// from the builtin a caller would catch (`ModelError` from `ValueError`, a missing model file
/// from `FileNotFoundError`, `UnknownQuantityError` from `KeyError`). Python makes them, since
/// a class with two bases cannot be declared from Rust.
static BUILTIN_BASED: GILOnceCell<Vec<(&'static str, Py<PyType>)>> = GILOnceCell::new();

fn builtin_based(py: Python<'_>) -> PyResult<&Vec<(&'static str, Py<PyType>)>> {
    BUILTIN_BASED.get_or_try_init(py, || {
        let builtins = py.import("builtins")?;
        let type_ = builtins.getattr("type")?;
        let make = |name: &str,
                    bases: Bound<'_, PyTuple>,
                    doc: Bound<'_, PyAny>,
                    plain_str: bool|
         -> PyResult<Py<PyType>> {
            let ns = PyDict::new(py);
            ns.set_item("__module__", "fpsolve")?;
            ns.set_item("__doc__", doc)?;
            if plain_str {
                // KeyError's str() quotes its message and OSError's shows errno and filename;
                // these keep the message as written.
                ns.set_item(
                    "__str__",
                    builtins.getattr("BaseException")?.getattr("__str__")?,
                )?;
            }
            Ok(type_
                .call1((name, bases, ns))?
                .downcast_into::<PyType>()?
                .unbind())
        };
        fn doc<'py>(t: Bound<'py, PyType>) -> PyResult<Bound<'py, PyAny>> {
            t.getattr("__doc__")
        }
        let model = make(
            "ModelError",
            PyTuple::new(
                py,
                [py.get_type::<ModelError>(), py.get_type::<PyValueError>()],
            )?,
            doc(py.get_type::<ModelError>())?,
            false,
        )?;
        let parameter = make(
            "ParameterError",
            PyTuple::new(
                py,
                [py.get_type::<ParameterError>(), model.bind(py).clone()],
            )?,
            doc(py.get_type::<ParameterError>())?,
            false,
        )?;
        let not_found = make(
            "ModelFileNotFoundError",
            PyTuple::new(
                py,
                [model.bind(py).clone(), py.get_type::<PyFileNotFoundError>()],
            )?,
            "A model file that does not exist: a ModelError and a FileNotFoundError \
             (`filename` is its path)."
                .into_pyobject(py)?
                .into_any(),
            true,
        )?;
        let unknown = make(
            "UnknownQuantityError",
            PyTuple::new(
                py,
                [
                    py.get_type::<UnknownQuantityError>(),
                    py.get_type::<PyKeyError>(),
                ],
            )?,
            doc(py.get_type::<UnknownQuantityError>())?,
            true,
        )?;
        Ok(vec![
            ("ModelError", model),
            ("ParameterError", parameter),
            ("ModelFileNotFoundError", not_found),
            ("UnknownQuantityError", unknown),
        ])
    })
}

/// The class Python sees for the error named `name`: its builtin-based class, if it has one.
fn class_of<'py>(py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyType>>> {
    Ok(builtin_based(py)?
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| t.bind(py).clone()))
}

/// Adds the exception classes to the module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FpsolveError", py.get_type::<FpsolveError>())?;
    m.add("SolveError", py.get_type::<SolveError>())?;
    m.add("NoConvergenceError", py.get_type::<NoConvergenceError>())?;
    m.add(
        "NotNormalisableError",
        py.get_type::<NotNormalisableError>(),
    )?;
    m.add("GridSolveError", py.get_type::<GridSolveError>())?;
    m.add("NotApplicableError", py.get_type::<NotApplicableError>())?;
    m.add("MonteCarloError", py.get_type::<MonteCarloError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    m.add("JobError", py.get_type::<JobError>())?;
    for (name, class) in builtin_based(py)? {
        m.add(*name, class.bind(py))?;
    }
    Ok(())
}

/// The error `T` (its builtin-based class where it has one) with `message`, `kind` and the
/// attributes `attrs`.
/// An exception of class `T` with text `message` and the attributes `attrs`; `kind` is always
/// set.
fn raise<T: pyo3::PyTypeInfo>(
    py: Python<'_>,
    message: String,
    kind: &str,
    attrs: &[(&str, PyObject)],
) -> PyErr {
    raise_as(
        py,
        T::NAME,
        || PyErr::new::<T, _>(message.clone()),
        &message,
        kind,
        attrs,
    )
}

/// [`raise`] by class name: the builtin-based class named `name` if there is one, else `plain`.
fn raise_as(
    py: Python<'_>,
    name: &str,
    plain: impl FnOnce() -> PyErr,
    message: &str,
    kind: &str,
    attrs: &[(&str, PyObject)],
) -> PyErr {
    let err = match class_of(py, name) {
        Ok(Some(class)) => match class.call1((message,)) {
            Ok(value) => PyErr::from_value(value),
            Err(e) => return e,
        },
        Ok(None) => plain(),
        Err(e) => return e,
    };
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("kind", kind)?;
        for (name, v) in attrs {
            value.setattr(*name, v)?;
        }
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

fn obj<'py, T: IntoPyObjectExt<'py>>(py: Python<'py>, v: T) -> PyObject {
    v.into_py_any(py).expect("plain values convert to Python")
}

/// The data of a located diagnostic (or None for each when there is none).
fn located(
    py: Python<'_>,
    path: Option<&Path>,
    d: Option<&Diagnostic>,
) -> Vec<(&'static str, PyObject)> {
    let path = path.map(|p| p.display().to_string());
    vec![
        ("path", obj(py, path)),
        ("line", obj(py, d.map(Diagnostic::line))),
        ("column", obj(py, d.map(Diagnostic::column))),
        ("message", obj(py, d.map(|d| d.message().to_string()))),
        (
            "help",
            obj(py, d.and_then(|d| d.help().map(str::to_string))),
        ),
    ]
}

/// A model that could not be read, parsed or validated.
pub(crate) fn model_error(py: Python<'_>, e: &LibModelError, path: Option<&Path>) -> PyErr {
    let kind = match e {
        LibModelError::Io { .. } => "io",
        LibModelError::TooLarge { .. } => "too_large",
        LibModelError::Encoding(_) => "encoding",
        LibModelError::Syntax(_) => "syntax",
        LibModelError::Semantic { .. } => "semantic",
    };
    let mut attrs = located(py, path, e.diagnostic());
    if e.diagnostic().is_none() {
        // An unreadable file: the message is the error itself.
        attrs[3].1 = obj(py, e.to_string());
    }
    if let LibModelError::Io { path, source } = e {
        if source.kind() == std::io::ErrorKind::NotFound {
            attrs.push(("filename", obj(py, path.display().to_string())));
            let text = e.to_string();
            return raise_as(
                py,
                "ModelFileNotFoundError",
                || PyErr::new::<ModelError, _>(text.clone()),
                &text,
                kind,
                &attrs,
            );
        }
    }
    raise::<ModelError>(py, e.to_string(), kind, &attrs)
}

/// Overrides that cannot be bound; the text is the CLI's (`error: path: …` when a path is known).
pub(crate) fn bind_error(py: Python<'_>, e: &BindError, path: Option<&Path>) -> PyErr {
    let text = cli_text(path, &e.to_string());
    let attrs = located(py, path, e.diagnostic());
    raise::<ParameterError>(py, text, "bind", &attrs)
}

/// An override that cannot be read (`mu=` with no value, a bad expression).
pub(crate) fn set_error(py: Python<'_>, e: &SetError) -> PyErr {
    let attrs = located(py, None, None);
    raise::<ParameterError>(py, e.to_string(), "set", &attrs)
}

fn cli_text(path: Option<&Path>, message: &str) -> String {
    match path {
        Some(p) => format!("error: {}: {message}", p.display()),
        None => message.to_string(),
    }
}

/// The method a solve error is about, for its `method` attribute.
pub(crate) struct Asked<'a> {
    pub(crate) method: &'a str,
    pub(crate) degree: Option<usize>,
}

/// A solve that gave no density, or a question a solution cannot answer.
pub(crate) fn solve_error(py: Python<'_>, e: &LibSolveError, asked: &Asked<'_>) -> PyErr {
    let text = e.to_string();
    let base = |extra: Vec<(&'static str, PyObject)>| {
        let mut attrs = vec![
            ("method", obj(py, asked.method)),
            ("degree", obj(py, asked.degree)),
        ];
        attrs.extend(extra);
        attrs
    };
    match e {
        LibSolveError::UnknownQuantity { name, known } => {
            let attrs = base(vec![
                ("name", obj(py, name.clone())),
                ("known", obj(py, known.clone())),
            ]);
            raise::<UnknownQuantityError>(py, text, "unknown_quantity", &attrs)
        }
        LibSolveError::Epc(e) | LibSolveError::EpcImpact(EpcImpactError::Epc(e)) => {
            epc_error(py, e, text, &base)
        }
        LibSolveError::Grid(g) => grid_error(py, g, text, &base),
        LibSolveError::EpcImpact(e) => epc_impact_error(py, e, text, &base),
        LibSolveError::Fpk(f) => fpk_error(py, f, text, &base),
        LibSolveError::Zhuravlev(z) => {
            let attrs = base(vec![("reason", obj(py, z.to_string()))]);
            raise::<NotApplicableError>(py, text, "zhuravlev", &attrs)
        }
        LibSolveError::NotApplicable(n) => {
            let attrs = base(vec![("reason", obj(py, n.to_string()))]);
            let kind = match n {
                fpsolve::solve::NotApplicable::PeriodicState { .. } => "periodic_state",
                _ => "not_applicable",
            };
            raise::<NotApplicableError>(py, text, kind, &attrs)
        }
        // An interrupted call raises its KeyboardInterrupt before reaching here; a flag set
        // by anyone else stops the solve the same way.
        LibSolveError::Cancelled(_) => PyErr::new::<pyo3::exceptions::PyKeyboardInterrupt, _>(text),
        // The package settles each method from its own name; kept typed all the same.
        LibSolveError::OtherSettings { .. } => {
            raise::<SolveError>(py, text, "other_settings", &base(vec![]))
        }
        // A method added later without a class of its own: its text, as a SolveError.
        _ => raise::<SolveError>(py, text, "solve", &base(vec![])),
    }
}

type Base<'a, 'py> = dyn Fn(Vec<(&'static str, PyObject)>) -> Vec<(&'static str, PyObject)> + 'a;

fn epc_error(py: Python<'_>, e: &EpcError, text: String, base: &Base<'_, '_>) -> PyErr {
    match e {
        EpcError::NoConvergence {
            degree,
            best,
            threshold,
            ..
        } => {
            let attrs = base(vec![
                ("degree", obj(py, *degree)),
                ("residual", obj(py, best.residual)),
                ("gradient", obj(py, best.gradient)),
                ("threshold", obj(py, *threshold)),
            ]);
            raise::<NoConvergenceError>(py, text, "no_convergence", &attrs)
        }
        EpcError::NotNormalisable { degree, reason } => {
            let attrs = base(vec![
                ("degree", obj(py, *degree)),
                ("reason", obj(py, reason.to_string())),
            ]);
            raise::<NotNormalisableError>(py, text, "not_normalisable", &attrs)
        }
        EpcError::UnsupportedImpact { law, reason } => {
            let attrs = base(vec![
                ("law", obj(py, law.clone())),
                ("reason", obj(py, reason.to_string())),
            ]);
            raise::<NotApplicableError>(py, text, "unsupported_impact", &attrs)
        }
        EpcError::Degree { degree, max } => {
            let attrs = base(vec![("degree", obj(py, *degree)), ("max", obj(py, *max))]);
            raise::<SolveError>(py, text, "degree", &attrs)
        }
        EpcError::OddDegree { degree } => {
            let attrs = base(vec![("degree", obj(py, *degree))]);
            raise::<SolveError>(py, text, "odd_degree", &attrs)
        }
        EpcError::Closure { residual, .. } => {
            let attrs = base(vec![("residual", obj(py, *residual))]);
            raise::<NoConvergenceError>(py, text, "closure", &attrs)
        }
        _ => raise::<SolveError>(py, text, "epc", &base(vec![])),
    }
}

fn grid_error(py: Python<'_>, e: &GridError, text: String, base: &Base<'_, '_>) -> PyErr {
    match e {
        GridError::Unsupported { reason, .. } => {
            let attrs = base(vec![("reason", obj(py, reason.to_string()))]);
            raise::<NotApplicableError>(py, text, "unsupported", &attrs)
        }
        GridError::Inadmissible(i) => {
            let attrs = base(vec![("reason", obj(py, i.to_string()))]);
            raise::<NotApplicableError>(py, text, "inadmissible", &attrs)
        }
        GridError::Singular { nx, nv, .. } => {
            let attrs = base(vec![("nx", obj(py, *nx)), ("nv", obj(py, *nv))]);
            raise::<GridSolveError>(py, text, "singular", &attrs)
        }
        GridError::Degenerate { nx, nv } => {
            let attrs = base(vec![("nx", obj(py, *nx)), ("nv", obj(py, *nv))]);
            raise::<GridSolveError>(py, text, "degenerate", &attrs)
        }
        GridError::DomainNotFound { tries, edge, width } => {
            let attrs = base(vec![
                ("tries", obj(py, *tries)),
                ("edge", obj(py, *edge)),
                ("width", obj(py, *width)),
            ]);
            raise::<GridSolveError>(py, text, "domain_not_found", &attrs)
        }
        GridError::NegativeMass {
            nx,
            nv,
            negative_mass,
            tolerance,
        } => {
            let attrs = base(vec![
                ("nx", obj(py, *nx)),
                ("nv", obj(py, *nv)),
                ("negative_mass", obj(py, *negative_mass)),
                ("tolerance", obj(py, *tolerance)),
            ]);
            raise::<GridSolveError>(py, text, "negative_mass", &attrs)
        }
        GridError::Setting { .. } => raise::<SolveError>(py, text, "setting", &base(vec![])),
        _ => raise::<GridSolveError>(py, text, "grid", &base(vec![])),
    }
}

fn epc_impact_error(
    py: Python<'_>,
    e: &EpcImpactError,
    text: String,
    base: &Base<'_, '_>,
) -> PyErr {
    match e {
        EpcImpactError::Unsupported { reason, .. } => {
            let attrs = base(vec![("reason", obj(py, reason.to_string()))]);
            raise::<NotApplicableError>(py, text, "unsupported", &attrs)
        }
        EpcImpactError::NotNormalisable { degree, reason } => {
            let attrs = base(vec![
                ("degree", obj(py, *degree)),
                ("reason", obj(py, reason.to_string())),
            ]);
            raise::<NotNormalisableError>(py, text, "not_normalisable", &attrs)
        }
        EpcImpactError::Refit {
            degree,
            residual,
            threshold,
            ..
        } => {
            let attrs = base(vec![
                ("degree", obj(py, *degree)),
                ("residual", obj(py, *residual)),
                ("threshold", obj(py, *threshold)),
            ]);
            raise::<NoConvergenceError>(py, text, "refit", &attrs)
        }
        EpcImpactError::Fpk(f) => fpk_error(py, f, text, base),
        _ => raise::<SolveError>(py, text, "epc_impact", &base(vec![])),
    }
}

fn fpk_error(py: Python<'_>, e: &FpkError, text: String, base: &Base<'_, '_>) -> PyErr {
    match e {
        FpkError::Inadmissible(i) => {
            let attrs = base(vec![("reason", obj(py, i.to_string()))]);
            raise::<NotApplicableError>(py, text, "inadmissible", &attrs)
        }
        _ => raise::<SolveError>(py, text, "fpk", &base(vec![])),
    }
}

/// An FPK operator that cannot be derived for a model (`model.check()`).
pub(crate) fn derive_error(py: Python<'_>, e: &FpkError, path: Option<&Path>) -> PyErr {
    let text = cli_text(path, &e.to_string());
    let base = |extra: Vec<(&'static str, PyObject)>| {
        let mut attrs = vec![
            ("method", obj(py, None::<&str>)),
            ("degree", obj(py, None::<usize>)),
        ];
        attrs.extend(extra);
        attrs
    };
    fpk_error(py, e, text, &base)
}

/// A Monte Carlo run refused or failed (cancellation is a KeyboardInterrupt, raised by the
/// caller before this is reached).
pub(crate) fn mc_error(py: Python<'_>, e: &McError) -> PyErr {
    let (kind, attrs): (&str, Vec<(&str, PyObject)>) = match e {
        McError::BadSetting { .. } => ("bad_setting", vec![]),
        McError::Inadmissible(_) => ("inadmissible", vec![]),
        McError::PeriodicState { .. } => ("periodic_state", vec![]),
        McError::StartHeldStill { .. } => ("start_held_still", vec![]),
        McError::UnknownQuantity { .. } => ("unknown_quantity", vec![]),
        McError::AllBlewUp { .. } => ("all_blew_up", vec![]),
        McError::TooManyBlowUps { .. } => ("too_many_blow_ups", vec![]),
        McError::NotStationary { .. } => ("not_stationary", vec![]),
        McError::TooLong { .. } => ("too_long", vec![]),
        McError::TooMuchMemory { .. } => ("too_much_memory", vec![]),
        McError::UnstableStep { .. } => ("unstable_step", vec![]),
        McError::Cancelled => ("cancelled", vec![]),
        _ => ("other", vec![]),
    };
    raise::<MonteCarloError>(py, e.to_string(), kind, &attrs)
}

/// A Monte Carlo transient refused or failed: its settings, a start beyond a wall, a period
/// that is not the coefficients' (a `ValueError`, as the grid's), a periodic state its pilot
/// never saw settle, or the stationary run's refusals.
pub(crate) fn mc_transient_error(py: Python<'_>, e: &McTransientError) -> PyErr {
    let kind = match e {
        McTransientError::Setting { .. } => "bad_setting",
        McTransientError::StartBeyondWall { .. } => "start_beyond_wall",
        McTransientError::Period(_) => return bad_argument(e.to_string()),
        McTransientError::NoPeriodicState { .. } => "no_periodic_state",
        McTransientError::Mc(e) => return mc_error(py, e),
    };
    raise::<MonteCarloError>(py, e.to_string(), kind, &[])
}

/// A grid transient refused or failed: a setting or a start the box does not hold is a
/// `ValueError` (checked before any step, as the CLI checks it), the grid's refusal of the
/// model its [`solve_error`], a failed time step a `GridSolveError` of kind `step`.
pub(crate) fn transient_error(py: Python<'_>, e: &TransientError) -> PyErr {
    match e {
        TransientError::Grid(g) => solve_error(
            py,
            &LibSolveError::Grid(g.clone()),
            &Asked {
                method: "grid",
                degree: None,
            },
        ),
        TransientError::Step(_) => grid_solve_error(py, "step", e.to_string(), vec![]),
        TransientError::Setting { .. }
        | TransientError::InitialOutsideDomain { .. }
        | TransientError::Period(_) => bad_argument(e.to_string()),
    }
}

/// A `GridSolveError` of `kind` with `text`, `method` "grid", no degree, and `attrs`.
pub(crate) fn grid_solve_error(
    py: Python<'_>,
    kind: &str,
    text: String,
    attrs: Vec<(&str, PyObject)>,
) -> PyErr {
    let mut all = vec![
        ("method", obj(py, "grid")),
        ("degree", obj(py, None::<usize>)),
    ];
    all.extend(attrs);
    raise::<GridSolveError>(py, text, kind, &all)
}

/// A `ModelError` of `kind` about a line given beside the model (a safe set, a start) that
/// cannot be bound at these parameters: the model's `path`, no line or column, `text` as
/// the message.
pub(crate) fn unlocated_model_error(
    py: Python<'_>,
    kind: &str,
    path: Option<&Path>,
    text: String,
) -> PyErr {
    let mut attrs = located(py, path, None);
    attrs[3].1 = obj(py, text.clone());
    raise::<ModelError>(py, text, kind, &attrs)
}

/// A sweep that cannot run.
pub(crate) fn sweep_error(py: Python<'_>, e: &LibSweepError) -> PyErr {
    let (kind, argument, name): (&str, Option<&str>, Option<&str>) = match e {
        LibSweepError::MissingEquals { arg } => ("missing_equals", Some(arg), None),
        LibSweepError::NotANumber { arg, .. } => ("not_a_number", Some(arg), None),
        LibSweepError::BadRange { arg, .. } => ("bad_range", Some(arg), None),
        LibSweepError::EmptyListItem { arg, .. } => ("empty_list_item", Some(arg), None),
        LibSweepError::SpanOverflow { arg, .. } => ("span_overflow", Some(arg), None),
        LibSweepError::Duplicate { name } => ("duplicate", None, Some(name)),
        LibSweepError::UnknownParameter { name, .. } => ("unknown_parameter", None, Some(name)),
        LibSweepError::NothingSwept => ("nothing_swept", None, None),
        LibSweepError::TooManySwept { .. } => ("too_many_swept", None, None),
        LibSweepError::TooManyPoints { .. } => ("too_many_points", None, None),
        LibSweepError::Method { .. } => ("method", None, None),
        LibSweepError::Bind { .. } => ("bind", None, None),
        LibSweepError::Set(_) => ("set", None, None),
        LibSweepError::TimeDependent { .. } => ("time_dependent", None, None),
    };
    let attrs = [("argument", obj(py, argument)), ("name", obj(py, name))];
    raise::<SweepError>(py, e.to_string(), kind, &attrs)
}

/// Any other library error, by its Display text.
pub(crate) fn other<T: pyo3::PyTypeInfo>(py: Python<'_>, kind: &str, text: String) -> PyErr {
    raise::<T>(py, text, kind, &[])
}

/// Raises `KeyError`-free plain ValueError for bad arguments of this package's own API.
pub(crate) fn bad_argument(text: impl Into<String>) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(text.into())
}
