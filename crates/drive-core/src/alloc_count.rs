//! A counting global allocator (feature `alloc-count`), for the tests that prove a codec, a
//! receiver or a state machine allocates nothing: every protocol crate has one, and they share
//! this allocator instead of each writing its own.
//!
//! ```ignore
//! use drive_core::alloc_count::CountingAllocator;
//!
//! #[global_allocator]
//! static GLOBAL: CountingAllocator = CountingAllocator;
//!
//! let before = CountingAllocator::count();
//! // … the code under test …
//! assert_eq!(CountingAllocator::count(), before);
//! ```
//!
//! The count is the calling thread's: another thread's allocations are not counted (the test
//! harness's main thread allocates while a test runs, at a moment that depends on the machine's
//! load), so the code under test must run on the thread that counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

std::thread_local! {
    // `const`, without a destructor: reading and writing it never allocates.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// One more allocation on this thread (none counted while the thread's storage is torn down).
fn count_one() {
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get().wrapping_add(1)));
}

/// The system allocator, counting every allocation and reallocation.
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAllocator;

impl CountingAllocator {
    /// Allocations and reallocations made by the calling thread since it started.
    pub fn count() -> usize {
        ALLOCATIONS.try_with(Cell::get).unwrap_or(0)
    }

    /// Run `f` and return its result with the number of allocations it made (on this thread).
    pub fn during<R>(f: impl FnOnce() -> R) -> (R, usize) {
        let before = Self::count();
        let r = f();
        (r, Self::count() - before)
    }
}

// SAFETY: every call is forwarded unchanged to the system allocator; the counter (a
// thread-local cell, which does not allocate) has no effect on the memory handed out.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: the caller's contract for `alloc_zeroed` is passed on unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        // SAFETY: the caller's contract for `realloc` is passed on unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc` is passed on unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }
}
