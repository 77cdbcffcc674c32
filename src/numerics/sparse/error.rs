//! Why a sparse factorisation or a checked solve failed: one enum for every
//! [`Factorization`](super::Factorization), so a caller that falls back from one to another
//! reports both failures in the same words.

/// 2³⁰ bytes, the unit of the size messages.
const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// Why a factorisation or a checked solve failed. `Display` is the sentence the grid's
/// refusal quotes.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(crate) enum FactorError {
    /// The symbolic analysis failed (memory, index overflow, a pattern it cannot use).
    #[error("symbolic analysis failed: {0}")]
    Analysis(String),
    /// A zero pivot at column `column` of the permuted matrix.
    #[error("zero pivot at column {column}")]
    ZeroPivot {
        /// The column of the permuted matrix.
        column: usize,
    },
    /// The factors would take `bytes`, more than the `limit` the caller allows (found by the
    /// symbolic analysis, before any value is allocated).
    #[error(
        "the factors need {:.1} GiB, more than the {:.1} GiB this solve may use",
        bytes / GIB,
        limit / GIB
    )]
    TooLarge {
        /// Bytes the factors need.
        bytes: f64,
        /// Bytes the caller allows.
        limit: f64,
    },
    /// faer's LU would take at least `bytes` (the Cholesky pattern of AᵀA for each of L and
    /// U), more than `limit`.
    #[error(
        "faer's LU needs at least {:.1} GiB, more than the {:.1} GiB this solve may use",
        bytes / GIB,
        limit / GIB
    )]
    FaerTooLarge {
        /// Bytes the factors need at least.
        bytes: f64,
        /// Bytes the caller allows.
        limit: f64,
    },
    /// faer refused (its error, printed).
    #[error("{0}")]
    Faer(String),
    /// The solve's normwise backward error stayed above `limit` after one step of iterative
    /// refinement (or is NaN).
    #[error("backward error {achieved:.1e} after refinement (limit {limit:.0e})")]
    BackwardError {
        /// ‖A x − b‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞) after refinement.
        achieved: f64,
        /// The largest backward error accepted.
        limit: f64,
    },
}

impl FactorError {
    /// faer's error `e`, printed as faer prints it.
    pub(crate) fn faer(e: impl std::fmt::Debug) -> FactorError {
        FactorError::Faer(format!("{e:?}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sentences the grid's refusal quotes.
    #[test]
    fn sentences() {
        let e = FactorError::BackwardError {
            achieved: 3.24e-9,
            limit: 1e-12,
        };
        assert_eq!(
            e.to_string(),
            "backward error 3.2e-9 after refinement (limit 1e-12)"
        );
        let e = FactorError::TooLarge {
            bytes: 3.0 * GIB,
            limit: 2.0 * GIB,
        };
        assert_eq!(
            e.to_string(),
            "the factors need 3.0 GiB, more than the 2.0 GiB this solve may use"
        );
        let e = FactorError::FaerTooLarge {
            bytes: 3.0 * GIB,
            limit: 2.0 * GIB,
        };
        assert_eq!(
            e.to_string(),
            "faer's LU needs at least 3.0 GiB, more than the 2.0 GiB this solve may use"
        );
        assert_eq!(
            FactorError::ZeroPivot { column: 7 }.to_string(),
            "zero pivot at column 7"
        );
    }
}
