//! Receiving a bus's replies until each of its motors has answered or the deadline passes.

use core::time::Duration;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Timestamp};
use rmd_protocol::Command;

use super::Exchange;
use super::frames::{Incoming, match_reply};
use super::motor::ReplyClass;
use crate::report::Fault;
use crate::stats::LoopStats;

/// The newest fresh reply of a collection: when it came, and its motor's round trip.
pub(crate) type NewestReply = Option<(Timestamp, Duration)>;

impl<B: CanBus> Exchange<B> {
    /// Receives from bus `b` until each of its motors has fresh feedback or `deadline` passes,
    /// accepting replies up to `max_age` ticks old as fresh in `tick`.
    pub(crate) fn collect(
        &mut self,
        b: usize,
        tick: u64,
        deadline: Timestamp,
        max_age: u64,
        stats: &mut LoopStats,
    ) -> Result<NewestReply, Fault> {
        let mut newest: NewestReply = None;
        while !self.bus_complete(b) {
            let received = match self.links[b].bus.recv_until(deadline) {
                Ok(None) => break,
                Ok(Some(received)) => received,
                Err(BusError::BusOff) => return Err(Fault::BusOff { bus: b }),
                Err(BusError::InterfaceDown) => {
                    return Err(Fault::Bus {
                        bus: b,
                        error: BusError::InterfaceDown,
                    });
                }
                Err(_) => {
                    // A transient receive error: count it and stop collecting on this bus for
                    // this tick rather than spin on it.
                    stats.buses[b].rx_errors += 1;
                    break;
                }
            };
            let frame = match received.message {
                BusMessage::Frame(frame) => frame,
                BusMessage::Event(event) => {
                    stats.buses[b].count_event(event);
                    if event == BusEvent::BusOff {
                        return Err(Fault::BusOff { bus: b });
                    }
                    continue;
                }
            };
            let joints = self.links[b].joints();
            let (m, status) = match match_reply(&frame, Command::Torque, &self.motors, joints) {
                Incoming::Foreign => {
                    stats.buses[b].unexpected_frames += 1;
                    continue;
                }
                Incoming::Bad { motor } => {
                    stats.motors[motor].bad_frames += 1;
                    continue;
                }
                Incoming::Reply { motor, reply } => match reply.status2() {
                    Some(status) => (motor, status),
                    None => {
                        stats.motors[motor].bad_frames += 1;
                        continue;
                    }
                },
            };
            let class = self.motors[m].on_reply(
                &status,
                received.at,
                tick,
                max_age,
                &mut self.feedback[m],
                &mut stats.motors[m],
            );
            if class == ReplyClass::Fresh
                && let Some(rtt) = self.motors[m].round_trip
                && newest.is_none_or(|(at, _)| received.at > at)
            {
                newest = Some((received.at, rtt));
            }
        }
        Ok(newest)
    }
}
