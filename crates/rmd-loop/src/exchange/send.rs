//! Sending a bus's 0x280 frame.

use rmd_bus::{BusError, CanBus, Timestamp};

use super::Exchange;
use super::frames::{TorqueSlots, torque_frame};
use crate::report::Fault;
use crate::stats::LoopStats;

impl<B: CanBus> Exchange<B> {
    /// Sends `slots` as one 0x280 frame on bus `b` and records the request, sent at `at` in
    /// `tick`, for each of its motors. A full transmit queue is counted and rides through (its
    /// motors will miss this tick); bus-off and a lost interface are faults.
    pub(crate) fn send(
        &mut self,
        b: usize,
        slots: &TorqueSlots,
        tick: u64,
        at: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<(), Fault> {
        let link = &mut self.links[b];
        link.commanded = true;
        match link.bus.send(&torque_frame(slots)) {
            Ok(()) => {
                for m in link.joints() {
                    self.motors[m].pending.push(tick, at);
                }
                Ok(())
            }
            Err(error) => {
                stats.buses[b].tx_errors += 1;
                match error {
                    BusError::TxQueueFull | BusError::Io(_) => Ok(()),
                    BusError::BusOff => Err(Fault::BusOff { bus: b }),
                    error => Err(Fault::Bus { bus: b, error }),
                }
            }
        }
    }
}
