//! Densities on a grid as CSV: one column for the grid variable, one per method.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{OutputDir, ReportError};

/// Densities of one variable tabulated on a common grid, e.g. the EPC solutions of two degrees
/// next to a Monte Carlo histogram and its standard error.
///
/// As CSV: a header `<variable>,<name1>,<name2>,...`, then one row per grid point. Numbers are
/// written in shortest round-trip form, so reading the file back gives the same `f64`s; a NaN
/// in a column (a value that is missing, e.g. no Monte Carlo sample in that bin) is written as
/// an empty field and read back as NaN.
///
/// ```
/// use fpsolve::report::PdfTable;
///
/// let table = PdfTable {
///     variable: "y".into(),
///     x: vec![0.0, 0.5],
///     columns: vec![
///         ("epc_n4".into(), vec![0.79, 0.61]),
///         ("mc".into(), vec![0.8, f64::NAN]),
///     ],
/// };
/// let text = table.to_csv()?;
/// assert_eq!(text, "y,epc_n4,mc\n0,0.79,0.8\n0.5,0.61,\n");
/// let back = PdfTable::parse_csv(&text)?;
/// assert_eq!(back.columns[0], table.columns[0]);
/// assert!(back.columns[1].1[1].is_nan());
/// # Ok::<(), fpsolve::report::TableError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct PdfTable {
    /// Name of the grid variable (the first header field), e.g. `y`.
    pub variable: String,
    /// Grid points; every one must be finite.
    pub x: Vec<f64>,
    /// Named columns, each as long as `x`; NaN marks a missing value.
    pub columns: Vec<(String, Vec<f64>)>,
}

/// What is wrong with a table to be written, or with CSV text to be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TableError {
    /// A column whose length differs from the grid's.
    #[error("column `{column}` has {found} values for {expected} grid points")]
    LengthMismatch {
        /// The column's name.
        column: String,
        /// Number of grid points.
        expected: usize,
        /// Number of values in the column.
        found: usize,
    },
    /// A grid point that is NaN or ±∞.
    #[error("grid point {index} of `{variable}` is {value}, not a finite number")]
    NonFiniteGrid {
        /// The grid variable's name.
        variable: String,
        /// Index of the grid point.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An infinite value in a column: unlike NaN it is not "missing", it is wrong.
    #[error("column `{column}` is {value} at grid point {index}")]
    InfiniteValue {
        /// The column's name.
        column: String,
        /// Index of the grid point.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A header name that is empty, repeated, or contains a comma, quote or line break.
    #[error(
        "`{name}` cannot be a CSV column name (empty, repeated, or contains , \" or a line break)"
    )]
    BadName {
        /// The name.
        name: String,
    },
    /// CSV text that is not a table of this shape.
    #[error("line {line}: {message}")]
    Parse {
        /// 1-based line number.
        line: usize,
        /// What is wrong there.
        message: String,
    },
}

impl PdfTable {
    /// Checks the table: finite grid, one value per grid point in every column, no infinite
    /// values, and header names that need no quoting and are unique.
    ///
    /// # Errors
    /// The first problem found, as a [`TableError`].
    pub fn validate(&self) -> Result<(), TableError> {
        let mut seen: Vec<&str> = Vec::with_capacity(self.columns.len() + 1);
        for name in std::iter::once(&self.variable).chain(self.columns.iter().map(|(n, _)| n)) {
            if name.is_empty() || name.contains([',', '"', '\n', '\r']) || seen.contains(&&**name) {
                return Err(TableError::BadName { name: name.clone() });
            }
            seen.push(name);
        }
        if let Some((index, &value)) = self.x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(TableError::NonFiniteGrid {
                variable: self.variable.clone(),
                index,
                value,
            });
        }
        for (column, values) in &self.columns {
            if values.len() != self.x.len() {
                return Err(TableError::LengthMismatch {
                    column: column.clone(),
                    expected: self.x.len(),
                    found: values.len(),
                });
            }
            if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| v.is_infinite())
            {
                return Err(TableError::InfiniteValue {
                    column: column.clone(),
                    index,
                    value,
                });
            }
        }
        Ok(())
    }

    /// The table as CSV text (after [`validate`](Self::validate)), with `\n` line ends.
    ///
    /// # Errors
    /// See [`validate`](Self::validate).
    pub fn to_csv(&self) -> Result<String, TableError> {
        self.validate()?;
        let mut out = String::with_capacity(24 * (self.columns.len() + 1) * (self.x.len() + 1));
        out.push_str(&self.variable);
        for (name, _) in &self.columns {
            out.push(',');
            out.push_str(name);
        }
        out.push('\n');
        for (i, &x) in self.x.iter().enumerate() {
            push_number(&mut out, x);
            for (_, values) in &self.columns {
                out.push(',');
                if !values[i].is_nan() {
                    push_number(&mut out, values[i]);
                }
            }
            out.push('\n');
        }
        Ok(out)
    }

    /// Writes the table atomically as `name` in `dir`; returns the file's path.
    ///
    /// # Errors
    /// [`ReportError::Table`] if the table is invalid, otherwise as
    /// [`OutputDir::write_atomic`].
    pub fn write_csv(&self, dir: &OutputDir, name: &str) -> Result<PathBuf, ReportError> {
        let path = dir.file_path(name)?;
        let text = self
            .to_csv()
            .map_err(|source| ReportError::Table { path, source })?;
        dir.write_atomic(name, text.as_bytes())
    }

    /// Parses CSV text in the form [`to_csv`](Self::to_csv) writes (empty fields become NaN;
    /// `\r\n` line ends and a missing final newline are accepted). The result is validated.
    ///
    /// # Errors
    /// [`TableError::Parse`] with the line number for malformed text, or a validation error.
    pub fn parse_csv(text: &str) -> Result<Self, TableError> {
        let mut lines = text.lines().enumerate();
        let (_, header) = lines.next().ok_or_else(|| TableError::Parse {
            line: 1,
            message: "empty file, expected a header".into(),
        })?;
        let mut names = header.split(',').map(str::to_string);
        let variable = names.next().unwrap_or_default();
        let mut columns: Vec<(String, Vec<f64>)> = names.map(|n| (n, Vec::new())).collect();
        let mut x = Vec::new();
        for (index, line) in lines {
            let line_no = index + 1;
            if line.is_empty() {
                return Err(TableError::Parse {
                    line: line_no,
                    message: "empty line".into(),
                });
            }
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != columns.len() + 1 {
                return Err(TableError::Parse {
                    line: line_no,
                    message: format!(
                        "{} fields, the header has {}",
                        fields.len(),
                        columns.len() + 1
                    ),
                });
            }
            let parse = |field: &str, missing_ok: bool| -> Result<f64, TableError> {
                if field.is_empty() && missing_ok {
                    return Ok(f64::NAN);
                }
                field.trim().parse::<f64>().map_err(|_| TableError::Parse {
                    line: line_no,
                    message: format!("`{field}` is not a number"),
                })
            };
            x.push(parse(fields[0], false)?);
            for (column, field) in columns.iter_mut().zip(&fields[1..]) {
                column.1.push(parse(field, true)?);
            }
        }
        let table = Self {
            variable,
            x,
            columns,
        };
        table.validate()?;
        Ok(table)
    }

    /// Reads a CSV file written by [`write_csv`](Self::write_csv).
    ///
    /// # Errors
    /// [`ReportError::Io`] if the file cannot be read or is not a regular file of at most
    /// [`MAX_RESULT_FILE_BYTES`](crate::base::input_file::MAX_RESULT_FILE_BYTES), [`ReportError::Table`]
    /// if its text is not a valid table.
    pub fn read_csv(path: impl AsRef<Path>) -> Result<Self, ReportError> {
        let path = path.as_ref();
        let text = crate::base::input_file::read_regular_text(
            path,
            crate::base::input_file::MAX_RESULT_FILE_BYTES,
        )
        .map_err(|source| ReportError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse_csv(&text).map_err(|source| ReportError::Table {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// A cell of a [`TextTable`].
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    /// A number, in the shortest text that parses back to it (NaN is an empty field).
    Number(f64),
    /// Text, in double quotes on one line (whitespace runs become one space).
    Text(String),
    /// A bare word (a status, a stage name): written as is.
    Word(String),
    /// Nothing.
    Empty,
}

/// A table of mixed cells under a header, as CSV: what a sweep writes (numbers beside status
/// words and messages). Numbers are written as [`PdfTable`] writes them.
///
/// ```
/// use fpsolve::report::{Cell, TextTable};
/// let table = TextTable {
///     header: vec!["eps".into(), "status".into(), "message".into()],
///     rows: vec![vec![Cell::Number(-0.25), Cell::Word("failed".into()), Cell::Text("a \"b\"\n c".into())]],
/// };
/// assert_eq!(table.to_csv(), "eps,status,message\n-0.25,failed,\"a \"\"b\"\" c\"\n");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct TextTable {
    /// Column names.
    pub header: Vec<String>,
    /// Rows; a row shorter than the header is padded with empty fields.
    pub rows: Vec<Vec<Cell>>,
}

impl TextTable {
    /// The table as CSV text with `\n` line ends.
    pub fn to_csv(&self) -> String {
        let mut out = self.header.join(",");
        out.push('\n');
        for row in &self.rows {
            for k in 0..self.header.len().max(row.len()) {
                if k > 0 {
                    out.push(',');
                }
                match row.get(k).unwrap_or(&Cell::Empty) {
                    Cell::Number(v) if !v.is_nan() => push_number(&mut out, *v),
                    Cell::Number(_) | Cell::Empty => {}
                    Cell::Word(w) => out.push_str(w),
                    Cell::Text(t) => {
                        let one_line = t.split_whitespace().collect::<Vec<_>>().join(" ");
                        out.push('"');
                        out.push_str(&one_line.replace('"', "\"\""));
                        out.push('"');
                    }
                }
            }
            out.push('\n');
        }
        out
    }

    /// Writes the table atomically as `name` in `dir`; returns the file's path.
    ///
    /// # Errors
    /// As [`OutputDir::write_atomic`].
    pub fn write_csv(&self, dir: &OutputDir, name: &str) -> Result<PathBuf, ReportError> {
        dir.write_atomic(name, self.to_csv().as_bytes())
    }
}

/// Shortest text that parses back to the same `f64`: plain decimals where they are short to
/// read, scientific notation for very small or large magnitudes (PDF tails reach 1e-12).
fn push_number(out: &mut String, v: f64) {
    let magnitude = v.abs();
    // Writing to a String cannot fail.
    if v == 0.0 || (1e-4..1e7).contains(&magnitude) {
        let _ = write!(out, "{v}");
    } else {
        let _ = write!(out, "{v:e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PdfTable {
        PdfTable {
            variable: "y".into(),
            x: vec![-1.5, 0.0, 1.0 / 3.0, 2.5e-9],
            columns: vec![
                ("epc_n2".into(), vec![1e-300, 0.1 + 0.2, 5e-13, 123456789.0]),
                ("mc".into(), vec![f64::NAN, 0.25, -0.0, 7e-5]),
            ],
        }
    }

    #[test]
    fn round_trip_is_bit_exact_and_keeps_missing_values() {
        let table = sample();
        let back = PdfTable::parse_csv(&table.to_csv().unwrap()).unwrap();
        assert_eq!(back.variable, "y");
        assert_eq!(back.x, table.x);
        for ((name, a), (name_b, b)) in table.columns.iter().zip(&back.columns) {
            assert_eq!(name, name_b);
            for (u, v) in a.iter().zip(b) {
                assert!(
                    u.to_bits() == v.to_bits() || (u.is_nan() && v.is_nan()),
                    "{u} vs {v}"
                );
            }
        }
    }

    #[test]
    fn number_format() {
        let text = sample().to_csv().unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "y,epc_n2,mc");
        assert_eq!(lines[1], "-1.5,1e-300,");
        assert_eq!(lines[2], "0,0.30000000000000004,0.25");
        assert_eq!(lines[4], "2.5e-9,1.23456789e8,7e-5");
        assert_eq!(lines[3], "0.3333333333333333,5e-13,-0");
    }

    #[test]
    fn rejects_bad_tables() {
        let mut t = sample();
        t.columns[1].1.pop();
        assert_eq!(
            t.validate(),
            Err(TableError::LengthMismatch {
                column: "mc".into(),
                expected: 4,
                found: 3
            })
        );
        let mut t = sample();
        t.x[2] = f64::NAN;
        assert!(matches!(
            t.to_csv(),
            Err(TableError::NonFiniteGrid { index: 2, .. })
        ));
        let mut t = sample();
        t.columns[0].1[1] = f64::INFINITY;
        assert!(matches!(
            t.to_csv(),
            Err(TableError::InfiniteValue { index: 1, .. })
        ));
        for bad in ["", "a,b", "q\"", "mc", "y"] {
            let mut t = sample();
            t.columns[0].0 = bad.into();
            assert_eq!(
                t.validate(),
                Err(TableError::BadName { name: bad.into() }),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn parse_errors_carry_line_numbers() {
        assert!(matches!(
            PdfTable::parse_csv(""),
            Err(TableError::Parse { line: 1, .. })
        ));
        assert!(matches!(
            PdfTable::parse_csv("y,a\n1,2\n3\n"),
            Err(TableError::Parse { line: 3, .. })
        ));
        assert!(matches!(
            PdfTable::parse_csv("y,a\n1,2\n3,x\n"),
            Err(TableError::Parse { line: 3, .. })
        ));
        // The grid variable may not be missing.
        assert!(matches!(
            PdfTable::parse_csv("y,a\n,2\n"),
            Err(TableError::Parse { line: 2, .. })
        ));
        let crlf = PdfTable::parse_csv("y,a\r\n1,2\r\n").unwrap();
        assert_eq!(crlf.columns, vec![("a".to_string(), vec![2.0])]);
    }

    #[test]
    fn write_csv_names_the_file_on_error() {
        let root = std::env::temp_dir().join(format!("fpsolve-csv-err-{}", std::process::id()));
        let dir = OutputDir::create(&root).unwrap();
        let mut t = sample();
        t.x[0] = f64::INFINITY;
        match t.write_csv(&dir, "pdf.csv") {
            Err(ReportError::Table { path, .. }) => assert_eq!(path, root.join("pdf.csv")),
            other => panic!("expected Table error, got {other:?}"),
        }
        assert!(!root.join("pdf.csv").exists());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
