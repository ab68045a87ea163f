//! What the tests of several rmd-rt crates share (a dev-dependency only, never published):
//!
//! - [`alloc`]: the counting global allocator that proves a real-time path allocates nothing;
//! - [`ran_in_own_process`]: a test alone in a process of its own, whatever the runner;
//! - [`example`]: a workspace example's executable, built as the test scripts build it.
//!
//! Each crate's integration tests are one binary (`tests/it/main.rs`), so what one test does to
//! its process (a global allocator, a signal, `SIGSTOP`, the environment, a panic hook) is
//! shared with every other test of the crate when they run as threads of one process
//! (`cargo test`); `cargo nextest` runs each test in a process of its own.

pub mod alloc;
mod examples;
mod process;

pub use examples::example;
pub use process::ran_in_own_process;
