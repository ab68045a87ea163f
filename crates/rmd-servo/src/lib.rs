//! # rmd-servo: a joint servo controller for the rmd-rt loop
//!
//! Position, velocity and effort setpoints, trajectories, a stale-setpoint policy and enable /
//! estop, driven by joint name from ordinary threads. Above `rmd-loop` and `rmd-traj`.
//!
//! [`ServoController`] is a [`Controller`](rmd_loop::Controller): run it in an
//! [`RtLoop`](rmd_loop::RtLoop). [`ServoHandle`] drives it from any thread (cheap to clone,
//! `Send + Sync`): setpoints and trajectories go in through a bounded lock-free queue, checked
//! on the caller's thread first; the state of every tick comes back the same way. The loop
//! thread allocates nothing, takes no lock and never waits.
//!
//! **Units**: joint side, SI: rad, rad/s, rad/s², rad/s³, N·m; gains in N·m/rad and
//! N·m·s/rad. Every joint needs its `torque_constant_nm_per_amp` in the robot description.
//!
//! **Modes** (per joint; [`Setpoint`]): position with velocity and effort feed-forward
//! (τ = kp·(x* − x) + kd·(v_ff − v) + τ_ff), velocity (a position reference advancing at the
//! velocity, PD on it, stopping at the position limits), effort, a [`trajectory`],
//! and hold (at start, after a trajectory, after enabling). The torque is clamped to the
//! joint's `max_effort_nm`; the loop clamps the current to `current_limit_amps`.
//!
//! **Motion mode**: a joint on a MyActuator V3 bus with `exchange = "motion"` gets the law's
//! reference, gains (per degree: the N·m/rad gains times π/180) and feed-forward as one motion
//! setpoint per tick ([`ServoConfig::command_kind`]); the motor runs the law itself.
//!
//! **Stale setpoints**: a position, velocity or effort setpoint not renewed within
//! `stale_after_ms` turns into a hold or zero torque (`stale_policy`), counted.
//!
//! **Enable / estop**: [`ServoHandle::disable`] puts every joint at zero torque with the loop
//! running; [`ServoHandle::enable`] holds every joint where it is. [`ServoHandle::estop`] ends
//! the run: the servo returns `Flow::Halt("estop")` and the loop's safe stop turns the motors
//! off.
//!
//! ```
//! use std::time::Duration;
//! use rmd_bus::VirtualClock;
//! use rmd_loop::{RtLoop, StopReason, robot::Robot};
//! use rmd_servo::{JointTrajectory, JointTrajectoryPoint, ServoConfig, ServoController};
//!
//! let robot = Robot::from_toml(r#"
//!     [[bus]]
//!     interface = "sim"
//!     [[bus.motor]]
//!     id = 1
//!     name = "elbow"
//!     gear_ratio = 9.0
//!     torque_constant_nm_per_amp = 2.09
//!     zero_offset_deg = 20.0
//! "#)?;
//! let config = ServoConfig::from_toml(&robot, "[defaults]\nkp_nm_per_rad = 60.0\nkd_nm_s_per_rad = 1.5")?;
//! let (servo, handle) = ServoController::new(config);
//! // Simulated motors in virtual time, ticked one by one here (a program would `spawn` the
//! // loop and use `handle` from its own threads).
//! let clock = VirtualClock::new();
//! let mut buses = rmd_rig::open::sim_buses(&clock, rmd_rig::sim::sim_configs(&robot, 1))?;
//! let rt = RtLoop::unsupervised(robot, clock, buses.iter_mut().collect(), servo)?;
//! let mut running = rt.start().map_err(|outcome| outcome.report.to_string())?;
//! let _ = running.step();
//!
//! let wave = JointTrajectory::new(["elbow"])
//!     .point(JointTrajectoryPoint::at(Duration::from_millis(500), [0.2]))
//!     .point(JointTrajectoryPoint::at(Duration::from_millis(1000), [0.0]));
//! let receipt = handle.send_trajectory(&wave)?;
//! assert_eq!(receipt.max_lateness_s, 0.0);
//! for _ in 0..1500 {
//!     let _ = running.step();
//! }
//! let elbow = handle.state().unwrap().joints()[0];
//! assert!(elbow.position_rad.abs() < 0.01, "{elbow:?}");
//! let outcome = running.finish(StopReason::Requested);
//! assert!(outcome.report.normal_stop);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! See `docs/servo.md` for the configuration keys and the semantics in full.

pub mod config;
mod controller;
mod error;
mod handle;
mod law;
mod link;
mod motion;
mod setpoint;
mod state;
mod status;
mod step;
pub mod trajectory;

pub use config::{
    Gains, JointLimits, JointServo, JointSettings, LimitSource, ServoConfig, ServoConfigError,
    ServoFile, StalePolicy,
};
pub use controller::ServoController;
pub use error::{ServoError, TrajectoryRefusal};
pub use handle::ServoHandle;
pub use setpoint::{JointRef, Setpoint};
pub use state::{JointCounters, JointStatus, Reference, ServoMode, ServoState};
pub use trajectory::{JointTrajectory, JointTrajectoryPoint, TrajectoryReceipt, TrajectoryStart};

/// docs/servo.md, whose code blocks `cargo test --doc -p rmd-servo` compiles and runs.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/servo.md")]
pub struct ServoGuide;
