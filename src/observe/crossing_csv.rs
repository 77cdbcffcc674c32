//! The table `crossings_<q>.csv`: the levels of one quantity and, for each method, its
//! up-crossing rates with their stated relative accuracy.

use super::{CrossingCurve, CrossingError};

/// The file name of quantity `quantity`'s crossing table.
///
/// ```
/// assert_eq!(fpsolve::observe::crossings_file_name("y"), "crossings_y.csv");
/// ```
pub fn crossings_file_name(quantity: &str) -> String {
    format!("crossings_{quantity}.csv")
}

/// The CSV text of one quantity's crossing curves by several methods: a header
/// `u,<method>,…` with, after each method that estimates its discretisation error (the
/// grid), a column `<method>_error` (the bound on each rate's error,
/// [`CrossingCurve::error`], empty where the method states no bound); one line per level, numbers in Rust's shortest round-trip
/// form, `\n` line ends. An empty list gives the header `u` alone.
///
/// # Errors
/// [`CrossingError::Levels`] when the curves differ in quantity or levels.
///
/// ```
/// use fpsolve::observe::{crossings_csv, CrossingCurve};
/// let epc = CrossingCurve {
///     quantity: "z".into(),
///     levels: vec![0.0, 1.0],
///     rate: vec![0.25, 0.125],
///     accuracy: 1e-9,
///     discretisation: None,
/// };
/// let grid = CrossingCurve { rate: vec![0.25, 0.12], ..epc.clone() }
///     .with_discretisation(vec![0.5, 0.25]);
/// let text = crossings_csv(&[("epc_n4", &epc), ("grid", &grid)])?;
/// assert_eq!(
///     text,
///     "u,epc_n4,grid,grid_error\n0,0.25,0.25,0.50000000025\n1,0.125,0.12,0.25000000012\n"
/// );
/// # Ok::<(), fpsolve::observe::CrossingError>(())
/// ```
pub fn crossings_csv(curves: &[(&str, &CrossingCurve)]) -> Result<String, CrossingError> {
    let mut out = String::from("u");
    let Some((_, first)) = curves.first() else {
        out.push('\n');
        return Ok(out);
    };
    let mut errors = Vec::with_capacity(curves.len());
    for (method, curve) in curves {
        if curve.quantity != first.quantity
            || curve.levels != first.levels
            || curve.rate.len() != first.levels.len()
        {
            return Err(CrossingError::Levels {
                method: method.to_string(),
                quantity: first.quantity.clone(),
            });
        }
        out.push_str(&format!(",{method}"));
        let error = curve.error();
        if error.is_some() {
            out.push_str(&format!(",{method}_error"));
        }
        errors.push(error);
    }
    out.push('\n');
    for (i, u) in first.levels.iter().enumerate() {
        out.push_str(&u.to_string());
        for ((_, curve), error) in curves.iter().zip(&errors) {
            out.push_str(&format!(",{}", curve.rate[i]));
            if let Some(e) = error {
                // No bound (a level in the far tail, where the estimate is not trusted):
                // an empty field, never a number.
                match e[i] {
                    e if e.is_finite() => out.push_str(&format!(",{e}")),
                    _ => out.push(','),
                }
            }
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_on_different_levels_are_refused() {
        let a = CrossingCurve {
            quantity: "z".into(),
            levels: vec![0.0, 1.0],
            rate: vec![0.2, 0.1],
            accuracy: 1e-9,
            discretisation: None,
        };
        let b = CrossingCurve {
            levels: vec![0.0, 2.0],
            ..a.clone()
        };
        assert!(matches!(
            crossings_csv(&[("epc", &a), ("grid", &b)]),
            Err(CrossingError::Levels { ref method, .. }) if method == "grid"
        ));
        let short = CrossingCurve {
            rate: vec![0.2],
            ..a.clone()
        };
        assert!(matches!(
            crossings_csv(&[("epc", &a), ("grid", &short)]),
            Err(CrossingError::Levels { ref method, .. }) if method == "grid"
        ));
        assert_eq!(
            crossings_csv(&[
                ("epc", &a),
                ("grid", &a.clone().with_discretisation(vec![1e-3, 0.5]))
            ])
            .unwrap(),
            "u,epc,grid,grid_error\n0,0.2,0.2,0.0010000002\n1,0.1,0.1,0.5000000001\n"
        );
    }
}
