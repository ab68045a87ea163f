//! A motion-mode reply (`0x500 + id`, MyActuator V3 on a `motion` bus): decoded with the
//! ranges of its motor's firmware, matched to its request like a torque reply, and turned into
//! the joint's feedback. Kept out of line: the torque replies' path does not carry it.

use rmd_bus::Timestamp;
use rmd_protocol::CanFrame;

use super::Exchange;
use super::collect::{Collected, Received};
use super::motor::ReplyClass;
use crate::stats::LoopStats;

impl<B> Exchange<B> {
    /// Handles `frame`, on motor `m`'s motion reply id, received at `at` in `tick` (replies up
    /// to `max_age` ticks old are fresh): a reply that does not decode (bad length, another
    /// motor's id in DATA\[0\]) is a bad frame.
    #[inline(never)]
    pub(super) fn on_motion_frame(
        &mut self,
        m: usize,
        frame: &CanFrame,
        at: Timestamp,
        (tick, max_age): (u64, u64),
        stats: &mut LoopStats,
        collected: &mut Collected,
    ) -> Received {
        let motor = &mut self.motors[m];
        let counters = &mut stats.motors[m];
        let decoded = motor
            .motion
            .map(|motion| motion.dialect.decode_mit_reply(frame));
        let reply = match decoded {
            Some(Ok((id, reply))) if id == motor.id => reply,
            _ => {
                counters.bad_frames += 1;
                return Received::Item;
            }
        };
        let feedback = &mut self.feedback[m];
        let was_fresh = feedback.freshness.is_fresh();
        match motor.on_motion_reply(&reply, at, tick, max_age, feedback, counters) {
            ReplyClass::Fresh => {
                collected.add(at, motor.round_trip_ns().unwrap_or(0));
                if !was_fresh {
                    let bus = motor.at.bus;
                    self.became_fresh(bus);
                }
            }
            ReplyClass::Late => stats.late_total += 1,
            ReplyClass::Unexpected => {}
        }
        Received::Item
    }
}
