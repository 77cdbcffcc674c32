//! The allocator's settings for the command-line process.
//!
//! glibc's malloc gives freed memory back to the system as soon as the top of a heap holds
//! more than 128 kB free (`M_TRIM_THRESHOLD`), and serves blocks from 128 kB up by `mmap`
//! (a threshold it raises only after such a block is freed). A sweep or a study allocates and
//! frees the same grid-sized buffers at every point, degree and quantity, so that memory goes
//! back to the kernel and returns as fresh zeroed pages, over and over. Measured with
//! `GLIBC_TUNABLES` on 1684aba (3 rounds interleaved, load 3): the 100-point EPC sweep's user +
//! system CPU and the default grid solve's peak memory were 1.71-1.73 s and 322 MB with the
//! defaults, 1.66-1.68 s and 330-335 MB with the values below, 1.63-1.66 s and 377 MB with an
//! `mmap` threshold of 32 or 64 MB. The values below take most of the time for a few per cent
//! of memory.

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
