//! How glibc's allocator hands memory back to the kernel, set once per process
//! ([`keep_freed_memory`]).
//!
//! With glibc's defaults, a worker thread's arena gives the top of its heap back
//! (`madvise`) whenever more than a few megabytes of it are free, and the next
//! allocations fault the same pages in again. A warm annual run frees each day's sky cuts
//! (about 3 MB of sources) and allocates the next day's: on the sample office that was
//! 59 000–130 000 page faults and a quarter of the run's CPU time in the kernel. Keeping
//! up to [`TRIM_BYTES`] of free memory per arena, and serving blocks up to [`MMAP_BYTES`]
//! from the arenas instead of fresh mappings, takes it to 12 000 faults; the peak
//! resident memory of the 10 000-triangle building's cold year did not change (660 MB).

/// Free memory an arena keeps at its top before giving it back, bytes.
pub const TRIM_BYTES: i32 = 64 << 20;
/// Blocks at least this large are mapped on their own (and unmapped when freed), bytes:
/// the largest value glibc's own adjustment reaches. At 4 MiB the building's cold year
/// mapped its large blocks afresh each time (6.4 million page faults against 1.1
/// million).
pub const MMAP_BYTES: i32 = 32 << 20;

/// Sets glibc's trim and mapping thresholds to [`TRIM_BYTES`] and [`MMAP_BYTES`] (fixed
/// values, so glibc stops adjusting them as it runs). Call it once, early, before the
/// worker threads start; elsewhere than Linux with glibc it does nothing. Results never
/// depend on it: only how often freed memory is handed back. Returns whether it applied.
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[allow(unsafe_code)]
    {
        // SAFETY: mallopt only changes the allocator's parameters; it takes plain
        // integers and is safe to call at any time.
        unsafe {
            libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_BYTES) == 1
                && libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_BYTES) == 1
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn glibc_takes_both_thresholds() {
        assert!(super::keep_freed_memory());
        // And a large allocation after it is still served and usable.
        let v = vec![1u8; (super::MMAP_BYTES as usize) * 2];
        assert_eq!(v.iter().map(|&b| b as usize).sum::<usize>(), v.len());
    }
}
