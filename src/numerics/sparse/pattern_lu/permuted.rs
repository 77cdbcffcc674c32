//! P A Pᵀ in the two layouts the numeric phase reads: by columns and by rows.

use faer::sparse::SparseColMatRef;

/// P A Pᵀ in compressed columns (`by_col`) and compressed rows (`by_row`, i.e. its
/// transpose in compressed columns), each as (pointers, indices, values).
pub(super) struct Permuted {
    pub(super) col_ptr: Vec<usize>,
    pub(super) row_idx: Vec<usize>,
    pub(super) val: Vec<f64>,
    pub(super) row_ptr: Vec<usize>,
    pub(super) col_idx: Vec<usize>,
    pub(super) tval: Vec<f64>,
}

pub(super) fn permute(a: SparseColMatRef<'_, usize, f64>, inv: &[usize]) -> Permuted {
    let n = a.ncols();
    let nnz = a.compute_nnz();
    let mut col_ptr = vec![0usize; n + 1];
    let mut row_ptr = vec![0usize; n + 1];
    for c in 0..n {
        for &r in a.symbolic().row_idx_of_col_raw(c) {
            col_ptr[inv[c] + 1] += 1;
            row_ptr[inv[r] + 1] += 1;
        }
    }
    for k in 0..n {
        col_ptr[k + 1] += col_ptr[k];
        row_ptr[k + 1] += row_ptr[k];
    }
    let (mut row_idx, mut val) = (vec![0usize; nnz], vec![0.0; nnz]);
    let (mut col_idx, mut tval) = (vec![0usize; nnz], vec![0.0; nnz]);
    let (mut cfill, mut rfill) = (col_ptr.clone(), row_ptr.clone());
    for c in 0..n {
        let vals = a.val_of_col(c);
        for (&r, &v) in a.symbolic().row_idx_of_col_raw(c).iter().zip(vals) {
            let (pr, pc) = (inv[r], inv[c]);
            row_idx[cfill[pc]] = pr;
            val[cfill[pc]] = v;
            cfill[pc] += 1;
            col_idx[rfill[pr]] = pc;
            tval[rfill[pr]] = v;
            rfill[pr] += 1;
        }
    }
    Permuted {
        col_ptr,
        row_idx,
        val,
        row_ptr,
        col_idx,
        tval,
    }
}
