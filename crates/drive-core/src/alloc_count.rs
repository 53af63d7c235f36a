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
//! Put it in a test binary with a single `#[test]` (or run the test threads one at a time): the
//! count is global, so another thread's allocations would be counted too.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, counting every allocation and reallocation.
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAllocator;

impl CountingAllocator {
    /// Allocations and reallocations since the program started.
    pub fn count() -> usize {
        ALLOCATIONS.load(Ordering::SeqCst)
    }

    /// Run `f` and return its result with the number of allocations made meanwhile.
    pub fn during<R>(f: impl FnOnce() -> R) -> (R, usize) {
        let before = Self::count();
        let r = f();
        (r, Self::count() - before)
    }
}

// SAFETY: every call is forwarded unchanged to the system allocator; the counter has no effect
// on the memory handed out.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller's contract for `alloc_zeroed` is passed on unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller's contract for `realloc` is passed on unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc` is passed on unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }
}
