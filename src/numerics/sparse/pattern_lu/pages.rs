//! The factor's memory in huge pages where the system offers them.
//!
//! The factor of a fine grid is hundreds of MB of freshly mapped memory, first touched as the
//! factorisation writes each supernode's block. In 4 kB pages that is one fault per page:
//! measured at 200x400 cells (vibro_impact_duffing, `perf record`), the faults taken while
//! zeroing the blocks were 19 % of the grid solve's CPU time. Transparent huge pages (2 MB)
//! take a 512th of the faults. Linux offers them to a region that asks (`madvise`, the
//! default setting `[madvise]`), or to every region (`always`), or not at all (`never`: the
//! advice is then ignored). The contents are the same either way: the allocation is zeroed.

/// `n` zeros, their pages advised to be huge (2 MB) where they are large enough to hold one.
pub(super) fn zeroed(n: usize) -> Vec<f64> {
    let mut v = vec![0.0; n];
    advise_huge(&mut v);
    v
}

/// Advises the kernel to back the 2 MB-aligned part of `v` with huge pages.
#[cfg(target_os = "linux")]
fn advise_huge(v: &mut [f64]) {
    use std::ffi::c_void;
    use std::os::raw::c_int;
    extern "C" {
        /// The paging advice call (sys/mman.h); returns 0 on success, −1 on error.
        fn madvise(addr: *mut c_void, len: usize, advice: c_int) -> c_int;
    }
    /// `MADV_HUGEPAGE` (asm-generic/mman-common.h, the same on every Linux architecture).
    const MADV_HUGEPAGE: c_int = 14;
    const HUGE: usize = 2 << 20;
    let start = v.as_mut_ptr() as usize;
    let end = start + std::mem::size_of_val(v);
    let (from, to) = (start.div_ceil(HUGE) * HUGE, end / HUGE * HUGE);
    if to > from {
        // SAFETY: [from, to) lies inside `v`'s allocation, which this function borrows
        // mutably, and is page-aligned. MADV_HUGEPAGE only changes how the kernel backs the
        // range; it reads and writes none of its bytes. A kernel without transparent huge
        // pages refuses the advice (−1), which leaves the 4 kB pages: only slower.
        unsafe {
            madvise(from as *mut c_void, to - from, MADV_HUGEPAGE);
        }
    }
}

/// Elsewhere the system's pages are kept.
#[cfg(not(target_os = "linux"))]
fn advise_huge(_: &mut [f64]) {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advice leaves the contents: zeros of every length, a huge page's worth and
    /// around it.
    #[test]
    fn zeroed_is_zeros() {
        for n in [0, 1, 511, 262_144, 262_145, 3 * 262_144 + 17] {
            let v = zeroed(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == 0.0));
        }
    }
}
