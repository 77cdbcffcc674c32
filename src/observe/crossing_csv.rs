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
/// `u,<method>,<method>_accuracy,…` and one line per level, numbers in Rust's shortest
/// round-trip form, `\n` line ends. An empty list gives the header `u` alone.
///
/// # Errors
/// [`CrossingError::Levels`] when the curves differ in quantity or levels.
///
/// ```
/// use fpsolve::observe::{crossings_csv, CrossingCurve};
/// let curve = CrossingCurve {
///     quantity: "z".into(),
///     levels: vec![0.0, 1.0],
///     rate: vec![0.25, 0.125],
///     accuracy: 1e-9,
/// };
/// let text = crossings_csv(&[("grid", &curve)])?;
/// assert_eq!(text, "u,grid,grid_accuracy\n0,0.25,0.000000001\n1,0.125,0.000000001\n");
/// # Ok::<(), fpsolve::observe::CrossingError>(())
/// ```
pub fn crossings_csv(curves: &[(&str, &CrossingCurve)]) -> Result<String, CrossingError> {
    let mut out = String::from("u");
    let Some((_, first)) = curves.first() else {
        out.push('\n');
        return Ok(out);
    };
    for (method, curve) in curves {
        if curve.quantity != first.quantity || curve.levels != first.levels {
            return Err(CrossingError::Levels {
                method: method.to_string(),
                quantity: first.quantity.clone(),
            });
        }
        out.push_str(&format!(",{method},{method}_accuracy"));
    }
    out.push('\n');
    for (i, u) in first.levels.iter().enumerate() {
        out.push_str(&u.to_string());
        for (_, curve) in curves {
            out.push_str(&format!(",{},{}", curve.rate[i], curve.accuracy));
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
        };
        let b = CrossingCurve {
            levels: vec![0.0, 2.0],
            ..a.clone()
        };
        assert!(matches!(
            crossings_csv(&[("epc", &a), ("grid", &b)]),
            Err(CrossingError::Levels { ref method, .. }) if method == "grid"
        ));
        assert_eq!(
            crossings_csv(&[("epc", &a), ("grid", &a.clone().with_accuracy(1e-3))]).unwrap(),
            "u,epc,epc_accuracy,grid,grid_accuracy\n0,0.2,0.000000001,0.2,0.001\n\
             1,0.1,0.000000001,0.1,0.001\n"
        );
    }
}
