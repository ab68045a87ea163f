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
//! The per-motor scenario ([`per_motor_loop`]) is the same on buses of MyActuator V3 motors,
//! which have no packed torque frame: one 0xA1 request per motor and tick, each answered by its
//! motor ([`CannedMotorBus`]).
//!
//! `benches/tick.rs` times the loop-alone scenario with criterion; `benches/tick-instructions.sh`
//! counts both scenarios' instructions per tick under callgrind with this crate's
//! `tick-instructions` binary.
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
use rmd_loop::robot::{BusConfig, ExchangeKind, MotorConfig, RobotConfig};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, RtLoop, Running, TickContext, robot::Robot,
    telemetry::TelemetryReceiver,
};
use rmd_protocol::{
    CanFrame, Dialect, EncoderValue, ErrorState, Iq, MULTI_TORQUE_CAN_ID, MotorId, OutputAngle,
    Reply, SINGLE_MOTOR_BASE_ID, ScaledCurrent, Speed, Status1, Status2, StatusPosition,
    Temperature, V161Status1, Voltage,
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
    robot_of(buses, rate_hz, MOTORS, |bus| bus)
}

/// A robot at `rate_hz` of `buses` buses (`bench0`, ...) of motors 1..=`motors`, each bus as
/// `configure` makes it.
fn robot_of(
    buses: usize,
    rate_hz: f64,
    motors: u8,
    configure: impl Fn(BusConfig) -> BusConfig,
) -> Robot {
    let mut robot = RobotConfig::new(rate_hz);
    for b in 0..buses {
        let mut bus = configure(BusConfig::new(&format!("bench{b}")));
        for id in 1..=motors {
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
        readiness_of(&self.clock, self.first_arrival())
    }
}

/// A canned bus's readiness when its next reply arrives at `next`.
#[inline(always)]
fn readiness_of(clock: &VirtualClock, next: Option<Timestamp>) -> Readiness<'static> {
    match next {
        Some(at) if at <= clock.now() => Readiness::Ready,
        Some(at) => Readiness::Pending(WaitOn::arrival(at, Duration::ZERO)),
        None => Readiness::Pending(WaitOn::default()),
    }
}

/// The loop of the scenario.
pub type LoopAlone = Running<CannedBus, VirtualClock, NoOp>;

/// Motors on each bus of the per-motor scenario: MyActuator V3 motors, ids 1..=3, the most a bus
/// drives one request at a time at [`RATE_HZ`] (the robot description refuses four).
pub const PER_MOTOR_MOTORS: u8 = 3;

/// Requests a [`CannedMotorBus`] holds replies for (more are refused, as a full transmit queue).
const PENDING_REQUESTS: usize = 2 * PER_MOTOR_MOTORS as usize;

/// DATA\[0\] of a torque request (0xA1).
const TORQUE_REQUEST: u8 = 0xA1;

/// A robot of `buses` buses of [`PER_MOTOR_MOTORS`] MyActuator V3 motors each (ids 1..=3), on the
/// per-motor exchange (one 0xA1 request per motor and tick: V3 has no packed torque frame), at
/// [`RATE_HZ`].
pub fn per_motor_robot(buses: usize) -> Robot {
    robot_of(buses, RATE_HZ, PER_MOTOR_MOTORS, |bus| {
        bus.protocol("myactuator-v3")
            .exchange(ExchangeKind::PerMotor)
    })
}

/// A bus of motors driven per motor: it answers each motor's 0xA1 torque request with that
/// motor's pre-encoded reply (in the motors' dialect), [`TURNAROUND`] after the request and at
/// least [`REPLY_GAP`] after the reply before it (virtual time, as [`CannedBus`]). Other frames
/// are taken and not answered. No allocation.
#[derive(Debug)]
pub struct CannedMotorBus {
    clock: VirtualClock,
    replies: [CanFrame; PER_MOTOR_MOTORS as usize],
    /// When each request not answered yet was sent (ns), oldest first (a ring)...
    sent_ns: [u64; PENDING_REQUESTS],
    /// ... and whose reply it asks for (index into `replies`).
    motor: [usize; PENDING_REQUESTS],
    head: usize,
    len: usize,
    /// While a request is pending, when its reply arrives (ns).
    next_ns: u64,
}

impl CannedMotorBus {
    /// A bus on `clock` for motors 1..=[`PER_MOTOR_MOTORS`] of `dialect`, nothing pending.
    pub fn new(clock: VirtualClock, dialect: Dialect) -> Self {
        let replies = core::array::from_fn(|i| {
            let motor = MotorId::new(i as u8 + 1).expect("ids 1..=3 are valid");
            let status = Status2 {
                temperature: Temperature::saturating(30),
                iq: ScaledCurrent::saturating(40 * i as i64 - 60, dialect.iq_scale()),
                speed: Speed::saturating(12 - 5 * i as i64),
                position: StatusPosition::OutputDegrees(
                    OutputAngle::new(90 * i as i64 - 45).expect("a small angle"),
                ),
            };
            dialect
                .encode_reply(motor, &Reply::Torque(status))
                .expect("a torque reply encodes")
        });
        Self {
            clock,
            replies,
            sent_ns: [0; PENDING_REQUESTS],
            motor: [0; PENDING_REQUESTS],
            head: 0,
            len: 0,
            next_ns: 0,
        }
    }

    /// When the next reply arrives.
    fn first_arrival(&self) -> Option<Timestamp> {
        (self.len > 0).then_some(Timestamp::from_nanos(self.next_ns))
    }
}

impl CanBus for CannedMotorBus {
    // Inlined into the loop, as the canned bus's (see there).
    #[inline(always)]
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        let first = SINGLE_MOTOR_BASE_ID + 1;
        let motor = usize::from(frame.id().wrapping_sub(first));
        if motor < usize::from(PER_MOTOR_MOTORS) && frame.data().first() == Some(&TORQUE_REQUEST) {
            if self.len == PENDING_REQUESTS {
                return Err(BusError::TxQueueFull);
            }
            let slot = (self.head + self.len) % PENDING_REQUESTS;
            let now_ns = self.clock.now().as_nanos();
            self.sent_ns[slot] = now_ns;
            self.motor[slot] = motor;
            if self.len == 0 {
                self.next_ns = now_ns + TURNAROUND.as_nanos() as u64;
            }
            self.len += 1;
        }
        Ok(())
    }

    // The wait for the arrival is `CannedBus`'s written out again: one helper for both, even
    // inlined, changed how the compiler laid out both scenarios' loops (+18 to +58 instructions
    // a tick, tick-instructions.sh).
    #[inline(always)]
    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        let Some(at) = self.first_arrival() else {
            self.clock.sleep_until(deadline);
            return Ok(None);
        };
        if at > self.clock.now() {
            if at > deadline {
                self.clock.sleep_until(deadline);
                return Ok(None);
            }
            self.clock.sleep_until(at);
        }
        let reply = self.replies[self.motor[self.head]];
        self.head = (self.head + 1) % PENDING_REQUESTS;
        self.len -= 1;
        // The next reply: its turnaround after its request, behind this one on the wire.
        self.next_ns = (self.sent_ns[self.head] + TURNAROUND.as_nanos() as u64)
            .max(at.as_nanos() + REPLY_GAP.as_nanos() as u64);
        Ok(Some(Received {
            at,
            message: BusMessage::Frame(reply),
        }))
    }

    /// Waited on with other buses, as [`CannedBus`].
    fn readiness(&mut self) -> Readiness<'_> {
        readiness_of(&self.clock, self.first_arrival())
    }
}

/// The loop of the per-motor scenario.
pub type PerMotorLoop = Running<CannedMotorBus, VirtualClock, NoOp>;

/// A started loop over `buses` canned buses of [`PER_MOTOR_MOTORS`] MyActuator V3 motors each,
/// driven per motor, publishing telemetry to the returned receiver (keep it alive).
// `#[inline]`: compiled in the crate that calls it (the `tick-instructions` binary), with the
// loop of this scenario, not beside the loop-alone scenario's in this crate, whose compiled code
// (and instruction count) would change with a second loop instantiated next to it.
#[inline]
pub fn per_motor_loop(buses: usize) -> (PerMotorLoop, TelemetryReceiver) {
    let robot = per_motor_robot(buses);
    let dialect = robot.joints()[0].dialect;
    let clock = VirtualClock::new();
    let canned = (0..buses)
        .map(|_| CannedMotorBus::new(clock.clone(), dialect))
        .collect();
    started(robot, clock, canned)
}

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
    fn each_torque_request_is_answered_by_its_motors_reply_in_turn() {
        let clock = VirtualClock::new();
        let dialect = per_motor_robot(1).joints()[0].dialect;
        let mut bus = CannedMotorBus::new(clock.clone(), dialect);
        let request = |id: u8| {
            let motor = MotorId::new(id).unwrap();
            let iq = ScaledCurrent::saturating(0, dialect.iq_control_scale());
            dialect
                .encode(motor, &rmd_protocol::Request::Torque { iq_control: iq })
                .unwrap()
        };
        // Motors 3 and 1, then a frame it does not answer (a status request), then motor 2.
        bus.send(&request(3)).unwrap();
        bus.send(&request(1)).unwrap();
        bus.send(
            &dialect
                .encode(
                    MotorId::new(2).unwrap(),
                    &rmd_protocol::Request::ReadStatus1,
                )
                .unwrap(),
        )
        .unwrap();
        clock.sleep_until(Timestamp::from_nanos(400_000));
        bus.send(&request(2)).unwrap();
        let mut got = Vec::new();
        while let Some(r) = bus.recv_until(Timestamp::from_nanos(10_000_000)).unwrap() {
            let BusMessage::Frame(f) = r.message else {
                panic!("{:?}", r.message)
            };
            let (_, Reply::Torque(status)) = dialect.decode_reply(&f).unwrap() else {
                panic!("{f:?}")
            };
            got.push((r.at.as_nanos() / 1_000, f.id(), status.position));
        }
        let angle = |deg: i64| StatusPosition::OutputDegrees(OutputAngle::new(deg).unwrap());
        assert_eq!(
            got,
            [
                // Its turnaround after the request, then behind the one before on the wire.
                (250, dialect.reply_id(MotorId::new(3).unwrap()), angle(135)),
                (370, dialect.reply_id(MotorId::new(1).unwrap()), angle(-45)),
                (650, dialect.reply_id(MotorId::new(2).unwrap()), angle(45)),
            ]
        );
        // Six requests outstanding fill its queue.
        for _ in 0..PENDING_REQUESTS {
            bus.send(&request(1)).unwrap();
        }
        assert_eq!(bus.send(&request(1)), Err(BusError::TxQueueFull));
    }

    #[test]
    fn the_per_motor_scenario_gets_every_reply_fresh() {
        let robot = per_motor_robot(2);
        assert!(
            robot
                .joints()
                .iter()
                .all(|j| j.dialect.family() == rmd_protocol::ProtocolFamily::MyActuatorV3)
        );
        let (mut rt, telemetry) = per_motor_loop(2);
        for _ in 0..1000 {
            assert!(rt.step().is_continue());
        }
        let stats = rt.stats().summary();
        assert_eq!(stats.missing_replies + stats.late_replies, 0, "{stats}");
        assert_eq!(stats.motors.len(), 6);
        for m in &stats.motors {
            let c = &m.counters;
            assert_eq!((c.unexpected_replies, c.bad_frames), (0, 0), "{m:?}");
        }
        // The replies' values reach the feedback: motor 2 of each bus reports +45 degrees at
        // its output (no gearbox: the rotor's angle too).
        let sample = telemetry.latest().expect("a telemetry sample");
        for bus in 0..2 {
            let feedback = &sample.joints()[bus * 3 + 1].feedback;
            assert!(feedback.freshness.is_fresh(), "{feedback:?}");
            assert_eq!(feedback.motor.angle_deg, 45.0, "{feedback:?}");
        }
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
