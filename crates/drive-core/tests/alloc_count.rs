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
