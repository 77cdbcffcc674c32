//! The report stage, last in the pipeline: CSV tables, JSON summaries and figures, written
//! atomically into an output directory. It takes plain data (grids, columns, curves, any
//! `Serialize` value) and knows nothing of how it was computed, so the methods, the study,
//! the sweep, the job and the CLI hand their results here without this module depending on
//! them.
//!
//! Every file goes through [`OutputDir::write_atomic`]: a run that dies part-way leaves either
//! the old file or the complete new one, never a truncated file with the final name.
//!
//! ```
//! use fpsolve::report::{write_json, OutputDir, PdfTable};
//!
//! # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-report-{}", std::process::id()));
//! let dir = OutputDir::create(&tmp)?;
//! let table = PdfTable {
//!     variable: "y".into(),
//!     x: vec![0.0, 0.5, 1.0],
//!     columns: vec![("epc_n4".into(), vec![0.8, 0.6, 0.2])],
//! };
//! table.write_csv(&dir, "pdf_y.csv")?;
//! write_json(&dir, "summary.json", &serde_json::json!({ "mean": 0.41 }))?;
//! assert!(tmp.join("pdf_y.csv").is_file() && tmp.join("summary.json").is_file());
//! # std::fs::remove_dir_all(&tmp).unwrap();
//! # Ok::<(), fpsolve::report::ReportError>(())
//! ```

#![warn(missing_docs)]

mod csv;
mod figure;
mod font;
mod json;
mod output;
mod run_dir;

use std::path::PathBuf;

/// Where a run came from: the model's module, re-exported where the writers use it.
pub use crate::model::{set_command, ModelSource, Provenance, SCHEMA_VERSION};
pub use csv::{Cell, PdfTable, TableError, TextTable};
pub use figure::error::FigureError;
pub use figure::render::FigureFiles;
pub use figure::{Band, Curve, CurveStyle, LineFigure, PanelFigure, PdfFigure, Points};
pub(crate) use json::check_finite;
pub use json::{
    json_flagging_undefined, undefined_fields, write_json, write_json_flagging_undefined,
    UndefinedField,
};
pub use output::OutputDir;
pub use run_dir::{abandon_unfinished, Abandoned, RunDir, RunDirError, MARKER};

/// Why writing or reading a report file failed. Every variant names the file (or directory)
/// concerned, so a message is actionable on its own.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// An operating-system error while creating, writing, syncing, renaming or reading.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory concerned.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The run's files were put in place, complete, but flushing one of them (or a
    /// directory) to disk failed: a crash before the system writes them back may lose them.
    /// The result is not discarded for it; the run reports it as this error.
    #[error(
        "the results were written to {}, but flushing {} to disk failed ({source}): a crash \
         before the system writes them back may lose them",
        dest.display(),
        path.display()
    )]
    NotFlushed {
        /// The run's output directory, in place.
        dest: PathBuf,
        /// The file or directory whose flush failed.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A file name that is not a plain name inside the output directory (empty, `.`/`..`,
    /// or containing a path separator).
    #[error("{}: `{name}` is not a plain file name", path.display())]
    BadFileName {
        /// The output directory.
        path: PathBuf,
        /// The rejected name.
        name: String,
    },
    /// A table that cannot be written, or a CSV file that cannot be read back.
    #[error("{}: {source}", path.display())]
    Table {
        /// The CSV file.
        path: PathBuf,
        /// What is wrong with the table or the text.
        source: TableError,
    },
    /// A value that contains NaN or ±∞ where JSON needs a number (serde_json would silently
    /// write `null`).
    #[error("{}: field `{field}` is {value}, which JSON cannot represent", path.display())]
    NonFiniteJson {
        /// The JSON file.
        path: PathBuf,
        /// JSONPath of the offending field, e.g. `$.moments.mean[2]`.
        field: String,
        /// The offending value.
        value: f64,
    },
    /// A value that serde refused to serialise (e.g. a map with non-string keys).
    #[error("{}: {source}", path.display())]
    Json {
        /// The JSON file.
        path: PathBuf,
        /// The serialiser's error.
        source: serde_json::Error,
    },
    /// An output directory that cannot take a run (locked, foreign files, not a directory).
    #[error(transparent)]
    RunDir(#[from] RunDirError),
    /// A figure that cannot be drawn from the data given, or a drawing failure.
    #[error("{}: {source}", path.display())]
    Figure {
        /// The figure file.
        path: PathBuf,
        /// What went wrong.
        source: FigureError,
    },
}

/// A count for a legend or title, exact: [`short_number`]'s form when it says the same number
/// (`6e8`), every digit otherwise (`401408`, never a rounded `401400`).
///
/// ```
/// assert_eq!(fpsolve::report::count_text(600_000_000), "6e8");
/// assert_eq!(fpsolve::report::count_text(401_408), "401408");
/// ```
pub fn count_text(n: u64) -> String {
    let short = short_number(n as f64);
    // Counts beyond 2^53 are not exact as f64: every digit then.
    match short.parse::<f64>() {
        Ok(v) if n < (1 << 53) && v == n as f64 => short,
        _ => n.to_string(),
    }
}

/// A number for a legend or title: at most four significant digits, no trailing zeros, in
/// exponent form outside [1e−4, 1e6) (`{}` of an f64 writes every digit of 1e56).
///
/// ```
/// assert_eq!(fpsolve::report::short_number(0.15915494309189535), "0.1592");
/// assert_eq!(fpsolve::report::short_number(4.0e9), "4e9");
/// ```
pub fn short_number(v: f64) -> String {
    let rounded: f64 = format!("{v:.3e}").parse().unwrap_or(v);
    crate::model::number(rounded)
}
