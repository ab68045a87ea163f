//! The GYEMS / MyActuator RMD CAN protocol (v1.61): a typed, `no_std`, allocation-free model of
//! every command and reply.
#![no_std]

pub mod error;
pub mod frame;

pub use error::ProtocolError;
pub use frame::CanFrame;
