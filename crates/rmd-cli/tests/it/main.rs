//! The integration tests of rmd-cli, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

// Shared with the kernel tests (tests/vcan.rs).
#[path = "../support/mod.rs"]
mod support;

mod bench;
mod completions;
mod decode;
mod docs;
mod drill;
mod durations;
mod encode;
mod families;
mod helpful;
mod live;
mod pipes;
mod progress;
mod protocols;
mod replay;
mod ros2;
mod safety;
mod traj;
