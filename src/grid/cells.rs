//! The grid solver's cells as `--cells NX,NV` gives them, checked before any work: even, at
//! least 8 per axis, and the sparse factorisation's memory within what the machine has.

use std::fmt;
use std::str::FromStr;

/// Cells of the grid solver, (position, velocity).
///
/// ```
/// use fpsolve::grid::{Cells, CellsError};
/// let c: Cells = "140,280".parse()?;
/// assert_eq!(c.0, [140, 280]);
/// assert!(matches!("141,280".parse::<Cells>(), Err(CellsError::Invalid { .. })));
/// assert!(matches!("6,280".parse::<Cells>(), Err(CellsError::Invalid { .. })));
/// assert!(matches!("140x280".parse::<Cells>(), Err(CellsError::Syntax { .. })));
/// # Ok::<(), CellsError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cells(pub [usize; 2]);

impl Default for Cells {
    /// [`crate::grid::DEFAULT_CELLS`].
    fn default() -> Self {
        Cells(super::DEFAULT_CELLS)
    }
}

/// Why a `--cells` value is refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CellsError {
    /// Not two whole numbers separated by a comma.
    #[error("`{text}` is not NX,NV (two whole numbers, e.g. 140,280)")]
    Syntax {
        /// The text given.
        text: String,
    },
    /// A count that is odd or below 8, or one more than 64 times the other.
    #[error("{nx},{nv}: each count must be even, at least 8, and within 64 times the other")]
    Invalid {
        /// Cells along the position.
        nx: usize,
        /// Cells along the velocity.
        nv: usize,
    },
    /// The sparse LU factorisation would need more memory than the machine has.
    #[error(
        "{nx},{nv}: the sparse factorisation needs about {:.1} GiB, more than the {:.1} GiB \
         this run may use",
        bytes / GIB,
        limit_bytes / GIB
    )]
    TooMuchMemory {
        /// Cells along the position.
        nx: usize,
        /// Cells along the velocity.
        nv: usize,
        /// The estimate.
        bytes: f64,
        /// The limit.
        limit_bytes: f64,
    },
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

impl FromStr for Cells {
    type Err = CellsError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let syntax = || CellsError::Syntax {
            text: s.to_string(),
        };
        let (a, b) = s.split_once(',').ok_or_else(syntax)?;
        let nx: usize = a.trim().parse().map_err(|_| syntax())?;
        let nv: usize = b.trim().parse().map_err(|_| syntax())?;
        if super::check_cells([nx, nv]).is_err() {
            return Err(CellsError::Invalid { nx, nv });
        }
        Ok(Cells([nx, nv]))
    }
}

impl fmt::Display for Cells {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.0[0], self.0[1])
    }
}

impl Cells {
    /// The estimated peak memory of a solve, in bytes: the sparse LU factors of the
    /// n = NX·NV unknowns and the solution's own arrays. The nested-dissection order keeps the
    /// factors' fill at n·log₂ n on a two-dimensional grid (not n·√n), so the estimate is
    /// 320 bytes per n·log₂ n plus 15 MB: above the whole process's peak resident memory
    /// (the error estimate's half-cells solve included) at every size `benches/grid_cells.sh`
    /// measures, by a factor 1.3 to 1.6 (the test below holds the measured peaks), so that
    /// the guard neither lets a solve run out of memory nor refuses one that fits.
    ///
    /// ```
    /// let c = fpsolve::grid::Cells([140, 280]);
    /// assert!(c.memory_bytes() < 1e9);
    /// ```
    pub fn memory_bytes(&self) -> f64 {
        super::memory::bytes_of(self.0[0] * self.0[1])
    }

    /// Checks [`Cells::memory_bytes`] against `limit_bytes`.
    ///
    /// # Errors
    /// [`CellsError::TooMuchMemory`] with the estimate.
    ///
    /// ```
    /// use fpsolve::grid::{Cells, CellsError};
    /// assert!(Cells([140, 280]).within(4e9).is_ok());
    /// assert!(matches!(Cells([20000, 20000]).within(4e9), Err(CellsError::TooMuchMemory { .. })));
    /// ```
    pub fn within(&self, limit_bytes: f64) -> Result<(), CellsError> {
        self.within_at_once(limit_bytes, 1)
    }

    /// Checks that `at_once` solves of these cells side by side (a sweep's points on
    /// several threads, each with its own factorisation) fit in `limit_bytes`.
    ///
    /// # Errors
    /// [`CellsError::TooMuchMemory`] with the estimate of all of them together.
    ///
    /// ```
    /// use fpsolve::grid::Cells;
    /// let one = Cells([200, 400]).memory_bytes();
    /// assert!(Cells([200, 400]).within_at_once(2.5 * one, 2).is_ok());
    /// assert!(Cells([200, 400]).within_at_once(2.5 * one, 3).is_err());
    /// ```
    pub fn within_at_once(&self, limit_bytes: f64, at_once: usize) -> Result<(), CellsError> {
        let bytes = self.memory_bytes() * at_once.max(1) as f64;
        if bytes > limit_bytes {
            return Err(CellsError::TooMuchMemory {
                nx: self.0[0],
                nv: self.0[1],
                bytes,
                limit_bytes,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate covers every measured peak (whole process `fpsolve solve
    /// models/vibro_impact_duffing.sde --method grid`, 2 threads, `benches/grid_cells.sh`) and
    /// is at most 1.6 times it: the guard neither lets a solve run out of memory nor refuses
    /// one that fits in much less.
    #[test]
    fn the_memory_estimate_covers_the_measured_peaks_closely() {
        let measured_mb = [
            ([100, 200], 74.0),
            ([200, 400], 314.0),
            ([392, 800], 1378.0),
            ([560, 1120], 2886.0),
        ];
        for (cells, mb) in measured_mb {
            let ratio = Cells(cells).memory_bytes() / (mb * 1e6);
            assert!(
                (1.0..1.6).contains(&ratio),
                "{cells:?}: estimate / measured = {ratio}"
            );
        }
    }

    /// 560×1120 fits under the 4 GiB cap, alone; twice its cells, or two of it at once, do not.
    #[test]
    fn the_cap_admits_627k_cells_and_refuses_twice_that() {
        let cap = crate::base::limits::MEMORY_LIMIT_BYTES;
        assert!(Cells([560, 1120]).within(cap).is_ok());
        assert!(Cells([560, 1120]).within_at_once(cap, 2).is_err());
        assert!(matches!(
            Cells([800, 1600]).within(cap),
            Err(CellsError::TooMuchMemory { .. })
        ));
    }
}
