//! # rmd-rt
//!
//! Real-time control of GYEMS / MyActuator RMD servo motors over CAN. This facade re-exports the
//! member crates:
//!
//! - [`protocol`]: the wire format (every command and reply of protocol v1.61, typed, `no_std`);
//! - [`bus`]: the [`bus::CanBus`] and [`bus::Clock`] abstractions, CAN wire timing, candump
//!   formats and the Linux SocketCAN backend;
//! - [`sim`]: simulated RMD motors and a simulated CAN bus (virtual or real time, fault injection);
//! - [`rt`]: the real-time loop; its main types are also at the root of this crate;
//! - [`traj`]: time-optimal, jerk-limited multi-axis trajectories (allocation-free, for the loop);
//! - [`connect`]: one bus per bus of a robot description, simulated or SocketCAN, and Ctrl-C.
//!
//! ```
//! use rmd_rt::{Commands, Controller, Feedback, Flow, TickContext};
//!
//! /// The smallest useful controller: hold every joint where it is told to be.
//! struct PdHold { target_deg: f64 }
//!
//! impl Controller for PdHold {
//!     fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
//!         for (i, joint) in fb.iter().enumerate() {
//!             let amps = 0.3 * (self.target_deg - joint.joint_angle_deg) - 0.01 * joint.joint_velocity_dps;
//!             let _ = cmd.set_current(i, amps);
//!         }
//!         Flow::Continue
//!     }
//! }
//! ```

pub mod connect;

pub use rmd_bus as bus;
pub use rmd_loop as rt;
pub use rmd_protocol as protocol;
pub use rmd_sim as sim;
pub use rmd_traj as traj;

pub use rmd_loop::{
    BusConfig, Commands, Controller, Fault, Feedback, Flow, LoopHandle, LoopOutcome, LoopReport,
    MotorConfig, MotorFeedback, RobotConfig, RtLoop, RunLimit, StopReason, TickContext,
};
