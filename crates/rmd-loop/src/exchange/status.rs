//! The health rotation: one status request (0x9A) per bus per tick, after the torque requests,
//! to each of the bus's motors in turn; and the status replies, which come on the motors'
//! torque reply ids and are told apart by their command byte.
//!
//! A status reply answers its motor's oldest outstanding status request, never a torque request:
//! the torque replies' matching (first in, first out, their freshness) never sees it. A status
//! request whose reply never comes is counted when the ring of outstanding ones gives it up,
//! and is no fault by itself. An error flag in a reply is a fault naming the motor.

use rmd_bus::{CanBus, Timestamp};
use rmd_protocol::{CanFrame, Command};

use super::Exchange;
use super::collect::Received;
use super::send::sent_error;
use crate::health::{MotorFlag, MotorHealth};
use crate::report::Fault;
use crate::stats::LoopStats;

/// DATA\[0\] of a status-1 reply.
const STATUS1: u8 = Command::ReadStatus1.code();

impl<B: CanBus> Exchange<B> {
    /// Sends bus `b`'s status request of `tick` (when its rotation is on) to the motor whose
    /// turn it is, and moves the rotation on. A refused send is counted like a torque
    /// request's.
    #[inline]
    pub(super) fn send_status(
        &mut self,
        b: usize,
        tick: u64,
        at: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<(), Fault> {
        let link = &mut self.links[b];
        let Some(m) = link.health_next else {
            return Ok(());
        };
        // The next motor of the bus, after the last the first (a comparison, no division).
        let next = m + 1;
        link.health_next = Some(if next == link.joints.end {
            link.joints.start
        } else {
            next
        });
        let motor = &mut self.motors[m];
        let Some(frame) = &motor.status_request else {
            return Ok(());
        };
        match link.bus.send(frame) {
            Ok(()) => {
                if motor.status_pending.push(tick, at.as_nanos()) {
                    stats.motors[m].missing_status_replies += 1;
                }
                Ok(())
            }
            Err(error) => sent_error(b, error, stats),
        }
    }
}

impl<B> Exchange<B> {
    /// Handles a frame on motor `m`'s reply id that is not its torque reply, received at `at`:
    /// a status reply answering its oldest outstanding status request updates its health (an
    /// error flag is a fault); one with none outstanding is unexpected; anything else is a bad
    /// frame. Kept out of line: the torque replies' path does not carry it.
    #[inline(never)]
    pub(super) fn on_other_reply(
        &mut self,
        m: usize,
        frame: &CanFrame,
        at: Timestamp,
        stats: &mut LoopStats,
    ) -> Result<Received, Fault> {
        let motor = &mut self.motors[m];
        let counters = &mut stats.motors[m];
        let status = match frame.data().first() {
            Some(&STATUS1) => motor
                .dialect
                .decode_reply_to(frame, Command::ReadStatus1)
                .ok()
                .and_then(|(_, reply)| reply.status1()),
            _ => None,
        };
        let Some(status) = status else {
            counters.bad_frames += 1;
            return Ok(Received::Item);
        };
        let min_round_trip_ns = motor.min_round_trip_ns();
        let round_trip_ns = motor.round_trip_ns();
        let Some((requested_tick, lost)) =
            motor
                .status_pending
                .answer(at.as_nanos(), min_round_trip_ns, round_trip_ns)
        else {
            counters.unexpected_replies += 1;
            return Ok(Received::Item);
        };
        counters.missing_status_replies += lost;
        counters.status_replies += 1;
        let health = MotorHealth::of(&status, requested_tick);
        self.feedback[m].health = Some(health);
        match MotorFlag::first_in(&status) {
            None => Ok(Received::Item),
            Some(flag) => Err(Fault::MotorError {
                at: motor.at,
                flag,
                error_flags: health.error_flags.raw(),
            }),
        }
    }
}
