//! # rmd-rt
//!
//! Real-time control of GYEMS / MyActuator RMD servo motors over CAN. This facade only
//! re-exports the member crates (see docs/architecture.md for who owns what):
//!
//! - [`protocol`]: the wire format (every command and reply of protocol v1.61, typed, `no_std`);
//! - [`bus`]: the [`bus::CanBus`] and [`bus::Clock`] abstractions, CAN wire timing, candump
//!   formats and the Linux SocketCAN backend;
//! - [`sim`]: simulated RMD motors and a simulated CAN bus (virtual or real time, fault injection);
//! - [`rt`]: the real-time loop and the robot description; its main types are also at the root
//!   of this crate;
//! - [`rig`]: opening a robot on its buses (SocketCAN or simulated motors matching the
//!   description), the signal policy, the runner and the standard flags;
//! - [`traj`]: time-optimal, jerk-limited multi-axis trajectories (`no_std`, allocation-free);
//! - [`servo`]: a joint servo controller (position / velocity / effort setpoints, trajectories)
//!   driven by joint name from ordinary threads;
//! - [`drill`]: fault drills on simulated motors, judged by the simulated firmware (`rmd drill`).
//!
//! A complete program: a controller by joint names, a robot from its description, simulated
//! motors, a supervised run ([`prelude`] has every name it uses):
//!
//! ```
//! use rmd_rt::prelude::*;
//!
//! /// Holds a joint at a target angle: current = kp * error - kd * velocity.
//! struct Hold { joint: JointId, target_deg: f64 }
//!
//! impl Controller for Hold {
//!     fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
//!         let state = fb[self.joint].joint;
//!         cmd.set_current(self.joint, 0.8 * (self.target_deg - state.angle_deg) - 0.03 * state.velocity_dps);
//!         Flow::Continue
//!     }
//! }
//!
//! fn main() -> Result<(), Box<dyn std::error::Error>> {
//!     // One RMD-X8-class motor on can0, joint "arm", with its limits (a shipped example).
//!     let robot = Robot::from_file("examples/robots/pd_hold.toml")?;
//!     let hold = Hold { joint: robot.joint("arm")?, target_deg: 10.0 };
//!     // Simulated motors in virtual time. On the real bus: `Rig::open` with the command
//!     // line's placement (`Placement::resolve`: `--iface can0`, `--sim`).
//!     let rig = Rig::simulated(&robot, SimTime::Virtual)?;
//!     // Supervised: a hung controller or bus is stopped from another thread.
//!     let outcome = rig.into_loop(robot, hold)?.run(RunLimit::Duration(Duration::from_secs(2)));
//!     println!("{}", outcome.report); // latencies, misses, per-joint counters, safe stop
//! #   assert_eq!(outcome.report.stop_reason, StopReason::TickLimit);
//! #   assert!(outcome.report.safe_stop.all_off_confirmed(), "{}", outcome.report);
//!     Ok(())
//! }
//! ```
//!
//! [`RtLoop::unsupervised`] builds a loop without that supervisor (tests, and loops whose buses have no
//! second way in); [`rig::Rig::into_loop`] is the supervised way.

pub use rmd_bus as bus;
pub use rmd_drill as drill;
pub use rmd_loop as rt;
pub use rmd_protocol as protocol;
pub use rmd_rig as rig;
pub use rmd_servo as servo;
pub use rmd_sim as sim;
pub use rmd_traj as traj;

pub use rmd_loop::{
    CommandKind, Commands, Controller, Fault, Feedback, Flow, JointArray, JointFeedback, JointId,
    LoopHandle, LoopOutcome, LoopReport, MotionCommand, RtLoop, RunLimit, StopReason, TickContext,
    robot::Robot,
};

/// The names a controller program uses: the controller trait and what it sees and writes each
/// tick, the robot description, and the rig that opens its buses (simulated or SocketCAN).
pub mod prelude {
    pub use crate::rig::{Placement, Rig, SimTime};
    pub use rmd_loop::{
        CommandKind, Commands, Controller, Fault, Feedback, Flow, JointId, LoopOutcome, LoopReport,
        MotionCommand, RunLimit, StopReason, TickContext, robot::Robot,
    };
    pub use std::time::Duration;
}

/// docs/controller.md, whose code blocks `cargo test --doc` compiles and runs (the guide's
/// complete 4-joint program among them).
#[cfg(doctest)]
#[doc = include_str!("../docs/controller.md")]
pub struct ControllerGuide;
