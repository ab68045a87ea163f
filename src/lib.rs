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
//! - [`traj`]: time-optimal, jerk-limited multi-axis trajectories (`no_std`, allocation-free);
//! - [`connect`]: one bus per bus of a robot description, simulated or SocketCAN, and Ctrl-C.
//!
//! A controller, a robot, motors, a run: the whole path, here on a simulated motor in virtual
//! time (with `Target::SocketCan(vec!["can0".into()])` the same code drives a real one). See
//! `examples/` and `docs/getting-started.md` in the repository for more.
//!
//! ```
//! use std::time::Duration;
//! use rmd_rt::connect::{self, SimTime, Target};
//! use rmd_rt::{BusConfig, Commands, Controller, Feedback, Flow, MotorConfig, RobotConfig};
//! use rmd_rt::{RtLoop, RunLimit, StopReason, TickContext};
//!
//! /// The smallest useful controller: hold every joint at a target angle.
//! struct PdHold { target_deg: f64 }
//!
//! impl Controller for PdHold {
//!     fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
//!         for (i, joint) in fb.iter().enumerate() {
//!             let amps = 0.8 * (self.target_deg - joint.joint_angle_deg) - 0.03 * joint.joint_velocity_dps;
//!             let _ = cmd.set_current(i, amps); // joint sign, clamped to the current limit
//!         }
//!         Flow::Continue
//!     }
//! }
//!
//! // One bus, one RMD-X8-class motor (1:9 gearbox), at most 3 A, at 1 kHz.
//! let motor = MotorConfig::new(1).gear_ratio(9.0).torque_constant(2.09).current_limit(3.0);
//! let robot = RobotConfig::new(1000.0).with_bus(BusConfig::new("can0").with_motor(motor));
//!
//! // Simulated motors matching the description, in virtual time.
//! let target = Target::Simulator(SimTime::Virtual);
//! let connection = connect::open(&target, &robot, connect::sim_configs(&robot, 1))?;
//! let rt = RtLoop::new(robot, connection.clock, connection.buses, PdHold { target_deg: 10.0 })?;
//! let telemetry = rt.telemetry();
//!
//! // On its own thread for 2 s; Ctrl-C would stop it (zero torque, then motor off).
//! connect::stop_on_ctrl_c(rt.stopper())?;
//! let handle = rt.spawn(RunLimit::Duration(Duration::from_secs(2)))?;
//! let outcome = handle.join()?;
//!
//! assert_eq!(outcome.report.stop_reason, StopReason::TickLimit);
//! assert_eq!(outcome.report.stats.deadline_misses, 0);
//! assert!(outcome.report.safe_stop.all_off_confirmed());
//! let joint = telemetry.latest().unwrap().joints()[0];
//! assert!((joint.joint_angle_deg - 10.0).abs() < 0.3);
//! println!("{}", outcome.report); // latencies, misses, per-motor counters, safe stop
//! # Ok::<(), Box<dyn std::error::Error>>(())
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
