//! Reading a sweep from `--set` arguments: ranges, lists and fixed overrides.

use std::str::FromStr;

use serde::Serialize;

use crate::model::set::split_assignment;
use crate::model::{number as short_number, parse_expr, Model, Override, SetError};

use super::{MAX_POINTS, MAX_SWEPT};

/// Why a sweep cannot run: `--set` arguments that do not describe one, or a method that does
/// not apply to the model. Every variant names the offending argument, parameter or method.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// An argument without `=`.
    #[error("`--set {arg}`: expected NAME=VALUE, NAME=LO:HI:COUNT or NAME=V1,V2,...")]
    MissingEquals {
        /// The argument.
        arg: String,
    },
    /// An argument with nothing before `=`, or a value (or a range end, or a list item) that
    /// is not an expression: the one `--set` reader's error ([`SetError`]).
    #[error(transparent)]
    Set(SetError),
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
    /// Swept values further apart than the largest floating-point number (`eps=-1e308:1e308:3`):
    /// no axis of a figure holds them, and no model's parameter means anything there.
    #[error(
        "`--set {arg}`: the values span from {} to {}, further apart than the largest \
         floating-point number (about 1.8e308); sweep a narrower range",
        short_number(*lo),
        short_number(*hi)
    )]
    SpanOverflow {
        /// The argument.
        arg: String,
        /// The smallest value.
        lo: f64,
        /// The largest value.
        hi: f64,
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
    /// A method that does not apply to the model, found before any work.
    #[error("--method {method}: {reason}")]
    Method {
        /// The method.
        method: crate::solve::MethodName,
        /// The model's name.
        model: String,
        /// Why.
        #[source]
        reason: Box<super::MethodRefusal>,
    },
    /// The model's equations depend on the time `t`: no point has a stationary density.
    #[error(
        "no stationary density: the equations of `{model}` depend on the time `t`, at every \
         point of the sweep; only a transient solution applies"
    )]
    TimeDependent {
        /// The model's name.
        model: String,
    },
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
            let parsed: SetArg = arg.parse()?;
            let name = parsed.name();
            if seen.iter().any(|s| s == name) {
                return Err(SweepError::Duplicate {
                    name: name.to_string(),
                });
            }
            seen.push(name.to_string());
            match parsed {
                SetArg::Swept(p) => swept.push(p),
                SetArg::Fixed(o) => fixed.push(o),
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
                    .map(|(p, &v)| format!("{} = {}", p.name, short_number(v)))
                    .collect::<Vec<_>>()
                    .join(", ");
                return Err(SweepError::Bind { point, source });
            }
        }
        Ok(())
    }
}

/// One `--set` argument of a sweep: a swept parameter (`name=lo:hi:count` or
/// `name=v1,v2,...`) or a fixed override (`name=expr`, read as [`Override`] reads it).
#[derive(Clone, Debug, PartialEq)]
pub enum SetArg {
    /// A range or a list.
    Swept(SweptParameter),
    /// A value that stays fixed.
    Fixed(Override),
}

impl SetArg {
    /// The parameter's name.
    pub fn name(&self) -> &str {
        match self {
            SetArg::Swept(p) => &p.name,
            SetArg::Fixed(o) => &o.name,
        }
    }
}

impl FromStr for SetArg {
    type Err = SweepError;

    /// Reads one argument; see [`SweepSpec::parse`].
    ///
    /// ```
    /// use fpsolve::sweep::SetArg;
    /// let SetArg::Swept(eps) = "eps=-0.3:0.3:13".parse()? else { unreachable!() };
    /// assert_eq!((eps.values[0], eps.values[12]), (-0.3, 0.3));
    /// assert!(matches!("mu=2*c".parse()?, SetArg::Fixed(_)));
    /// # Ok::<(), fpsolve::sweep::SweepError>(())
    /// ```
    fn from_str(arg: &str) -> Result<SetArg, SweepError> {
        // The sweep's own message for a missing `=` names its range and list forms too.
        let set_error = |e: SetError| match e {
            SetError::MissingEquals { arg } => SweepError::MissingEquals { arg },
            other => SweepError::Set(other),
        };
        match arg.split_once('=').map(|(_, value)| classify(value)) {
            Some(Value::Range(parts)) => {
                let (name, _) = split_assignment(arg).map_err(set_error)?;
                Ok(SetArg::Swept(SweptParameter {
                    name: name.to_string(),
                    values: within_span(arg, range(arg, &parts)?)?,
                }))
            }
            Some(Value::List(items)) => {
                let (name, _) = split_assignment(arg).map_err(set_error)?;
                Ok(SetArg::Swept(SweptParameter {
                    name: name.to_string(),
                    values: within_span(arg, list(arg, &items)?)?,
                }))
            }
            Some(Value::Single) | None => Ok(SetArg::Fixed(arg.parse().map_err(set_error)?)),
        }
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
    let expr = parse_expr(item).map_err(|source| {
        SweepError::Set(SetError::BadExpression {
            arg: arg.to_string(),
            source,
        })
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

/// The values, when their span max − min is a finite number (the figures' axis runs over
/// it; an infinite span made the axis' tick search loop forever).
fn within_span(arg: &str, values: Vec<f64>) -> Result<Vec<f64>, SweepError> {
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if (hi - lo).is_finite() {
        Ok(values)
    } else {
        Err(SweepError::SpanOverflow {
            arg: arg.to_string(),
            lo,
            hi,
        })
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commas_inside_calls_do_not_split_a_list() {
        assert!(matches!(classify("max(1, 2)"), Value::Single));
        assert!(matches!(classify("max(1, 2), 3"), Value::List(v) if v.len() == 2));
        assert!(matches!(classify("0:1:3"), Value::Range(v) if v.len() == 3));
    }

    #[test]
    fn values_further_apart_than_the_largest_float_are_refused() {
        for arg in [
            "eps=-1e308:1e308:3",
            "eps=-1e308,0,1e308",
            "eps=1.7e308,-1e308",
        ] {
            let err = arg.parse::<SetArg>().unwrap_err();
            assert!(
                matches!(err, SweepError::SpanOverflow { .. }),
                "{arg}: {err}"
            );
            // Short numbers in the message, not 309 digits.
            assert!(!err.to_string().contains("0000000000"), "{err}");
        }
        assert!("eps=-1e307:1e307:3".parse::<SetArg>().is_ok());
        assert!("eps=1e308,1.7e308".parse::<SetArg>().is_ok());
    }

    #[test]
    fn range_values_are_clean_decimals() {
        let v = range("eps=-0.3:0.3:13", &["-0.3", "0.3", "13"]).unwrap();
        assert_eq!(v[1], -0.25);
        assert_eq!(v[6], 0.0);
        assert_eq!(v[12], 0.3);
    }
}
