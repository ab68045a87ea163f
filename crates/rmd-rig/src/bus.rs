//! One bus of a run: simulated motors or a SocketCAN interface; and the supervisor's own way onto
//! it (a second socket on the interface, or a second handle to the simulated bus).

use rmd_bus::{BusError, CanBus, Readiness, Received, Timestamp};
use rmd_loop::supervisor::SafetyPort;
use rmd_protocol::CanFrame;

use crate::clock::AnyClock;

/// A simulated bus of a run, on the run's clock, shared by the loop thread and the supervisor
/// (the simulated motors are one world: both see the same wire).
pub type SharedSim = rmd_sim::SharedSimBus<AnyClock>;

/// One bus of a run.
#[derive(Debug)]
pub enum AnyBus {
    /// Simulated motors.
    Sim(SharedSim),
    /// A real (or virtual) CAN interface.
    #[cfg(target_os = "linux")]
    SocketCan(Box<rmd_bus::socketcan::SocketCanBus>),
}

impl AnyBus {
    /// The simulated bus, if this is one (to look at the simulated motors).
    pub fn sim(&self) -> Option<&SharedSim> {
        match self {
            AnyBus::Sim(bus) => Some(bus),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(_) => None,
        }
    }

    /// A second way onto this bus for the supervisor: a second handle to the simulated bus, or
    /// a second socket on the interface.
    pub fn safety_port(&self) -> Result<SafetyPort, crate::RigError> {
        match self {
            AnyBus::Sim(bus) => Ok(Box::new(bus.clone())),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => {
                use rmd_bus::socketcan::SocketCanBus;
                let iface = bus.iface().to_string();
                SocketCanBus::open(&iface, &loop_socket_options())
                    .map(|port| Box::new(port) as SafetyPort)
                    .map_err(|source| crate::RigError::Open {
                        bus: format!("{iface} (the supervisor's socket)"),
                        source,
                    })
            }
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

    fn readiness(&mut self) -> Readiness<'_> {
        match self {
            AnyBus::Sim(bus) => bus.readiness(),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => bus.readiness(),
        }
    }
}

/// The loop's socket: the motors' replies on `0x140 + id`, and `0x240 + id` (where MyActuator V3
/// firmware answers: the start-up identification must see it to refuse it).
#[cfg(target_os = "linux")]
pub(crate) fn loop_socket_options() -> rmd_bus::socketcan::SocketCanOptions {
    rmd_bus::socketcan::SocketCanOptions::new().accept_ids(
        rmd_protocol::V3_REPLY_BASE_ID + u16::from(rmd_protocol::MotorId::MIN)
            ..=rmd_protocol::V3_REPLY_BASE_ID + u16::from(rmd_protocol::MotorId::MAX),
    )
}
