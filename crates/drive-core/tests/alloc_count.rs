//! The counting allocator counts: the no-allocation tests of the protocol crates rely on it.

#![cfg(feature = "alloc-count")]

use drive_core::alloc_count::CountingAllocator;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn allocations_are_counted() {
    let (v, n) = CountingAllocator::during(|| Vec::<u8>::with_capacity(16));
    assert_eq!(n, 1);
    let (v, n) = CountingAllocator::during(move || {
        let mut v = v;
        v.extend_from_slice(&[0; 64]); // grows: a reallocation
        v
    });
    assert_eq!(n, 1);
    let (_, n) = CountingAllocator::during(|| v.len());
    assert_eq!(n, 0);
}

/// The count is the calling thread's: a thread that allocates all the time (as the test
/// harness's main thread may while a test runs) does not show in it.
#[test]
fn another_threads_allocations_are_not_counted() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let stop = Arc::new(AtomicBool::new(false));
    let made = Arc::new(AtomicUsize::new(0));
    let other = {
        let (stop, made) = (stop.clone(), made.clone());
        std::thread::spawn(move || {
            while !stop.load(Ordering::SeqCst) {
                std::hint::black_box(Vec::<u8>::with_capacity(32));
                made.fetch_add(1, Ordering::SeqCst);
            }
        })
    };
    let (other_made, n) = CountingAllocator::during(|| {
        let start = made.load(Ordering::SeqCst);
        while made.load(Ordering::SeqCst) < start + 1000 {
            std::hint::spin_loop();
        }
        made.load(Ordering::SeqCst) - start
    });
    stop.store(true, Ordering::SeqCst);
    other.join().unwrap();
    assert!(other_made >= 1000, "{other_made}");
    assert_eq!(
        n, 0,
        "the other thread's {other_made} allocations were counted"
    );
}
