//! Support code of the root benchmarks: the counting allocator of the tests
//! (`rmd-test-support`), so that a benchmark can show that the code it measures allocates
//! nothing.

use rmd_test_support::alloc::{self, CountingAllocator};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Runs `f` and returns its result with the number of allocations made meanwhile (on any thread:
/// call it while nothing else runs; a benchmark binary is a process of its own).
pub(crate) fn allocations_during<R>(f: impl FnOnce() -> R) -> (R, u64) {
    alloc::reset_counted();
    alloc::count_every_thread(true);
    let result = f();
    alloc::count_every_thread(false);
    (result, alloc::counted().allocations)
}
