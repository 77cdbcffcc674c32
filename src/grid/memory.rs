//! The estimated peak memory of a solve on n cells, which the `--cells` guard
//! ([`Cells::within`](super::Cells::within)) and the cells a tolerance may choose
//! ([`tolerance_cell_limit`](super::tolerance_cell_limit)) both hold to.

/// Bytes of peak memory per n·log₂ n unknowns (measured 241 to 259, with a margin).
const FILL_BYTES: f64 = 320.0;

/// [`Cells::memory_bytes`](super::Cells::memory_bytes) of `n` cells in all: the sparse LU's
/// fill at n·log₂ n under the nested-dissection order, plus 15 MB.
pub(super) fn bytes_of(n: usize) -> f64 {
    let n = n as f64;
    FILL_BYTES * n * n.log2().max(1.0) + 15e6
}
