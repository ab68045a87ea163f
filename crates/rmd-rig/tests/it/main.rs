//! The integration tests of rmd-rig, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod open;
mod program;
mod signals;
