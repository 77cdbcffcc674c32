//! [`EFolds`]: a depth in e-folds (a ridge below the mode of exp(Q)) as a reader can use it.

/// A depth in e-folds of Q, printed with the digits a reader can use: one decimal below 100,
/// whole e-folds up to 1000, and "more than 1000" beyond (a ridge that deep holds no mass a
/// double can represent: e^−1000 underflows, so more digits would state nothing).
///
/// ```
/// use fpsolve::epc::EFolds;
/// assert_eq!(EFolds(16.24).to_string(), "16.2");
/// assert_eq!(EFolds(345.6).to_string(), "346");
/// assert_eq!(EFolds(1282645.4).to_string(), "more than 1000");
/// assert_eq!(EFolds(f64::INFINITY).to_string(), "more than 1000");
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EFolds(pub f64);

/// Beyond this depth the number is not printed: e^−1000 is below the smallest double.
const MOST_PRINTED: f64 = 1000.0;

impl std::fmt::Display for EFolds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = self.0;
        if d.is_nan() {
            f.write_str("an undefined number of")
        } else if d > MOST_PRINTED {
            write!(f, "more than {MOST_PRINTED}")
        } else if d.abs() >= 100.0 {
            write!(f, "{d:.0}")
        } else {
            write!(f, "{d:.1}")
        }
    }
}
