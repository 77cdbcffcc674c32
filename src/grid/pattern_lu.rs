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
//! caller checks the backward error of each solve and refines (`assemble::solve`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_unit_lower_triangular_in_place,
};
use faer::perm::PermRef;
use faer::reborrow::*;
#[cfg(test)]
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Mat, MatMut, MatRef, Par, Side, Spec};

/// The LU factors of P A Pᵀ, ready to solve.
pub(crate) struct PatternLu {
    symbolic: SymbolicCholesky<usize>,
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

/// Why the factorisation failed.
#[derive(Debug)]
pub(crate) enum LuFailure {
    /// faer's analysis failed (memory, index overflow).
    Analysis(String),
    /// A zero pivot at column `column` of the permuted matrix.
    ZeroPivot { column: usize },
}

impl std::fmt::Display for LuFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LuFailure::Analysis(e) => write!(f, "symbolic analysis failed: {e}"),
            LuFailure::ZeroPivot { column } => write!(f, "zero pivot at column {column}"),
        }
    }
}

/// The fill-reducing symmetric ordering: AMD on A + Aᵀ with cell `last` moved to the end.
#[cfg(test)]
fn ordering(a: SymbolicSparseColMatRef<'_, usize>, last: usize) -> Result<Vec<usize>, LuFailure> {
    let n = a.ncols();
    let nnz = a.compute_nnz();
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(n, nnz))
        .map_err(|e| LuFailure::Analysis(format!("{e:?}")))?;
    amd::order(
        &mut fwd,
        &mut inv,
        a,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| LuFailure::Analysis(format!("{e:?}")))?;
    fwd.retain(|&c| c != last);
    fwd.push(last);
    Ok(fwd)
}

/// P A Pᵀ in compressed columns (`by_col`) and compressed rows (`by_row`, i.e. its
/// transpose in compressed columns), each as (pointers, indices, values).
struct Permuted {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    tval: Vec<f64>,
}

fn permute(a: SparseColMatRef<'_, usize, f64>, inv: &[usize]) -> Permuted {
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

impl PatternLu {
    /// Factorises the square matrix `a` whose row `last` is the unit row e_last, ordered by
    /// AMD on A + Aᵀ (measured against nested dissection, docs/method.md section 8).
    #[cfg(test)]
    pub(crate) fn new(
        a: SparseColMatRef<'_, usize, f64>,
        last: usize,
    ) -> Result<PatternLu, LuFailure> {
        let fwd = ordering(a.symbolic(), last)?;
        PatternLu::ordered(a, fwd)
    }

    /// Factorises `a` in the symmetric order `fwd` (position → cell), disjoint subtrees of
    /// the supernodal elimination tree in parallel (the same bits as one task).
    pub(crate) fn ordered(
        a: SparseColMatRef<'_, usize, f64>,
        fwd: Vec<usize>,
    ) -> Result<PatternLu, LuFailure> {
        PatternLu::ordered_with(a, fwd, true)
    }

    fn ordered_with(
        a: SparseColMatRef<'_, usize, f64>,
        fwd: Vec<usize>,
        parallel: bool,
    ) -> Result<PatternLu, LuFailure> {
        let n = a.ncols();
        let analysis = |e: &dyn std::fmt::Debug| LuFailure::Analysis(format!("{e:?}"));
        let mut inv = vec![0usize; n];
        for (k, &c) in fwd.iter().enumerate() {
            inv[c] = k;
        }
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
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return Err(LuFailure::Analysis("not supernodal".into()));
        };
        let p = permute(a, &inv);
        let (l, u, pivots) = numeric(sym, &p, parallel)?;
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
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("checked in PatternLu::new"),
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

    /// Solves A x = b in place (`b` in, x out).
    pub(crate) fn solve(&self, b: &mut [f64]) {
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
            let lcols = &self.l[cpv[s]..cpv[s + 1]];
            for j in 0..ns {
                let x = y[s0 + j];
                let col = &lcols[j * (ns + nr) + ns..(j + 1) * (ns + nr)];
                for (&r, &v) in pattern.iter().zip(col) {
                    y[r] -= v * x;
                }
            }
        }
        for s in (0..sym.n_supernodes()).rev() {
            let (s0, s1) = (begin[s], end[s]);
            let ns = s1 - s0;
            let pattern = &rows[cpr[s]..cpr[s + 1]];
            let nr = pattern.len();
            let ucols = &self.u[cpv[s]..cpv[s + 1]];
            for j in 0..ns {
                let col = &ucols[j * (ns + nr) + ns..(j + 1) * (ns + nr)];
                let acc: f64 = pattern.iter().zip(col).map(|(&r, &v)| v * y[r]).sum();
                y[s0 + j] -= acc;
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

/// The pattern of A + Aᵀ (values unused).
fn symmetric_pattern(
    a: SymbolicSparseColMatRef<'_, usize>,
) -> faer::sparse::SymbolicSparseColMat<usize> {
    let n = a.ncols();
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
    for c in 0..n {
        for &r in a.row_idx_of_col_raw(c) {
            cols[c].push(r);
            cols[r].push(c);
        }
    }
    let mut ptr = Vec::with_capacity(n + 1);
    let mut idx = Vec::new();
    ptr.push(0);
    for mut col in cols {
        col.sort_unstable();
        col.dedup();
        idx.extend(col);
        ptr.push(idx.len());
    }
    faer::sparse::SymbolicSparseColMat::new_checked(n, n, ptr, None, idx)
}

/// One update of a supernode by a descendant `d`: `d`'s unconsumed pattern starts at its
/// position `p`, and its first `mid` rows fall in the updated supernode's columns.
#[derive(Clone, Copy)]
struct Update {
    d: usize,
    p: usize,
    mid: usize,
}

/// The schedule of the numeric factorisation, fixed before any arithmetic: each
/// supernode's updates in the order of the sequential left-looking sweep (linked lists, as
/// in George and Liu's supernodal Cholesky), and the supernodal elimination tree. A
/// supernode writes only its own columns and reads only its descendants', so disjoint
/// subtrees are factorised at once (`rayon::join`) and every supernode still sums its
/// updates in the same order: the factors are the same bits whatever the thread count.
struct Plan {
    upd_ptr: Vec<usize>,
    upd: Vec<Update>,
    children: Vec<Vec<usize>>,
    roots: Vec<usize>,
    /// The lowest supernode of each supernode's subtree.
    first: Vec<usize>,
    /// Multiply-adds of each subtree, roughly.
    cost: Vec<f64>,
    /// Whether every subtree is a contiguous range of supernodes (a postorder), which the
    /// parallel schedule needs to split the value arrays between tasks.
    contiguous: bool,
}

fn plan(sym: &SymbolicSupernodalCholesky<usize>) -> Plan {
    let (n, nsup) = (sym.nrows(), sym.n_supernodes());
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let (cpr, rows) = (sym.col_ptr_for_row_idx(), sym.row_idx());
    let mut of_col = vec![0usize; n];
    for s in 0..nsup {
        of_col[begin[s]..end[s]].fill(s);
    }
    let none = usize::MAX;
    let (mut head, mut next, mut pos) = (vec![none; nsup], vec![none; nsup], vec![0; nsup]);
    let mut parent = vec![none; nsup];
    let mut upd_ptr = Vec::with_capacity(nsup + 1);
    upd_ptr.push(0);
    let mut upd = Vec::new();
    for s in 0..nsup {
        let mut d = head[s];
        while d != none {
            let after = next[d];
            let p = pos[d];
            let rest = &rows[cpr[d] + p..cpr[d + 1]];
            let mid = rest.partition_point(|&r| r < end[s]);
            upd.push(Update { d, p, mid });
            pos[d] = p + mid;
            if mid < rest.len() {
                let t = of_col[rest[mid]];
                next[d] = head[t];
                head[t] = d;
            }
            d = after;
        }
        upd_ptr.push(upd.len());
        if cpr[s + 1] > cpr[s] {
            let t = of_col[rows[cpr[s]]];
            parent[s] = t;
            next[s] = head[t];
            head[t] = s;
        }
    }
    let (mut children, mut roots) = (vec![Vec::new(); nsup], Vec::new());
    let mut first: Vec<usize> = (0..nsup).collect();
    let (mut size, mut cost) = (vec![1usize; nsup], vec![0.0; nsup]);
    for s in 0..nsup {
        let ns = (end[s] - begin[s]) as f64;
        let nr = (cpr[s + 1] - cpr[s]) as f64;
        cost[s] += ns * (ns + nr) * (ns + nr);
        match parent[s] {
            t if t == none => roots.push(s),
            // t > s: a supernode's pattern lies below its columns.
            t => {
                children[t].push(s);
                first[t] = first[t].min(first[s]);
                size[t] += size[s];
                cost[t] += cost[s];
            }
        }
    }
    let contiguous = (0..nsup).all(|s| s + 1 - first[s] == size[s]);
    Plan {
        upd_ptr,
        upd,
        children,
        roots,
        first,
        cost,
        contiguous,
    }
}

/// One task's work space.
struct Scratch {
    /// Row → position in the current supernode's block (`usize::MAX` elsewhere).
    local: Vec<usize>,
    work: Vec<f64>,
    rel: Vec<usize>,
    lu_mem: MemBuffer,
    perm_fwd: Vec<usize>,
    perm_inv: Vec<usize>,
}

impl Scratch {
    fn new(n: usize) -> Scratch {
        Scratch {
            local: vec![usize::MAX; n],
            work: Vec::new(),
            rel: Vec::new(),
            lu_mem: MemBuffer::new(lu_in_place_scratch::<usize, f64>(
                1,
                1,
                Par::Seq,
                Spec::default(),
            )),
            perm_fwd: Vec::new(),
            perm_inv: Vec::new(),
        }
    }
}

/// What every task reads: the pattern, A and the plan.
struct Ctx<'a> {
    sym: &'a SymbolicSupernodalCholesky<usize>,
    a: &'a Permuted,
    plan: &'a Plan,
    /// Subtrees cheaper than this are factorised by one task.
    min_cost: f64,
}

/// A task's part of the factors: the values from position `vbase` of L and U and the
/// pivots from column `pbase`.
struct Part<'a> {
    l: &'a mut [f64],
    u: &'a mut [f64],
    vbase: usize,
    pivots: &'a mut [usize],
    pbase: usize,
}

impl<'a> Part<'a> {
    fn rb(&mut self) -> Part<'_> {
        Part {
            l: &mut *self.l,
            u: &mut *self.u,
            vbase: self.vbase,
            pivots: &mut *self.pivots,
            pbase: self.pbase,
        }
    }

    /// Splits off the part from supernode `s` on.
    fn split(self, ctx: &Ctx<'_>, s: usize) -> (Part<'a>, Part<'a>) {
        let (v, c) = (ctx.sym.col_ptr_for_val()[s], ctx.sym.supernode_begin()[s]);
        let (l0, l1) = self.l.split_at_mut(v - self.vbase);
        let (u0, u1) = self.u.split_at_mut(v - self.vbase);
        let (p0, p1) = self.pivots.split_at_mut(c - self.pbase);
        let lo = Part {
            l: l0,
            u: u0,
            vbase: self.vbase,
            pivots: p0,
            pbase: self.pbase,
        };
        let hi = Part {
            l: l1,
            u: u1,
            vbase: v,
            pivots: p1,
            pbase: c,
        };
        (lo, hi)
    }
}

/// The first failure in the sequential order: the lower column.
fn first_failure(a: Result<(), LuFailure>, b: Result<(), LuFailure>) -> Result<(), LuFailure> {
    match (a, b) {
        (Err(LuFailure::ZeroPivot { column: x }), Err(LuFailure::ZeroPivot { column: y })) => {
            Err(LuFailure::ZeroPivot { column: x.min(y) })
        }
        (Err(e), _) | (_, Err(e)) => Err(e),
        _ => Ok(()),
    }
}

/// Factorises the subtrees `list` (consecutive, ascending) within `part`, halves in parallel.
fn forest(
    ctx: &Ctx<'_>,
    list: &[usize],
    part: Part<'_>,
    sc: &mut Scratch,
) -> Result<(), LuFailure> {
    if let [s] = list {
        return subtree(ctx, *s, part, sc);
    }
    let (left, right) = list.split_at(list.len() / 2);
    let (lo, hi) = part.split(ctx, ctx.plan.first[right[0]]);
    let (a, b) = rayon::join(
        || forest(ctx, left, lo, sc),
        || forest(ctx, right, hi, &mut Scratch::new(ctx.sym.nrows())),
    );
    first_failure(a, b)
}

/// Factorises the subtree of supernode `s`: its children's subtrees in parallel when it is
/// costly enough, then `s`.
fn subtree(ctx: &Ctx<'_>, s: usize, mut part: Part<'_>, sc: &mut Scratch) -> Result<(), LuFailure> {
    let kids = &ctx.plan.children[s];
    if ctx.plan.cost[s] < ctx.min_cost || kids.is_empty() {
        for t in ctx.plan.first[s]..=s {
            factor_one(ctx, t, &mut part, sc)?;
        }
        return Ok(());
    }
    // The children's subtrees end where s begins; the last task's part reaches s's values
    // but does not touch them.
    forest(ctx, kids, part.rb(), sc)?;
    factor_one(ctx, s, &mut part, sc)
}

/// The numeric factorisation, left-looking by supernodes in the order of `plan`: each
/// supernode gathers the updates of its descendants, then factorises its diagonal block with
/// partial pivoting among its rows and solves for its L21 and U12. With `parallel`,
/// disjoint subtrees run at once; the result is the same bits either way.
type Factors = (Vec<f64>, Vec<f64>, Vec<usize>);
fn numeric(
    sym: &SymbolicSupernodalCholesky<usize>,
    a: &Permuted,
    parallel: bool,
) -> Result<Factors, LuFailure> {
    let n = sym.nrows();
    let plan = plan(sym);
    let mut l = vec![0.0; sym.len_val()];
    let mut u = vec![0.0; sym.len_val()];
    let mut pivots = vec![0usize; n];
    let total: f64 = plan.roots.iter().map(|&r| plan.cost[r]).sum();
    let ctx = Ctx {
        sym,
        a,
        plan: &plan,
        // About 64 tasks at most: enough to balance two to eight cores.
        min_cost: total / 64.0,
    };
    let mut part = Part {
        l: &mut l,
        u: &mut u,
        vbase: 0,
        pivots: &mut pivots,
        pbase: 0,
    };
    let mut sc = Scratch::new(n);
    if parallel && plan.contiguous && !plan.roots.is_empty() {
        forest(&ctx, &plan.roots, part, &mut sc)?;
    } else {
        for s in 0..sym.n_supernodes() {
            factor_one(&ctx, s, &mut part, &mut sc)?;
        }
    }
    Ok((l, u, pivots))
}

/// Factorises supernode `s`: A's entries, the planned updates, the diagonal block, L21, U12.
fn factor_one(
    ctx: &Ctx<'_>,
    s: usize,
    part: &mut Part<'_>,
    sc: &mut Scratch,
) -> Result<(), LuFailure> {
    let (sym, a) = (ctx.sym, ctx.a);
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let (cpr, cpv, rows) = (
        sym.col_ptr_for_row_idx(),
        sym.col_ptr_for_val(),
        sym.row_idx(),
    );
    let vb = part.vbase;
    let (s0, s1) = (begin[s], end[s]);
    let ns = s1 - s0;
    let pattern = &rows[cpr[s]..cpr[s + 1]];
    let nr = pattern.len();
    let local = &mut sc.local;
    for (k, &r) in pattern.iter().enumerate() {
        local[r] = ns + k;
    }
    let (lhead, ltail) = part.l.split_at_mut(cpv[s] - vb);
    let (uhead, utail) = part.u.split_at_mut(cpv[s] - vb);
    let len = cpv[s + 1] - cpv[s];
    let (lcols, ucols) = (&mut ltail[..len], &mut utail[..len]);
    // Written before anything reads them: the first touch of a page of the zeroed
    // allocation is then a write fault, not a read that maps the shared zero page and a
    // write that replaces it (a TLB flush of every core running the process, measured as
    // 6% of the run under `perf` with two threads).
    lcols.fill(0.0);
    ucols.fill(0.0);
    let lds = ns + nr;
    // A's entries: columns J from the diagonal down into L, rows J right of the block
    // into Uᵀ.
    for j in s0..s1 {
        let (lcol, ucol) = (
            &mut lcols[(j - s0) * lds..(j - s0 + 1) * lds],
            &mut ucols[(j - s0) * lds..(j - s0 + 1) * lds],
        );
        for k in a.col_ptr[j]..a.col_ptr[j + 1] {
            let i = a.row_idx[k];
            if i >= s0 {
                lcol[if i < s1 { i - s0 } else { local[i] }] += a.val[k];
            }
        }
        for k in a.row_ptr[j]..a.row_ptr[j + 1] {
            let i = a.col_idx[k];
            if i >= s1 {
                ucol[local[i]] += a.tval[k];
            }
        }
    }
    // Updates from the descendants, in the planned order.
    let plan = ctx.plan;
    for &Update { d, p, mid } in &plan.upd[plan.upd_ptr[s]..plan.upd_ptr[s + 1]] {
        let nd = end[d] - begin[d];
        let dpat = &rows[cpr[d]..cpr[d + 1]];
        let rest = &dpat[p..];
        let m = rest.len();
        let (v0, v1) = (cpv[d] - vb, cpv[d + 1] - vb);
        let ld = MatRef::from_column_major_slice(&lhead[v0..v1], nd + dpat.len(), nd);
        let ud = MatRef::from_column_major_slice(&uhead[v0..v1], nd + dpat.len(), nd);
        let ld_rest = ld.subrows(nd + p, m);
        let ud_rest = ud.subrows(nd + p, m);
        // Where each remaining row of d lands in s's block.
        sc.rel.clear();
        sc.rel
            .extend(rest.iter().map(|&r| if r < s1 { r - s0 } else { local[r] }));
        let (rel, work) = (&sc.rel, &mut sc.work);
        // L(rest, mid) -= Ld(rest) · U12d(:, mid) = Ld(rest) · Udᵀ(mid)ᵀ.
        if work.len() < m * mid {
            work.resize(m * mid, 0.0);
        }
        matmul(
            MatMut::from_column_major_slice_mut(&mut work[..m * mid], m, mid),
            Accum::Replace,
            ld_rest,
            ud_rest.subrows(0, mid).transpose(),
            1.0,
            Par::Seq,
        );
        for (jj, &c) in rest[..mid].iter().enumerate() {
            let col = &mut lcols[(c - s0) * lds..(c - s0 + 1) * lds];
            for (&at, &w) in rel.iter().zip(&work[jj * m..(jj + 1) * m]) {
                col[at] -= w;
            }
        }
        // U12(mid, bot) -= Ld(mid) · U12d(:, bot): Uᵀ(bot, mid) -= Udᵀ(bot) · Ld(mid)ᵀ.
        let bot = m - mid;
        if bot > 0 {
            matmul(
                MatMut::from_column_major_slice_mut(&mut work[..bot * mid], bot, mid),
                Accum::Replace,
                ud_rest.subrows(mid, bot),
                ld_rest.subrows(0, mid).transpose(),
                1.0,
                Par::Seq,
            );
            for (jj, &c) in rest[..mid].iter().enumerate() {
                let col = &mut ucols[(c - s0) * lds..(c - s0 + 1) * lds];
                for (&at, &w) in rel[mid..].iter().zip(&work[jj * bot..(jj + 1) * bot]) {
                    col[at] -= w;
                }
            }
        }
    }
    // The diagonal block, with partial pivoting among its rows.
    let ls = MatMut::from_column_major_slice_mut(lcols, lds, ns);
    let us = MatMut::from_column_major_slice_mut(ucols, lds, ns);
    let par = Par::Seq;
    let (mut top, mut lbot) = ls.split_at_row_mut(ns);
    sc.perm_fwd.resize(ns, 0);
    sc.perm_inv.resize(ns, 0);
    let req = lu_in_place_scratch::<usize, f64>(ns, ns, par, Spec::default());
    if req.size_bytes() > sc.lu_mem.len() {
        sc.lu_mem = MemBuffer::new(req);
    }
    let (_, _) = lu_in_place(
        top.rb_mut(),
        &mut sc.perm_fwd,
        &mut sc.perm_inv,
        par,
        MemStack::new(&mut sc.lu_mem),
        Spec::default(),
    );
    for &r in pattern {
        local[r] = usize::MAX;
    }
    for k in 0..ns {
        if top[(k, k)] == 0.0 || !top[(k, k)].is_finite() {
            return Err(LuFailure::ZeroPivot { column: s0 + k });
        }
    }
    part.pivots[s0 - part.pbase..s1 - part.pbase].copy_from_slice(&sc.perm_fwd);
    // L21 = F21 U11⁻¹: U11ᵀ L21ᵀ = F21ᵀ.
    solve_lower_triangular_in_place(top.rb().transpose(), lbot.rb_mut().transpose_mut(), par);
    // U12 = L11⁻¹ P F12, kept transposed: permute the columns of Uᵀ, then solve.
    let mut ubot = us.split_at_row_mut(ns).1;
    if nr > 0 {
        let old = Mat::from_fn(nr, ns, |i, j| ubot[(i, j)]);
        for (j, &from) in sc.perm_fwd.iter().enumerate() {
            for i in 0..nr {
                ubot[(i, j)] = old[(i, from)];
            }
        }
        solve_unit_lower_triangular_in_place(top.rb(), ubot.rb_mut().transpose_mut(), par);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::lu::tests::system;
    use crate::grid::lu::{Factor, Ordering};

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
            Factor::new(a.as_ref(), &Ordering::Colamd)
                .unwrap()
                .solve(&mut p);
            let coords = crate::grid::nested::cell_coords(mesh.nx, mesh.nv, false);
            let mut nd = crate::grid::nested::nested_dissection(a.symbolic(), &coords, 1);
            nd.retain(|&c| c != pin);
            nd.push(pin);
            for lu in [
                PatternLu::new(a.as_ref(), pin).unwrap(),
                PatternLu::ordered(a.as_ref(), nd).unwrap(),
            ] {
                let mut q = vec![0.0; n];
                q[pin] = 1.0;
                lu.solve(&mut q);
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
            let one = PatternLu::ordered_with(a.as_ref(), nd.clone(), false).unwrap();
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
                    .install(|| PatternLu::ordered(a.as_ref(), nd.clone()))
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
    /// `cargo test --release --lib grid::pattern_lu::tests::ordering_table -- --ignored --nocapture`.
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
                let f = Factor::new(a.as_ref(), &Ordering::Colamd).unwrap();
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
                    let lu = PatternLu::ordered(a.as_ref(), order).unwrap();
                    let name = format!("A + Aᵀ, ND {hops}-step separators");
                    row(&name, lu.entries() as f64, lu.flops(), ms(t));
                }
            }
        }
    }
}
