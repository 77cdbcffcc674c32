//! Geometric nested dissection of the cells, the fill-reducing ordering of the LU.
//!
//! The cells are split in two at the middle of their longer extent, a separator is taken
//! from one half (its cells within `hops` steps of the other half in the matrix graph), the
//! halves are ordered recursively and the separator last. The separator is built from the
//! matrix graph, not the geometry, so an entry the stencil does not predict (a
//! re-injection across the barrier) still cannot join the two halves: the ordering is
//! valid for any pattern, the geometry only makes it good. The solver's LU
//! ([`super::pattern_lu`]) works on the pattern of A + Aᵀ, which one hop separates; faer's
//! LU allocates the pattern of the Cholesky factor of AᵀA, in which two cells are joined
//! when a common row touches both, so it needs two hops (measured, docs/method.md §8).

use crate::numerics::sparse::pattern::union_with_transpose;
use faer::sparse::SymbolicSparseColMatRef;

/// Geometric coordinates of the cells of an nx × nv mesh (cell k at (k / nv, k % nv)),
/// the velocity folded at v = 0 when `fold`: a wall re-injects at the mirrored velocity
/// (−r·v), which the fold puts next to the exit cell, so that no cut in v separates them.
pub(crate) fn cell_coords(nx: usize, nv: usize, fold: bool) -> Vec<[u32; 2]> {
    let half = nv / 2;
    let mut coords = Vec::with_capacity(nx * nv);
    for i in 0..nx {
        for j in 0..nv {
            let v = match (fold, j >= half) {
                (false, _) => j,
                (true, true) => j - half,
                (true, false) => half - 1 - j,
            };
            coords.push([i as u32, v as u32]);
        }
    }
    coords
}

/// Subsets at most this large are ordered as they come (cell index order).
const LEAF: usize = 64;

/// The column permutation (new position → cell) of the square pattern `a`, cell k having
/// the geometric coordinates `coords[k]`.
pub(crate) fn nested_dissection(
    a: SymbolicSparseColMatRef<'_, usize>,
    coords: &[[u32; 2]],
    hops: usize,
) -> Vec<usize> {
    let n = a.ncols();
    let graph = Graph::new(a);
    let mut state = State {
        graph,
        coords,
        hops: hops.max(1),
        mark: vec![0u8; n],
        out: Vec::with_capacity(n),
    };
    state.dissect((0..n).collect());
    state.out
}

/// The undirected graph of A + Aᵀ (without the diagonal), as adjacency lists.
struct Graph {
    start: Vec<usize>,
    next: Vec<usize>,
}

impl Graph {
    fn new(a: SymbolicSparseColMatRef<'_, usize>) -> Graph {
        let (start, next) = union_with_transpose(a, false);
        Graph { start, next }
    }

    fn neighbours(&self, k: usize) -> &[usize] {
        &self.next[self.start[k]..self.start[k + 1]]
    }
}

struct State<'a> {
    graph: Graph,
    coords: &'a [[u32; 2]],
    hops: usize,
    /// 0 outside the subset being split, 1 first half, 2 second half, 3 separator.
    mark: Vec<u8>,
    out: Vec<usize>,
}

impl State<'_> {
    fn dissect(&mut self, mut cells: Vec<usize>) {
        if cells.len() <= LEAF {
            cells.sort_unstable();
            self.out.extend(cells);
            return;
        }
        let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
        for &k in &cells {
            for d in 0..2 {
                lo[d] = lo[d].min(self.coords[k][d]);
                hi[d] = hi[d].max(self.coords[k][d]);
            }
        }
        let axis = if hi[0] - lo[0] >= hi[1] - lo[1] { 0 } else { 1 };
        let cut = lo[axis] + (hi[axis] - lo[axis]).div_ceil(2);
        for &k in &cells {
            self.mark[k] = if self.coords[k][axis] < cut { 1 } else { 2 };
        }
        // The separator: cells of the first half within `hops` steps of the second.
        let mut frontier: Vec<usize> = cells
            .iter()
            .copied()
            .filter(|&k| self.mark[k] == 2)
            .collect();
        for _ in 0..self.hops {
            let mut reached = Vec::new();
            for &k in &frontier {
                for &m in self.graph.neighbours(k) {
                    if self.mark[m] == 1 {
                        self.mark[m] = 3;
                        reached.push(m);
                    }
                }
            }
            frontier = reached;
        }
        let mut parts: [Vec<usize>; 3] = [Vec::new(), Vec::new(), Vec::new()];
        for &k in &cells {
            parts[usize::from(self.mark[k]) - 1].push(k);
            self.mark[k] = 0;
        }
        // The second half is never empty (it holds the cells at the upper end); the first
        // may be, when the separator took it whole, and the recursion still shrinks.
        let [first, second, mut separator] = parts;
        drop(cells);
        self.dissect(first);
        self.dissect(second);
        separator.sort_unstable();
        self.out.extend(separator);
    }
}
