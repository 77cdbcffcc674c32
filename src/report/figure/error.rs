//! Why a figure could not be drawn.

/// Why a figure could not be drawn.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FigureError {
    /// Nothing to draw: no series, or no finite value in any of them.
    #[error("nothing to draw: no finite data")]
    NoData,
    /// A density figure whose data has no positive value, so its log panel has no range.
    #[error("no positive density value to draw on a log scale")]
    NoPositiveValues,
    /// Two vectors of one series with different lengths.
    #[error("`{series}`: {field} has {found} values for {expected} abscissae")]
    LengthMismatch {
        /// The series' label.
        series: String,
        /// Which vector: `y` or `stderr`.
        field: &'static str,
        /// Length of `x`.
        expected: usize,
        /// Length of the other vector.
        found: usize,
    },
    /// An abscissa that is NaN or ±∞.
    #[error("`{series}`: x[{index}] is {value}, not a finite number")]
    NonFiniteX {
        /// The series' label.
        series: String,
        /// Index of the value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// An infinite ordinate, or a negative or infinite standard error.
    #[error("`{series}`: {field}[{index}] is {value}")]
    BadValue {
        /// The series' label.
        series: String,
        /// Which vector: `y` or `stderr`.
        field: &'static str,
        /// Index of the value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The bundled font could not be loaded (a build defect).
    #[error("the bundled font could not be loaded")]
    Font,
    /// plotters failed to draw.
    #[error("drawing failed: {0}")]
    Drawing(String),
    /// The PNG encoder failed.
    #[error("PNG encoding failed: {0}")]
    Encoding(String),
    /// Values further apart on one axis than the largest floating-point number: no axis
    /// holds them.
    #[error(
        "the {axis} values span from {} to {}, further than the largest floating-point number",
        crate::model::number(*lo),
        crate::model::number(*hi)
    )]
    Span {
        /// `x` or `y`.
        axis: &'static str,
        /// The axis' lower end.
        lo: f64,
        /// The axis' upper end.
        hi: f64,
    },
}

/// A plotters failure as a [`FigureError`].
pub(super) fn drawing_error<E: std::fmt::Display>(e: E) -> FigureError {
    FigureError::Drawing(e.to_string())
}
