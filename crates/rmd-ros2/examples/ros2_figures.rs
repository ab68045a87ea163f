//! Figures for `docs/ros2.md`, printed, not asserted: the cost of publishing one
//! `joint_states` message, and the latency from publishing a `joint_commands` sample to the
//! port receiving its setpoints, both in one process over loopback DDS.
//!
//! ```text
//! cargo run --release -p rmd-ros2 --example ros2_figures -- --commands 3000
//! ```
//!
//! On a shared or busy machine the figures say little; run it on a quiet one.

fn main() {
    println!("placeholder");
}
