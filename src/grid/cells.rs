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
    /// A count that is odd or below 8.
    #[error("{nx},{nv}: each count must be even and at least 8")]
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
    /// n = NX·NV unknowns, whose fill grows like n·√n on a two-dimensional grid, and the
    /// solution's own arrays. Measured peak resident memory of `fpsolve solve` on
    /// `models/linear.sde` above the 50 MB of a run without the grid: 125 MB at 140×280,
    /// 340 MB at 200×400, 780 MB at 280×560 (12.6 to 16 bytes per n·√n); on
    /// `models/vibro_impact_duffing.sde`, with the error estimate's solve alongside the main
    /// one: 440 MB at 200×400, 990 MB at 280×560, 2.2 GB at 392×800 (17, 15, 12 bytes per
    /// n·√n: the fill grows more slowly than n·√n). The estimate takes 24, 1.4 to 2 times
    /// that.
    ///
    /// ```
    /// let c = fpsolve::grid::Cells([140, 280]);
    /// assert!(c.memory_bytes() < 1e9);
    /// ```
    pub fn memory_bytes(&self) -> f64 {
        let n = (self.0[0] * self.0[1]) as f64;
        FILL_BYTES * n * n.sqrt() + 200.0 * n
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
        let bytes = self.memory_bytes();
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

/// Bytes of LU factor per n·√n (measured 12.6 to 16, with a margin).
const FILL_BYTES: f64 = 24.0;

/// The memory a grid solve may use: the memory available on the machine (`MemAvailable` of
/// `/proc/meminfo`), at most [`crate::mc::MEMORY_LIMIT_BYTES`]; that limit where the machine
/// does not say.
pub fn memory_limit_bytes() -> f64 {
    let cap = crate::mc::MEMORY_LIMIT_BYTES;
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(cap, |kb| (kb * 1024.0).min(cap))
}
