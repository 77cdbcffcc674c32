//! The EPC degrees a run asks for, checked when they are read (`--degree 2,4,8`).

use std::fmt;
use std::str::FromStr;

use super::MAX_DEGREE;

/// A non-empty list of distinct, even EPC degrees in 2..=[`MAX_DEGREE`], in ascending order.
///
/// ```
/// use fpsolve::epc::DegreeList;
/// let d: DegreeList = "4, 2,8".parse().unwrap();
/// assert_eq!(d.as_slice(), &[2, 4, 8]);
/// let err = "4,4".parse::<DegreeList>().unwrap_err();
/// assert_eq!(err.to_string(), "degree 4 is given twice");
/// assert!("3".parse::<DegreeList>().unwrap_err().to_string().contains("odd"));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DegreeList(Vec<usize>);

/// Why a degree list was refused.
///
/// ```
/// use fpsolve::epc::{DegreeList, DegreeListError};
/// assert_eq!(DegreeList::new(&[2, 3]), Err(DegreeListError::Odd { degree: 3 }));
/// ```
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DegreeListError {
    /// No degree at all.
    #[error("no degree given (e.g. `2,4`)")]
    Empty,
    /// An entry that is not a whole number.
    #[error("`{text}` is not a whole number")]
    NotANumber {
        /// The entry.
        text: String,
    },
    /// A degree outside 2..=MAX_DEGREE.
    #[error("degree {degree} is outside the supported range 2 to {max}")]
    OutOfRange {
        /// The degree.
        degree: usize,
        /// The largest supported degree.
        max: usize,
    },
    /// An odd degree (exp(Q) with Q of odd degree is never normalisable).
    #[error(
        "degree {degree} is odd: exp(Q) with Q of odd degree is never normalisable (use even degrees, e.g. {} or {})",
        degree - 1,
        degree + 1
    )]
    Odd {
        /// The degree.
        degree: usize,
    },
    /// A degree listed twice.
    #[error("degree {degree} is given twice")]
    Duplicate {
        /// The degree.
        degree: usize,
    },
}

impl DegreeList {
    /// Checks a list of degrees (order does not matter: they are sorted).
    ///
    /// # Errors
    /// As [`DegreeListError`].
    ///
    /// ```
    /// use fpsolve::epc::DegreeList;
    /// assert_eq!(DegreeList::new(&[6, 2]).unwrap().as_slice(), &[2, 6]);
    /// assert!(DegreeList::new(&[]).is_err());
    /// ```
    pub fn new(degrees: &[usize]) -> Result<DegreeList, DegreeListError> {
        if degrees.is_empty() {
            return Err(DegreeListError::Empty);
        }
        let mut sorted = Vec::with_capacity(degrees.len());
        for &d in degrees {
            if !(2..=MAX_DEGREE).contains(&d) {
                return Err(DegreeListError::OutOfRange {
                    degree: d,
                    max: MAX_DEGREE,
                });
            }
            if d % 2 == 1 {
                return Err(DegreeListError::Odd { degree: d });
            }
            if sorted.contains(&d) {
                return Err(DegreeListError::Duplicate { degree: d });
            }
            sorted.push(d);
        }
        sorted.sort_unstable();
        Ok(DegreeList(sorted))
    }

    /// The degrees, ascending.
    ///
    /// ```
    /// let d = fpsolve::epc::DegreeList::new(&[4, 2]).unwrap();
    /// assert_eq!(d.as_slice(), &[2, 4]);
    /// ```
    pub fn as_slice(&self) -> &[usize] {
        &self.0
    }

    /// The largest degree.
    ///
    /// ```
    /// let d = fpsolve::epc::DegreeList::new(&[4, 8, 2]).unwrap();
    /// assert_eq!(d.max(), 8);
    /// ```
    pub fn max(&self) -> usize {
        *self.0.last().expect("a degree list is not empty")
    }
}

impl FromStr for DegreeList {
    type Err = DegreeListError;

    fn from_str(s: &str) -> Result<DegreeList, DegreeListError> {
        let mut degrees = Vec::new();
        for part in s.split(',') {
            let t = part.trim();
            if t.is_empty() && s.trim().is_empty() {
                return Err(DegreeListError::Empty);
            }
            let d = t
                .parse::<usize>()
                .map_err(|_| DegreeListError::NotANumber {
                    text: t.chars().take(40).collect(),
                })?;
            degrees.push(d);
        }
        DegreeList::new(&degrees)
    }
}

impl fmt::Display for DegreeList {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self.0.iter().map(|d| d.to_string()).collect();
        f.write_str(&parts.join(","))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_the_engine_would_answer_differently() {
        for (text, expected) in [
            ("", DegreeListError::Empty),
            (
                "0",
                DegreeListError::OutOfRange {
                    degree: 0,
                    max: MAX_DEGREE,
                },
            ),
            (
                "1",
                DegreeListError::OutOfRange {
                    degree: 1,
                    max: MAX_DEGREE,
                },
            ),
            (
                "14",
                DegreeListError::OutOfRange {
                    degree: 14,
                    max: MAX_DEGREE,
                },
            ),
            ("3", DegreeListError::Odd { degree: 3 }),
            ("2,4,4", DegreeListError::Duplicate { degree: 4 }),
            (
                "2,,4",
                DegreeListError::NotANumber {
                    text: String::new(),
                },
            ),
            ("-2", DegreeListError::NotANumber { text: "-2".into() }),
            ("4.0", DegreeListError::NotANumber { text: "4.0".into() }),
        ] {
            assert_eq!(text.parse::<DegreeList>(), Err(expected), "{text:?}");
        }
        assert_eq!("8,2".parse::<DegreeList>().unwrap().as_slice(), &[2, 8]);
        assert_eq!("12".parse::<DegreeList>().unwrap().max(), 12);
    }
}
