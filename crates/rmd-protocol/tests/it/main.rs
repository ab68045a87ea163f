//! The integration tests of rmd-protocol, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod dialects;
mod golden;
mod properties;
mod rejection;
mod v3;
