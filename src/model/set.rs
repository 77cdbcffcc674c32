//! `name=value`: the one reader of a parameter override, as `--set` gives it on every command.

use std::str::FromStr;

use super::{parse_expr, ModelError, Override};

/// Why `name=value` is not an override. Every variant keeps the argument as given.
#[derive(Debug, thiserror::Error)]
pub enum SetError {
    /// No `=` in the argument.
    #[error("`--set {arg}`: expected NAME=VALUE")]
    MissingEquals {
        /// The argument.
        arg: String,
    },
    /// Nothing before `=`.
    #[error("`--set {arg}`: the parameter name is missing")]
    MissingName {
        /// The argument.
        arg: String,
    },
    /// The value is not an expression; the parser's diagnostic (line, column, caret) follows.
    #[error("error: in `--set {arg}`\n{source}")]
    BadExpression {
        /// The argument.
        arg: String,
        /// The parser's diagnostic.
        source: ModelError,
    },
}

/// Splits `name=value` at the first `=`, trimming the name; the value is left as written.
pub(crate) fn split_assignment(arg: &str) -> Result<(&str, &str), SetError> {
    let Some((name, value)) = arg.split_once('=') else {
        return Err(SetError::MissingEquals { arg: arg.into() });
    };
    let name = name.trim();
    if name.is_empty() {
        return Err(SetError::MissingName { arg: arg.into() });
    }
    Ok((name, value))
}

/// Parses a value of `arg` as an expression, naming `arg` when it is not one.
pub(crate) fn parse_value(arg: &str, value: &str) -> Result<crate::symbolic::Expr, SetError> {
    parse_expr(value).map_err(|source| SetError::BadExpression {
        arg: arg.into(),
        source,
    })
}

impl FromStr for Override {
    type Err = SetError;

    /// Reads `name=value`, the value an expression of numbers, `pi`, `e` and other parameters
    /// (whether the name exists is checked when the model is bound).
    ///
    /// ```
    /// use fpsolve::model::{Override, SetError};
    /// let o: Override = "mu = 2*c".parse()?;
    /// assert_eq!((o.name.as_str(), o.value.to_string().as_str()), ("mu", "2*c"));
    /// assert!(matches!("mu".parse::<Override>(), Err(SetError::MissingEquals { .. })));
    /// assert!(matches!("=1".parse::<Override>(), Err(SetError::MissingName { .. })));
    /// assert!(matches!("mu=2*".parse::<Override>(), Err(SetError::BadExpression { .. })));
    /// # Ok::<(), SetError>(())
    /// ```
    fn from_str(arg: &str) -> Result<Override, SetError> {
        let (name, value) = split_assignment(arg)?;
        Ok(Override {
            name: name.to_string(),
            value: parse_value(arg, value)?,
        })
    }
}
