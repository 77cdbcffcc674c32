//! The entry points: model text or file → [`Model`], and lone expressions.

use std::path::Path;

use super::ast::Span;
use super::diagnostic::Diagnostic;
use super::error::ModelError;
use super::parse::{parse_file, parse_lone_expr, MAX_SOURCE_BYTES};
use super::syntax::SyntaxFailure;
use super::validate::{lower_free, validate, Located, SemanticError};
use super::Model;
use crate::base::input_file::{read_regular_file, refusal, FileRefusal};
use crate::symbolic::Expr;

/// Parses and validates a model from its text. `path`, if given, is shown in error messages.
///
/// ```
/// let src = "\
/// model duffing \"Duffing oscillator\"
/// param c = 0.1, k = 1, mu = 0.1, K = 1/(2*pi)
/// state z, v
/// drift z: v
/// drift v: -c*v - k*z - mu*z^3
/// noise xi: intensity 2*pi*K
/// diffusion v: xi
/// ";
/// let model = fpsolve::model::parse_model(src, None).unwrap();
/// assert_eq!(model.name(), "duffing");
/// assert_eq!(model.drift()[1].to_string(), "-c*v - k*z - mu*z^3");
///
/// let err = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v +\n", None)
///     .unwrap_err();
/// assert_eq!((err.line(), err.column()), (Some(3), Some(13)));
/// assert!(err.to_string().contains("expected an expression"));
/// ```
pub fn parse_model(source: &str, path: Option<&Path>) -> Result<Model, ModelError> {
    let shown = path.map(|p| p.display().to_string());
    let shown = shown.as_deref();
    if source.len() > MAX_SOURCE_BYTES {
        return Err(ModelError::TooLarge {
            path: shown.unwrap_or("the model").to_string(),
            limit: MAX_SOURCE_BYTES,
        });
    }
    let ast = parse_file(source).map_err(|f| syntax_error(source, shown, f))?;
    validate(&ast, source, shown).map_err(|l| semantic_error(source, shown, *l))
}

/// Reads, checks and parses a model file. The bytes are checked for UTF-8 here, so that an
/// encoding error says where the first bad byte is.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// assert_eq!(model.states()[0].as_ref(), "z");
///
/// let missing = fpsolve::model::load_model(std::path::Path::new("no/such.sde"));
/// assert!(matches!(missing, Err(fpsolve::model::ModelError::Io { .. })));
/// ```
pub fn load_model(path: &Path) -> Result<Model, ModelError> {
    let io = |source| ModelError::Io {
        path: path.to_path_buf(),
        source,
    };
    let shown = path.display().to_string();
    // A regular file only, read at most one byte past the limit: `/dev/zero` or a FIFO
    // passed by mistake is refused at once instead of read (or waited on) forever.
    let bytes =
        read_regular_file(path, MAX_SOURCE_BYTES as u64).map_err(|e| match refusal(&e) {
            Some(FileRefusal::TooLarge { .. }) => ModelError::TooLarge {
                path: shown.clone(),
                limit: MAX_SOURCE_BYTES,
            },
            _ => io(e),
        })?;
    let source = match std::str::from_utf8(&bytes) {
        Ok(s) => s,
        Err(e) => return Err(encoding_error(&bytes, e, &shown)),
    };
    parse_model(source, Some(path))
}

/// Parses a lone expression, as given to `--set name=value`. Names are not resolved (that
/// is done when the value is bound), but functions, their arity and numbers are checked;
/// `pi` and `e` become numbers.
///
/// ```
/// let e = fpsolve::model::parse_expr("-x^2 + 2^-1").unwrap();
/// assert_eq!(e.to_string(), "-x^2 + 2^(-1)");
/// assert!(fpsolve::model::parse_expr("1 +").is_err());
/// assert!(fpsolve::model::parse_expr("sinh(1)").is_err());
/// ```
pub fn parse_expr(source: &str) -> Result<Expr, ModelError> {
    if source.len() > MAX_SOURCE_BYTES {
        return Err(ModelError::TooLarge {
            path: "the expression".into(),
            limit: MAX_SOURCE_BYTES,
        });
    }
    let node = parse_lone_expr(source).map_err(|f| syntax_error(source, None, f))?;
    lower_free(&node).map_err(|l| semantic_error(source, None, *l))
}

pub(super) fn syntax_error(source: &str, path: Option<&str>, failure: SyntaxFailure) -> ModelError {
    ModelError::Syntax(Diagnostic::new(
        source,
        path,
        failure.span,
        failure.message,
        None,
    ))
}

pub(super) fn semantic_error(source: &str, path: Option<&str>, located: Located) -> ModelError {
    let Located { error, span } = located;
    let diagnostic = Diagnostic::new(source, path, span, error.to_string(), error.help());
    match error {
        // A malformed literal is a slip of syntax, found only when the tree is lowered.
        SemanticError::MalformedNumber { .. } => ModelError::Syntax(diagnostic),
        error => ModelError::Semantic {
            error: Box::new(error),
            diagnostic,
        },
    }
}

/// Points at the first byte that is not UTF-8, showing the valid text before it.
fn encoding_error(bytes: &[u8], error: std::str::Utf8Error, path: &str) -> ModelError {
    let valid = error.valid_up_to();
    // The prefix is valid by construction; `from_utf8` cannot fail here.
    let prefix = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
    let message = format!(
        "the file is not valid UTF-8 (byte 0x{:02X}); fpsolve reads model files as UTF-8 text",
        bytes.get(valid).copied().unwrap_or(0)
    );
    ModelError::Encoding(Diagnostic::new(
        prefix,
        Some(path),
        Span::new(valid, valid),
        message,
        Some("re-save the file as UTF-8".into()),
    ))
}

impl super::Model {
    /// The safe set from the model's `safe` line (or [`Model::with_safe`](Self::with_safe)),
    /// if any.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
    /// assert!(fpsolve::model::load_model(&path).unwrap().safe().is_none());
    /// ```
    pub fn safe(&self) -> Option<&super::SafeSet> {
        self.safe.as_ref()
    }

    /// The model with the safe set `text` (`abs(z) < 2.5`, `-2 < z < 3`; what follows
    /// `safe` on a model line) in place of its own. Names are checked against the model's;
    /// errors point into `text`, shown as `--safe`.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let safe = model.with_safe("abs(z) < 2").unwrap();
    /// assert_eq!(safe.safe().unwrap().text, "abs(z) < 2");
    /// let err = model.with_safe("abs(q) < 2").unwrap_err();
    /// assert_eq!((err.line(), err.column()), (Some(1), Some(5)));
    /// ```
    ///
    /// # Errors
    /// A [`ModelError`]: a syntax error, an unknown name, a quantity
    /// without a state, a bound that is not a constant.
    pub fn with_safe(&self, text: &str) -> Result<super::Model, super::ModelError> {
        let shown = Some("--safe");
        let spec = super::parse::parse_lone_safe(text).map_err(|f| syntax_error(text, shown, f))?;
        let source = self.origin.as_ref().map_or("", |o| o.source.as_str());
        // The model's own text parsed once more for its declarations: it was valid when read.
        let ast = super::parse::parse_file(source).map_err(|f| syntax_error(source, None, f))?;
        let safe = super::validate::validate_safe(&ast, source, &spec, text, &self.observables)
            .map_err(|l| semantic_error(text, shown, *l))?;
        let mut out = self.clone();
        out.safe = Some(safe);
        Ok(out)
    }

    /// The model with the initial state `text` (what follows `initial` on a model line:
    /// `rest`, `point z = 1, v = 0`, `gaussian mean z = 0, v = 0 cov 1, 0, 0, 1`), in place
    /// of its own; errors point into `text`, shown as `--initial`.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let started = model.with_initial("point z = 1, v = 0").unwrap();
    /// assert!(started.initial().is_some());
    /// let err = model.with_initial("point q = 1, v = 0").unwrap_err();
    /// assert!(err.to_string().contains("`q` is not a state"), "{err}");
    /// ```
    ///
    /// # Errors
    /// A [`super::ModelError`] located in `text`.
    pub fn with_initial(&self, text: &str) -> Result<super::Model, super::ModelError> {
        let shown = Some("--initial");
        let spec =
            super::parse::parse_lone_initial(text).map_err(|f| syntax_error(text, shown, f))?;
        let source = self.origin.as_ref().map_or("", |o| o.source.as_str());
        // The model's own text parsed once more for its declarations: it was valid when read.
        let ast = super::parse::parse_file(source).map_err(|f| syntax_error(source, None, f))?;
        let initial = super::validate::validate_initial(&ast, source, &spec, text)
            .map_err(|l| semantic_error(text, shown, *l))?;
        let mut out = self.clone();
        out.initial = Some(initial);
        Ok(out)
    }
}
