//! The integration tests of rmd-traj-vectors, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod vectors;
