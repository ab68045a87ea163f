//! # rmd-tick-bench: the loop-alone tick as a benchmark scenario
//!
//! The framework's own cost of one control tick, without a controller (a no-op) and without a
//! simulator: [`Running::step`] on buses that answer every 0x280 frame with four pre-encoded 0xA1
//! replies, [`TURNAROUND`] later and then one every [`REPLY_GAP`], on a virtual clock (the tick's
//! timed waits return at once, so what is measured is CPU work). The buses can be waited on
//! together ([`CanBus::readiness`]), so the loop collects from every bus at once, as it does on
//! SocketCAN and on threaded simulators. Telemetry is published to a receiver nobody drains (the
//! mailbox overwrites), as with a live display that fell behind.
//!
//! `benches/tick.rs` times this scenario with criterion; `benches/tick-instructions.sh` counts
//! its instructions per tick under callgrind with this crate's `tick-instructions` binary.
//!
//! ```
//! let (mut rt, _telemetry) = rmd_tick_bench::loop_alone(2);
//! for _ in 0..100 {
//!     assert!(rt.step().is_continue());
//! }
//! assert_eq!(rt.stats().missed_ticks, 0);
//! ```

use std::time::Duration;

use rmd_bus::{
    BusError, BusMessage, CanBus, Clock, Readiness, Received, Timestamp, VirtualClock, WaitOn,
};
use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, RtLoop, Running, TickContext, robot::Robot,
    telemetry::TelemetryReceiver,
};
use rmd_protocol::{
    CanFrame, Dialect, EncoderValue, ErrorState, Iq, MULTI_TORQUE_CAN_ID, MotorId, Reply, Speed,
    Status1, Status2, StatusPosition, Temperature, V161Status1, Voltage,
};

/// Loop rate of the scenario.
pub const RATE_HZ: f64 = 1000.0;
/// A rate at which four motors per bus leave room for the health rotation (a status request
/// and reply each tick): the same tick's work, one frame more each way.
pub const HEALTH_RATE_HZ: f64 = 800.0;
/// Motors on each bus (ids 1..=4: one 0x280 frame drives them all).
pub const MOTORS: u8 = 4;
/// When the first reply comes after the request (virtual time): longer than the shortest
/// physical round trip at 1 Mbit/s (216 us), which the loop's reply matching requires.
pub const TURNAROUND: Duration = Duration::from_micros(250);
/// Between a bus's replies (about one 8-byte frame at 1 Mbit/s).
pub const REPLY_GAP: Duration = Duration::from_micros(120);

/// DATA\[0\] of a status request (0x9A).
const STATUS1: u8 = 0x9A;

/// 0x280 frames a [`CannedBus`] holds replies for (more are refused, as a full transmit queue).
const PENDING_FRAMES: usize = 2;

/// The controller is excluded: it does nothing (every command stays zero).
#[derive(Copy, Clone, Debug, Default)]
pub struct NoOp;

impl Controller for NoOp {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        Flow::Continue
    }
}

/// A robot of `buses` buses of [`MOTORS`] motors each (ids 1..=4, v1.61), at [`RATE_HZ`]: the
/// health rotation has no room there (four replies and a 0x280 frame fill the reply window).
pub fn robot(buses: usize) -> Robot {
    robot_at(buses, RATE_HZ)
}

/// [`robot`] at `rate_hz`; at [`HEALTH_RATE_HZ`] every bus also carries the health rotation.
pub fn robot_at(buses: usize, rate_hz: f64) -> Robot {
    let mut robot = RobotConfig::new(rate_hz);
    for b in 0..buses {
        let mut bus = BusConfig::new(&format!("bench{b}"));
        for id in 1..=MOTORS {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        robot = robot.with_bus(bus);
    }
    Robot::try_from(robot).expect("the scenario's robot is valid")
}

/// A bus that answers each 0x280 frame with the pre-encoded 0xA1 replies of motors 1..=4, the
/// first [`TURNAROUND`] after it and then one every [`REPLY_GAP`] (virtual time: the receive
/// moves the clock to each arrival); a status request (0x9A, the health rotation) sent after a
/// 0x280 frame adds its motor's pre-encoded status reply after that frame's four. It keeps only
/// when each frame was sent and when the next reply arrives: its own work per frame is small
/// beside the loop's, which is what the benchmark measures. No allocation.
#[derive(Debug)]
pub struct CannedBus {
    clock: VirtualClock,
    replies: [CanFrame; MOTORS as usize],
    /// Each motor's status reply (supply 24 V, no error flag).
    status_replies: [CanFrame; MOTORS as usize],
    /// When each 0x280 frame not fully answered yet was sent (ns), oldest first (a ring).
    sent_ns: [u64; PENDING_FRAMES],
    /// Per frame of the ring: the replies it is owed (four, five with a status reply), and the
    /// motor (index) whose status reply is the fifth.
    owed: [usize; PENDING_FRAMES],
    status_of: [usize; PENDING_FRAMES],
    head: usize,
    len: usize,
    /// Replies to the oldest frame already received.
    taken: usize,
    /// While a frame is pending, when the next reply arrives (ns): the oldest frame's send time,
    /// plus [`TURNAROUND`], plus a [`REPLY_GAP`] for each of its replies already received.
    next_ns: u64,
}

impl CannedBus {
    /// A bus on `clock` with nothing pending.
    pub fn new(clock: VirtualClock) -> Self {
        let replies = core::array::from_fn(|i| {
            let status = Status2 {
                temperature: Temperature::saturating(30),
                iq: Iq::saturating(40 * i as i64 - 60).into(),
                speed: Speed::saturating(12 - 5 * i as i64),
                position: StatusPosition::Encoder(EncoderValue::from_raw(4000 * i as u16 + 17)),
            };
            let motor = MotorId::new(i as u8 + 1).expect("ids 1..=4 are valid");
            Dialect::V161
                .encode_reply(motor, &Reply::Torque(status))
                .expect("a v1.61 torque reply encodes")
        });
        let status_replies = core::array::from_fn(|i| {
            let motor = MotorId::new(i as u8 + 1).expect("ids 1..=4 are valid");
            let status = Status1::V161(V161Status1 {
                temperature: Temperature::saturating(31),
                voltage: Voltage::from_volts_saturating(24.0),
                error_state: ErrorState::NONE,
            });
            Dialect::V161
                .encode_reply(motor, &Reply::ReadStatus1(status))
                .expect("a v1.61 status reply encodes")
        });
        Self {
            clock,
            replies,
            status_replies,
            sent_ns: [0; PENDING_FRAMES],
            owed: [MOTORS as usize; PENDING_FRAMES],
            status_of: [0; PENDING_FRAMES],
            head: 0,
            len: 0,
            taken: 0,
            next_ns: 0,
        }
    }

    /// When the next reply arrives.
    fn first_arrival(&self) -> Option<Timestamp> {
        (self.len > 0).then_some(Timestamp::from_nanos(self.next_ns))
    }
}

impl CanBus for CannedBus {
    // The canned bus's send and receive are inlined into the loop wherever it calls them: the
    // benchmark counts the loop's own work on each frame, not a call into the scenario's bus
    // (a real bus's receive is mostly a system call, whose kernel work callgrind does not count).
    #[inline(always)]
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if frame.id() == MULTI_TORQUE_CAN_ID {
            if self.len == PENDING_FRAMES {
                return Err(BusError::TxQueueFull);
            }
            let slot = (self.head + self.len) % PENDING_FRAMES;
            let now_ns = self.clock.now().as_nanos();
            self.sent_ns[slot] = now_ns;
            self.owed[slot] = MOTORS as usize;
            if self.len == 0 {
                self.next_ns = now_ns + TURNAROUND.as_nanos() as u64;
            }
            self.len += 1;
        } else if frame.data().first() == Some(&STATUS1) && self.len > 0 {
            // The newest frame's replies are followed by this motor's status reply.
            let newest = (self.head + self.len - 1) % PENDING_FRAMES;
            self.owed[newest] = MOTORS as usize + 1;
            self.status_of[newest] = usize::from(frame.id() & 0x1F).saturating_sub(1) % 4;
        }
        Ok(())
    }

    #[inline(always)]
    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        let Some(at) = self.first_arrival() else {
            self.clock.sleep_until(deadline);
            return Ok(None);
        };
        if at > self.clock.now() {
            // Not arrived yet: wait for it, up to the deadline.
            if at > deadline {
                self.clock.sleep_until(deadline);
                return Ok(None);
            }
            self.clock.sleep_until(at);
        }
        let reply = match self.replies.get(self.taken) {
            Some(reply) => *reply,
            None => self.status_replies[self.status_of[self.head]],
        };
        self.taken += 1;
        if self.taken == self.owed[self.head] {
            self.taken = 0;
            self.head = (self.head + 1) % PENDING_FRAMES;
            self.len -= 1;
            self.next_ns = self.sent_ns[self.head] + TURNAROUND.as_nanos() as u64;
        } else {
            self.next_ns += REPLY_GAP.as_nanos() as u64;
        }
        Ok(Some(Received {
            at,
            message: BusMessage::Frame(reply),
        }))
    }

    /// Like a SocketCAN socket or a threaded simulator, it can be waited on with other buses:
    /// the loop collects from all of them at once (the path real runs take).
    fn readiness(&mut self) -> Readiness<'_> {
        match self.first_arrival() {
            Some(at) if at <= self.clock.now() => Readiness::Ready,
            Some(at) => Readiness::Pending(WaitOn::arrival(at, Duration::ZERO)),
            None => Readiness::Pending(WaitOn::default()),
        }
    }
}

/// The loop of the scenario.
pub type LoopAlone = Running<CannedBus, VirtualClock, NoOp>;

/// A started loop over `buses` canned buses publishing telemetry to the returned receiver (keep
/// it alive: without a receiver nothing is published).
pub fn loop_alone(buses: usize) -> (LoopAlone, TelemetryReceiver) {
    loop_alone_at(buses, RATE_HZ)
}

/// [`loop_alone`] at `rate_hz` ([`HEALTH_RATE_HZ`]: with the health rotation).
pub fn loop_alone_at(buses: usize, rate_hz: f64) -> (LoopAlone, TelemetryReceiver) {
    let clock = VirtualClock::new();
    let canned = (0..buses).map(|_| CannedBus::new(clock.clone())).collect();
    started(robot_at(buses, rate_hz), clock, canned)
}

/// A started loop of `robot` over `buses` with the no-op controller, publishing telemetry to
/// the returned receiver.
pub fn started<B: CanBus>(
    robot: Robot,
    clock: VirtualClock,
    buses: Vec<B>,
) -> (Running<B, VirtualClock, NoOp>, TelemetryReceiver) {
    let mut rt =
        RtLoop::unsupervised(robot, clock, buses, NoOp).expect("one bus per bus of the robot");
    let telemetry = rt.telemetry();
    let Ok(rt) = rt.start() else {
        panic!("every motor answers the start-up probe")
    };
    (rt, telemetry)
}

/// Runs `ticks` ticks of `rt`. Never inlined: callgrind counts the instructions of this
/// function and everything it calls (`--toggle-collect`), and nothing else.
#[inline(never)]
pub fn measured_ticks(rt: &mut LoopAlone, ticks: u64) {
    for _ in 0..ticks {
        assert!(
            rt.step().is_continue(),
            "the loop-alone scenario never stops"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{IqControl, MultiTorque};

    #[test]
    fn each_torque_frame_is_answered_by_four_replies_at_their_times() {
        let clock = VirtualClock::new();
        let mut bus = CannedBus::new(clock.clone());
        let frame = MultiTorque::new([IqControl::default().into(); 4]).encode();
        assert!(matches!(bus.readiness(), Readiness::Pending(w) if w.next_arrival().is_none()));
        bus.send(&frame).unwrap();
        clock.sleep_until(Timestamp::from_nanos(100_000));
        bus.send(&frame).unwrap();
        assert_eq!(bus.send(&frame), Err(BusError::TxQueueFull));
        let mut got = Vec::new();
        while let Some(r) = bus.recv_until(Timestamp::from_nanos(10_000_000)).unwrap() {
            got.push((r.at.as_nanos() / 1_000, r.message));
        }
        let us: Vec<u64> = got.iter().map(|g| g.0).collect();
        assert_eq!(us, [250, 370, 490, 610, 350, 470, 590, 710]);
        for (i, (_, message)) in got.iter().enumerate() {
            let BusMessage::Frame(f) = message else {
                panic!("{message:?}")
            };
            assert_eq!(f.id(), 0x141 + (i % 4) as u16);
        }
        // Nothing more; the receive waited until its deadline.
        assert_eq!(clock.now(), Timestamp::from_nanos(10_000_000));
    }

    #[test]
    fn with_the_health_rotation_every_status_request_is_answered() {
        assert!(
            robot_at(2, HEALTH_RATE_HZ)
                .buses()
                .iter()
                .all(|b| b.health_rotation)
        );
        let (mut rt, _telemetry) = loop_alone_at(2, HEALTH_RATE_HZ);
        for _ in 0..1000 {
            assert!(rt.step().is_continue());
        }
        let stats = rt.stats().summary();
        assert_eq!(stats.missing_replies + stats.late_replies, 0, "{stats}");
        for m in &stats.motors {
            let c = &m.counters;
            assert!(c.status_replies >= 249, "{m:?}");
            assert_eq!(
                (c.missing_status_replies, c.unexpected_replies, c.bad_frames),
                (0, 0, 0)
            );
        }
        assert!(!robot(1).buses()[0].health_rotation);
    }
}
