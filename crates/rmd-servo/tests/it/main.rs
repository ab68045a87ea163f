//! The integration tests of rmd-servo, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod common;

#[global_allocator]
static ALLOCATOR: rmd_test_support::alloc::CountingAllocator =
    rmd_test_support::alloc::CountingAllocator;

mod motion;
mod no_alloc;
mod safety;
mod setpoints;
mod trajectories;
