//! # rmd-demos: the models and controllers of the rmd-rt examples
//!
//! What is specific to the examples in `examples/` (their `main`s only parse flags and hand
//! their robot, controller and results to `rmd_rig::program::Program`): the 4-motor leg's model, the Cartesian
//! impedance law, the step cycle, and each example's controller, simulated robot, status line and
//! results. Ordinary library code, so the examples' tests import it like any crate. It sits on
//! `rmd-loop`, `rmd-rig`, `rmd-sim` and `rmd-traj`; nothing depends on it but the examples and
//! their tests (`publish = false`).
//!
//! - [`leg`]: geometry, forward and inverse kinematics, Jacobian and gravity of one leg; its
//!   joints found by name; the simulated leg;
//! - [`impedance`]: `torque = J^T (K (x_d - x) + D (v_d - v)) + g(q)` with joint-limit springs;
//! - [`step_cycle`]: a stance and a swing planned with the trajectory generator;
//! - [`pd_hold`], [`leg4`], [`quadruped`], [`trajectory_follow`]: each example's controller,
//!   simulated robot, status line (`rmd_rig::runner::Status`) and results
//!   (`rmd_rig::program::Verdict`);
//! - [`support`]: the motors' part of the status line and the value parser of the examples' flags.
//!
//! The robot descriptions the examples start from are `examples/robots/*.toml`.
//!
//! A controller, a robot, simulated motors, a run (what `examples/pd_hold.rs` does without its
//! flags and display):
//!
//! ```
//! use rmd_demos::pd_hold::{self, PdHold};
//! use rmd_loop::{RtLoop, RunLimit, robot::Robot};
//! use rmd_rig::{Placement, Rig, SimTime};
//!
//! let robot = Robot::from_toml(r#"
//!     [[bus]]
//!     interface = "can0"
//!     [[bus.motor]]
//!     id = 1
//!     name = "arm"
//!     gear_ratio = 9.0
//!     torque_constant_nm_per_amp = 2.09
//!     current_limit_amps = 3.0
//!     zero_offset_deg = 20.0
//! "#)?;
//! let placement = Placement::simulated(&robot, SimTime::Virtual);
//! let rig = Rig::open(&robot, &placement, pd_hold::sims(&robot, 1))?;
//! let hold = PdHold::new(&robot, 30.0);
//! let outcome = rig.into_loop(robot, hold)?.run(RunLimit::Ticks(1000));
//! assert!(outcome.report.normal_stop, "{}", outcome.report);
//! assert!((outcome.controller.targets.as_slice()[0] - 30.0).abs() < 0.1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
pub mod impedance;
pub mod leg;
pub mod leg4;
pub mod pd_hold;
pub mod quadruped;
pub mod step_cycle;
pub mod support;
pub mod trajectory_follow;

pub use error::DemoError;
