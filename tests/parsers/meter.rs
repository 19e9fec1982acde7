//! The allocation meter: the system allocator, counting the current thread's allocations
//! while [`metered`] runs, so that a parser's largest allocation and its total can be held
//! to a bound.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::{Duration, Instant};

thread_local! {
    static METERING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
    static TOTAL: Cell<usize> = const { Cell::new(0) };
}

/// The system allocator, counting the current thread's allocations while [`metered`] runs.
struct Meter;

fn note(size: usize) {
    // `try_with`: allocations during thread teardown are simply not counted.
    let _ = METERING.try_with(|on| {
        if on.get() {
            LARGEST.set(LARGEST.get().max(size));
            TOTAL.set(TOTAL.get().saturating_add(size));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`; the bookkeeping touches only
// const-initialised thread-locals without destructors, which never allocate.
unsafe impl GlobalAlloc for Meter {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static METER: Meter = Meter;

/// What `f` allocated on this thread: (its value, largest single allocation, total bytes
/// allocated, time taken).
pub(super) fn metered<T>(f: impl FnOnce() -> T) -> (T, usize, usize, Duration) {
    LARGEST.set(0);
    TOTAL.set(0);
    METERING.set(true);
    let start = Instant::now();
    let value = f();
    let took = start.elapsed();
    METERING.set(false);
    (value, LARGEST.get(), TOTAL.get(), took)
}
