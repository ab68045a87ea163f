//! One bus of a run: simulated motors or a SocketCAN interface.

use rmd_bus::{BusError, CanBus, Received, Timestamp};
use rmd_protocol::CanFrame;
use rmd_sim::SimBus;

use crate::clock::AnyClock;

/// One bus of a run.
#[derive(Debug)]
pub enum AnyBus {
    /// Simulated motors.
    Sim(Box<SimBus<AnyClock>>),
    /// A real (or virtual) CAN interface.
    #[cfg(target_os = "linux")]
    SocketCan(Box<rmd_bus::socketcan::SocketCanBus>),
}

impl AnyBus {
    /// The simulated bus, if this is one (to look at the simulated motors).
    pub fn as_sim_mut(&mut self) -> Option<&mut SimBus<AnyClock>> {
        match self {
            AnyBus::Sim(bus) => Some(bus),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(_) => None,
        }
    }
}

impl CanBus for AnyBus {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        match self {
            AnyBus::Sim(bus) => bus.send(frame),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => bus.send(frame),
        }
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        match self {
            AnyBus::Sim(bus) => bus.recv_until(deadline),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => bus.recv_until(deadline),
        }
    }
}
