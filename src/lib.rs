//! # rmd-rt
//!
//! Real-time control of GYEMS / MyActuator RMD servo motors over CAN. This facade re-exports the
//! member crates:
//!
//! - [`protocol`]: the wire format (every command and reply of protocol v1.61, typed, `no_std`);
//! - [`bus`]: the [`bus::CanBus`] and [`bus::Clock`] abstractions;
//! - [`traj`]: time-optimal, jerk-limited, multi-axis trajectory generation (`no_std`).

pub use rmd_bus as bus;
pub use rmd_protocol as protocol;
pub use rmd_traj as traj;
