//! The allocator's settings for the command-line process.
//!
//! glibc's malloc gives freed memory back to the system as soon as the top of a heap holds
//! more than 128 kB free (`M_TRIM_THRESHOLD`), and serves blocks from 128 kB up by `mmap`
//! (a threshold it raises only after such a block is freed). A sweep or a study allocates and
//! frees the same grid-sized buffers at every point, degree and quantity, so that memory goes
//! back to the kernel and returns as fresh zeroed pages, over and over. Keeping freed memory
//! and serving mid-sized blocks from the heap removes most of that cost (a few per cent of a
//! sweep's CPU time) for a few per cent more peak memory; a larger `mmap` threshold would
//! save a little more time but keep whole grid-sized buffers resident.

/// Keeps freed memory in the process (trimmed only above 256 MB free) and serves blocks up to
/// 4 MB from the heap, where freed blocks are reused, instead of by `mmap`. Larger blocks
/// (the grid solver's factor blocks) are still mapped and unmapped on their own.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub(crate) fn keep_freed_memory() {
    use std::os::raw::c_int;
    extern "C" {
        /// glibc's allocator tuning call (malloc.h); returns 1 on success, 0 on error.
        fn mallopt(param: c_int, value: c_int) -> c_int;
    }
    const M_TRIM_THRESHOLD: c_int = -1;
    const M_MMAP_THRESHOLD: c_int = -3;
    // SAFETY: `mallopt` takes two plain integers and only changes allocator parameters; it
    // is called first thing in `main`, before any other thread exists. A value it does not
    // accept is refused with 0 and leaves the default, which is only slower.
    unsafe {
        mallopt(M_TRIM_THRESHOLD, 256 << 20);
        mallopt(M_MMAP_THRESHOLD, 4 << 20);
    }
}

/// Elsewhere the system allocator's defaults are kept.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub(crate) fn keep_freed_memory() {}
