//! The [`Factorization`] trait: factor a square sparse matrix once, solve for as many
//! right-hand sides as needed, and check each solve by its backward error.

use faer::sparse::SparseColMatRef;

use super::error::FactorError;

/// When a solve is accepted: the backward error above which one step of iterative refinement
/// is taken, and the largest backward error accepted after it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Check {
    /// Refine when the backward error exceeds this.
    pub(crate) refine_above: f64,
    /// Fail when the backward error (after refinement) exceeds this, or is NaN.
    pub(crate) limit: f64,
}

/// A factorisation of a square sparse matrix A: built once by [`Factorization::factor`], then
/// [`Factorization::solve_in_place`] for each right-hand side, and
/// [`Factorization::checked_solve`] when the result must be trusted.
///
/// Implementations: [`PatternLu`](super::pattern_lu::PatternLu) (pivoting only inside its
/// supernodes, so its solves must be checked) and [`FaerLu`](super::faer_lu::FaerLu) (faer's
/// LU with row pivoting). An iterative solver fits as a third: `factor` builds its
/// preconditioner (an incomplete LU, say) within the memory limit, `solve_in_place` runs the
/// iteration from the preconditioned start, and the same `checked_solve` judges the result,
/// so a caller that falls back from one implementation to the next needs no new logic.
pub(crate) trait Factorization: Sized {
    /// What fixes the elimination order (a permutation, or a rule to compute one).
    type Ordering;

    /// Factorises `a` in `ordering`, refusing factors of more than `limit` bytes before any
    /// value is allocated.
    fn factor(
        a: SparseColMatRef<'_, usize, f64>,
        ordering: Self::Ordering,
        limit: f64,
    ) -> Result<Self, FactorError>;

    /// Solves A x = b in place (`b` in, x out), unchecked.
    fn solve_in_place(&self, b: &mut [f64]);

    /// Solves A x = `b`, takes one step of iterative refinement when the backward error
    /// exceeds `check.refine_above`, and fails when it still exceeds `check.limit`.
    fn checked_solve(
        &self,
        a: SparseColMatRef<'_, usize, f64>,
        b: &[f64],
        check: Check,
    ) -> Result<Vec<f64>, FactorError> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x);
        let mut error = backward_error(a, &x, b);
        if error > check.refine_above {
            let mut r = residual(a, &x, b);
            self.solve_in_place(&mut r);
            x.iter_mut().zip(&r).for_each(|(x, d)| *x += d);
            error = backward_error(a, &x, b);
        }
        if error.is_nan() || error > check.limit {
            return Err(FactorError::BackwardError {
                achieved: error,
                limit: check.limit,
            });
        }
        Ok(x)
    }

    /// Solves A x = `b` with this factorisation of another matrix M of A's pattern (A at a
    /// nearby time, say) as the preconditioner of x ← x + M⁻¹(b − A x), from x = M⁻¹b, until
    /// the backward error is within `limit` (as [`Factorization::checked_solve`]'s); returns
    /// x and the corrections taken. `None` when `sweeps` corrections do not reach `limit` or
    /// a correction does not halve the residual (M too far from A: factorise A instead).
    fn preconditioned_solve(
        &self,
        a: SparseColMatRef<'_, usize, f64>,
        b: &[f64],
        limit: f64,
        sweeps: usize,
    ) -> Option<(Vec<f64>, usize)> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x);
        let scale = row_sum_norm(a);
        let norm = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let b_norm = norm(b);
        let mut last = f64::INFINITY;
        for taken in 0..=sweeps {
            let mut r = residual(a, &x, b);
            let size = norm(&r);
            let error = size / (scale * norm(&x) + b_norm);
            if error <= limit {
                return Some((x, taken));
            }
            if taken == sweeps || size.is_nan() || size > 0.5 * last {
                return None;
            }
            last = size;
            self.solve_in_place(&mut r);
            x.iter_mut().zip(&r).for_each(|(x, d)| *x += d);
        }
        None
    }
}

/// ‖A‖∞, the largest row sum of |A|.
fn row_sum_norm(a: SparseColMatRef<'_, usize, f64>) -> f64 {
    let mut row_sums = vec![0.0f64; a.nrows()];
    for c in 0..a.ncols() {
        let rows = a.symbolic().row_idx_of_col_raw(c);
        for (&row, &v) in rows.iter().zip(a.val_of_col(c)) {
            row_sums[row] += v.abs();
        }
    }
    row_sums.iter().fold(0.0f64, |m, x| m.max(*x))
}

/// b − A x.
fn residual(a: SparseColMatRef<'_, usize, f64>, x: &[f64], b: &[f64]) -> Vec<f64> {
    let mut r = b.to_vec();
    for (c, &x) in x.iter().enumerate() {
        let rows = a.symbolic().row_idx_of_col_raw(c);
        for (&row, &v) in rows.iter().zip(a.val_of_col(c)) {
            r[row] -= v * x;
        }
    }
    r
}

/// ‖A x − b‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞), the normwise backward error of a solve.
fn backward_error(a: SparseColMatRef<'_, usize, f64>, x: &[f64], b: &[f64]) -> f64 {
    let r = residual(a, x, b);
    let norm = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    norm(&r) / (row_sum_norm(a) * norm(x) + norm(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};

    /// A "factorisation" whose solve is wrong by a factor of three.
    struct Tripled;

    impl Factorization for Tripled {
        type Ordering = ();

        fn factor(
            _: SparseColMatRef<'_, usize, f64>,
            _: (),
            _: f64,
        ) -> Result<Tripled, FactorError> {
            Ok(Tripled)
        }

        fn solve_in_place(&self, b: &mut [f64]) {
            b.iter_mut().for_each(|x| *x *= 3.0);
        }
    }

    /// A solve with a factor of 2I: the preconditioner of a nearby diagonal matrix.
    struct Doubled;

    impl Factorization for Doubled {
        type Ordering = ();

        fn factor(
            _: SparseColMatRef<'_, usize, f64>,
            _: (),
            _: f64,
        ) -> Result<Doubled, FactorError> {
            Ok(Doubled)
        }

        fn solve_in_place(&self, b: &mut [f64]) {
            b.iter_mut().for_each(|x| *x *= 0.5);
        }
    }

    /// The iteration preconditioned by 2I solves diag(2.2, 2, 1.9) x = b to the limit in a
    /// few corrections, and gives up on diag(5, 2, 2), on which it would diverge.
    #[test]
    fn a_nearby_factor_preconditions_the_solve() {
        let diagonal = |d: [f64; 3]| {
            let t: Vec<_> = (0..3).map(|i| Triplet::new(i, i, d[i])).collect();
            SparseColMat::<usize, f64>::try_new_from_triplets(3, 3, &t).unwrap()
        };
        let b = [1.0, -2.0, 3.0];
        let near = diagonal([2.2, 2.0, 1.9]);
        let (x, sweeps) = Doubled
            .preconditioned_solve(near.as_ref(), &b, 1e-12, 20)
            .unwrap();
        assert!((1..=12).contains(&sweeps), "{sweeps}");
        for (x, exact) in x.iter().zip([1.0 / 2.2, -1.0, 3.0 / 1.9]) {
            assert!((x - exact).abs() < 1e-11, "{x} vs {exact}");
        }
        let far = diagonal([5.0, 2.0, 2.0]);
        assert!(Doubled
            .preconditioned_solve(far.as_ref(), &b, 1e-12, 20)
            .is_none());
    }

    /// A solve that is wrong fails the check, refinement with the same wrong solve included;
    /// the identity passes it.
    #[test]
    fn wrong_solves_fail_the_check() {
        let t = [
            Triplet::new(0usize, 0usize, 1.0),
            Triplet::new(1, 1, 1.0),
            Triplet::new(2, 2, 1.0),
        ];
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(3, 3, &t).unwrap();
        let check = Check {
            refine_above: 1e-14,
            limit: 1e-12,
        };
        let b = [0.5, -1.0, 2.0];
        let wrong = Tripled::factor(a.as_ref(), (), 0.0).unwrap();
        let result = wrong.checked_solve(a.as_ref(), &b, check);
        assert!(
            matches!(result, Err(FactorError::BackwardError { achieved, .. }) if achieved > 0.1),
            "{result:?}"
        );
        let identity = a.as_ref();
        assert!(backward_error(identity, &b, &b) == 0.0);
    }
}
