//! How glibc's allocator hands memory back to the kernel ([`keep_freed_memory`], once per
//! process, before the work).
//!
//! glibc serves a block of at least its mapping threshold by a mapping of its own, and a
//! worker thread's arena gives the top of its heap back (`madvise`) when more than the
//! trim threshold of it is free; then the next allocations fault the same pages in again.
//! Both thresholds start small (128 KiB) and grow only when a mapped block is freed (to
//! its size, and the trim threshold to twice that; up to 32 MiB). A warm annual run frees
//! each day's sky cuts (about 3 MB of sources in blocks of ~130 KB) and allocates the
//! next day's: on the sample office that was 59 000–133 000 page faults and a quarter of
//! the run's CPU time in the kernel, since no block large enough had been freed to raise
//! the thresholds. Freeing one [`PRIME_BYTES`] block at start raises them as such a block
//! would (mapping threshold 4 MiB, trim 8 MiB): 12 500 faults.
//!
//! Why not `mallopt`: setting either threshold fixes both for the process. Fixed at 1 or
//! 4 MiB, the building's cold year mapped its larger blocks afresh every time (6.4
//! million page faults against 1.1 million); fixed at 32 MiB, the building's warm year
//! kept 25 MB more resident (330 against 305 MB). Raised by a freed block, glibc still
//! raises them further when a run frees larger blocks, as before.

/// The block freed at start, bytes: the mapping threshold it leaves (and twice it, the
/// trim threshold).
pub const PRIME_BYTES: usize = 4 << 20;

/// Allocates and frees one [`PRIME_BYTES`] block, so that glibc's thresholds start where
/// such a block leaves them (see the module). Call it once, early; elsewhere than glibc
/// it costs one allocation. Results never depend on it.
pub fn keep_freed_memory() {
    // Zeroed, so calloc maps it without touching its pages; black_box keeps it.
    let block = std::hint::black_box(vec![0u8; PRIME_BYTES]);
    drop(block);
}

/// Hands the memory the allocator holds free back to the kernel (glibc `malloc_trim`),
/// between stages: a stage's freed blocks below the mapping threshold stay in the heap
/// otherwise, counted in the resident memory of every later stage. Elsewhere than glibc,
/// nothing. Results never depend on it.
pub fn give_back_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    trim();
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
fn trim() {
    // SAFETY: `malloc_trim` takes no pointers and only returns free pages of glibc's own
    // heaps to the kernel; it is safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(all(test, target_os = "linux", target_env = "gnu"))]
mod tests {
    /// Minor page faults of the calling thread so far.
    fn thread_faults() -> i64 {
        let mut u = std::mem::MaybeUninit::<libc::rusage>::zeroed();
        // SAFETY: getrusage fills the struct it is given; RUSAGE_THREAD is Linux's.
        #[allow(unsafe_code)]
        let u = unsafe {
            assert_eq!(libc::getrusage(libc::RUSAGE_THREAD, u.as_mut_ptr()), 0);
            u.assume_init()
        };
        u.ru_minflt
    }

    #[test]
    fn blocks_under_the_primed_threshold_are_reused_not_faulted_in_again() {
        super::keep_freed_memory();
        // A day's worth of blocks as a warm year's steps make them (24 of 130 KB),
        // written, then all freed, 40 times over: with glibc's starting thresholds each
        // freeing gives the arena's top back and the next round faults its ~780 pages
        // in again; with the thresholds primed, only the first round does.
        let faults = std::thread::spawn(|| {
            let before = thread_faults();
            for i in 0..40u8 {
                let day: Vec<Vec<u8>> = (0..24).map(|_| vec![i; 130_000]).collect();
                drop(std::hint::black_box(day));
            }
            thread_faults() - before
        })
        .join()
        .unwrap();
        assert!(faults < 40 * 780 / 4, "{faults} page faults");
    }
}
