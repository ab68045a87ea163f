//! The integration tests of rmd-rt, one binary: each file a module, so the crate and its
//! dependencies are linked once for all of them.

mod support;

mod example_leg4;
mod example_leg4_v3;
mod example_leg_model;
mod example_pd_hold;
mod example_quadruped;
mod example_robots;
mod example_trajectory_follow;
