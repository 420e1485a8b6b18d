//! Handing the allocator's free memory back to the operating system between the phases of a
//! long computation.
//!
//! glibc's malloc keeps memory that a program frees for its next requests, and a freed
//! full-length column (14 MB per channel on a 10-hour drive) often lands between chunks still
//! in use, where it stays resident although nothing uses it (a 10-hour drive's diagnosis, trimmed
//! after each step, peaked at 1 097 MB resident against 1 313 MB untrimmed in one run each:
//! docs/validation/benchmarks.md). [`release_free_memory`] asks glibc to return every free page it holds
//! (`malloc_trim(0)`, which also releases whole free pages inside its heaps); it changes no
//! value a computation sees. It costs a walk of the allocator's free lists — milliseconds —
//! so it is called between phases, not in loops. Other platforms' allocators keep their own
//! policy.

/// Returns the allocator's free pages to the operating system (see the module documentation).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn release_free_memory() {
    // SAFETY: `malloc_trim` only releases memory the allocator holds free; it has no
    // preconditions and leaves every live allocation in place.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Other allocators keep their own policy.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn release_free_memory() {}
