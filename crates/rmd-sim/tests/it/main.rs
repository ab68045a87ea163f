//! The integration tests of rmd-sim, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod common;

mod bus_timing;
mod faults;
mod firmware_commands;
mod firmware_families;
mod firmware_v3;
mod ground_truth;
mod physics_behaviour;
mod robustness;
mod threaded;
