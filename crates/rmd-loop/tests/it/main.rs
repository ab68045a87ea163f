//! The integration tests of rmd-loop, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod common;

#[global_allocator]
static ALLOCATOR: rmd_test_support::alloc::CountingAllocator =
    rmd_test_support::alloc::CountingAllocator;

mod firmware;
mod joint_limits;
mod motion;
mod multi_bus;
mod no_alloc;
mod no_alloc_threaded;
mod panic_backtrace;
mod per_motor;
mod stall_os;
mod supervisor;
mod telemetry;
mod threaded;
mod virtual_time;
