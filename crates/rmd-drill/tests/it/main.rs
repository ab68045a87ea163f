//! The integration tests of rmd-drill, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod chaos;
mod drills;
