//! Matching replies to requests, per motor.
//!
//! Every 0x280 frame asks each motor on its bus for one 0xA1 reply, and all replies look alike,
//! so the loop keeps, per motor, the frames not answered yet and the motor's round-trip time
//! (measured in the start-up probe exchange, when only one request is outstanding, then tracked
//! with a moving average). A reply can be late but not (much) early: it can only answer a request
//! whose expected arrival (`sent + round trip - tolerance`) it has reached. Among those it answers
//! the newest; the firmware answers in order, so older outstanding requests are then known lost.
//! The reply's age (this tick minus that request's tick) says whether it is this tick's reply or
//! one that missed an earlier deadline (late). A reply with nothing outstanding is a duplicate or
//! an answer to somebody else's request (unexpected).
//!
//! Why not first-in-first-out: after one lost reply, FIFO would take every later reply as the
//! answer to the previous tick (all late, for ever). Why the round trip: a motor slower than the
//! period answers the previous tick's frame shortly after this tick's frame was sent, and a late
//! reply arrives before the next request's reply is due; only the round trip tells them apart
//! from fresh replies.

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_protocol::{EncoderWidth, MotorId, Status2};

use crate::config::MotorConfig;
use crate::controller::MotorFeedback;
use crate::joint::{EncoderUnwrapper, JointMap};
use crate::stats::MotorCounters;

/// Outstanding requests kept per motor.
const PENDING_CAPACITY: usize = 8;

/// How much earlier than its tracked round trip a reply may arrive: a quarter of the round trip
/// plus 20 us (turnaround jitter, arbitration behind other motors).
fn early_tolerance(round_trip: Duration) -> Duration {
    round_trip / 4 + Duration::from_micros(20)
}

/// The ticks (and send times) of the frames a motor has not answered yet, oldest first.
#[derive(Copy, Clone, Debug)]
pub(crate) struct PendingRequests {
    entries: [(u64, Timestamp); PENDING_CAPACITY],
    head: usize,
    len: usize,
}

impl PendingRequests {
    pub(crate) fn new() -> Self {
        Self {
            entries: [(0, Timestamp::ZERO); PENDING_CAPACITY],
            head: 0,
            len: 0,
        }
    }

    fn get(&self, i: usize) -> (u64, Timestamp) {
        self.entries[(self.head + i) % PENDING_CAPACITY]
    }

    /// Records a request sent in `tick` at `at`; the oldest is given up if the ring is full.
    pub(crate) fn push(&mut self, tick: u64, at: Timestamp) {
        if self.len == PENDING_CAPACITY {
            self.head = (self.head + 1) % PENDING_CAPACITY;
            self.len -= 1;
        }
        self.entries[(self.head + self.len) % PENDING_CAPACITY] = (tick, at);
        self.len += 1;
    }

    /// Takes the request that a reply received at `received` answers: the newest request whose
    /// expected arrival, `sent + round_trip - tolerance`, has passed (any request sent before
    /// the reply when the round trip is not known yet). If the reply came earlier than expected
    /// for every request, it answers the oldest one sent before it. Older outstanding requests
    /// are dropped as lost.
    pub(crate) fn answer(
        &mut self,
        received: Timestamp,
        round_trip: Option<Duration>,
    ) -> Option<(u64, Timestamp)> {
        let mut oldest_causal = None;
        let mut newest_plausible = None;
        for i in 0..self.len {
            let (_, sent) = self.get(i);
            if sent > received {
                break; // sent after the reply arrived: cannot be what it answers
            }
            oldest_causal.get_or_insert(i);
            let plausible = match round_trip {
                None => true,
                Some(rtt) => received >= (sent + rtt).saturating_sub(early_tolerance(rtt)),
            };
            if plausible {
                newest_plausible = Some(i);
            }
        }
        let i = newest_plausible.or(oldest_causal)?;
        let answered = self.get(i);
        self.head = (self.head + i + 1) % PENDING_CAPACITY;
        self.len -= i + 1;
        Some(answered)
    }

    /// Forgets everything outstanding.
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Number of outstanding requests.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }
}

/// How a received reply was classified.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum ReplyClass {
    /// Accepted as this tick's feedback.
    Fresh,
    /// Answers an earlier tick than accepted: counted late, its values still update the state.
    Late,
    /// No outstanding request: counted unexpected, ignored.
    Unexpected,
}

/// Everything the loop keeps about one motor.
#[derive(Clone, Debug)]
pub(crate) struct MotorState {
    pub(crate) bus: usize,
    pub(crate) id: MotorId,
    /// Index in the 0x280 frame (id - 1).
    pub(crate) slot: usize,
    pub(crate) width: EncoderWidth,
    pub(crate) map: JointMap,
    pub(crate) unwrapper: EncoderUnwrapper,
    pub(crate) limit_raw: i16,
    pub(crate) temperature_limit: Option<f64>,
    pub(crate) pending: PendingRequests,
    pub(crate) last_reply_at: Option<Timestamp>,
    pub(crate) consecutive_missing: u32,
    /// Estimated round trip (request sent to reply received); `None` until the first reply.
    pub(crate) round_trip: Option<Duration>,
}

impl MotorState {
    pub(crate) fn new(bus: usize, config: &MotorConfig) -> Self {
        let id = config.motor_id();
        let width = config.encoder_width();
        Self {
            bus,
            id,
            slot: usize::from(id.get().saturating_sub(1)).min(3),
            width,
            map: JointMap::from_config(config),
            unwrapper: EncoderUnwrapper::new(width),
            limit_raw: config.current_limit_raw(),
            temperature_limit: config.temperature_limit_celsius,
            pending: PendingRequests::new(),
            last_reply_at: None,
            consecutive_missing: 0,
            round_trip: None,
        }
    }

    /// Folds one measured round trip into the estimate (moving average, weight 1/8).
    fn track_round_trip(&mut self, sample: Duration) {
        self.round_trip = Some(match self.round_trip {
            None => sample,
            Some(rtt) => {
                let rtt = rtt.as_nanos() as i128;
                let next = rtt + (sample.as_nanos() as i128 - rtt) / 8;
                Duration::from_nanos(next.max(0) as u64)
            }
        });
    }

    /// Handles a decoded torque reply received at `at` during `tick`, where replies up to
    /// `max_age` ticks old are accepted; updates `feedback` and `counters`.
    pub(crate) fn on_reply(
        &mut self,
        status: &Status2,
        at: Timestamp,
        tick: u64,
        max_age: u64,
        feedback: &mut MotorFeedback,
        counters: &mut MotorCounters,
    ) -> ReplyClass {
        if status.encoder.check(self.width).is_err() {
            counters.bad_frames += 1;
            return ReplyClass::Unexpected;
        }
        let Some((sent_tick, sent_at)) = self.pending.answer(at, self.round_trip) else {
            counters.unexpected_replies += 1;
            return ReplyClass::Unexpected;
        };
        self.track_round_trip(at - sent_at);
        let age = tick.saturating_sub(sent_tick);
        let class = if age <= max_age {
            ReplyClass::Fresh
        } else {
            counters.late_replies += 1;
            ReplyClass::Late
        };
        // Values of late replies still update the state (they are newer than what we have, and
        // the encoder unwrapping needs every reading), but the feedback is not marked fresh.
        let elapsed = self.last_reply_at.map_or(Duration::ZERO, |last| at - last);
        let speed_dps = status.speed.dps();
        let motor_deg = self
            .unwrapper
            .update(status.encoder.raw(), speed_dps, elapsed);
        let iq_amps = status.iq.amps();
        self.last_reply_at = Some(at);
        *feedback = MotorFeedback {
            bus: self.bus,
            motor: self.id,
            valid: true,
            fresh: feedback.fresh || class == ReplyClass::Fresh,
            age_ticks: u32::try_from(age).unwrap_or(u32::MAX),
            ticks_since_reply: 0,
            received_at: at,
            temperature_celsius: status.temperature.celsius(),
            iq: status.iq.raw(),
            iq_amps,
            speed_dps,
            encoder: status.encoder.raw(),
            motor_angle_deg: motor_deg,
            joint_angle_deg: self.map.joint_angle_deg(motor_deg),
            joint_velocity_dps: self.map.joint_velocity_dps(speed_dps),
            joint_torque_nm: self.map.joint_torque_nm(iq_amps),
        };
        class
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{EncoderValue, Iq, Speed, Temperature};

    fn t(us: u64) -> Timestamp {
        Timestamp::from_nanos(us * 1_000)
    }

    fn status(encoder: u16) -> Status2 {
        Status2 {
            temperature: Temperature::saturating(30),
            iq: Iq::saturating(100),
            speed: Speed::saturating(0),
            encoder: EncoderValue::from_raw(encoder),
        }
    }

    fn motor() -> (MotorState, MotorFeedback, MotorCounters) {
        let config = MotorConfig::new(2).gear_ratio(2.0);
        let m = MotorState::new(0, &config);
        let fb = MotorFeedback::empty(0, m.id);
        let c = MotorCounters::new(0, m.id);
        (m, fb, c)
    }

    #[test]
    fn a_reply_answers_the_newest_request_whose_expected_arrival_has_passed() {
        let mut p = PendingRequests::new();
        p.push(1, t(1000));
        p.push(2, t(2000));
        p.push(3, t(3000));
        // Nothing was sent before the reply arrived: it answers none of them.
        assert_eq!(p.answer(t(500), None), None);
        // Round trip 1.3 ms: a reply at 3.3 ms is too early for request 3 (due 4.3 ms), so it
        // answers request 2 (due 3.3 ms)...
        let rtt = Some(Duration::from_micros(1300));
        assert_eq!(p.answer(t(3300), rtt).map(|e| e.0), Some(2));
        // ...and request 1, older, is given up as lost.
        assert_eq!(p.len(), 1);
        // Without a round-trip estimate the newest possible request wins.
        p.push(4, t(4000));
        assert_eq!(p.answer(t(4100), None).map(|e| e.0), Some(4));
        assert_eq!(p.len(), 0);
        // Earlier than expected for every request: the oldest sent before it.
        p.push(5, t(5000));
        p.push(6, t(6000));
        assert_eq!(p.answer(t(6100), rtt).map(|e| e.0), Some(5));
        // A full ring gives up its oldest entries.
        for k in 0..20 {
            p.push(k, t(k * 1000));
        }
        assert_eq!(p.len(), PENDING_CAPACITY);
        assert_eq!(
            p.answer(t(100_000), Some(Duration::from_secs(1)))
                .map(|e| e.0),
            Some(12)
        );
    }

    #[test]
    fn a_reply_late_by_most_of_a_period_is_recognised() {
        // Round trip 600 us at 1 kHz; the reply to tick 1 is 500 us late: it arrives 100 us
        // after tick 2's frame was sent, long before tick 2's reply is due (2.6 ms).
        let (mut m, mut fb, mut c) = motor();
        m.pending.push(0, t(0));
        m.on_reply(&status(0), t(600), 0, 0, &mut fb, &mut c);
        m.pending.push(1, t(1000));
        m.pending.push(2, t(2000));
        assert_eq!(
            m.on_reply(&status(0), t(2100), 2, 0, &mut fb, &mut c),
            ReplyClass::Late
        );
        assert_eq!(
            m.on_reply(&status(0), t(2600), 2, 0, &mut fb, &mut c),
            ReplyClass::Fresh
        );
        assert_eq!((c.late_replies, c.unexpected_replies), (1, 0));
    }

    #[test]
    fn a_reply_to_this_tick_is_fresh_and_maps_to_the_joint() {
        let (mut m, mut fb, mut c) = motor();
        m.pending.push(7, t(7000));
        let class = m.on_reply(&status(4096), t(7300), 7, 0, &mut fb, &mut c);
        assert_eq!(class, ReplyClass::Fresh);
        assert!(fb.valid && fb.fresh);
        assert_eq!(fb.age_ticks, 0);
        assert_eq!(fb.motor_angle_deg, 90.0);
        assert_eq!(fb.joint_angle_deg, 45.0);
        assert_eq!(fb.temperature_celsius, 30.0);
        assert_eq!(fb.iq, 100);
        assert_eq!(m.round_trip, Some(Duration::from_micros(300)));
    }

    #[test]
    fn a_lost_reply_does_not_make_later_replies_late() {
        let (mut m, mut fb, mut c) = motor();
        // Tick 0 measures a 300 us round trip; tick 1's reply is lost.
        m.pending.push(0, t(0));
        m.on_reply(&status(0), t(300), 0, 0, &mut fb, &mut c);
        m.pending.push(1, t(1000));
        for k in 2..50u64 {
            fb.fresh = false;
            m.pending.push(k, t(k * 1000));
            let class = m.on_reply(&status(0), t(k * 1000 + 300), k, 0, &mut fb, &mut c);
            assert_eq!(class, ReplyClass::Fresh, "tick {k}");
            assert_eq!(fb.age_ticks, 0);
        }
        assert_eq!(c.late_replies, 0);
        assert_eq!(m.pending.len(), 0);
    }

    #[test]
    fn a_motor_slower_than_the_period_is_late_or_pipelined() {
        // Round trip 1.3 ms at 1 kHz: the reply to tick k-1 arrives 0.3 ms into tick k.
        for (max_age, expect) in [(0, ReplyClass::Late), (1, ReplyClass::Fresh)] {
            let (mut m, mut fb, mut c) = motor();
            // The start-up probe: one request, its reply 1.3 ms later measures the round trip.
            m.pending.push(0, t(100_000));
            m.on_reply(&status(0), t(101_300), 0, u64::MAX, &mut fb, &mut c);
            // Periodic ticks from 200 ms: tick k sends at 200 ms + k ms.
            let send = |k: u64| t(200_000 + k * 1000);
            m.pending.push(0, send(0));
            for k in 1..20u64 {
                fb.fresh = false;
                m.pending.push(k, send(k));
                let at = Timestamp::from_nanos(send(k).as_nanos() + 300_000);
                let class = m.on_reply(&status(0), at, k, max_age, &mut fb, &mut c);
                assert_eq!(class, expect, "tick {k}");
                assert_eq!(fb.age_ticks, 1);
            }
            assert_eq!(c.late_replies, if max_age == 0 { 19 } else { 0 });
        }
    }

    #[test]
    fn duplicates_and_out_of_range_encoders_are_counted_not_used() {
        let (mut m, mut fb, mut c) = motor();
        m.pending.push(1, t(1000));
        m.on_reply(&status(10), t(1200), 1, 0, &mut fb, &mut c);
        let before = fb;
        assert_eq!(
            m.on_reply(&status(20), t(1250), 1, 0, &mut fb, &mut c),
            ReplyClass::Unexpected
        );
        assert_eq!(c.unexpected_replies, 1);
        m.pending.push(2, t(2000));
        // 14-bit encoder: 20000 is impossible.
        assert_eq!(
            m.on_reply(&status(20_000), t(2200), 2, 0, &mut fb, &mut c),
            ReplyClass::Unexpected
        );
        assert_eq!(c.bad_frames, 1);
        assert_eq!(fb, before);
    }
}
