//! A supernodal LU on the pattern of A + Aᵀ, with pivoting only inside the supernodes'
//! diagonal blocks: the factorisation the grid operator needs (docs/method.md, section 8).
//!
//! faer's sparse LU pivots by rows freely, so it must allocate the pattern of the Cholesky
//! factor of AᵀA (George and Ng's bound, whatever the pivots turn out to be). The grid
//! stencil reaches two cells each way, so AᵀA reaches four: at 80k cells that pattern needs
//! 1.5 times the entries and 3 times the multiply-adds of the pattern of A + Aᵀ. Free pivoting is
//! not needed here: without the pin row the operator is a generator matrix (zero column
//! sums, negative diagonal, off-diagonals mostly positive), whose proper principal
//! submatrices are nonsingular, and the pin row (p_pin = 1, only its diagonal) is ordered
//! last, where its pivot is exactly 1. So the elimination follows a symmetric ordering (the
//! caller's: nested dissection in the solver) with faer's supernodal symbolic Cholesky as
//! the pattern of L and Uᵀ, and each supernode's diagonal block is factorised with partial
//! pivoting among its own rows (which keeps the pattern). Since pivoting is restricted, the
//! caller checks the backward error of each solve and refines
//! ([`Factorization::checked_solve`]).

mod numeric;
mod pages;
mod permuted;

use super::error::FactorError;
use super::factorization::Factorization;
use super::pattern::union_with_transpose;
#[cfg(test)]
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_unit_lower_triangular_in_place;
use faer::perm::PermRef;
#[cfg(test)]
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, MatMut, MatRef, Par, Side};
use numeric::numeric;
use permuted::permute;
use std::sync::Arc;

#[cfg(test)]
use numeric::plan;

/// Supernodes whose off-diagonal block has at least this many entries are updated in the
/// substitutions by one dense matrix–vector product (SIMD, contiguous) and one scatter or
/// gather; smaller ones entry by entry, where the product's call would cost more.
const DENSE_UPDATE: usize = 64;

/// The LU factors of P A Pᵀ, ready to solve.
pub(crate) struct PatternLu {
    /// Shared by the refactorisations of matrices of one pattern ([`PatternLu::refactor`]).
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// P: row k of P A Pᵀ is row `fwd[k]` of A.
    fwd: Vec<usize>,
    /// Per supernode: the unit lower L11 and upper U11 in the diagonal block, L21 below it
    /// (faer's Cholesky value layout).
    l: Vec<f64>,
    /// Per supernode, the same layout: U12ᵀ below the (unused) diagonal block.
    u: Vec<f64>,
    /// Per supernode, its rows' order after pivoting in its diagonal block (local indices).
    pivots: Vec<usize>,
    /// max |L|, |U| / max |A|, the pivot growth.
    #[cfg(test)]
    pub(crate) growth: f64,
}

/// The fill-reducing symmetric ordering: AMD on A + Aᵀ with cell `last` moved to the end.
#[cfg(test)]
fn ordering(a: SymbolicSparseColMatRef<'_, usize>, last: usize) -> Result<Vec<usize>, FactorError> {
    let n = a.ncols();
    let nnz = a.compute_nnz();
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(n, nnz))
        .map_err(|e| FactorError::Analysis(format!("{e:?}")))?;
    amd::order(
        &mut fwd,
        &mut inv,
        a,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| FactorError::Analysis(format!("{e:?}")))?;
    fwd.retain(|&c| c != last);
    fwd.push(last);
    Ok(fwd)
}

impl PatternLu {
    /// Factorises the square matrix `a` whose row `last` is the unit row e_last, ordered by
    /// AMD on A + Aᵀ (measured against nested dissection, docs/method.md section 8).
    #[cfg(test)]
    pub(crate) fn new(
        a: SparseColMatRef<'_, usize, f64>,
        last: usize,
    ) -> Result<PatternLu, FactorError> {
        let fwd = ordering(a.symbolic(), last)?;
        PatternLu::factor(a, fwd, f64::INFINITY)
    }

    /// [`PatternLu::factor`] on one task or in parallel, refusing factors of more than
    /// `limit` bytes.
    fn ordered_with(
        a: SparseColMatRef<'_, usize, f64>,
        fwd: Vec<usize>,
        parallel: bool,
        limit: f64,
    ) -> Result<PatternLu, FactorError> {
        let n = a.ncols();
        let analysis = |e: &dyn std::fmt::Debug| FactorError::Analysis(format!("{e:?}"));
        let inv = inverse(&fwd);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let perm = PermRef::new_checked(&fwd, &inv, n);
        // The Cholesky analysis reads one triangle; A's pattern is not symmetric, so it is
        // given the pattern of A + Aᵀ.
        let sum = symmetric_pattern(a.symbolic());
        let symbolic = factorize_symbolic_cholesky(
            sum.as_ref(),
            Side::Upper,
            SymmetricOrdering::Custom(perm),
            params,
        )
        .map_err(|e| analysis(&e))?;
        if !matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
            return Err(FactorError::Analysis("not supernodal".into()));
        }
        PatternLu::numeric_with(a, fwd, inv, Arc::new(symbolic), parallel, limit, None)
    }

    /// Factorises `a`, whose pattern is that of the matrix `self` factorises (the caller
    /// compares them), in the same order, reusing the symbolic analysis: the numeric
    /// factorisation alone, the same bits as [`Factorization::factor`] on `a`.
    pub(crate) fn refactor(
        &self,
        a: SparseColMatRef<'_, usize, f64>,
        limit: f64,
    ) -> Result<PatternLu, FactorError> {
        let inv = inverse(&self.fwd);
        let symbolic = Arc::clone(&self.symbolic);
        PatternLu::numeric_with(a, self.fwd.clone(), inv, symbolic, true, limit, None)
    }

    /// [`PatternLu::refactor`] into this factorisation's own memory, which it consumes (a
    /// factorisation about to be dropped): the same bits, without mapping new pages.
    pub(crate) fn refactor_into(
        self,
        a: SparseColMatRef<'_, usize, f64>,
        limit: f64,
    ) -> Result<PatternLu, FactorError> {
        let inv = inverse(&self.fwd);
        let spare = Some((self.l, self.u, self.pivots));
        PatternLu::numeric_with(a, self.fwd, inv, self.symbolic, true, limit, spare)
    }

    /// The numeric factorisation of `a` in the order `fwd` (`inv` its inverse) on the
    /// supernodal analysis `symbolic`, refusing factors of more than `limit` bytes; into
    /// `spare`'s memory when it is an earlier factorisation's on this analysis.
    fn numeric_with(
        a: SparseColMatRef<'_, usize, f64>,
        fwd: Vec<usize>,
        inv: Vec<usize>,
        symbolic: Arc<SymbolicCholesky<usize>>,
        parallel: bool,
        limit: f64,
        spare: Option<numeric::Factors>,
    ) -> Result<PatternLu, FactorError> {
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return Err(FactorError::Analysis("not supernodal".into()));
        };
        // L and U, one value each per entry of the pattern: refused before allocation.
        let bytes = 16.0 * sym.len_val() as f64;
        if bytes > limit {
            return Err(FactorError::TooLarge { bytes, limit });
        }
        let p = permute(a, &inv);
        let (l, u, pivots) = numeric(sym, &p, parallel, spare)?;
        #[cfg(test)]
        let growth = {
            let scale = p.val.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            l.iter().chain(&u).fold(0.0f64, |m, v| m.max(v.abs())) / scale
        };
        Ok(PatternLu {
            symbolic,
            fwd,
            l,
            u,
            pivots,
            #[cfg(test)]
            growth,
        })
    }

    fn sym(&self) -> &SymbolicSupernodalCholesky<usize> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sym) => sym,
            SymbolicCholeskyRaw::Simplicial(_) => {
                unreachable!("checked in PatternLu::ordered_with")
            }
        }
    }

    /// Multiply-adds of the factorisation: Σ over columns of (ns + nr)·(nr + 1) per column
    /// of a supernode with ns columns and nr rows below, roughly.
    #[cfg(test)]
    pub(crate) fn flops(&self) -> f64 {
        let sym = self.sym();
        let (cpr, b, e) = (
            sym.col_ptr_for_row_idx(),
            sym.supernode_begin(),
            sym.supernode_end(),
        );
        (0..sym.n_supernodes())
            .map(|s| {
                let ns = (e[s] - b[s]) as f64;
                let nr = (cpr[s + 1] - cpr[s]) as f64;
                // Each column k of the block updates (rows below k) × (columns right of k).
                (0..e[s] - b[s])
                    .map(|k| (ns - k as f64 + nr) * (ns - k as f64 + nr))
                    .sum::<f64>()
            })
            .sum()
    }

    /// Entries of L and U (the stored values, explicit zeros of the supernodes included).
    #[cfg(test)]
    pub(crate) fn entries(&self) -> usize {
        2 * self.sym().len_val()
    }

    /// Solves A x = b in place (`b` in, x out): forward substitution through the supernodes
    /// (their pivots applied), then backward.
    fn substitute(&self, b: &mut [f64]) {
        self.substitute_with(b, DENSE_UPDATE);
    }

    /// [`PatternLu::substitute`], the supernodes with at least `dense` off-diagonal entries
    /// updated by dense products.
    fn substitute_with(&self, b: &mut [f64], dense: usize) {
        let sym = self.sym();
        let n = self.fwd.len();
        let mut y: Vec<f64> = self.fwd.iter().map(|&r| b[r]).collect();
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let (cpr, cpv, rows) = (
            sym.col_ptr_for_row_idx(),
            sym.col_ptr_for_val(),
            sym.row_idx(),
        );
        let mut seg = vec![0.0; n.min(4096)];
        // The widest supernode's rows below plus its columns: the dense updates' buffer.
        let widest = (0..sym.n_supernodes())
            .map(|s| (end[s] - begin[s]) + (cpr[s + 1] - cpr[s]))
            .max()
            .unwrap_or(0);
        let mut update = vec![0.0; widest];
        for s in 0..sym.n_supernodes() {
            let (s0, s1) = (begin[s], end[s]);
            let ns = s1 - s0;
            let pattern = &rows[cpr[s]..cpr[s + 1]];
            let ls = MatRef::from_column_major_slice(
                &self.l[cpv[s]..cpv[s + 1]],
                ns + pattern.len(),
                ns,
            );
            if seg.len() < ns {
                seg.resize(ns, 0.0);
            }
            for (k, &r) in self.pivots[s0..s1].iter().enumerate() {
                seg[k] = y[s0 + r];
            }
            y[s0..s1].copy_from_slice(&seg[..ns]);
            solve_unit_lower_triangular_in_place(
                ls.split_at_row(ns).0,
                MatMut::from_column_major_slice_mut(&mut y[s0..s1], ns, 1),
                Par::Seq,
            );
            let nr = pattern.len();
            if nr > 0 && ns * nr >= dense {
                // t = L21 x_s as one dense product, then one scatter.
                let t = &mut update[..nr];
                matmul(
                    MatMut::from_column_major_slice_mut(t, nr, 1),
                    Accum::Replace,
                    ls.split_at_row(ns).1,
                    MatRef::from_column_major_slice(&y[s0..s1], ns, 1),
                    1.0,
                    Par::Seq,
                );
                for (&r, &v) in pattern.iter().zip(t.iter()) {
                    y[r] -= v;
                }
            } else {
                let lcols = &self.l[cpv[s]..cpv[s + 1]];
                for j in 0..ns {
                    let x = y[s0 + j];
                    let col = &lcols[j * (ns + nr) + ns..(j + 1) * (ns + nr)];
                    for (&r, &v) in pattern.iter().zip(col) {
                        y[r] -= v * x;
                    }
                }
            }
        }
        for s in (0..sym.n_supernodes()).rev() {
            let (s0, s1) = (begin[s], end[s]);
            let ns = s1 - s0;
            let pattern = &rows[cpr[s]..cpr[s + 1]];
            let nr = pattern.len();
            let ucols = &self.u[cpv[s]..cpv[s + 1]];
            if nr > 0 && ns * nr >= dense {
                // x_s −= U12 y[pattern] as one dense product on the gathered values.
                let (gathered, acc) = update.split_at_mut(nr);
                for (g, &r) in gathered.iter_mut().zip(pattern) {
                    *g = y[r];
                }
                let acc = &mut acc[..ns];
                matmul(
                    MatMut::from_column_major_slice_mut(acc, ns, 1),
                    Accum::Replace,
                    MatRef::from_column_major_slice(ucols, ns + nr, ns)
                        .split_at_row(ns)
                        .1
                        .transpose(),
                    MatRef::from_column_major_slice(gathered, nr, 1),
                    1.0,
                    Par::Seq,
                );
                for (x, a) in y[s0..s1].iter_mut().zip(acc.iter()) {
                    *x -= a;
                }
            } else {
                for j in 0..ns {
                    let col = &ucols[j * (ns + nr) + ns..(j + 1) * (ns + nr)];
                    let acc: f64 = pattern.iter().zip(col).map(|(&r, &v)| v * y[r]).sum();
                    y[s0 + j] -= acc;
                }
            }
            let ls = MatRef::from_column_major_slice(&self.l[cpv[s]..cpv[s + 1]], ns + nr, ns);
            faer::linalg::triangular_solve::solve_upper_triangular_in_place(
                ls.split_at_row(ns).0,
                MatMut::from_column_major_slice_mut(&mut y[s0..s1], ns, 1),
                Par::Seq,
            );
        }
        for (k, &r) in self.fwd.iter().enumerate() {
            b[r] = y[k];
        }
    }
}

impl Factorization for PatternLu {
    /// The symmetric order (position → cell).
    type Ordering = Vec<usize>;

    /// Factorises `a` in the symmetric order `fwd`, disjoint subtrees of the supernodal
    /// elimination tree in parallel (the same bits as one task).
    fn factor(
        a: SparseColMatRef<'_, usize, f64>,
        fwd: Vec<usize>,
        limit: f64,
    ) -> Result<PatternLu, FactorError> {
        PatternLu::ordered_with(a, fwd, true, limit)
    }

    fn solve_in_place(&self, b: &mut [f64]) {
        self.substitute(b);
    }
}

/// The pattern of A + Aᵀ (values unused).
fn symmetric_pattern(
    a: SymbolicSparseColMatRef<'_, usize>,
) -> faer::sparse::SymbolicSparseColMat<usize> {
    let n = a.ncols();
    // Column c of A + Aᵀ: the rows of A's column c and the columns of A's row c, each column
    // then sorted and its repeats dropped in place.
    let (mut ptr, mut idx) = union_with_transpose(a, true);
    // Compacting never overtakes the reading: a column starts at or after its output.
    let mut write = 0;
    for c in 0..n {
        let (start, end) = (ptr[c], ptr[c + 1]);
        idx[start..end].sort_unstable();
        let first = write;
        for k in start..end {
            let r = idx[k];
            if write == first || idx[write - 1] != r {
                idx[write] = r;
                write += 1;
            }
        }
        ptr[c] = first;
    }
    ptr[n] = write;
    idx.truncate(write);
    faer::sparse::SymbolicSparseColMat::new_checked(n, n, ptr, None, idx)
}

/// The inverse of the permutation `fwd` (`inv[fwd[k]] = k`).
fn inverse(fwd: &[usize]) -> Vec<usize> {
    let mut inv = vec![0usize; fwd.len()];
    for (k, &c) in fwd.iter().enumerate() {
        inv[c] = k;
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::sparse::faer_lu::tests::system;
    use crate::numerics::sparse::faer_lu::{FaerLu, Ordering};

    /// The pattern of A + Aᵀ by its definition: each column's set of rows, from A's column
    /// and A's row.
    fn symmetric_pattern_by_sets(a: SymbolicSparseColMatRef<'_, usize>) -> Vec<Vec<usize>> {
        let mut cols = vec![std::collections::BTreeSet::new(); a.ncols()];
        for c in 0..a.ncols() {
            for &r in a.row_idx_of_col_raw(c) {
                cols[c].insert(r);
                cols[r].insert(c);
            }
        }
        cols.into_iter().map(|s| s.into_iter().collect()).collect()
    }

    /// The counted pattern of A + Aᵀ is the definition's, column by column, on the grid
    /// operators of both coordinate systems and on random patterns with repeats, empty
    /// columns and a dense row.
    #[test]
    fn symmetric_pattern_is_the_union_of_a_and_its_transpose() {
        let check = |a: SymbolicSparseColMatRef<'_, usize>| {
            let sum = symmetric_pattern(a);
            let sum = sum.as_ref();
            let expected = symmetric_pattern_by_sets(a);
            assert_eq!(sum.ncols(), a.ncols());
            for (c, rows) in expected.iter().enumerate() {
                assert_eq!(sum.row_idx_of_col_raw(c), rows.as_slice(), "column {c}");
            }
        };
        for file in [
            "models/vibro_duffing.sde",
            "models/vibro_impact_duffing.sde",
        ] {
            let (_, a, _) = system(file, 20, 40);
            check(a.symbolic());
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = |m: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m as u64) as usize
        };
        for n in [1, 2, 7, 50, 300] {
            let mut ptr = vec![0usize];
            let mut idx = Vec::new();
            for c in 0..n {
                // Unsorted rows with repeats; every fifth column empty; row 0 everywhere.
                if c % 5 != 4 {
                    idx.push(0);
                    for _ in 0..next(6) {
                        idx.push(next(n));
                    }
                }
                ptr.push(idx.len());
            }
            let a = faer::sparse::SymbolicSparseColMat::new_unsorted_checked(n, n, ptr, None, idx);
            check(a.as_ref());
        }
    }

    /// The LU on the pattern of A + Aᵀ, ordered by AMD and by nested dissection (the
    /// solver's), solves the grid system as faer's LU does, to rounding (3e-15 and 6e-15 of
    /// the largest value measured with AMD), on both coordinate systems.
    #[test]
    fn solves_as_faers_lu() {
        for file in [
            "models/vibro_duffing.sde",
            "models/vibro_impact_duffing.sde",
        ] {
            let (mesh, a, pin) = system(file, 40, 80);
            let n = mesh.cells();
            let mut p = vec![0.0; n];
            p[pin] = 1.0;
            FaerLu::factor(a.as_ref(), Ordering::Colamd, f64::INFINITY)
                .unwrap()
                .solve_in_place(&mut p);
            let coords = crate::grid::nested::cell_coords(mesh.nx, mesh.nv, false);
            let mut nd = crate::grid::nested::nested_dissection(a.symbolic(), &coords, 1);
            nd.retain(|&c| c != pin);
            nd.push(pin);
            for lu in [
                PatternLu::new(a.as_ref(), pin).unwrap(),
                PatternLu::factor(a.as_ref(), nd, f64::INFINITY).unwrap(),
            ] {
                let mut q = vec![0.0; n];
                q[pin] = 1.0;
                lu.solve_in_place(&mut q);
                let top = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let worst = p
                    .iter()
                    .zip(&q)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(lu.growth.is_finite() && lu.growth >= 1.0);
                assert!(worst <= 1e-12 * top, "{file}: {worst:e} of {top:e}");
            }
        }
    }

    /// The substitutions give the same solution whether each supernode is updated entry by
    /// entry or by a dense product, on a right-hand side with every entry set: all dense, all
    /// entry by entry and the production threshold (which uses both) agree to rounding.
    #[test]
    fn dense_and_entrywise_updates_agree() {
        let (mesh, a, pin) = system("models/vibro_impact_duffing.sde", 40, 80);
        let n = mesh.cells();
        let lu = PatternLu::new(a.as_ref(), pin).unwrap();
        let sym = lu.sym();
        let sizes: Vec<usize> = (0..sym.n_supernodes())
            .map(|s| {
                let ns = sym.supernode_end()[s] - sym.supernode_begin()[s];
                ns * (sym.col_ptr_for_row_idx()[s + 1] - sym.col_ptr_for_row_idx()[s])
            })
            .collect();
        // The production threshold splits the supernodes: both paths are exercised.
        assert!(sizes.iter().any(|&k| k > 0 && k < DENSE_UPDATE));
        assert!(sizes.iter().any(|&k| k >= DENSE_UPDATE));
        let b: Vec<f64> = (0..n)
            .map(|k| ((k * 7919) % 1000) as f64 / 1000.0 - 0.5)
            .collect();
        let solve = |dense: usize| {
            let mut x = b.clone();
            lu.substitute_with(&mut x, dense);
            x
        };
        let entrywise = solve(usize::MAX);
        let top = entrywise.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for dense in [0, DENSE_UPDATE] {
            let x = solve(dense);
            let worst = x
                .iter()
                .zip(&entrywise)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(
                worst <= 1e-12 * top,
                "dense from {dense}: {worst:e} of {top:e}"
            );
            assert_ne!(x, entrywise, "the dense path was not taken");
        }
    }

    /// Factors larger than the memory a solve may use are refused by the symbolic analysis,
    /// before any value is allocated, with their size.
    #[test]
    fn factors_beyond_the_limit_are_refused_before_allocation() {
        let (_, a, pin) = system("models/vibro_duffing.sde", 40, 80);
        let fwd = ordering(a.symbolic(), pin).unwrap();
        let lu = PatternLu::ordered_with(a.as_ref(), fwd.clone(), false, f64::INFINITY).unwrap();
        let bytes = 8.0 * lu.entries() as f64;
        let refused = PatternLu::ordered_with(a.as_ref(), fwd.clone(), false, 0.99 * bytes);
        assert!(
            matches!(refused, Err(FactorError::TooLarge { bytes: b, .. }) if b == bytes),
            "{:?}",
            refused.err()
        );
        assert!(PatternLu::ordered_with(a.as_ref(), fwd, false, bytes).is_ok());
    }

    /// The factors are the same bits in one task (supernodes in index order) and in parallel
    /// on 1, 2 and 3 threads, on both coordinate systems, and the parallel schedule does
    /// split the work (the supernodes are postordered and the root has two subtrees).
    #[test]
    fn factors_do_not_depend_on_the_thread_count() {
        for file in [
            "models/vibro_duffing.sde",
            "models/vibro_impact_duffing.sde",
        ] {
            let (mesh, a, pin) = system(file, 40, 80);
            let coords = crate::grid::nested::cell_coords(mesh.nx, mesh.nv, false);
            let mut nd = crate::grid::nested::nested_dissection(a.symbolic(), &coords, 1);
            nd.retain(|&c| c != pin);
            nd.push(pin);
            let one =
                PatternLu::ordered_with(a.as_ref(), nd.clone(), false, f64::INFINITY).unwrap();
            let p = plan(one.sym());
            assert!(p.contiguous, "{file}: supernodes not postordered");
            let total: f64 = p.roots.iter().map(|&r| p.cost[r]).sum();
            let split = (0..p.cost.len())
                .filter(|&s| p.cost[s] >= total / 64.0 && p.children[s].len() >= 2)
                .count();
            assert!(split >= 3, "{file}: {split} subtrees split");
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let lu = pool
                    .install(|| PatternLu::factor(a.as_ref(), nd.clone(), f64::INFINITY))
                    .unwrap();
                assert_eq!(bits(&lu.l), bits(&one.l), "{file}: L on {threads} threads");
                assert_eq!(bits(&lu.u), bits(&one.u), "{file}: U on {threads} threads");
                assert_eq!(lu.pivots, one.pivots, "{file}: pivots on {threads} threads");
            }
        }
    }

    /// The ordering table of docs/method.md section 8: stored entries of L and U,
    /// multiply-adds and time of faer's LU (COLAMD, pattern of AᵀA) and of this LU (pattern
    /// of A + Aᵀ) under AMD and nested dissection, by cell count. Run it with
    /// `cargo test --release --lib numerics::sparse::pattern_lu::tests::ordering_table -- --ignored --nocapture`.
    #[test]
    #[ignore = "a measurement, a minute long: prints the ordering table"]
    fn ordering_table() {
        use crate::grid::nested::{cell_coords, nested_dissection};
        println!("| model | cells | LU, ordering | L+U entries | multiply-adds | factor ms |");
        println!("|---|---|---|---|---|---|");
        let ms = |t: std::time::Instant| t.elapsed().as_secs_f64() * 1e3;
        for file in [
            "models/vibro_impact_duffing.sde",
            "models/vibro_duffing.sde",
        ] {
            let model = file.trim_start_matches("models/").trim_end_matches(".sde");
            for n in [50usize, 100, 200, 400] {
                let (_, a, pin) = system(file, n, 2 * n);
                let row = |name: &str, entries: f64, flops: f64, t: f64| {
                    println!(
                        "| {model} | {n}x{} | {name} | {entries:.2e} | {flops:.2e} | {t:.0} |",
                        2 * n
                    );
                };
                let t = std::time::Instant::now();
                let f = FaerLu::factor(a.as_ref(), Ordering::Colamd, f64::INFINITY).unwrap();
                // faer allocates L and U, each with the pattern of the Cholesky factor of AᵀA.
                row(
                    "faer, COLAMD on AᵀA",
                    2.0 * f.size.entries,
                    f.size.flops,
                    ms(t),
                );
                let t = std::time::Instant::now();
                let lu = PatternLu::new(a.as_ref(), pin).unwrap();
                row("A + Aᵀ, AMD", lu.entries() as f64, lu.flops(), ms(t));
                for hops in [1, 2] {
                    let t = std::time::Instant::now();
                    let coords = cell_coords(n, 2 * n, false);
                    let mut order = nested_dissection(a.symbolic(), &coords, hops);
                    order.retain(|&c| c != pin);
                    order.push(pin);
                    let lu = PatternLu::factor(a.as_ref(), order, f64::INFINITY).unwrap();
                    let name = format!("A + Aᵀ, ND {hops}-step separators");
                    row(&name, lu.entries() as f64, lu.flops(), ms(t));
                }
            }
        }
    }
}
