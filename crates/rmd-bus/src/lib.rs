//! The bus layer of rmd-rt: the `CanBus` and `Clock` traits, wire timing, candump formats, the
//! SocketCAN backend. Above `rmd-protocol`; `rmd-sim` and `rmd-loop` sit on it.
//!
//! The [`CanBus`] trait every transport implements (the simulator,
//! Linux SocketCAN) and the [`Clock`] that lets everything run in real or virtual time; CAN wire
//! timing ([`wire`]); candump's text formats ([`candump`]); recording a bus to a `candump -L`
//! log without blocking it ([`record`]) and playing a log back in time ([`replay`]); waiting
//! on several buses at once ([`ready`]).

pub mod bus;
pub mod candump;
pub mod clock;
pub mod ready;
pub mod record;
pub mod replay;
pub mod time;
pub mod wire;

#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;

pub use bus::{BusError, BusEvent, BusMessage, CanBus, Readiness, Received, WaitOn};
pub use clock::{Clock, MonotonicClock, VirtualClock};
pub use rmd_protocol::CanFrame;
pub use time::Timestamp;
