//! Errors in model files, rendered the way rustc renders its own.
//!
//! Every error — syntax, semantic, encoding — is rendered by pest's [`pest::error::Error`]
//! from a span of the source, so they all look alike:
//!
//! ```text
//! error: unknown identifier `mux`
//!  --> models/m.sde:5:11
//!   |
//! 5 | drift v: -mux*v
//!   |           ^-^
//!   |
//!   = did you mean `mu`?
//! ```
//!
//! The source line is shown with control characters replaced and cut after a short window,
//! so that NUL bytes, binary garbage or a 10 MB line never reach the terminal.

use std::fmt;

use pest::error::{Error as PestError, ErrorVariant, LineColLocation};

use super::ast::Span;

/// How many bytes of the offending line are shown after the span.
const WINDOW_AFTER: usize = 80;
/// How many bytes of the offending line are shown before the span, at most.
const WINDOW_BEFORE: usize = 160;

/// One located, rendered error message.
///
/// ```
/// let err = fpsolve::model::parse_expr("1 +").unwrap_err();
/// let d = err.diagnostic().unwrap();
/// assert_eq!((d.line(), d.column()), (1, 4));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    inner: Box<DiagnosticInner>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
struct DiagnosticInner {
    message: String,
    help: Option<String>,
    line: usize,
    column: usize,
    rendered: String,
}

impl Diagnostic {
    /// Renders `message` at `span` of `source`. `help`, if any, is shown under the caret
    /// line; otherwise the message is repeated there.
    pub(crate) fn new(
        source: &str,
        path: Option<&str>,
        span: Span,
        message: String,
        help: Option<String>,
    ) -> Diagnostic {
        let (display, start, end, column) = display_window(source, span);
        let note = help.clone().unwrap_or_else(|| message.clone());
        let variant = ErrorVariant::<()>::CustomError { message: note };
        let error = match pest::Span::new(&display, start, end) {
            Some(s) if end > start => PestError::new_from_span(variant, s),
            _ => {
                let pos = pest::Position::new(&display, start)
                    .unwrap_or_else(|| pest::Position::from_start(&display));
                PestError::new_from_pos(variant, pos)
            }
        };
        let error = match path {
            Some(p) => error.with_path(p),
            None => error,
        };
        let (line, shown_column) = match &error.line_col {
            LineColLocation::Pos(lc) | LineColLocation::Span(lc, _) => *lc,
        };
        let mut rendered = format!("error: {message}\n{error}");
        if shown_column != column {
            // The line was cut in front of the span; pest counted columns in the cut line.
            let path = path.map(|p| format!("{p}:")).unwrap_or_default();
            rendered = rendered.replacen(
                &format!("--> {path}{line}:{shown_column}"),
                &format!("--> {path}{line}:{column}"),
                1,
            );
        }
        Diagnostic {
            inner: Box::new(DiagnosticInner {
                message,
                help,
                line,
                column,
                rendered,
            }),
        }
    }

    /// The rendering without its leading `error: `, for a caller that prefixes its own.
    pub(crate) fn without_prefix(&self) -> String {
        let text = &self.inner.rendered;
        text.strip_prefix("error: ").unwrap_or(text).to_string()
    }

    /// The one-line message (`unknown identifier `mux``).
    ///
    /// ```
    /// let err = fpsolve::model::parse_expr("1 +").unwrap_err();
    /// assert_eq!(err.diagnostic().unwrap().message(), "expected an expression");
    /// ```
    pub fn message(&self) -> &str {
        &self.inner.message
    }

    /// A suggestion, if there is one (`did you mean `mu`?`).
    ///
    /// ```
    /// let src = "model m\nparam mu = 1\nstate z, v\ndrift z: v\ndrift v: -mux*z\n";
    /// let err = fpsolve::model::parse_model(src, None).unwrap_err();
    /// assert_eq!(err.diagnostic().unwrap().help(), Some("did you mean `mu`?"));
    /// ```
    pub fn help(&self) -> Option<&str> {
        self.inner.help.as_deref()
    }

    /// 1-based line of the error.
    ///
    /// ```
    /// let err = fpsolve::model::parse_expr("1 +").unwrap_err();
    /// assert_eq!(err.diagnostic().unwrap().line(), 1);
    /// ```
    pub fn line(&self) -> usize {
        self.inner.line
    }

    /// 1-based column (in characters) of the error.
    ///
    /// ```
    /// let err = fpsolve::model::parse_expr("1 +").unwrap_err();
    /// assert_eq!(err.diagnostic().unwrap().column(), 4);
    /// ```
    pub fn column(&self) -> usize {
        self.inner.column
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.inner.rendered)
    }
}

/// Builds the text pest renders from: the source up to the offending line, then that line
/// with control characters replaced and cut to a window around the span (marked `...` where
/// cut). Returns the text, the span's start and end in it, and the span's true 1-based column.
fn display_window(source: &str, span: Span) -> (String, usize, usize, usize) {
    let floor = |mut i: usize| {
        i = i.min(source.len());
        while !source.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    let start = floor(span.start);
    let line_start = source[..start].rfind('\n').map_or(0, |i| i + 1);
    let mut line_end = source[start..]
        .find('\n')
        .map_or(source.len(), |i| start + i);
    if line_end > start && source.as_bytes()[line_end - 1] == b'\r' {
        line_end -= 1;
    }
    let end = floor(span.end.max(start)).min(line_end);
    let column = source[line_start..start].chars().count() + 1;
    let cut_from = if start - line_start > WINDOW_BEFORE {
        floor(start - WINDOW_BEFORE / 2)
    } else {
        line_start
    };
    let window_end = floor((end.max(start) + WINDOW_AFTER).min(line_end));

    let mut display = String::with_capacity(line_start + (window_end - cut_from) + 8);
    display.push_str(&source[..line_start]);
    if cut_from > line_start {
        display.push_str("...");
    }
    let mut new_start = None;
    let mut new_end = None;
    for (i, c) in source[cut_from..window_end].char_indices() {
        let at = cut_from + i;
        if at == start {
            new_start = Some(display.len());
        }
        if at == end {
            new_end = Some(display.len());
        }
        display.push(if c.is_control() && c != '\t' {
            '\u{fffd}'
        } else {
            c
        });
    }
    let tail = display.len();
    let new_start = new_start.unwrap_or(tail);
    let new_end = new_end.unwrap_or(tail).max(new_start);
    if window_end < line_end {
        display.push_str("...");
    }
    (display, new_start, new_end, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_like_rustc_with_path_line_and_caret() {
        let src = "model m\ndrift v: -mux*v\n";
        let d = Diagnostic::new(
            src,
            Some("m.sde"),
            Span::new(18, 21),
            "unknown identifier `mux`".into(),
            Some("did you mean `mu`?".into()),
        );
        assert_eq!((d.line(), d.column()), (2, 11));
        let text = d.to_string();
        assert!(
            text.starts_with("error: unknown identifier `mux`\n"),
            "{text}"
        );
        assert!(text.contains(" --> m.sde:2:11"), "{text}");
        assert!(text.contains("2 | drift v: -mux*v"), "{text}");
        assert!(text.contains("^-^"), "{text}");
        assert!(text.contains("= did you mean `mu`?"), "{text}");
    }

    #[test]
    fn control_characters_and_long_lines_are_not_echoed() {
        let mut src = String::from("model m\nparam a = 1\0+");
        src.push_str(&"x".repeat(100_000));
        let d = Diagnostic::new(&src, None, Span::new(20, 21), "bad".into(), None);
        let text = d.to_string();
        assert!(!text.contains('\0'));
        assert!(text.len() < 1000, "{} bytes", text.len());
        assert_eq!((d.line(), d.column()), (2, 13));
    }

    #[test]
    fn columns_far_into_a_line_stay_exact() {
        let mut src = "y".repeat(5000);
        src.push_str("ab");
        let d = Diagnostic::new(&src, None, Span::new(5001, 5002), "here".into(), None);
        assert_eq!((d.line(), d.column()), (1, 5002));
        assert!(d.to_string().len() < 1000);
    }

    #[test]
    fn a_span_at_the_end_of_input_is_rendered() {
        let d = Diagnostic::new("1 +", None, Span::new(3, 3), "expected".into(), None);
        assert_eq!((d.line(), d.column()), (1, 4));
    }
}
