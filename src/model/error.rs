//! [`ModelError`]: why a model file could not be turned into a [`crate::model::Model`], each
//! kind of failure with its located [`Diagnostic`].

use std::path::PathBuf;

use super::diagnostic::Diagnostic;
use super::validate::SemanticError;

/// Why a model file could not be turned into a [`crate::model::Model`]. `Display` is the
/// full rendered message (`error: ...`, location, source line, caret).
///
/// ```
/// use fpsolve::model::{parse_model, ModelError};
/// let err = parse_model("model m\nstate z\n", None).unwrap_err();
/// assert!(matches!(err, ModelError::Semantic { .. }));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file could not be read.
    #[error("error: cannot read `{}`: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is larger than any model file has reason to be.
    #[error("error: `{path}` is larger than {limit} bytes; is it really a model file?")]
    TooLarge {
        /// The file, as given.
        path: String,
        /// The limit, in bytes.
        limit: usize,
    },
    /// The file is not UTF-8; the diagnostic points at the first bad byte.
    #[error("{0}")]
    Encoding(Diagnostic),
    /// The text does not follow the grammar (or exceeds a nesting or line-length limit).
    #[error("{0}")]
    Syntax(Diagnostic),
    /// The text parses, but says something impossible (unknown name, cycle, ...).
    #[error("{diagnostic}")]
    Semantic {
        /// What is wrong, as a typed value.
        error: Box<SemanticError>,
        /// Where, rendered.
        diagnostic: Diagnostic,
    },
}

impl ModelError {
    /// The located diagnostic, for every kind of error except I/O and size.
    ///
    /// ```
    /// let err = fpsolve::model::parse_expr("(1").unwrap_err();
    /// assert!(err.diagnostic().unwrap().message().contains("`)`"));
    /// ```
    pub fn diagnostic(&self) -> Option<&Diagnostic> {
        match self {
            ModelError::Io { .. } | ModelError::TooLarge { .. } => None,
            ModelError::Encoding(d) | ModelError::Syntax(d) => Some(d),
            ModelError::Semantic { diagnostic, .. } => Some(diagnostic),
        }
    }

    /// The typed semantic error, if this is one.
    ///
    /// ```
    /// use fpsolve::model::{parse_model, SemanticError};
    /// let err = parse_model("param a = 1\n", None).unwrap_err();
    /// assert!(matches!(err.semantic(), Some(SemanticError::MissingModelLine)));
    /// ```
    pub fn semantic(&self) -> Option<&SemanticError> {
        match self {
            ModelError::Semantic { error, .. } => Some(error),
            _ => None,
        }
    }

    /// 1-based line of the error, where known.
    ///
    /// ```
    /// let err = fpsolve::model::parse_model("model m\nstate z\n", None).unwrap_err();
    /// assert_eq!(err.line(), Some(2));
    /// ```
    pub fn line(&self) -> Option<usize> {
        self.diagnostic().map(Diagnostic::line)
    }

    /// 1-based column (in characters) of the error, where known.
    ///
    /// ```
    /// let err = fpsolve::model::parse_model("model m\nstate z\n", None).unwrap_err();
    /// assert_eq!(err.column(), Some(1));
    /// ```
    pub fn column(&self) -> Option<usize> {
        self.diagnostic().map(Diagnostic::column)
    }
}
