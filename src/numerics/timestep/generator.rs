//! The operator A(t) of dp/dt = A(t) p, and the products and stage matrices the stepper
//! builds from it.

use std::borrow::Cow;

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};

use super::error::StepError;

/// A linear operator A(t) in compressed columns. A time-invariant one (a matrix) is
/// factorised once per step size; one that depends on t once per step size and stage time.
pub(crate) trait Generator {
    /// The number of unknowns.
    fn dim(&self) -> usize;
    /// Whether A is the same at every t.
    fn time_invariant(&self) -> bool;
    /// A at time `t`, or why it could not be built there ([`StepError::Operator`]).
    fn at(&self, t: f64) -> Result<Cow<'_, SparseColMat<usize, f64>>, StepError>;
}

impl Generator for SparseColMat<usize, f64> {
    fn dim(&self) -> usize {
        self.ncols()
    }

    fn time_invariant(&self) -> bool {
        true
    }

    fn at(&self, _t: f64) -> Result<Cow<'_, SparseColMat<usize, f64>>, StepError> {
        Ok(Cow::Borrowed(self))
    }
}

/// out = A y.
pub(crate) fn apply(a: &SparseColMat<usize, f64>, y: &[f64], out: &mut [f64]) {
    apply_ref(a.as_ref(), y, out);
}

/// out = A y, for A by reference (values in another matrix's pattern, say).
pub(crate) fn apply_ref(a: SparseColMatRef<'_, usize, f64>, y: &[f64], out: &mut [f64]) {
    out.iter_mut().for_each(|o| *o = 0.0);
    for (c, &yc) in y.iter().enumerate() {
        if yc == 0.0 {
            continue;
        }
        let rows = a.symbolic().row_idx_of_col_raw(c);
        for (&r, &v) in rows.iter().zip(a.val_of_col(c)) {
            out[r] += v * yc;
        }
    }
}

/// I − c A, with a diagonal entry in every column (A's columns sorted by row, as faer keeps
/// them).
pub(crate) fn shifted(a: &SparseColMat<usize, f64>, c: f64) -> SparseColMat<usize, f64> {
    shifted_ref(a.as_ref(), c)
}

/// I − c A for A by reference, as [`shifted`].
pub(crate) fn shifted_ref(a: SparseColMatRef<'_, usize, f64>, c: f64) -> SparseColMat<usize, f64> {
    let n = a.ncols();
    let mut ptr = Vec::with_capacity(n + 1);
    let mut rows = Vec::with_capacity(a.symbolic().compute_nnz() + n);
    let mut vals = Vec::with_capacity(a.symbolic().compute_nnz() + n);
    ptr.push(0);
    for col in 0..n {
        let mut diagonal = false;
        for (&r, &v) in a
            .symbolic()
            .row_idx_of_col_raw(col)
            .iter()
            .zip(a.val_of_col(col))
        {
            if r > col && !diagonal {
                rows.push(col);
                vals.push(1.0);
                diagonal = true;
            }
            if r == col {
                rows.push(r);
                vals.push(1.0 - c * v);
                diagonal = true;
            } else {
                rows.push(r);
                vals.push(-c * v);
            }
        }
        if !diagonal {
            rows.push(col);
            vals.push(1.0);
        }
        ptr.push(rows.len());
    }
    let symbolic = SymbolicSparseColMat::new_checked(n, n, ptr, None, rows);
    SparseColMat::new(symbolic, vals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::Triplet;

    #[test]
    fn shift_and_product() {
        // A with an empty column 1 and no diagonal in column 0.
        let t = [
            Triplet::new(1usize, 0usize, 2.0),
            Triplet::new(0, 2, 3.0),
            Triplet::new(2, 2, -1.0),
        ];
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(3, 3, &t).unwrap();
        let m = shifted(&a, 0.5);
        let dense = |m: &SparseColMat<usize, f64>| {
            let mut d = [[0.0; 3]; 3];
            #[allow(clippy::needless_range_loop)] // c is a column of m and of d
            for c in 0..3 {
                for (&r, &v) in m
                    .symbolic()
                    .row_idx_of_col_raw(c)
                    .iter()
                    .zip(m.val_of_col(c))
                {
                    d[r][c] += v;
                }
            }
            d
        };
        assert_eq!(
            dense(&m),
            [[1.0, 0.0, -1.5], [-1.0, 1.0, 0.0], [0.0, 0.0, 1.5]]
        );
        let mut out = [0.0; 3];
        apply(&a, &[1.0, 5.0, 2.0], &mut out);
        assert_eq!(out, [6.0, 2.0, -2.0]);
    }
}
