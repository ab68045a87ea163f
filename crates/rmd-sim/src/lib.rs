//! Simulated RMD motors (firmware, physics, faults) behind a simulated CAN wire, as a `CanBus`.
//! Above `rmd-protocol` and `rmd-bus`; `rmd-rig` opens it for a robot description.
//!
//! Simulated GYEMS / MyActuator RMD motors and a simulated CAN bus, so that controllers can be
//! developed, tested and benchmarked without hardware: in virtual time (deterministic, faster
//! than real time) or in real time, with seeded fault injection.
//!
//! The crate is split by concern:
//!
//! - [`firmware`]: one motor's firmware: every command of protocol v1.61, RAM/ROM, modes,
//!   protection flags ([`control`]: its closed loops); optionally LK-TECH V2.3x or MyActuator
//!   V3 firmware and firmware-state traps ([`family`]);
//! - [`physics`]: rotor + gearbox + load, friction, torque constant, current response, gravity
//!   link, temperature, supply sag ([`params`]: the parameters and their sources);
//! - `medium`: the event-driven CAN wire (exact frame lengths, arbitration, queues; its
//!   [`WireTiming`], [`Transmission`] and [`Node`] are re-exported);
//! - [`fault`]: fault-injection rules;
//! - [`SimMotors`]: the motors of a bus as firmware (frames in, timed replies out), usable on a
//!   real CAN interface too;
//! - [`SimBus`]: motors behind the simulated wire, implementing [`rmd_bus::CanBus`];
//! - [`SharedSimBus`]: one `SimBus` behind several handles (the loop thread, a supervisor, a
//!   program looking at the motors), each a `CanBus`;
//! - [`threaded`]: a `SimBus` on a thread of its own, used through lock-free queues (Linux).
//!
//! See `docs/simulator.md` in the repository for what is and is not modelled.
//!
//! ```
//! use core::time::Duration;
//! use rmd_bus::{CanBus, Clock, VirtualClock};
//! use rmd_protocol::{Command, Dialect, MotorId, Request};
//! use rmd_sim::{FaultRule, ReplyFault, SimBus, SimConfig};
//!
//! let clock = VirtualClock::new();
//! let config = SimConfig::with_motors(2)
//!     .seed(42)
//!     .fault(FaultRule::new(ReplyFault::DropReply).command(Command::ReadStatus1).with_probability(0.5));
//! let mut bus = SimBus::new(clock.clone(), config)?;
//! let m1 = MotorId::new(1).unwrap();
//! bus.send(&Dialect::V161.encode(m1, &Request::ReadStatus2).unwrap()).unwrap();
//! let rx = bus.recv_until(clock.now() + Duration::from_millis(1)).unwrap().unwrap();
//! # let rmd_bus::BusMessage::Frame(frame) = rx.message else { panic!() };
//! let (motor, reply) = Dialect::V161.decode_reply(&frame).unwrap();
//! assert_eq!(motor, m1);
//! assert_eq!(reply.status2().unwrap().temperature.celsius(), 25.0);
//! # Ok::<(), rmd_sim::ConfigError>(())
//! ```

pub mod bus;
pub mod config;
pub mod control;
mod encoder;
pub mod error;
pub mod family;
pub mod fault;
pub mod firmware;
mod medium;
pub mod motor;
pub mod motors;
pub mod params;
pub mod physics;
mod request;
mod shared;
#[cfg(target_os = "linux")]
pub mod threaded;

pub use bus::{BusStats, SimBus};
pub use config::{
    ClearErrorReply, FirmwareParams, SimBusConfig, SimConfig, SimMotorConfig, V3Params,
};
pub use error::ConfigError;
pub use family::{CommandSet, FirmwareFamily, FirmwareTraps};
pub use fault::{
    BusFault, FaultKind, FaultRule, FrameFilter, MotorSet, PhysicalFault, ReplyFault, Window,
};
pub use firmware::ControlMode;
pub use medium::{Node, Transmission, WireTiming};
pub use motor::{MotorSnapshot, MotorStats, SimMotor, TrapStats};
pub use motors::{Replies, ScheduledFrame, SimMotors};
pub use params::{GravityLink, LoadParams, MotorParams, STANDARD_GRAVITY};
pub use physics::SUBSTEP;
pub use shared::SharedSimBus;
