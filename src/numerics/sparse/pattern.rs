//! Sparsity patterns built from a matrix's pattern alone: the union of A and Aᵀ, which both
//! the grid's nested dissection and the pattern LU's symbolic analysis start from.

use faer::sparse::SymbolicSparseColMatRef;

/// The pattern of A + Aᵀ as lists: entry k's list is `next[start[k]..start[k + 1]]`, the
/// rows of A's column k and the columns of A's row k, in the order A's entries come (column by
/// column), repeats kept; the diagonal entries only `with_diagonal` (then twice each).
pub(crate) fn union_with_transpose(
    a: SymbolicSparseColMatRef<'_, usize>,
    with_diagonal: bool,
) -> (Vec<usize>, Vec<usize>) {
    let n = a.ncols();
    let kept = |r: usize, c: usize| with_diagonal || r != c;
    let mut start = vec![0usize; n + 1];
    for c in 0..n {
        for &r in a.row_idx_of_col_raw(c) {
            if kept(r, c) {
                start[r + 1] += 1;
                start[c + 1] += 1;
            }
        }
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut fill = start[..n].to_vec();
    let mut next = vec![0usize; start[n]];
    for c in 0..n {
        for &r in a.row_idx_of_col_raw(c) {
            if kept(r, c) {
                next[fill[r]] = c;
                fill[r] += 1;
                next[fill[c]] = r;
                fill[c] += 1;
            }
        }
    }
    (start, next)
}
