//! Parameter sweeps: one model solved by EPC on a grid of parameter values, with the moments
//! and tail probabilities of every state and observable at each point — how a response
//! statistic changes with, say, the parametric-noise strength ε, for two nonlinearities μ.
//!
//! A sweep is described by `--set` arguments ([`SweepSpec::parse`]): a range
//! `name=lo:hi:count`, a list `name=v1,v2,...`, or a plain `name=expr` that stays fixed. The
//! points are the Cartesian product of the ranged and listed parameters (one or two of them).
//! [`Sweep::run`] solves every point in parallel through [`Study::run`] and keeps the points
//! that fail next to the others; [`SweepResult::write`] writes `sweep.csv`, `sweep.json` and
//! figures of the statistics against the first swept parameter.
//!
//! Each point is solved from scratch (Gaussian closure, degree 2, then the target degree):
//! the study API takes no starting solution, so a point is not continued from its neighbour.
//! That costs some iterations, but makes every point independent of the others — of the
//! sweep's order, of its spacing and of which neighbour happened to fail — so a point's result
//! is the same as `fpsolve solve` at those values, and the points can run in parallel.
//!
//! ```
//! use fpsolve::model::parse_model;
//! use fpsolve::sweep::{PointOutcome, Sweep, SweepSpec};
//!
//! let model = parse_model(
//!     "model linear
//! param c = 0.1, k = 1, K = 1/(2*pi)
//! state z, v
//! drift z: v
//! drift v: -c*v - k*z
//! noise xi: intensity 2*pi*K
//! diffusion v: xi
//! ",
//!     None,
//! )?;
//! let spec = SweepSpec::parse(&["c=0.1:0.2:2".to_string(), "k=2".to_string()])?;
//! let result = Sweep::run(&model, &spec, 2);
//! assert_eq!(result.points.len(), 2);
//! // The exact stationary variance of z is πK/(ck) = 1/(2ck).
//! for point in &result.points {
//!     let PointOutcome::Converged(solution) = &point.outcome else { panic!("failed") };
//!     let z = &solution.stats[0];
//!     let exact = 1.0 / (2.0 * point.values[0] * 2.0);
//!     assert!((z.std_dev.powi(2) - exact).abs() < 1e-4 * exact);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::epc::NormalisationKind;
use crate::model::{parse_expr, Model, ModelError, Override};
use crate::report::{write_json, Curve, LineFigure, OutputDir, ReportError};
use crate::study::{Study, StudyError};

/// Most parameters a sweep may vary at once (a table and line figures stay readable).
pub const MAX_SWEPT: usize = 2;
/// Most points a sweep may have: a typo like `eps=0:1:10000000` is refused instead of
/// allocating and solving for hours.
pub const MAX_POINTS: usize = 10_000;
/// Tail thresholds are these multiples of a quantity's root mean square at the first point.
pub const TAIL_MULTIPLES: [f64; 3] = [2.0, 3.0, 4.0];

/// Why `--set` arguments do not describe a sweep. Every variant names the offending argument
/// (or parameter).
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// An argument without `=`.
    #[error("`--set {arg}`: expected NAME=VALUE, NAME=LO:HI:COUNT or NAME=V1,V2,...")]
    MissingEquals {
        /// The argument.
        arg: String,
    },
    /// An argument with nothing before `=`.
    #[error("`--set {arg}`: the parameter name is missing")]
    MissingName {
        /// The argument.
        arg: String,
    },
    /// A value (or a range end, or a list item) that is not an expression.
    #[error("error: in `--set {arg}`\n{source}")]
    BadExpression {
        /// The argument.
        arg: String,
        /// The parser's diagnostic.
        source: ModelError,
    },
    /// A range end or list item that is not a finite number (it mentions a parameter, or
    /// evaluates to NaN or ±∞).
    #[error("`--set {arg}`: `{item}` {reason}; swept values must be numbers")]
    NotANumber {
        /// The argument.
        arg: String,
        /// The offending range end or list item.
        item: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A range that is not `lo:hi:count` with an integer count ≥ 2 and lo ≠ hi.
    #[error(
        "`--set {arg}`: {reason} (a range is LO:HI:COUNT with COUNT ≥ 2 points, ends included)"
    )]
    BadRange {
        /// The argument.
        arg: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A list with an empty item (`mu=0.1,,1` or a trailing comma).
    #[error("`--set {arg}`: item {index} of the list is empty")]
    EmptyListItem {
        /// The argument.
        arg: String,
        /// 1-based position of the empty item.
        index: usize,
    },
    /// The same parameter given twice.
    #[error("parameter `{name}` is set more than once")]
    Duplicate {
        /// The parameter.
        name: String,
    },
    /// More than [`MAX_SWEPT`] swept parameters.
    #[error("{count} parameters are swept ({names}); a sweep varies at most {max}")]
    TooManySwept {
        /// How many were given.
        count: usize,
        /// Their names, comma-separated.
        names: String,
        /// The limit, [`MAX_SWEPT`].
        max: usize,
    },
    /// No ranged or listed parameter.
    #[error(
        "nothing to sweep: give at least one `--set NAME=LO:HI:COUNT` or `--set NAME=V1,V2,...`"
    )]
    NothingSwept,
    /// More than [`MAX_POINTS`] points.
    #[error("the sweep has {points} points; at most {max} are allowed")]
    TooManyPoints {
        /// The number of points asked for.
        points: usize,
        /// The limit, [`MAX_POINTS`].
        max: usize,
    },
    /// The model cannot be bound at a point of the sweep (a fixed value that names no
    /// parameter, `--set mu=abc`, or a value that makes a default non-finite): a usage error
    /// found before any work, not a failed point.
    #[error("{source} (at the sweep point {point})")]
    Bind {
        /// The point, `name = value` for each swept parameter.
        point: String,
        /// Why binding failed.
        source: crate::model::BindError,
    },
    /// A parameter the model does not declare (from [`SweepSpec::validate`]).
    #[error("unknown parameter `{name}` (the model declares: {known})")]
    UnknownParameter {
        /// The name given.
        name: String,
        /// The declared parameters, comma-separated.
        known: String,
    },
}

/// A parameter and the values a sweep gives it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweptParameter {
    /// The parameter's name.
    pub name: String,
    /// Its values, in the order given (at least two).
    pub values: Vec<f64>,
}

/// What to sweep: the swept parameters and the overrides that stay fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSpec {
    /// Overrides applied at every point.
    pub fixed: Vec<Override>,
    /// The swept parameters (one or two); the points are their Cartesian product.
    pub swept: Vec<SweptParameter>,
}

impl SweepSpec {
    /// Reads `--set` arguments: `name=lo:hi:count` is a range of `count` evenly spaced values
    /// from `lo` to `hi`, both included; `name=v1,v2,...` is a list; anything else is
    /// `name=expr`, a fixed override as `fpsolve solve --set` takes it. Range ends and list
    /// items are constant expressions (`1/(2*pi)` is fine, another parameter's name is not);
    /// a comma inside parentheses (`max(a, b)`) does not split a list.
    ///
    /// ```
    /// use fpsolve::sweep::{SweepError, SweepSpec};
    ///
    /// let args = ["eps=-0.3:0.3:13", "mu=0.1,1", "r=0.9"].map(String::from);
    /// let spec = SweepSpec::parse(&args)?;
    /// assert_eq!(spec.swept[0].values.len(), 13);
    /// assert_eq!(spec.swept[1].values, vec![0.1, 1.0]);
    /// assert_eq!(spec.fixed[0].name, "r");
    /// assert_eq!(spec.len(), 26);
    ///
    /// let bad = SweepSpec::parse(&["eps=0:1:1".to_string()]).unwrap_err();
    /// assert!(matches!(bad, SweepError::BadRange { ref arg, .. } if arg == "eps=0:1:1"));
    /// # Ok::<(), SweepError>(())
    /// ```
    ///
    /// # Errors
    /// A [`SweepError`] naming the first argument that is malformed, a parameter given twice,
    /// no swept parameter, more than [`MAX_SWEPT`] of them, or more than [`MAX_POINTS`] points.
    pub fn parse(args: &[String]) -> Result<SweepSpec, SweepError> {
        let mut fixed = Vec::new();
        let mut swept: Vec<SweptParameter> = Vec::new();
        let mut seen: Vec<String> = Vec::new();
        for arg in args {
            let Some((name, value)) = arg.split_once('=') else {
                return Err(SweepError::MissingEquals { arg: arg.clone() });
            };
            let name = name.trim();
            if name.is_empty() {
                return Err(SweepError::MissingName { arg: arg.clone() });
            }
            if seen.iter().any(|s| s == name) {
                return Err(SweepError::Duplicate {
                    name: name.to_string(),
                });
            }
            seen.push(name.to_string());
            match classify(value) {
                Value::Range(parts) => swept.push(SweptParameter {
                    name: name.to_string(),
                    values: range(arg, &parts)?,
                }),
                Value::List(items) => swept.push(SweptParameter {
                    name: name.to_string(),
                    values: list(arg, &items)?,
                }),
                Value::Single => fixed.push(Override {
                    name: name.to_string(),
                    value: parse_expr(value).map_err(|source| SweepError::BadExpression {
                        arg: arg.clone(),
                        source,
                    })?,
                }),
            }
        }
        if swept.is_empty() {
            return Err(SweepError::NothingSwept);
        }
        if swept.len() > MAX_SWEPT {
            return Err(SweepError::TooManySwept {
                count: swept.len(),
                names: swept
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                max: MAX_SWEPT,
            });
        }
        let points = swept
            .iter()
            .try_fold(1usize, |n, s| n.checked_mul(s.values.len()))
            .unwrap_or(usize::MAX);
        if points > MAX_POINTS {
            return Err(SweepError::TooManyPoints {
                points,
                max: MAX_POINTS,
            });
        }
        Ok(SweepSpec { fixed, swept })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.swept.iter().map(|s| s.values.len()).product()
    }

    /// Whether the sweep has no point (only for a hand-built spec with an empty value list).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The points, each as the values of the swept parameters in order. The first parameter
    /// varies fastest, so the points of one value of the second parameter are consecutive.
    ///
    /// ```
    /// let spec = fpsolve::sweep::SweepSpec::parse(&["a=1,2".into(), "b=10,20".into()]).unwrap();
    /// assert_eq!(spec.points(), vec![vec![1.0, 10.0], vec![2.0, 10.0], vec![1.0, 20.0], vec![2.0, 20.0]]);
    /// ```
    pub fn points(&self) -> Vec<Vec<f64>> {
        let mut points = vec![Vec::new()];
        for p in &self.swept {
            points = p
                .values
                .iter()
                .flat_map(|&v| {
                    points.iter().map(move |head| {
                        let mut point = head.clone();
                        point.push(v);
                        point
                    })
                })
                .collect();
        }
        points
    }

    /// The overrides at one point: the fixed ones, then the swept parameters at `values`.
    pub fn overrides_at(&self, values: &[f64]) -> Vec<Override> {
        let mut out = self.fixed.clone();
        out.extend(
            self.swept
                .iter()
                .zip(values)
                .map(|(p, &v)| Override::number(&p.name, v)),
        );
        out
    }

    /// Checks that every parameter named exists in `model` and that the model binds at every
    /// point (binding takes microseconds), so that a typo fails once, before any work, rather
    /// than at every point.
    ///
    /// ```
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let spec = fpsolve::sweep::SweepSpec::parse(&["cc=1,2".into()]).unwrap();
    /// assert!(spec.validate(&model).is_err());
    /// ```
    ///
    /// # Errors
    /// [`SweepError::UnknownParameter`] for the first unknown name, [`SweepError::Bind`] for
    /// the first point where binding fails.
    pub fn validate(&self, model: &Model) -> Result<(), SweepError> {
        let names = self
            .fixed
            .iter()
            .map(|o| o.name.as_str())
            .chain(self.swept.iter().map(|s| s.name.as_str()));
        for name in names {
            if !model.params().iter().any(|p| &*p.name == name) {
                return Err(SweepError::UnknownParameter {
                    name: name.to_string(),
                    known: model
                        .params()
                        .iter()
                        .map(|p| p.name.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
        for values in self.points() {
            if let Err(source) = model.bind(&self.overrides_at(&values)) {
                let point = self
                    .swept
                    .iter()
                    .zip(&values)
                    .map(|(p, v)| format!("{} = {v}", p.name))
                    .collect::<Vec<_>>()
                    .join(", ");
                return Err(SweepError::Bind { point, source });
            }
        }
        Ok(())
    }
}

enum Value<'a> {
    Range(Vec<&'a str>),
    List(Vec<&'a str>),
    Single,
}

/// Splits a value at top-level `:` (a range) or `,` (a list); commas and colons inside
/// parentheses belong to function calls.
fn classify(value: &str) -> Value<'_> {
    let split = |sep: char| -> Vec<&str> {
        let mut parts = Vec::new();
        let mut depth = 0i32;
        let mut start = 0;
        for (i, ch) in value.char_indices() {
            match ch {
                '(' => depth += 1,
                ')' => depth -= 1,
                c if c == sep && depth == 0 => {
                    parts.push(&value[start..i]);
                    start = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&value[start..]);
        parts
    };
    let colons = split(':');
    if colons.len() > 1 {
        return Value::Range(colons);
    }
    let commas = split(',');
    if commas.len() > 1 {
        return Value::List(commas);
    }
    Value::Single
}

/// A range end or list item: a constant expression with a finite value.
fn number(arg: &str, item: &str) -> Result<f64, SweepError> {
    let expr = parse_expr(item).map_err(|source| SweepError::BadExpression {
        arg: arg.to_string(),
        source,
    })?;
    let not_a_number = |reason: String| SweepError::NotANumber {
        arg: arg.to_string(),
        item: item.trim().to_string(),
        reason,
    };
    let value = expr
        .eval(&|_| None)
        .map_err(|e| not_a_number(e.to_string()))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(not_a_number(format!("evaluates to {value}")))
    }
}

fn range(arg: &str, parts: &[&str]) -> Result<Vec<f64>, SweepError> {
    let bad = |reason: &str| SweepError::BadRange {
        arg: arg.to_string(),
        reason: reason.to_string(),
    };
    let [lo, hi, count] = parts else {
        return Err(bad(&format!("{} fields separated by `:`", parts.len())));
    };
    let count: usize = count.trim().parse().map_err(|_| {
        bad(&format!(
            "the count `{}` is not a whole number",
            count.trim()
        ))
    })?;
    if count < 2 {
        return Err(bad(&format!("the count is {count}")));
    }
    if count > MAX_POINTS {
        return Err(SweepError::TooManyPoints {
            points: count,
            max: MAX_POINTS,
        });
    }
    let lo = number(arg, lo)?;
    let hi = number(arg, hi)?;
    if lo == hi {
        return Err(bad("both ends are equal"));
    }
    // Computed from both ends (not by repeated addition) so the last value is `hi` exactly;
    // then rounded to 12 significant digits and snapped to 0 within 1e-12 of the span, so
    // that `-0.3:0.3:13` gives −0.25 and 0, not −0.24999999999999997 and 5.6e-17.
    let last = (count - 1) as f64;
    let span = lo.abs().max(hi.abs());
    Ok((0..count)
        .map(|i| {
            let t = i as f64 / last;
            let v = lo * (1.0 - t) + hi * t;
            if v.abs() < 1e-12 * span {
                0.0
            } else {
                format!("{v:.11e}").parse().unwrap_or(v)
            }
        })
        .collect())
}

fn list(arg: &str, items: &[&str]) -> Result<Vec<f64>, SweepError> {
    items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            if item.trim().is_empty() {
                Err(SweepError::EmptyListItem {
                    arg: arg.to_string(),
                    index: i + 1,
                })
            } else {
                number(arg, item)
            }
        })
        .collect()
}

/// Statistics of one state or observable at one point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointStats {
    /// The quantity's name.
    pub name: String,
    /// E\[g\].
    pub mean: f64,
    /// √Var\[g\].
    pub std_dev: f64,
    /// E\[(g − mean)⁴\] / Var\[g\]².
    pub kurtosis: f64,
    /// P(|g| > a) for each threshold a of [`SweepResult::tail_thresholds`] (empty when no
    /// threshold could be set); `None` where a lies beyond the tabulated PDF on both sides
    /// (the density there is below about 1e−8 of its peak, so the tail is not resolved).
    /// Accurate to a few per mille while P ≳ 1e−7; smaller values lean on an exponential
    /// continuation of the curve beyond its last point and are good to a few per cent.
    pub tail: Vec<Option<f64>>,
}

/// A point that was solved at the sweep's degree.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointSolution {
    /// Nonlinear-solver iterations at the target degree.
    pub iterations: usize,
    /// Final Galerkin residual ‖R‖ (scaled variables).
    pub residual: f64,
    /// The bound ‖R‖ had to reach.
    pub residual_threshold: f64,
    /// FPK residual indicator ∫|F|·p dx (0 for an exact solution).
    pub fpk_residual: f64,
    /// How the density was normalised: `plane` or `inside_ridge`.
    pub normalisation: String,
    /// Statistics of each state, then each observable.
    pub stats: Vec<PointStats>,
}

/// What happened at one point.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum PointOutcome {
    /// EPC converged at the target degree.
    Converged(PointSolution),
    /// The point could not be solved; the other points are unaffected.
    Failed {
        /// Where it failed: `bind`, `fpk`, `epc` or `statistics`.
        stage: String,
        /// The error message.
        message: String,
    },
}

/// One point of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepPoint {
    /// The swept parameters' values, in the order of [`SweepResult::parameters`].
    pub values: Vec<f64>,
    /// The solution's statistics, or why there is none.
    #[serde(flatten)]
    pub outcome: PointOutcome,
    /// Wall time of this point's study in milliseconds.
    pub wall_ms: f64,
}

/// The thresholds a of P(|g| > a) for one quantity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailThresholds {
    /// The quantity's name.
    pub name: String,
    /// √E\[g²\] of the degree-2 solution at the reference point.
    pub rms: f64,
    /// [`TAIL_MULTIPLES`] × `rms`.
    pub thresholds: Vec<f64>,
}

/// A finished sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepResult {
    /// The model's name.
    pub model: String,
    /// The EPC degree every point was solved at.
    pub degree: usize,
    /// The swept parameters' names.
    pub parameters: Vec<String>,
    /// The fixed overrides, as `name=expr`.
    pub fixed: Vec<String>,
    /// The states, then the observables: the order of [`PointSolution::stats`].
    pub quantities: Vec<String>,
    /// The observables (the states when the model declares none): what the figures show.
    pub figure_quantities: Vec<String>,
    /// Index of the point whose degree-2 solution set the tail thresholds (the first point
    /// whose degree 2 converged), if any.
    pub threshold_point: Option<usize>,
    /// Tail thresholds per quantity, fixed for the whole sweep so that curves are comparable.
    pub tail_thresholds: Vec<TailThresholds>,
    /// One entry per point, in the order of [`SweepSpec::points`].
    pub points: Vec<SweepPoint>,
    /// Total wall time in milliseconds.
    pub wall_ms: f64,
}

/// Runs sweeps.
pub struct Sweep;

/// A point's data before the tail thresholds are known.
struct Raw {
    values: Vec<f64>,
    wall_ms: f64,
    outcome: Result<Solved, (String, String)>,
    /// √E\[g²\] per quantity at degree 2, when degree 2 converged.
    rms2: Option<Vec<f64>>,
}

struct Solved {
    iterations: usize,
    residual: f64,
    residual_threshold: f64,
    fpk_residual: f64,
    normalisation: String,
    /// Per quantity at the target degree.
    quantities: Vec<QuantityCurve>,
}

/// A quantity's moments and its PDF curve at one point.
struct QuantityCurve {
    name: String,
    mean: f64,
    std_dev: f64,
    kurtosis: f64,
    x: Vec<f64>,
    p: Vec<f64>,
}

impl Sweep {
    /// Solves every point of `spec` by EPC at `degree` (continued from degree 2 within the
    /// point), all points in parallel, and collects the statistics of each state and
    /// observable. A point that fails — bind error (e.g. a negative intensity), FPK error,
    /// EPC failure at degree 2 or at `degree` — is kept as [`PointOutcome::Failed`] with its
    /// message; the other points are unaffected.
    ///
    /// Tail probabilities P(|g| > a) use thresholds a = 2, 3, 4 × √E\[g²\] of the degree-2
    /// solution at the first point (the first whose degree 2 converged), fixed for the whole
    /// sweep. √E\[g²\] is σ for a zero-mean quantity and makes the thresholds of |z| those of
    /// z. The probabilities are integrals of the quantity's PDF curve (Eqs. 23–28 via
    /// [`Study`]) beyond ±a, normalised by the curve's mass.
    ///
    /// Every point's result is the same as a [`Study::run`] at its values, whatever the
    /// number of threads.
    pub fn run(model: &Model, spec: &SweepSpec, degree: usize) -> SweepResult {
        Sweep::run_with_progress(model, spec, degree, &|_, _| {})
    }

    /// [`Sweep::run`], calling `progress(done, total)` as each point finishes (from the
    /// worker threads, in completion order), e.g. for a progress bar.
    ///
    /// ```
    /// use std::sync::atomic::{AtomicU64, Ordering};
    /// use fpsolve::sweep::{Sweep, SweepSpec};
    /// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let spec = SweepSpec::parse(&["c=0.5,1".into()]).unwrap();
    /// let seen = AtomicU64::new(0);
    /// let result = Sweep::run_with_progress(&model, &spec, 2, &|_, total| {
    ///     assert_eq!(total, 2);
    ///     seen.fetch_add(1, Ordering::Relaxed);
    /// });
    /// assert_eq!((result.converged(), seen.into_inner()), (2, 2));
    /// ```
    pub fn run_with_progress(
        model: &Model,
        spec: &SweepSpec,
        degree: usize,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> SweepResult {
        let start = Instant::now();
        let total = spec.len() as u64;
        let done = std::sync::atomic::AtomicU64::new(0);
        let degrees: Vec<usize> = if degree == 2 {
            vec![2]
        } else {
            vec![2, degree]
        };
        let raw: Vec<Raw> = spec
            .points()
            .into_par_iter()
            .map(|values| {
                let point = solve_point(model, spec, values, &degrees);
                let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(k, total);
                point
            })
            .collect();
        let quantities: Vec<String> = model
            .states()
            .iter()
            .map(|s| s.to_string())
            .chain(model.observables().iter().map(|o| o.name.to_string()))
            .collect();
        let figure_quantities = if model.observables().is_empty() {
            quantities.clone()
        } else {
            quantities[2..].to_vec()
        };
        let threshold_point = raw.iter().position(|r| r.rms2.is_some());
        let tail_thresholds: Vec<TailThresholds> = threshold_point
            .and_then(|i| raw[i].rms2.as_ref())
            .map(|rms| {
                quantities
                    .iter()
                    .zip(rms)
                    .map(|(name, &rms)| TailThresholds {
                        name: name.clone(),
                        rms,
                        thresholds: TAIL_MULTIPLES.iter().map(|k| k * rms).collect(),
                    })
                    .collect()
            })
            .unwrap_or_default();
        let points = raw
            .into_iter()
            .map(|r| SweepPoint {
                values: r.values,
                wall_ms: r.wall_ms,
                outcome: match r.outcome {
                    Ok(s) => PointOutcome::Converged(PointSolution {
                        iterations: s.iterations,
                        residual: s.residual,
                        residual_threshold: s.residual_threshold,
                        fpk_residual: s.fpk_residual,
                        normalisation: s.normalisation,
                        stats: s
                            .quantities
                            .into_iter()
                            .map(|q| {
                                let QuantityCurve {
                                    name,
                                    mean,
                                    std_dev,
                                    kurtosis,
                                    x,
                                    p,
                                } = q;
                                let tail = tail_thresholds
                                    .iter()
                                    .find(|t| t.name == name)
                                    .map(|t| {
                                        t.thresholds
                                            .iter()
                                            .map(|&a| tail_probability(&x, &p, a))
                                            .collect()
                                    })
                                    .unwrap_or_default();
                                PointStats {
                                    name,
                                    mean,
                                    std_dev,
                                    kurtosis,
                                    tail,
                                }
                            })
                            .collect(),
                    }),
                    Err((stage, message)) => PointOutcome::Failed { stage, message },
                },
            })
            .collect();
        SweepResult {
            model: model.name().to_string(),
            degree,
            parameters: spec.swept.iter().map(|s| s.name.clone()).collect(),
            fixed: spec
                .fixed
                .iter()
                .map(|o| format!("{}={}", o.name, o.value))
                .collect(),
            quantities,
            figure_quantities,
            threshold_point,
            tail_thresholds,
            points,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }
}

fn solve_point(model: &Model, spec: &SweepSpec, values: Vec<f64>, degrees: &[usize]) -> Raw {
    let start = Instant::now();
    let study = Study::run(model, &spec.overrides_at(&values), degrees);
    let (outcome, rms2) = match study {
        Err(e) => {
            let stage = match e {
                StudyError::Bind(_) => "bind",
                StudyError::Fpk(_) => "fpk",
                StudyError::NoDegree => "epc",
            };
            (Err((stage.to_string(), e.to_string())), None)
        }
        Ok(study) => {
            let rms2 = study.degrees[0]
                .outcome
                .is_ok()
                .then(|| {
                    study.degrees[0]
                        .stats
                        .iter()
                        .map(|s| s.mean.hypot(s.std_dev))
                        .collect::<Vec<f64>>()
                })
                .filter(|r| {
                    r.len() == study.quantities.len() && r.iter().all(|v| v.is_finite() && *v > 0.0)
                });
            (solved(&study), rms2)
        }
    };
    Raw {
        values,
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
        outcome,
        rms2,
    }
}

/// The target degree's data (the last degree of the study), or why there is none.
fn solved(study: &Study) -> Result<Solved, (String, String)> {
    let failed = |stage: &str, message: String| Err((stage.to_string(), message));
    // A failure at degree 2 is the reason the target degree has no solution either.
    let first_failure = study
        .degrees
        .iter()
        .find_map(|d| d.outcome.as_ref().err().map(|e| (d.degree, e)));
    if let Some((degree, e)) = first_failure {
        return failed("epc", format!("degree {degree}: {e}"));
    }
    let Some(last) = study.degrees.last() else {
        return failed("epc", "no degree was solved".to_string());
    };
    let Ok(sol) = &last.outcome else {
        return failed("epc", format!("degree {} did not converge", last.degree));
    };
    let mut quantities = Vec::with_capacity(study.quantities.len());
    for q in &study.quantities {
        let stats = last.stats.iter().find(|s| s.name == q.name);
        let curve = study.curves.iter().find(|c| c.name == q.name);
        let column = curve.and_then(|c| c.columns.iter().find(|(d, _)| *d == last.degree));
        let (Some(stats), Some(curve), Some((_, p))) = (stats, curve, column) else {
            return failed(
                "statistics",
                format!("no PDF of `{}` could be tabulated", q.name),
            );
        };
        let values = [stats.mean, stats.std_dev, stats.kurtosis];
        if values.iter().any(|v| !v.is_finite()) {
            return failed(
                "statistics",
                format!(
                    "statistics of `{}` are not finite (mean {}, std dev {}, kurtosis {})",
                    q.name, stats.mean, stats.std_dev, stats.kurtosis
                ),
            );
        }
        quantities.push(QuantityCurve {
            name: q.name.clone(),
            mean: stats.mean,
            std_dev: stats.std_dev,
            kurtosis: stats.kurtosis,
            x: curve.x.clone(),
            p: p.clone(),
        });
    }
    Ok(Solved {
        iterations: sol.solve.iterations,
        residual: sol.solve.residual,
        residual_threshold: sol.solve.residual_threshold,
        fpk_residual: sol.fpk_residual,
        normalisation: match sol.normalisation.kind {
            NormalisationKind::Plane { .. } => "plane",
            NormalisationKind::InsideRidge { .. } => "inside_ridge",
        }
        .to_string(),
        quantities,
    })
}

/// ∫ p over [u, w] ⊂ [x0, x1], with p interpolated log-linearly between (x0, p0) and
/// (x1, p1): exact for an exponential tail and much closer than a straight line for the
/// Gaussian-like tails of EPC densities, whose log is smooth. Cells with a zero end (the edge
/// of a support) fall back to linear interpolation.
fn cell_integral(x0: f64, x1: f64, p0: f64, p1: f64, u: f64, w: f64) -> f64 {
    if w <= u {
        return 0.0;
    }
    let h = x1 - x0;
    if p0 > 0.0 && p1 > 0.0 {
        let s = (p1 / p0).ln() / h;
        let pu = p0 * (s * (u - x0)).exp();
        let d = w - u;
        if (s * d).abs() < 1e-12 {
            pu * d
        } else {
            pu * (s * d).exp_m1() / s
        }
    } else {
        let at = |x: f64| p0 + (p1 - p0) * (x - x0) / h;
        0.5 * (at(u) + at(w)) * (w - u)
    }
}

/// P(|g| > a) from g's PDF tabulated on the grid `x`, normalised by the curve's own mass so
/// that quadrature error largely cancels. Beyond the grid's ends (where the density is below
/// about 1e−8 of its peak) the last cell's exponential decay is continued to infinity. `None`
/// when a lies beyond the grid on both sides: the curve does not resolve that tail.
fn tail_probability(x: &[f64], p: &[f64], a: f64) -> Option<f64> {
    let n = x.len();
    if n < 2 || (x[n - 1] <= a && x[0] >= -a) {
        return None;
    }
    let mut mass = 0.0;
    let mut tail = 0.0;
    for i in 1..n {
        let (x0, x1, p0, p1) = (x[i - 1], x[i], p[i - 1], p[i]);
        mass += cell_integral(x0, x1, p0, p1, x0, x1);
        tail += cell_integral(x0, x1, p0, p1, x0.max(a), x1);
        tail += cell_integral(x0, x1, p0, p1, x0, x1.min(-a));
    }
    // ∫ beyond an end of p_end·exp(−λ|x − x_end|) = p_end/λ, λ the last cell's decay rate;
    // only where the grid ends in a decaying tail (not at a support edge like |z| = 0).
    let peak = p.iter().copied().fold(0.0, f64::max);
    let beyond = |p_in: f64, p_end: f64, h: f64| {
        if p_in > p_end && p_end > 0.0 && p_end < 1e-6 * peak {
            p_end * h / (p_in / p_end).ln()
        } else {
            0.0
        }
    };
    let right = beyond(p[n - 2], p[n - 1], x[n - 1] - x[n - 2]);
    let left = beyond(p[1], p[0], x[1] - x[0]);
    mass += right + left;
    if x[n - 1] > a {
        tail += right;
    }
    if x[0] < -a {
        tail += left;
    }
    (mass > 0.0 && tail.is_finite()).then(|| tail / mass)
}

impl SweepResult {
    /// The points that converged.
    pub fn converged(&self) -> usize {
        self.points
            .iter()
            .filter(|p| matches!(p.outcome, PointOutcome::Converged(_)))
            .count()
    }

    /// The sweep as CSV text: one row per point with the swept parameters, `status`
    /// (`converged` or `failed`), `stage` and `message` of a failure, the solver's
    /// iterations, residual, residual threshold, FPK residual and normalisation, then per
    /// quantity `<g>_mean`, `<g>_std_dev`, `<g>_kurtosis` and `<g>_p_gt_<k>rms` = P(|g| > k·rms)
    /// for k = 2, 3, 4 (the thresholds are in `sweep.json`). A failed point has empty
    /// statistic fields.
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        let mut header: Vec<String> = self.parameters.clone();
        header.extend(
            [
                "status",
                "stage",
                "message",
                "iterations",
                "residual",
                "residual_threshold",
                "fpk_residual",
                "normalisation",
            ]
            .map(String::from),
        );
        for q in &self.quantities {
            header.extend(["mean", "std_dev", "kurtosis"].map(|s| format!("{q}_{s}")));
            if self.tail_thresholds.iter().any(|t| &t.name == q) {
                header.extend(TAIL_MULTIPLES.iter().map(|k| format!("{q}_p_gt_{k}rms")));
            }
        }
        out.push_str(&header.join(","));
        out.push('\n');
        for point in &self.points {
            let mut row: Vec<String> = point.values.iter().map(|&v| number_text(v)).collect();
            match &point.outcome {
                PointOutcome::Converged(s) => {
                    row.extend([
                        "converged".to_string(),
                        String::new(),
                        String::new(),
                        s.iterations.to_string(),
                        number_text(s.residual),
                        number_text(s.residual_threshold),
                        number_text(s.fpk_residual),
                        s.normalisation.clone(),
                    ]);
                    for q in &self.quantities {
                        let st = s.stats.iter().find(|st| &st.name == q);
                        row.extend(
                            [
                                st.map(|s| s.mean),
                                st.map(|s| s.std_dev),
                                st.map(|s| s.kurtosis),
                            ]
                            .map(|v| v.map_or_else(String::new, number_text)),
                        );
                        if self.tail_thresholds.iter().any(|t| &t.name == q) {
                            for k in 0..TAIL_MULTIPLES.len() {
                                let v = st.and_then(|s| s.tail.get(k).copied().flatten());
                                row.push(v.map_or_else(String::new, number_text));
                            }
                        }
                    }
                }
                PointOutcome::Failed { stage, message } => {
                    row.extend([
                        "failed".to_string(),
                        stage.clone(),
                        quoted(message),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                        String::new(),
                    ]);
                    row.resize(header.len(), String::new());
                }
            }
            out.push_str(&row.join(","));
            out.push('\n');
        }
        out
    }

    /// The line figures: mean, standard deviation and kurtosis of the figure quantities
    /// against the first swept parameter (one series per quantity and value of the second
    /// parameter), and per figure quantity log10 P(|g| > a) for each threshold. Figures
    /// without any finite value (every point failed) are left out. Returned with their file
    /// stems.
    pub fn figures(&self) -> Vec<(String, LineFigure)> {
        let mut out = Vec::new();
        let x_label = self.parameters.first().cloned().unwrap_or_default();
        let groups = self.series_groups();
        let stat = |s: &PointStats, which: usize| match which {
            0 => s.mean,
            1 => s.std_dev,
            _ => s.kurtosis,
        };
        for (which, (stem, label)) in [
            ("mean", "mean"),
            ("std_dev", "standard deviation"),
            ("kurtosis", "kurtosis"),
        ]
        .into_iter()
        .enumerate()
        {
            let mut series = Vec::new();
            for q in &self.figure_quantities {
                for (group_label, indices) in &groups {
                    let (x, y) = self.column(indices, |sol| {
                        sol.stats
                            .iter()
                            .find(|s| &s.name == q)
                            .map_or(f64::NAN, |s| stat(s, which))
                    });
                    series.push(Curve {
                        label: join_label(q, group_label),
                        x,
                        y,
                    });
                }
            }
            out.push((
                format!("sweep_{stem}"),
                LineFigure {
                    title: format!("{}: {label} (EPC n = {})", self.model, self.degree),
                    x_label: x_label.clone(),
                    y_label: label.to_string(),
                    series,
                },
            ));
        }
        for q in &self.figure_quantities {
            let Some(t) = self.tail_thresholds.iter().find(|t| &t.name == q) else {
                continue;
            };
            let mut series = Vec::new();
            for (k, a) in t.thresholds.iter().enumerate() {
                for (group_label, indices) in &groups {
                    let (x, y) = self.column(indices, |sol| {
                        sol.stats
                            .iter()
                            .find(|s| &s.name == q)
                            .and_then(|s| s.tail.get(k).copied().flatten())
                            .map_or(f64::NAN, |p| if p > 0.0 { p.log10() } else { f64::NAN })
                    });
                    series.push(Curve {
                        label: join_label(&format!("a = {}", short(*a)), group_label),
                        x,
                        y,
                    });
                }
            }
            out.push((
                format!("sweep_tail_{q}"),
                LineFigure {
                    title: format!(
                        "{}: P(|{q}| > a), a = 2, 3, 4 × rms at {} (EPC n = {})",
                        self.model,
                        self.threshold_label(),
                        self.degree
                    ),
                    x_label: x_label.clone(),
                    y_label: format!("log10 P(|{q}| > a)"),
                    series,
                },
            ));
        }
        out.retain(|(_, f)| f.series.iter().any(|s| s.y.iter().any(|v| v.is_finite())));
        out
    }

    /// The reference point of the tail thresholds as `p1 = v1, p2 = v2`.
    fn threshold_label(&self) -> String {
        let Some(point) = self.threshold_point.and_then(|i| self.points.get(i)) else {
            return "no point".to_string();
        };
        self.parameters
            .iter()
            .zip(&point.values)
            .map(|(n, v)| format!("{n} = {}", short(*v)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Point indices of each series: one per value of the second swept parameter (in the
    /// order given), or a single unlabelled series.
    fn series_groups(&self) -> Vec<(String, Vec<usize>)> {
        let Some(second) = self.parameters.get(1) else {
            return vec![(String::new(), (0..self.points.len()).collect())];
        };
        let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
        for (i, p) in self.points.iter().enumerate() {
            let v = p.values[1];
            match groups.iter_mut().find(|(g, _)| *g == v) {
                Some((_, idx)) => idx.push(i),
                None => groups.push((v, vec![i])),
            }
        }
        groups
            .into_iter()
            .map(|(v, idx)| (format!("{second} = {}", short(v)), idx))
            .collect()
    }

    /// The first swept parameter and a statistic at the given points (NaN where a point
    /// failed, leaving a gap in the line).
    fn column(
        &self,
        indices: &[usize],
        value: impl Fn(&PointSolution) -> f64,
    ) -> (Vec<f64>, Vec<f64>) {
        indices
            .iter()
            .map(|&i| {
                let p = &self.points[i];
                let y = match &p.outcome {
                    PointOutcome::Converged(sol) => value(sol),
                    PointOutcome::Failed { .. } => f64::NAN,
                };
                (p.values[0], if y.is_finite() { y } else { f64::NAN })
            })
            .unzip()
    }

    /// Writes `sweep.csv`, `sweep.json` and the figures of [`figures`](Self::figures)
    /// (PNG and SVG) into `out`; returns the files written.
    ///
    /// # Errors
    /// The first [`ReportError`] met; files written before it stay.
    pub fn write(&self, out: &OutputDir) -> Result<Vec<PathBuf>, ReportError> {
        let mut files = vec![
            out.write_atomic("sweep.csv", self.to_csv().as_bytes())?,
            write_json(out, "sweep.json", self)?,
        ];
        for (stem, figure) in self.figures() {
            let written = figure.write(out, &stem)?;
            files.push(written.png);
            files.push(written.svg);
        }
        Ok(files)
    }
}

fn join_label(a: &str, b: &str) -> String {
    if b.is_empty() {
        a.to_string()
    } else {
        format!("{a}, {b}")
    }
}

/// A number for a legend: at most four significant digits, no trailing zeros.
fn short(v: f64) -> String {
    let rounded: f64 = format!("{v:.3e}").parse().unwrap_or(v);
    format!("{rounded}")
}

/// Shortest round-trip text, in exponent form for very small or large magnitudes.
fn number_text(v: f64) -> String {
    let mut out = String::new();
    // Writing to a String cannot fail.
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
        let _ = write!(out, "{v}");
    } else {
        let _ = write!(out, "{v:e}");
    }
    out
}

/// A CSV field in double quotes, on one line.
fn quoted(text: &str) -> String {
    let one_line = text.split_whitespace().collect::<Vec<_>>().join(" ");
    format!("\"{}\"", one_line.replace('"', "\"\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_integral_is_exact_for_an_exponential() {
        let f = |x: f64| 3.0 * (-1.7 * x).exp();
        let got = cell_integral(0.5, 1.5, f(0.5), f(1.5), 0.8, 1.2);
        let exact = 3.0 / 1.7 * ((-1.7f64 * 0.8).exp() - (-1.7f64 * 1.2).exp());
        approx::assert_relative_eq!(got, exact, max_relative = 1e-13);
        // A zero end falls back to the straight line.
        approx::assert_relative_eq!(cell_integral(0.0, 1.0, 0.0, 2.0, 0.0, 1.0), 1.0);
    }

    /// P(|g| > a) for a standard normal, by Simpson's rule on a fine grid.
    fn normal_tail(a: f64) -> f64 {
        let n = 20_000;
        let b = a + 14.0;
        let h = (b - a) / n as f64;
        let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let mut s = phi(a) + phi(b);
        for i in 1..n {
            s += phi(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        2.0 * s * h / 3.0
    }

    #[test]
    fn tail_of_a_gaussian_curve() {
        // A grid like the study's: 401 points to where the density is 1e-8 of its peak.
        let end = (2.0 * 1e8f64.ln()).sqrt();
        let x: Vec<f64> = (0..401)
            .map(|i| -end + 2.0 * end * i as f64 / 400.0)
            .collect();
        let p: Vec<f64> = x.iter().map(|x| (-0.5 * x * x).exp()).collect();
        for a in [1.0, 2.0, 3.0, 4.0, 5.5] {
            let got = tail_probability(&x, &p, a).unwrap();
            approx::assert_relative_eq!(got, normal_tail(a), max_relative = 2e-3);
        }
        // Beyond the tabulated range the tail is not resolved.
        assert_eq!(tail_probability(&x, &p, end + 0.1), None);
    }

    #[test]
    fn one_sided_grid_of_an_absolute_value() {
        // |g| for a standard normal g: density 2φ on [0, end], support edge at 0.
        let end = (2.0 * 1e8f64.ln()).sqrt();
        let x: Vec<f64> = (0..401).map(|i| end * i as f64 / 400.0).collect();
        let p: Vec<f64> = x.iter().map(|x| 2.0 * (-0.5 * x * x).exp()).collect();
        approx::assert_relative_eq!(
            tail_probability(&x, &p, 3.0).unwrap(),
            normal_tail(3.0),
            max_relative = 2e-3
        );
    }

    #[test]
    fn commas_inside_calls_do_not_split_a_list() {
        assert!(matches!(classify("max(1, 2)"), Value::Single));
        assert!(matches!(classify("max(1, 2), 3"), Value::List(v) if v.len() == 2));
        assert!(matches!(classify("0:1:3"), Value::Range(v) if v.len() == 3));
    }

    #[test]
    fn range_values_are_clean_decimals() {
        let v = range("eps=-0.3:0.3:13", &["-0.3", "0.3", "13"]).unwrap();
        assert_eq!(v[1], -0.25);
        assert_eq!(v[6], 0.0);
        assert_eq!(v[12], 0.3);
    }
}
