//! Everything the loop keeps about one motor between ticks, and what a reply does to it.
//!
//! Times are kept as nanoseconds on the bus clock: a reply's arithmetic (its round trip, the time
//! since the previous reply) is then plain integer arithmetic.

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_protocol::{
    CanFrame, CurrentScale, Dialect, MitCommand, MitFeedback, MitRanges, MotorId, Request, Status2,
    StatusPosition,
};

use super::frames::ReplyExpectation;
use super::pending::{PendingRequests, RESYNC_AFTER, min_round_trip};
use crate::feedback::{
    Freshness, JointFeedback, JointSide, MotorSide, RawMotion, RawReply, RawStatus,
};
use crate::joint::JointId;
use crate::mapping::{EncoderUnwrapper, JointMap, nearest_integer_within};
use crate::motion::{MotionMap, zero_torque};
use crate::report::MotorRef;
use crate::robot::{ExchangeKind, JointSpec};
use crate::stats::MotorCounters;

/// How a received reply was classified.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum ReplyClass {
    /// Accepted as this tick's feedback.
    Fresh,
    /// Answers an earlier tick than accepted: counted late, its values still update the state.
    Late,
    /// No outstanding request, or an impossible value: counted, ignored.
    Unexpected,
}

/// A motor's torque command scale, with the conversions of every tick worked out once.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct CommandScale {
    /// The scale of its torque commands.
    pub(crate) scale: CurrentScale,
    /// Raw steps per ampere.
    raw_per_amp: f64,
    /// The scale's raw range.
    min_raw: f64,
    max_raw: f64,
    /// The joint's current limit, in raw steps (at most the scale's range, checked with the
    /// description).
    pub(crate) limit_raw: i16,
}

impl CommandScale {
    fn new(joint: &JointSpec) -> Self {
        let scale = joint.command_scale();
        Self {
            scale,
            raw_per_amp: 1.0 / scale.amps_per_lsb(),
            min_raw: f64::from(scale.min_raw()),
            max_raw: f64::from(scale.max_raw()),
            limit_raw: joint.current_limit.raw(),
        }
    }

    /// The raw command for `amps`: the nearest raw value (half away from zero; NaN gives 0)
    /// within the scale's range, as `ScaledCurrent::from_amps_saturating` gives, then limited to
    /// the joint's current limit; and whether the limit changed it.
    #[inline]
    pub(crate) fn limited_raw(&self, amps: f64) -> (i64, bool) {
        let raw = nearest_integer_within(amps * self.raw_per_amp, self.min_raw, self.max_raw);
        let limit = i64::from(self.limit_raw);
        let limited = raw.clamp(-limit, limit);
        (limited, limited != raw)
    }
}

/// What the loop keeps about a motor on a `motion` bus.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct MotorMotion {
    /// Its conversions, with its firmware's ranges.
    pub(crate) map: MotionMap,
    /// Its dialect with the firmware the start-up read (what its motion frames are encoded
    /// and decoded with).
    pub(crate) dialect: Dialect,
    /// The command of its next request.
    pub(crate) staged: MitCommand,
}

impl MotorMotion {
    /// The motion state of `joint` speaking `dialect` (a V3 dialect: checked with the
    /// description), with the ranges of that dialect's firmware (`None` when they are not
    /// known yet: V4.4 firmware without a maximum torque; the start-up decides).
    fn new(joint: &JointSpec, dialect: Dialect) -> Self {
        let ranges = dialect.mit_ranges().unwrap_or(MitRanges::V4_3);
        Self {
            map: MotionMap::new(joint, ranges),
            dialect,
            staged: zero_torque(ranges),
        }
    }

    /// The same with the firmware `dialect` and its `ranges`, the commands zero.
    pub(crate) fn with_firmware(self, dialect: Dialect, ranges: MitRanges) -> Self {
        Self {
            map: self.map.with_ranges(ranges),
            dialect,
            staged: zero_torque(ranges),
        }
    }

    /// Its request of `command`, `motor`'s `0x400 + id` frame (or, were its ranges not the
    /// firmware's, motor-off: never a value packed for other ranges).
    #[inline]
    pub(crate) fn request(&self, motor: MotorId, command: &MitCommand) -> CanFrame {
        self.dialect
            .encode_mit(motor, command)
            .unwrap_or_else(|_| self.dialect.motor_off(motor))
    }
}

/// Everything the loop keeps about one motor.
#[derive(Clone, Debug)]
pub(crate) struct MotorLink {
    /// Which joint, bus and motor this is.
    pub(crate) at: MotorRef,
    pub(crate) id: MotorId,
    /// What its reply to the torque frame looks like.
    pub(crate) expect: ReplyExpectation,
    /// Its torque commands' scale and limit.
    pub(crate) command: CommandScale,
    /// Index in the 0x280 frame (id - 1).
    pub(crate) slot: usize,
    /// The dialect of its requests (the per-motor 0xA1).
    pub(crate) dialect: Dialect,
    /// The raw torque command staged for its next request, in [`CommandScale::scale`] (its
    /// dialect's command scale; a `per-motor` bus sends it as its own 0xA1; a `multi-torque` bus
    /// sends its slot of the bus's staged 0x280 frame).
    pub(crate) staged: i16,
    /// The largest encoder reading its width allows.
    max_encoder: u16,
    pub(crate) map: JointMap,
    unwrapper: EncoderUnwrapper,
    pub(crate) temperature_limit: Option<f64>,
    pub(crate) pending: PendingRequests,
    /// When the last reply came, ns; `u64::MAX` before the first (so that the time since it,
    /// a saturating difference, is 0 until there is one).
    last_reply_ns: u64,
    ticks_since_reply: u32,
    pub(crate) consecutive_missing: u32,
    /// When this tick's newest late reply came, if it was timed like a newer request's reply.
    late_fits_next: Option<Timestamp>,
    /// Consecutive ticks ending with such a reply (see [`RESYNC_AFTER`]).
    late_streak: u32,
    /// Estimated round trip (request sent to reply received), ns, at most
    /// [`MAX_ROUND_TRIP_NS`]; [`NO_ROUND_TRIP`] until the first fresh reply.
    round_trip_ns: u64,
    /// The shortest physical round trip on its bus (see [`min_round_trip`]), ns.
    min_round_trip_ns: u64,
    /// Its status request (0x9A in its dialect), encoded once (`None`: its dialect could not
    /// encode it, and the rotation passes it by; every family has 0x9A).
    pub(crate) status_request: Option<CanFrame>,
    /// Its status requests not answered yet.
    pub(crate) status_pending: StatusPending,
    /// The CAN id of its status replies (its dialect's reply id: on a `motion` bus not the id
    /// of its torque replies).
    pub(crate) status_reply_id: u16,
    /// On a `motion` bus, its motion state.
    pub(crate) motion: Option<MotorMotion>,
}

impl MotorLink {
    /// The link of joint `index`, `joint`, on a bus at `bitrate` bit/s exchanging `exchange`.
    pub(crate) fn new(
        index: usize,
        joint: &JointSpec,
        bitrate: u32,
        exchange: ExchangeKind,
    ) -> Self {
        let motion = match exchange {
            ExchangeKind::Motion => Some(MotorMotion::new(joint, joint.dialect)),
            ExchangeKind::MultiTorque | ExchangeKind::PerMotor => None,
        };
        Self {
            at: MotorRef {
                joint: JointId::from_index(index),
                bus: joint.bus,
                motor: joint.motor,
            },
            id: joint.motor,
            expect: match exchange {
                ExchangeKind::Motion => ReplyExpectation::motion(joint),
                ExchangeKind::MultiTorque | ExchangeKind::PerMotor => {
                    ReplyExpectation::torque(joint)
                }
            },
            command: CommandScale::new(joint),
            slot: joint.slot(),
            dialect: joint.dialect,
            staged: 0,
            max_encoder: joint.encoder.max_value(),
            map: JointMap::from_spec(joint),
            unwrapper: EncoderUnwrapper::new(joint.encoder),
            temperature_limit: joint.temperature_limit_celsius,
            pending: PendingRequests::new(),
            last_reply_ns: u64::MAX,
            ticks_since_reply: 0,
            consecutive_missing: 0,
            late_fits_next: None,
            late_streak: 0,
            round_trip_ns: NO_ROUND_TRIP,
            min_round_trip_ns: duration_ns(min_round_trip(bitrate)),
            status_request: status_request(joint.dialect, joint.motor),
            status_pending: StatusPending::default(),
            status_reply_id: joint.dialect.reply_id(joint.motor),
            motion,
        }
    }

    /// The shortest physical round trip on its bus, ns.
    #[inline]
    pub(crate) fn min_round_trip_ns(&self) -> u64 {
        self.min_round_trip_ns
    }

    /// The estimated round trip, once a reply measured one.
    pub(crate) fn round_trip(&self) -> Option<Duration> {
        self.round_trip_ns().map(Duration::from_nanos)
    }

    /// [`round_trip`](Self::round_trip) in nanoseconds.
    #[inline]
    pub(crate) fn round_trip_ns(&self) -> Option<u64> {
        (self.round_trip_ns != NO_ROUND_TRIP).then_some(self.round_trip_ns)
    }

    /// Forgets the round trip measured so far (it may span a stall: the next reply measures it
    /// afresh).
    pub(crate) fn forget_round_trip(&mut self) {
        self.round_trip_ns = NO_ROUND_TRIP;
    }

    /// Marks the end of a tick's collection: after [`RESYNC_AFTER`] ticks in a row whose newest
    /// reply was late but timed like a newer request's, the requests before that one are
    /// declared lost (replies went missing and every later one was taken too old).
    #[inline]
    pub(crate) fn end_tick(&mut self, feedback: &JointFeedback) {
        match (feedback.freshness, self.late_fits_next) {
            (Freshness::Late { .. }, Some(at)) => {
                self.late_streak += 1;
                if self.late_streak >= RESYNC_AFTER {
                    self.pending.drop_through(at, self.round_trip());
                    self.late_streak = 0;
                }
            }
            _ => self.late_streak = 0,
        }
        self.late_fits_next = None;
    }

    /// Marks the start of a tick: until a reply comes, the feedback is missing.
    #[inline]
    pub(crate) fn begin_tick(&mut self, feedback: &mut JointFeedback) {
        self.ticks_since_reply = self.ticks_since_reply.saturating_add(1);
        feedback.freshness = Freshness::Missing {
            ticks_since_reply: self.ticks_since_reply,
        };
    }

    /// Folds one measured round trip into the estimate (moving average, weight 1/8).
    #[inline]
    fn track_round_trip(&mut self, sample_ns: u64) {
        let sample = sample_ns.min(MAX_ROUND_TRIP_NS) as i64;
        let rtt = self.round_trip_ns;
        // The estimate and the sample both lie in 0..=MAX_ROUND_TRIP_NS (far below 2^62): the
        // difference fits an i64, and the average stays in that range.
        self.round_trip_ns = if rtt == NO_ROUND_TRIP {
            sample as u64
        } else {
            (rtt as i64 + (sample - rtt as i64) / 8) as u64
        };
    }

    /// Matches a reply received at `at` during `tick` to its request (replies up to `max_age`
    /// ticks old are fresh): its class and age, or `None` (counted unexpected) when it answers
    /// no outstanding request.
    #[inline(always)]
    fn answer(
        &mut self,
        at: Timestamp,
        tick: u64,
        max_age: u64,
        counters: &mut MotorCounters,
    ) -> Option<(ReplyClass, u32)> {
        let at_ns = at.as_nanos();
        let Some((sent_tick, sent_at)) = self.pending.answer(at_ns, self.min_round_trip_ns) else {
            counters.unexpected_replies += 1;
            return None;
        };
        let age = tick.saturating_sub(sent_tick);
        let age_ticks = u32::try_from(age).unwrap_or(u32::MAX);
        let class = if age <= max_age {
            // Only fresh replies measure the round trip: a late one's includes its delay.
            self.track_round_trip(at_ns.saturating_sub(sent_at.as_nanos()));
            self.late_fits_next = None;
            ReplyClass::Fresh
        } else {
            counters.late_replies += 1;
            // Timed like a newer request's reply? (Replies held up behind a late one come
            // later than that; a reply whose predecessors were lost comes just then.)
            self.late_fits_next = self
                .round_trip()
                .and_then(|rtt| self.pending.on_time(at, rtt))
                .map(|_| at);
            ReplyClass::Late
        };
        Some((class, age_ticks))
    }

    /// The freshness after a reply of `class`, `age_ticks` old, when the feedback was
    /// `before`: a fresh reply is fresh; a late one leaves fresh feedback fresh.
    #[inline(always)]
    fn freshness(class: ReplyClass, age_ticks: u32, before: Freshness) -> Freshness {
        match (class, before) {
            (ReplyClass::Fresh, _) => Freshness::Fresh { age_ticks },
            (_, fresh @ Freshness::Fresh { .. }) => fresh,
            _ => Freshness::Late { age_ticks },
        }
    }

    /// Handles a decoded torque reply received at `at` during `tick`, where replies up to
    /// `max_age` ticks old are accepted; updates `feedback` and `counters`.
    // Inlined into the collection's receive, with the encoder unwrapping and the round-trip
    // tracking it calls: a call per reply cost 6 instructions a tick per motor more
    // (benches/tick-instructions.sh).
    #[inline(always)]
    pub(crate) fn on_reply(
        &mut self,
        status: &Status2,
        at: Timestamp,
        tick: u64,
        max_age: u64,
        feedback: &mut JointFeedback,
        counters: &mut MotorCounters,
    ) -> ReplyClass {
        let reading = match status.position {
            StatusPosition::Encoder(e) if e.raw() <= self.max_encoder => Reading::Encoder(e.raw()),
            StatusPosition::OutputDegrees(a) => Reading::OutputDegrees(a.raw()),
            StatusPosition::Encoder(_) => {
                counters.bad_frames += 1;
                return ReplyClass::Unexpected;
            }
        };
        let Some((class, age_ticks)) = self.answer(at, tick, max_age, counters) else {
            return ReplyClass::Unexpected;
        };
        let at_ns = at.as_nanos();
        // Values of late replies still update the state (they are newer than what we have, and
        // the encoder unwrapping needs every reading), but the feedback is not marked fresh.
        let elapsed_ns = at_ns.saturating_sub(self.last_reply_ns);
        let (motor_deg, speed_dps, raw_position) = match reading {
            Reading::Encoder(raw) => {
                let speed_dps = status.speed.dps();
                let motor_deg = self.unwrapper.update_ns(raw, speed_dps, elapsed_ns);
                (motor_deg, speed_dps, raw)
            }
            // The output shaft, multi-turn from its zero: the rotor is `gear_ratio` times it.
            Reading::OutputDegrees(deg) => {
                let ratio = self.map.gear_ratio();
                (
                    f64::from(deg) * ratio,
                    status.speed.dps() * ratio,
                    deg as u16,
                )
            }
        };
        let motor = MotorSide {
            angle_deg: motor_deg,
            speed_dps,
            current_amps: status.iq.amps(),
            temperature_celsius: status.temperature.celsius(),
        };
        let raw = RawReply::Torque(RawStatus {
            temperature: status.temperature.raw(),
            iq: status.iq.raw(),
            speed: status.speed.raw(),
            encoder: raw_position,
        });
        self.record(feedback, at, (class, age_ticks), motor, raw);
        class
    }

    /// Writes a matched reply's values, received at `at`, into `feedback`, field by field (the
    /// motor's health, from status replies, stays as it is), with its class and age.
    #[inline(always)]
    fn record(
        &mut self,
        feedback: &mut JointFeedback,
        at: Timestamp,
        (class, age_ticks): (ReplyClass, u32),
        motor: MotorSide,
        raw: RawReply,
    ) {
        self.last_reply_ns = at.as_nanos();
        self.ticks_since_reply = 0;
        feedback.joint = JointSide {
            angle_deg: self.map.joint_angle_deg(motor.angle_deg),
            velocity_dps: self.map.joint_velocity_dps(motor.speed_dps),
            torque_nm: self.map.joint_torque_nm(motor.current_amps),
        };
        feedback.motor = motor;
        feedback.raw = raw;
        feedback.freshness = Self::freshness(class, age_ticks, feedback.freshness);
        feedback.received_at = at;
    }

    /// Handles a motion-mode reply (decoded with its firmware's ranges) as
    /// [`on_reply`](Self::on_reply) does a torque reply. The reply carries no temperature: the
    /// newest status reply's stays.
    pub(crate) fn on_motion_reply(
        &mut self,
        reply: &MitFeedback,
        at: Timestamp,
        tick: u64,
        max_age: u64,
        feedback: &mut JointFeedback,
        counters: &mut MotorCounters,
    ) -> ReplyClass {
        let Some(motion) = self.motion else {
            counters.bad_frames += 1;
            return ReplyClass::Unexpected;
        };
        let Some((class, age_ticks)) = self.answer(at, tick, max_age, counters) else {
            return ReplyClass::Unexpected;
        };
        let (motor_deg, speed_dps, current_amps) = motion.map.motor_side(reply);
        let motor = MotorSide {
            angle_deg: motor_deg,
            speed_dps,
            current_amps,
            temperature_celsius: feedback
                .health
                .map_or(feedback.motor.temperature_celsius, |h| {
                    h.temperature_celsius
                }),
        };
        let [position, velocity, torque] = reply.raw();
        let raw = RawReply::Motion(RawMotion {
            position,
            velocity,
            torque,
        });
        self.record(feedback, at, (class, age_ticks), motor, raw);
        class
    }
}

/// A motor's status requests (0x9A) not answered yet: the tick and send time (ns) of the newest
/// [`STATUS_PENDING`], oldest first. The firmware answers in order, and a status reply rides
/// the bus right behind the torque replies of its tick, so it takes about the motor's torque
/// round trip. A reply answers, among the requests it could answer (sent at least the shortest
/// physical round trip before it arrived), the one whose delay is closest to that round trip;
/// the older ones outstanding then are lost (counted). So a lost reply never shifts the later
/// ones, and a link slower than the rotation (a round trip of a period or more, pipelined)
/// still matches each reply to its own request. A reply that fits no request's timing (a stall
/// held every reply up), or a motor with no round trip measured, answers the oldest: first in,
/// first out, as the firmware answers. A request pushed when the ring is full gives up the
/// oldest (counted).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct StatusPending {
    entries: [(u64, u64); STATUS_PENDING],
    len: usize,
}

/// Status requests kept per motor. Pipelined, a status reply is read two ticks after its
/// request: it comes just after the torque reply its tick's collection (one tick later) stops
/// at, so the next tick's reads it, when two newer requests are outstanding.
const STATUS_PENDING: usize = 4;

/// How far from the torque round trip a status reply's delay may be and still fit its request:
/// the round trip again (the replies of the bus's other motors come between, at most one round
/// trip's worth of frames) plus 100 us of turnaround jitter. A reply held up longer (a stall)
/// fits none, and is matched first in, first out.
fn status_slack(round_trip_ns: u64) -> u64 {
    round_trip_ns.saturating_add(100_000)
}

impl StatusPending {
    /// Records a request of `tick` sent at `sent_ns`; returns whether the oldest was given up
    /// (its reply lost).
    #[inline]
    pub(crate) fn push(&mut self, tick: u64, sent_ns: u64) -> bool {
        let full = self.len == STATUS_PENDING;
        if full {
            self.entries.copy_within(1.., 0);
            self.entries[STATUS_PENDING - 1] = (tick, sent_ns);
        } else {
            self.entries[self.len] = (tick, sent_ns);
            self.len += 1;
        }
        full
    }

    /// The tick of the request a reply received at `received_ns` answers, and how many older
    /// requests it shows lost; `None` when it could answer none (an unexpected reply). See the
    /// type's docs for the rule; `round_trip_ns` is the motor's tracked torque round trip.
    #[inline]
    pub(crate) fn answer(
        &mut self,
        received_ns: u64,
        min_round_trip_ns: u64,
        round_trip_ns: Option<u64>,
    ) -> Option<(u64, u64)> {
        // Send times grow: the requests it could answer are a prefix of the ring.
        let answerable = self.entries[..self.len]
            .iter()
            .take_while(|&&(_, sent)| sent.saturating_add(min_round_trip_ns) <= received_ns)
            .count();
        if answerable == 0 {
            return None;
        }
        let i = round_trip_ns
            .and_then(|rtt| self.closest_on_time(answerable, received_ns, rtt))
            .unwrap_or(0);
        let tick = self.entries[i].0;
        // Entries after `i` (newer requests) stay outstanding, moved to the front.
        self.entries.copy_within(i + 1..self.len, 0);
        self.len -= i + 1;
        Some((tick, i as u64))
    }

    /// Of the first `answerable` requests, the one whose delay to `received_ns` is closest to
    /// `round_trip_ns` (the older on a tie), if that delay is within [`status_slack`] of it.
    fn closest_on_time(
        &self,
        answerable: usize,
        received_ns: u64,
        round_trip_ns: u64,
    ) -> Option<usize> {
        let miss = |i: usize| {
            let delay = received_ns.saturating_sub(self.entries[i].1);
            delay.abs_diff(round_trip_ns)
        };
        let best = (1..answerable).fold(0, |best, i| if miss(i) < miss(best) { i } else { best });
        (miss(best) <= status_slack(round_trip_ns)).then_some(best)
    }

    /// Forgets everything outstanding.
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }
}

/// The status-1 request (0x9A) to `motor` in `dialect` (the same frame in every family).
fn status_request(dialect: Dialect, motor: MotorId) -> Option<CanFrame> {
    dialect.encode(motor, &Request::ReadStatus1).ok()
}

/// The position a status-2 reply carries.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Reading {
    /// v1.61 and LK-TECH: the single-turn encoder, in range for its width.
    Encoder(u16),
    /// MyActuator V3: the output shaft's angle, whole degrees from its zero.
    OutputDegrees(i16),
}

/// The longest round trip the estimate takes in (one hour): anything longer is no reply.
const MAX_ROUND_TRIP_NS: u64 = 3_600_000_000_000;

/// The round trip of a motor no fresh reply has measured yet (above any measured one).
const NO_ROUND_TRIP: u64 = u64::MAX;

/// `d` in nanoseconds, saturating.
fn duration_ns(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

#[cfg(test)]
mod tests {
    use super::super::pending::PENDING_CAPACITY;
    use super::*;
    use crate::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
    use rmd_protocol::{EncoderValue, Speed, Temperature};

    fn t(us: u64) -> Timestamp {
        Timestamp::from_nanos(us * 1_000)
    }

    fn status(encoder: u16) -> Status2 {
        Status2 {
            temperature: Temperature::saturating(30),
            iq: rmd_protocol::ScaledCurrent::saturating(100, CurrentScale::V161_IQ),
            speed: Speed::saturating(0),
            position: rmd_protocol::StatusPosition::Encoder(EncoderValue::from_raw(encoder)),
        }
    }

    fn motor() -> (MotorLink, JointFeedback, MotorCounters) {
        let robot = Robot::try_from(
            RobotConfig::new(100.0)
                .with_bus(BusConfig::new("can0").with_motor(MotorConfig::new(2).gear_ratio(2.0))),
        )
        .unwrap();
        let m = MotorLink::new(0, &robot.joints()[0], 1_000_000, ExchangeKind::MultiTorque);
        let c = MotorCounters::new(0, m.id);
        (m, JointFeedback::UNSET, c)
    }

    fn fresh(fb: &JointFeedback) -> bool {
        fb.freshness.is_fresh()
    }

    #[test]
    fn a_reply_answers_the_oldest_request_it_could_answer() {
        let mut p = PendingRequests::new();
        p.push(1, t(1000));
        p.push(2, t(2000));
        p.push(3, t(3000));
        // At 1 Mbit/s no reply comes sooner than 216 us after its request.
        let shortest = super::super::pending::min_round_trip(1_000_000);
        assert_eq!(shortest, Duration::from_micros(216));
        let shortest = duration_ns(shortest);
        let ns = |us: u64| t(us).as_nanos();
        // Sent after the reply arrived: it answers none of them.
        assert_eq!(p.answer(ns(500), shortest), None);
        // A reply at 3.3 ms answers the oldest, request 1 (first in, first out), whatever its
        // timing says about request 3.
        assert_eq!(p.answer(ns(3300), shortest).map(|e| e.0), Some(1));
        assert_eq!(p.len(), 2);
        // Too early for the oldest outstanding request (a duplicate right after the original):
        // unexpected, and nothing is taken.
        let mut q = PendingRequests::new();
        q.push(7, t(7000));
        assert_eq!(q.answer(ns(7050), shortest), None);
        assert_eq!(q.len(), 1);
        // A full ring gives up its oldest entries.
        for k in 0..20 {
            p.push(k, t(k * 1000));
        }
        assert_eq!(p.len(), PENDING_CAPACITY);
        assert_eq!(p.answer(ns(100_000), shortest).map(|e| e.0), Some(12));
        p.drop_oldest();
        assert_eq!(p.oldest().map(|e| e.0), Some(14));
    }

    #[test]
    fn replies_held_up_behind_a_late_one_count_late_with_their_true_age() {
        // Round trip 300 us at 1 kHz. The reply to tick 3 is 2.5 ms late; the firmware answers in
        // order, so the replies to ticks 4 and 5 come right behind it, in tick 5.
        let (mut m, mut fb, mut c) = motor();
        m.pending.push(0, t(0));
        m.on_reply(&status(0), t(300), 0, 0, &mut fb, &mut c);
        for k in 1..=3 {
            m.begin_tick(&mut fb);
            m.pending.push(k, t(k * 1000));
            if k < 3 {
                m.on_reply(&status(0), t(k * 1000 + 300), k, 0, &mut fb, &mut c);
            }
            m.end_tick(&fb);
        }
        m.begin_tick(&mut fb);
        m.pending.push(4, t(4000));
        m.end_tick(&fb);
        m.begin_tick(&mut fb);
        m.pending.push(5, t(5000));
        let ages: Vec<_> = [5800, 5930, 6060]
            .into_iter()
            .map(|us| {
                m.on_reply(&status(0), t(us), 5, 0, &mut fb, &mut c);
                fb.freshness
            })
            .collect();
        assert_eq!(
            ages,
            [
                Freshness::Late { age_ticks: 2 },
                Freshness::Late { age_ticks: 1 },
                Freshness::Fresh { age_ticks: 0 }
            ]
        );
        assert_eq!((c.late_replies, c.unexpected_replies), (2, 0));
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
        assert_eq!(fb.freshness, Freshness::Fresh { age_ticks: 0 });
        assert_eq!(fb.motor.angle_deg, 90.0);
        assert_eq!(fb.joint.angle_deg, 45.0);
        assert_eq!(fb.motor.temperature_celsius, 30.0);
        assert!(matches!(
            fb.raw,
            RawReply::Torque(RawStatus { iq: 100, .. })
        ));
        assert_eq!(fb.joint.torque_nm, None);
        assert_eq!(m.round_trip(), Some(Duration::from_micros(300)));
    }

    #[test]
    fn after_a_lost_reply_the_link_resynchronises_within_a_few_ticks() {
        let (mut m, mut fb, mut c) = motor();
        // Tick 0 measures a 300 us round trip; tick 1's reply is lost.
        m.pending.push(0, t(0));
        m.on_reply(&status(0), t(300), 0, 0, &mut fb, &mut c);
        m.pending.push(1, t(1000));
        m.end_tick(&fb);
        let mut classes = Vec::new();
        for k in 2..50u64 {
            m.begin_tick(&mut fb);
            assert!(!fresh(&fb));
            m.pending.push(k, t(k * 1000));
            classes.push(m.on_reply(&status(0), t(k * 1000 + 300), k, 0, &mut fb, &mut c));
            m.end_tick(&fb);
        }
        // When in doubt, not fresh: two ticks seem one tick old; then the lost request is
        // given up and every reply is this tick's again.
        let late = RESYNC_AFTER as usize;
        assert!(
            classes[..late].iter().all(|c| *c == ReplyClass::Late),
            "{classes:?}"
        );
        assert!(
            classes[late..].iter().all(|c| *c == ReplyClass::Fresh),
            "{classes:?}"
        );
        assert_eq!(c.late_replies, u64::from(RESYNC_AFTER));
        assert_eq!(c.unexpected_replies, 0);
        assert_eq!(m.pending.len(), 0);
    }

    #[test]
    fn a_motor_slower_than_the_period_is_late_or_pipelined_and_never_resynchronised_away() {
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
                m.begin_tick(&mut fb);
                m.pending.push(k, send(k));
                let at = Timestamp::from_nanos(send(k).as_nanos() + 300_000);
                let class = m.on_reply(&status(0), at, k, max_age, &mut fb, &mut c);
                m.end_tick(&fb);
                assert_eq!(class, expect, "tick {k}");
                let expected = if max_age == 0 {
                    Freshness::Late { age_ticks: 1 }
                } else {
                    Freshness::Fresh { age_ticks: 1 }
                };
                assert_eq!(fb.freshness, expected);
            }
            assert_eq!(c.late_replies, if max_age == 0 { 19 } else { 0 });
        }
    }

    #[test]
    fn duplicates_and_out_of_range_encoders_are_counted_not_used() {
        let (mut m, mut fb, mut c) = motor();
        m.pending.push(1, t(1000));
        m.on_reply(&status(10), t(1300), 1, 0, &mut fb, &mut c);
        let before = fb;
        assert_eq!(
            m.on_reply(&status(20), t(1350), 1, 0, &mut fb, &mut c),
            ReplyClass::Unexpected
        );
        assert_eq!(c.unexpected_replies, 1);
        m.pending.push(2, t(2000));
        // 14-bit encoder: 20000 is impossible.
        assert_eq!(
            m.on_reply(&status(20_000), t(2300), 2, 0, &mut fb, &mut c),
            ReplyClass::Unexpected
        );
        assert_eq!(c.bad_frames, 1);
        assert_eq!(fb, before);
    }

    #[test]
    fn a_status_reply_answers_its_own_request_on_a_fast_link_or_a_slow_one() {
        let ms = |ms: u64| ms * 1_000_000;
        let shortest = 216_000;
        // Requests 10 ms apart (a rotation), round trip 1 ms. Request 1's reply was lost: request
        // 2's answers request 2, and request 1 is counted lost.
        let mut p = StatusPending::default();
        p.push(1, ms(0));
        p.push(2, ms(10));
        assert_eq!(p.answer(ms(11), shortest, Some(ms(1))), Some((2, 1)));
        assert_eq!(p.len, 0);
        // A link slower than the rotation: requests 100 ms apart, each answered 100.5 ms later.
        // The reply to request 1 comes after request 2 went out, and still answers request 1.
        let mut p = StatusPending::default();
        p.push(1, ms(0));
        p.push(2, ms(100));
        let rtt = Some(ms(100));
        assert_eq!(p.answer(ms(100) + 500_000, shortest, rtt), Some((1, 0)));
        assert_eq!(p.answer(ms(200) + 500_000, shortest, rtt), Some((2, 0)));
        assert_eq!(p.answer(ms(201), shortest, rtt), None);
        // A stall held every reply up 50 ms: they fit no request's timing and are taken first in,
        // first out, none left unexpected.
        let mut p = StatusPending::default();
        for k in 0..3 {
            p.push(k, ms(k));
        }
        for k in 0..3 {
            assert_eq!(p.answer(ms(50 + k), shortest, Some(ms(1))), Some((k, 0)));
        }
        // No round trip measured yet: first in, first out. Too early for every request: none.
        let mut p = StatusPending::default();
        p.push(4, ms(0));
        p.push(5, ms(10));
        assert_eq!(p.answer(ms(10), shortest, None), Some((4, 0)));
        assert_eq!(p.answer(ms(10) + 100_000, shortest, None), None);
    }
}
