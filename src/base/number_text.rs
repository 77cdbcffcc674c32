//! Numbers in tables meant for reading: fixed-point as usual, scientific once the integer
//! part would be long. A run that blew up can have a finite mean of 1e280, which fixed-point
//! prints as 281 digits.

/// Magnitude from which [`fixed_or_scientific`] switches to scientific notation.
pub const SCIENTIFIC_FROM: f64 = 1e7;

/// `x` with `decimals` digits after the point when |x| < [`SCIENTIFIC_FROM`], else in
/// scientific notation with the same number of digits after the point; right-aligned to
/// `width`.
///
/// ```
/// use fpsolve::base::number_text::fixed_or_scientific;
/// assert_eq!(fixed_or_scientific(0.0245853, 6, 0), "0.024585");
/// assert_eq!(fixed_or_scientific(-1.5e280, 6, 0), "-1.500000e280");
/// assert_eq!(fixed_or_scientific(12.5, 2, 8), "   12.50");
/// assert_eq!(fixed_or_scientific(f64::NAN, 2, 0), "NaN");
/// ```
pub fn fixed_or_scientific(x: f64, decimals: usize, width: usize) -> String {
    if x.abs() < SCIENTIFIC_FROM || !x.is_finite() {
        format!("{x:>width$.decimals$}")
    } else {
        format!("{x:>width$.decimals$e}")
    }
}
