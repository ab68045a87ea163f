//! The integration tests of rmd-bus, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

#[global_allocator]
static ALLOCATOR: rmd_test_support::alloc::CountingAllocator =
    rmd_test_support::alloc::CountingAllocator;

mod record;
