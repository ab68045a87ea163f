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
//! A controller by joint names, a robot from its description, simulated motors, a run:
//!
//! ```
//! use std::time::Duration;
//! use rmd_rt::rig::{Placement, Rig, SimTime, sim};
//! use rmd_rt::{Commands, Controller, Feedback, Flow, JointId, Robot, RtLoop, RunLimit, StopReason, TickContext};
//!
//! /// The smallest useful controller: hold the elbow at a target angle.
//! struct Hold { elbow: JointId, target_deg: f64 }
//!
//! impl Controller for Hold {
//!     fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
//!         let elbow = fb[self.elbow].joint;
//!         cmd.set_current(self.elbow, 0.8 * (self.target_deg - elbow.angle_deg) - 0.03 * elbow.velocity_dps);
//!         Flow::Continue
//!     }
//! }
//!
//! // One RMD-X8-class motor (1:9 gearbox), at most 3 A, at 1 kHz.
//! let robot = Robot::from_toml(r#"
//!     [[bus]]
//!     interface = "can0"
//!     [[bus.motor]]
//!     id = 1
//!     name = "elbow"
//!     gear_ratio = 9.0
//!     torque_constant_nm_per_amp = 2.09
//!     current_limit_amps = 3.0
//! "#)?;
//! let hold = Hold { elbow: robot.joint("elbow")?, target_deg: 10.0 };
//!
//! // Simulated motors matching the description, in virtual time (`Placement::resolve` with
//! // the command line's `--iface` picks real interfaces instead).
//! let rig = Rig::open(&robot, &Placement::simulated(&robot, SimTime::Virtual), sim::sim_configs(&robot, 1))?;
//! let mut rt = RtLoop::new(robot, rig.clock, rig.buses, hold)?;
//! let telemetry = rt.telemetry();
//! let outcome = rt.spawn(RunLimit::Duration(Duration::from_secs(2)))?.join()?;
//!
//! assert_eq!(outcome.report.stop_reason, StopReason::TickLimit);
//! assert!(outcome.report.safe_stop.all_off_confirmed());
//! let elbow = telemetry.latest().unwrap().joints()[0].feedback.joint;
//! assert!((elbow.angle_deg - 10.0).abs() < 0.3);
//! println!("{}", outcome.report); // latencies, misses, per-joint counters, safe stop
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use rmd_bus as bus;
pub use rmd_drill as drill;
pub use rmd_loop as rt;
pub use rmd_protocol as protocol;
pub use rmd_rig as rig;
pub use rmd_servo as servo;
pub use rmd_sim as sim;
pub use rmd_traj as traj;

pub use rmd_loop::{
    Commands, Controller, Fault, Feedback, Flow, JointArray, JointFeedback, JointId, LoopHandle,
    LoopOutcome, LoopReport, Robot, RtLoop, RunLimit, StopReason, TickContext,
};

/// docs/controller.md, whose code blocks `cargo test --doc` compiles and runs (the guide's
/// complete 4-joint program among them).
#[cfg(doctest)]
#[doc = include_str!("../docs/controller.md")]
pub struct ControllerGuide;
