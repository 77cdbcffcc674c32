//! The numeric phase of [`super::PatternLu`]: the schedule (each supernode's updates in the
//! sequential sweep's order, the supernodal elimination tree) and the factorisation of
//! disjoint subtrees in parallel, bit-identical to one task.

use super::super::error::FactorError;
use super::pages;
use super::permuted::Permuted;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_unit_lower_triangular_in_place,
};
use faer::reborrow::*;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, Mat, MatMut, MatRef, Par, Spec};

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
pub(super) struct Plan {
    upd_ptr: Vec<usize>,
    upd: Vec<Update>,
    pub(super) children: Vec<Vec<usize>>,
    pub(super) roots: Vec<usize>,
    /// The lowest supernode of each supernode's subtree.
    first: Vec<usize>,
    /// Multiply-adds of each subtree, roughly.
    pub(super) cost: Vec<f64>,
    /// Whether every subtree is a contiguous range of supernodes (a postorder), which the
    /// parallel schedule needs to split the value arrays between tasks.
    pub(super) contiguous: bool,
}

pub(super) fn plan(sym: &SymbolicSupernodalCholesky<usize>) -> Plan {
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
fn first_failure(
    a: Result<(), FactorError>,
    b: Result<(), FactorError>,
) -> Result<(), FactorError> {
    match (a, b) {
        (Err(FactorError::ZeroPivot { column: x }), Err(FactorError::ZeroPivot { column: y })) => {
            Err(FactorError::ZeroPivot { column: x.min(y) })
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
) -> Result<(), FactorError> {
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
fn subtree(
    ctx: &Ctx<'_>,
    s: usize,
    mut part: Part<'_>,
    sc: &mut Scratch,
) -> Result<(), FactorError> {
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
pub(super) type Factors = (Vec<f64>, Vec<f64>, Vec<usize>);
pub(super) fn numeric(
    sym: &SymbolicSupernodalCholesky<usize>,
    a: &Permuted,
    parallel: bool,
    spare: Option<Factors>,
) -> Result<Factors, FactorError> {
    let n = sym.nrows();
    let plan = plan(sym);
    // The values of an earlier factorisation on the same analysis, zeroed again: a time
    // stepper refactorising at every stage time spent a third of its time mapping fresh
    // pages and unmapping old ones.
    let (mut l, mut u, mut pivots) = match spare {
        Some((mut l, mut u, mut pivots))
            if l.len() == sym.len_val() && u.len() == sym.len_val() && pivots.len() == n =>
        {
            l.fill(0.0);
            u.fill(0.0);
            pivots.fill(0);
            (l, u, pivots)
        }
        _ => (
            pages::zeroed(sym.len_val()),
            pages::zeroed(sym.len_val()),
            vec![0usize; n],
        ),
    };
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
) -> Result<(), FactorError> {
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
            return Err(FactorError::ZeroPivot { column: s0 + k });
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
