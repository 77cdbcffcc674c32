//! faer's supernodal sparse LU (free row pivoting, the pattern of AᵀA) with a column ordering
//! of our choice. The grid falls back to it when the pattern LU ([`super::pattern_lu`],
//! pivoting only inside its supernodes) fails its backward-error check; it is also the tests'
//! reference and a row of the ordering table (docs/method.md, section 8).
//!
//! faer's `sp_lu` always orders by COLAMD, so the symbolic analysis is done here with faer's
//! public building blocks (column elimination tree, postorder, column counts of AᵀA,
//! supernodal symbolic LU), the steps `sp_lu` takes, with our column permutation in place of
//! COLAMD's.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::lu::supernodal::{
    factorize_supernodal_numeric_lu, factorize_supernodal_numeric_lu_scratch,
    factorize_supernodal_symbolic_lu, factorize_supernodal_symbolic_lu_scratch, SupernodalLu,
    SymbolicSupernodalLu,
};
use faer::sparse::linalg::{colamd, qr};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, Par};

use super::error::FactorError;
use super::factorization::Factorization;

/// The fill-reducing column ordering of the LU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Ordering {
    /// faer's default (approximate minimum degree on AᵀA).
    Colamd,
    /// A given column order (position → column): the grid's nested dissection, measured
    /// against COLAMD only.
    #[cfg(test)]
    Given(Vec<usize>),
}

/// The size of a factorisation from its symbolic analysis: entries and flops of the
/// Cholesky factor of AᵀA, the pattern faer allocates for L and U.
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FactorSize {
    /// Σ column counts.
    pub(crate) entries: f64,
    /// Σ column counts².
    pub(crate) flops: f64,
}

/// faer's numeric LU factorisation, ready to solve.
pub(crate) struct FaerLu {
    lu: SupernodalLu<usize, f64>,
    row_fwd: Vec<usize>,
    row_inv: Vec<usize>,
    col_fwd: Vec<usize>,
    col_inv: Vec<usize>,
    par: Par,
    /// The symbolic size (for the ordering table).
    #[cfg(test)]
    pub(crate) size: FactorSize,
}

/// The column permutation (fwd, inv) of `a` by `ordering`.
fn order(
    a: SymbolicSparseColMatRef<'_, usize>,
    ordering: &Ordering,
) -> Result<(Vec<usize>, Vec<usize>), FactorError> {
    let n = a.ncols();
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    match ordering {
        Ordering::Colamd => {
            let req = colamd::order_scratch::<usize>(n, n, a.compute_nnz());
            let mut mem = MemBuffer::try_new(req).map_err(FactorError::faer)?;
            colamd::order(
                &mut fwd,
                &mut inv,
                a,
                Default::default(),
                MemStack::new(&mut mem),
            )
            .map_err(FactorError::faer)?;
        }
        #[cfg(test)]
        Ordering::Given(given) => {
            fwd.clone_from(given);
            for (new, &old) in fwd.iter().enumerate() {
                inv[old] = new;
            }
        }
    }
    Ok((fwd, inv))
}

impl Factorization for FaerLu {
    type Ordering = Ordering;

    /// Factorises the square matrix `a` (its columns ordered by `ordering`) with faer's
    /// supernodal LU, the steps of faer's `sp_lu` with the ordering ours. With
    /// [`Ordering::Colamd`] the factors are those of `sp_lu`, bit for bit.
    fn factor(
        a: SparseColMatRef<'_, usize, f64>,
        ordering: Ordering,
        limit: f64,
    ) -> Result<FaerLu, FactorError> {
        let par = faer::get_global_parallelism();
        let n = a.ncols();
        let (col_fwd, col_inv) = order(a.symbolic(), &ordering)?;
        let col_perm = PermRef::new_checked(&col_fwd, &col_inv, n);
        let sym = a.symbolic();
        let at = a.transpose().to_col_major().map_err(FactorError::faer)?;
        let req = StackReq::any_of(&[
            qr::col_etree_scratch::<usize>(n, n),
            qr::postorder_scratch::<usize>(n),
            qr::column_counts_aat_scratch::<usize>(n, n),
            factorize_supernodal_symbolic_lu_scratch::<usize>(n, n),
        ]);
        let mut mem = MemBuffer::try_new(req).map_err(FactorError::faer)?;
        let stack = MemStack::new(&mut mem);
        let mut etree = vec![0usize; n];
        let mut post = vec![0usize; n];
        let mut col_counts = vec![0usize; n];
        let mut min_col = vec![0usize; n];
        let etree = qr::col_etree(sym, Some(col_perm), &mut etree, stack);
        qr::postorder(&mut post, etree, stack);
        qr::column_counts_ata(
            &mut col_counts,
            &mut min_col,
            at.symbolic(),
            Some(col_perm),
            etree,
            &post,
            stack,
        );
        // L and U hold at least the Cholesky pattern of AᵀA each: refused before allocation.
        let entries: f64 = col_counts.iter().map(|&c| c as f64).sum();
        if 16.0 * entries > limit {
            return Err(FactorError::FaerTooLarge {
                bytes: 16.0 * entries,
                limit,
            });
        }
        #[cfg(test)]
        let size = FactorSize {
            entries: col_counts.iter().map(|&c| c as f64).sum(),
            flops: col_counts.iter().map(|&c| (c as f64) * (c as f64)).sum(),
        };
        let symbolic: SymbolicSupernodalLu<usize> = factorize_supernodal_symbolic_lu(
            sym,
            Some(col_perm),
            &min_col,
            etree,
            &col_counts,
            stack,
            Default::default(),
        )
        .map_err(FactorError::faer)?;
        drop(mem);
        let req =
            factorize_supernodal_numeric_lu_scratch::<usize, f64>(&symbolic, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(FactorError::faer)?;
        let mut lu = SupernodalLu::new();
        let (mut row_fwd, mut row_inv) = (vec![0usize; n], vec![0usize; n]);
        factorize_supernodal_numeric_lu(
            &mut row_fwd,
            &mut row_inv,
            &mut lu,
            a,
            at.as_ref(),
            col_perm,
            &symbolic,
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .map_err(FactorError::faer)?;
        Ok(FaerLu {
            lu,
            row_fwd,
            row_inv,
            col_fwd,
            col_inv,
            par,
            #[cfg(test)]
            size,
        })
    }

    fn solve_in_place(&self, b: &mut [f64]) {
        self.solve_either(b, false);
    }
}

impl FaerLu {
    /// Solves Aᵀ x = b in place (`b` in, x out), unchecked: the same factors serve the
    /// transposed system (the first-passage solver's backward operator Kᵀ is factorised,
    /// and its forward K's solves for the quasi-stationary density come from it).
    pub(crate) fn solve_transpose_in_place(&self, b: &mut [f64]) {
        self.solve_either(b, true);
    }

    /// A x = b, or Aᵀ x = b when `transpose`, in place.
    fn solve_either(&self, b: &mut [f64], transpose: bool) {
        let n = self.col_fwd.len();
        let mut work = Mat::<f64>::zeros(n, 1);
        let row = PermRef::new_checked(&self.row_fwd, &self.row_inv, n);
        let col = PermRef::new_checked(&self.col_fwd, &self.col_inv, n);
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        if transpose {
            self.lu.solve_transpose_in_place_with_conj(
                row,
                col,
                Conj::No,
                rhs,
                self.par,
                work.as_mut(),
            );
        } else {
            self.lu
                .solve_in_place_with_conj(row, col, Conj::No, rhs, self.par, work.as_mut());
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::grid::assemble::{assemble, matrix};
    use crate::grid::mesh::{Domain, Mesh};
    use crate::grid::nested::{cell_coords, nested_dissection};
    use crate::grid::problem::Mechanical;
    use faer::linalg::solvers::SolveCore;
    use faer::sparse::{SparseColMat, Triplet};

    /// The operator of `file` (r = 0.95) on `nx` × `nv` cells of the domain the solver sizes
    /// for the paper's case 1, pinned at v = 0 on the wall or at the centre (where the
    /// density is large: a pin in the tail scales the solution up by orders of magnitude).
    pub(crate) fn system(
        file: &str,
        nx: usize,
        nv: usize,
    ) -> (Mesh, SparseColMat<usize, f64>, usize) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
        let b = crate::model::load_model(&path).unwrap().bind(&[]).unwrap();
        let problem = Mechanical::new(&crate::dynamics::Dynamics::read(&b)).unwrap();
        let x = if file.contains("impact") {
            [0.0, 9.9645]
        } else {
            [-9.9645, 9.9645]
        };
        let d = Domain {
            x,
            v: [-21.5452, 21.5452],
        };
        let mesh = Mesh::new(d, nx, nv, &problem.barriers, 4);
        let op = assemble(&mesh, &problem).unwrap();
        let wall = mesh.exits.iter().any(|e| e.from == e.into);
        let pin = mesh.index(if wall { 0 } else { nx / 2 }, nv / 2);
        let a = matrix(mesh.cells(), &op, pin);
        (mesh, a, pin)
    }

    /// The column-bucketed matrix has the pattern of faer's triplet conversion, and its
    /// values up to the order in which duplicates are summed.
    #[test]
    fn matrix_is_the_triplet_conversion() {
        for file in [
            "models/vibro_duffing.sde",
            "tests/models/grid_impact_duffing.sde",
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
            let b = crate::model::load_model(&path).unwrap().bind(&[]).unwrap();
            let problem = Mechanical::new(&crate::dynamics::Dynamics::read(&b)).unwrap();
            let d = Domain {
                x: [-6.0, 6.0],
                v: [-9.0, 9.0],
            };
            let mesh = Mesh::new(d, 24, 36, &problem.barriers, 4);
            let op = assemble(&mesh, &problem).unwrap();
            let n = mesh.cells();
            let pin = 7 * 36 + 20;
            let mut entries: Vec<Triplet<usize, usize, f64>> = op
                .transport
                .iter()
                .chain(&op.outflow)
                .chain(&op.reinjection)
                .filter(|e| e.row != pin)
                .copied()
                .collect();
            entries.push(Triplet {
                row: pin,
                col: pin,
                val: 1.0,
            });
            let reference = SparseColMat::try_new_from_triplets(n, n, &entries).unwrap();
            let ours = matrix(n, &op, pin);
            assert_eq!(ours.symbolic().col_ptr(), reference.symbolic().col_ptr());
            assert_eq!(ours.symbolic().row_idx(), reference.symbolic().row_idx());
            let scale = ours.val().iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for (a, b) in ours.val().iter().zip(reference.val()) {
                assert!((a - b).abs() <= 1e-14 * scale, "{file}: {a} vs {b}");
            }
        }
    }

    /// With COLAMD, [`FaerLu`] solves bit for bit as faer's `sp_lu` does; nested dissection
    /// solves the same system to rounding.
    #[test]
    fn factor_is_faers_lu() {
        for file in [
            "models/vibro_duffing.sde",
            "models/vibro_impact_duffing.sde",
        ] {
            let (mesh, a, pin) = system(file, 40, 80);
            let n = mesh.cells();
            let mut reference = faer::Mat::<f64>::zeros(n, 1);
            reference[(pin, 0)] = 1.0;
            a.sp_lu()
                .unwrap()
                .solve_in_place_with_conj(Conj::No, reference.as_mut());
            let mut p = vec![0.0; n];
            p[pin] = 1.0;
            FaerLu::factor(a.as_ref(), Ordering::Colamd, f64::INFINITY)
                .unwrap()
                .solve_in_place(&mut p);
            assert!((0..n).all(|k| p[k].to_bits() == reference[(k, 0)].to_bits()));
            let coords = cell_coords(mesh.nx, mesh.nv, false);
            let nd = Ordering::Given(nested_dissection(a.symbolic(), &coords, 2));
            let mut q = vec![0.0; n];
            q[pin] = 1.0;
            FaerLu::factor(a.as_ref(), nd, f64::INFINITY)
                .unwrap()
                .solve_in_place(&mut q);
            let top = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = p
                .iter()
                .zip(&q)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst <= 1e-9 * top, "{file}: {worst:e} of {top:e}");
        }
    }

    /// The transposed solve from the same factors solves Aᵀ x = b: its residual against Aᵀ
    /// is at rounding level.
    #[test]
    fn transpose_solve_solves_the_transpose() {
        let (mesh, a, _) = system("models/vibro_duffing.sde", 40, 80);
        let n = mesh.cells();
        let lu = FaerLu::factor(a.as_ref(), Ordering::Colamd, f64::INFINITY).unwrap();
        let b: Vec<f64> = (0..n).map(|k| 1.0 + (k % 7) as f64).collect();
        let mut x = b.clone();
        lu.solve_transpose_in_place(&mut x);
        // (Aᵀ x)_c = Σ_r A[r, c] x_r: column c of A against x.
        let worst = (0..n)
            .map(|c| {
                let rows = a.symbolic().row_idx_of_col_raw(c);
                let atx: f64 = rows
                    .iter()
                    .zip(a.val_of_col(c))
                    .map(|(&r, v)| v * x[r])
                    .sum();
                (atx - b[c]).abs()
            })
            .fold(0.0f64, f64::max);
        let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(worst <= 1e-9 * scale.max(1.0), "{worst:e}");
    }

    /// The main solve and the error estimate's half-cells solve run side by side; the result
    /// (density and estimate) is the same bit for bit on one thread as on two.
    #[test]
    fn solve_is_the_same_on_one_and_two_threads() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/vibro_impact_duffing.sde");
        let b = crate::model::load_model(&path).unwrap().bind(&[]).unwrap();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                crate::grid::GridSolver::new(&b)
                    .cells(60, 120)
                    .solve()
                    .unwrap()
            })
        };
        let (one, two) = (run(1), run(2));
        assert!(one
            .density
            .iter()
            .zip(&two.density)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        let (e1, e2) = (
            one.report.discretisation_estimate.unwrap(),
            two.report.discretisation_estimate.unwrap(),
        );
        assert_eq!(
            (e1.x.to_bits(), e1.v.to_bits()),
            (e2.x.to_bits(), e2.v.to_bits())
        );
        assert!(e1.x > 0.0 && e1.v > 0.0);
    }

    /// The ordering table of docs/method.md section 8: factor entries, flops, memory and
    /// time of COLAMD and nested dissection by cell count. Run it with
    /// `cargo test --release --lib numerics::sparse::faer_lu::tests::ordering_table -- --ignored --nocapture`.
    #[test]
    #[ignore = "a measurement, minutes long: prints the ordering table"]
    fn ordering_table() {
        println!("model | cells | ordering | factor entries | flops | factor MB | order+factor ms | solve ms");
        for file in [
            "models/vibro_impact_duffing.sde",
            "models/vibro_duffing.sde",
        ] {
            for n in [50, 100, 200, 400] {
                let (mesh, a, pin) = system(file, n, 2 * n);
                let fold = mesh.exits.iter().any(|e| e.from == e.into);
                // (name, nested dissection's (hops, v folded), or COLAMD)
                let orderings = [
                    ("COLAMD", None),
                    ("ND, 1-step separators", Some((1, false))),
                    ("ND, 2-step separators", Some((2, false))),
                    ("ND, 2-step, v folded", Some((2, true))),
                ];
                for (name, nd) in orderings {
                    if name.contains("folded") && !fold {
                        continue;
                    }
                    if name.contains("1-step") && n > 100 {
                        continue;
                    }
                    let t = std::time::Instant::now();
                    let ordering = match nd {
                        None => Ordering::Colamd,
                        Some((hops, fold)) => {
                            let coords = cell_coords(mesh.nx, mesh.nv, fold);
                            Ordering::Given(nested_dissection(a.symbolic(), &coords, hops))
                        }
                    };
                    let f = FaerLu::factor(a.as_ref(), ordering, f64::INFINITY).unwrap();
                    let factor_ms = t.elapsed().as_secs_f64() * 1e3;
                    let mut p = vec![0.0; mesh.cells()];
                    p[pin] = 1.0;
                    let t = std::time::Instant::now();
                    f.solve_in_place(&mut p);
                    let solve_ms = t.elapsed().as_secs_f64() * 1e3;
                    println!(
                        "{file} | {}x{} | {name} | {:.3e} | {:.3e} | {:.0} | {factor_ms:.0} | {solve_ms:.1}",
                        mesh.nx,
                        mesh.nv,
                        f.size.entries,
                        f.size.flops,
                        2.0 * f.size.entries * 12.0 / 1e6,
                    );
                }
            }
        }
    }
}
