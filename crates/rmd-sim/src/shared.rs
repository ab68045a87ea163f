//! [`SharedSimBus`]: one [`SimBus`] behind several handles, each a [`CanBus`].
//!
//! The simulated motors are one world: whoever holds a handle (the loop thread, a supervisor's
//! second way onto the bus, a test or a program looking at the motors) sees the same wire and
//! the same motors. A handle takes the lock only inside a bus call or [`SharedSimBus::lock`],
//! and a lock poisoned by a panic elsewhere is taken over: the simulation stays usable, so a
//! safe stop after a panic still reaches the motors.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use rmd_bus::{BusError, CanBus, Clock, Received, Timestamp};
use rmd_protocol::CanFrame;

use crate::bus::SimBus;

/// A [`SimBus`] shared by every clone of this handle.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::{CanBus, Clock, VirtualClock};
/// use rmd_protocol::{Dialect, MotorId, Request};
/// use rmd_sim::{ControlMode, SharedSimBus, SimBus, SimConfig};
///
/// let clock = VirtualClock::new();
/// let shared = SharedSimBus::new(SimBus::new(clock.clone(), SimConfig::with_motors(1))?);
/// let mut for_the_loop = shared.clone();
/// let m1 = MotorId::new(1).unwrap();
/// for_the_loop.send(&Dialect::V161.encode(m1, &Request::MotorOff).unwrap()).unwrap();
/// assert!(for_the_loop.recv_until(clock.now() + Duration::from_millis(1)).unwrap().is_some());
/// // The other handle looks at the same motor.
/// assert_eq!(shared.lock().snapshot(m1).unwrap().mode, ControlMode::Off);
/// # Ok::<(), rmd_sim::ConfigError>(())
/// ```
#[derive(Debug)]
pub struct SharedSimBus<C: Clock>(Arc<Mutex<SimBus<C>>>);

impl<C: Clock> SharedSimBus<C> {
    /// Shares `bus`.
    pub fn new(bus: SimBus<C>) -> Self {
        Self(Arc::new(Mutex::new(bus)))
    }

    /// The simulated bus (to look at the motors or change them); every other handle waits
    /// until the guard is dropped.
    pub fn lock(&self) -> MutexGuard<'_, SimBus<C>> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl<C: Clock> Clone for SharedSimBus<C> {
    fn clone(&self) -> Self {
        Self(Arc::clone(&self.0))
    }
}

impl<C: Clock> CanBus for SharedSimBus<C> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        self.lock().send(frame)
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        self.lock().recv_until(deadline)
    }
}

#[cfg(test)]
mod tests {
    use core::time::Duration;

    use rmd_bus::{BusMessage, VirtualClock};
    use rmd_protocol::{Dialect, MotorId, Request};

    use super::*;
    use crate::config::SimConfig;

    #[test]
    fn a_panic_while_locked_leaves_the_simulation_usable() {
        let clock = VirtualClock::new();
        let shared =
            SharedSimBus::new(SimBus::new(clock.clone(), SimConfig::with_motors(2)).unwrap());
        let other = shared.clone();
        let panicked = std::thread::spawn(move || {
            let _guard = other.lock();
            panic!("a test thread dies holding the lock");
        })
        .join();
        assert!(panicked.is_err());
        let mut bus = shared.clone();
        let m2 = MotorId::new(2).unwrap();
        bus.send(&Dialect::V161.encode(m2, &Request::ReadStatus1).unwrap())
            .unwrap();
        let reply = bus
            .recv_until(clock.now() + Duration::from_millis(1))
            .unwrap()
            .unwrap();
        let BusMessage::Frame(frame) = reply.message else {
            panic!("{reply:?}")
        };
        assert_eq!(Dialect::V161.decode_reply(&frame).unwrap().0, m2);
        assert_eq!(shared.lock().stats().received_frames, 1);
    }
}
