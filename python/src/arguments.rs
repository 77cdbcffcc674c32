//! Arguments the package's calls share, read as the command line reads the same flags: output
//! times (`--times`) and the grid's cells (`--cells`), each a `ValueError` naming the keyword
//! when it is out of range.

use fpsolve::job::passage::parse_times;
use pyo3::prelude::*;

use crate::errors;

/// Output times: the CLI's `A:B:N` text, or the times themselves (finite, non-negative,
/// non-decreasing, 1 to 100000 of them).
pub(crate) fn times_of(times: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    if let Ok(text) = times.extract::<String>() {
        return parse_times(&text).map_err(|e| errors::bad_argument(format!("times: {e}")));
    }
    let t: Vec<f64> = times.extract().map_err(|_| {
        errors::bad_argument("times: expected the text `FIRST:LAST:COUNT` or a sequence of times")
    })?;
    let ordered = t.windows(2).all(|w| w[0] <= w[1]);
    if t.is_empty()
        || t.len() > 100_000
        || !ordered
        || t.iter().any(|t| !(t.is_finite() && *t >= 0.0))
    {
        return Err(errors::bad_argument(format!(
            "times: expected 1 to 100000 finite, non-negative, non-decreasing times, got {} \
             values",
            t.len()
        )));
    }
    Ok(t)
}

/// The grid's cells `(nx, nv)` (even, at least 8 per axis, within the aspect the grid takes);
/// default [`fpsolve::grid::DEFAULT_CELLS`].
pub(crate) fn cells_of(cells: Option<[i64; 2]>) -> PyResult<[usize; 2]> {
    let cells = match cells {
        None => fpsolve::grid::DEFAULT_CELLS,
        Some([nx, nv]) => {
            let n = |c: i64| {
                usize::try_from(c).map_err(|_| {
                    errors::bad_argument(format!(
                        "cells: ({nx}, {nv}): expected even numbers of cells, at least 8 per axis"
                    ))
                })
            };
            [n(nx)?, n(nv)?]
        }
    };
    fpsolve::grid::check_cells(cells).map_err(|e| errors::bad_argument(format!("cells: {e}")))?;
    Ok(cells)
}
