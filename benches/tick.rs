//! The framework's own cost of one control tick, without the controller (a no-op controller) and
//! without waiting (a virtual clock: the tick's timed waits return at once), so what is measured
//! is CPU time: wake bookkeeping, one 0x280 frame sent per bus, the replies received, decoded and
//! matched, joint unwrapping, missing-reply accounting, command staging, telemetry, statistics.
//!
//! Three views, for 1 bus x 4 motors and 4 buses x 4 motors (targets: under 2 us and under 8 us):
//!
//! - `loop+sim`: `Running::step` on the simulator in its instant configuration (no wire time)
//!   but for a fixed turnaround of [`TURNAROUND`]: the loop pairs a reply with its request only
//!   when it comes at least the shortest physical round trip after it (two frames on the wire,
//!   216 us at 1 Mbit/s), so replies at the instant of the request would all be unexpected. The
//!   simulator runs inside the tick: the motors' firmware and 1 ms of physics (20 substeps per
//!   motor) per tick, at 1 kHz;
//! - `sim alone`: the same simulator work without the loop (send the 0x280 frame, receive the
//!   replies, on to the next period), so that `loop+sim - sim alone` is the loop's share;
//! - `loop alone`: `Running::step` on a bus that answers every 0x280 frame with four pre-encoded
//!   replies, [`TURNAROUND`] later and then one every [`REPLY_GAP`] (no simulator at all): the
//!   framework's own overhead. The bus can be waited on with others (`CanBus::readiness`), so
//!   the loop collects from every bus at once, as it does on SocketCAN and on threaded
//!   simulators.
//!
//! Before measuring, each loop runs 10 000 ticks under a counting allocator and prints the
//! allocations per tick (zero: the real-time path never allocates).
//!
//! Run: `cargo bench --bench tick`

mod support;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rmd_rt::bus::{
    BusError, BusMessage, CanBus, Clock, Readiness, Received, Timestamp, VirtualClock, WaitOn,
};
use rmd_rt::protocol::{
    CanFrame, Dialect, EncoderValue, Iq, IqControl, MotorId, MultiTorque, Reply, Speed, Status2,
    StatusPosition, Temperature,
};
use rmd_rt::rt::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_rt::rt::{Running, TelemetryReceiver};
use rmd_rt::sim::{SimBus, SimConfig};
use rmd_rt::{Commands, Controller, Feedback, Flow, RtLoop, TickContext};

/// Loop rate: the period is the virtual time the simulator integrates per tick.
const RATE_HZ: f64 = 1000.0;
const MOTORS: u8 = 4;
/// Ticks run under the counting allocator.
const COUNTED_TICKS: u64 = 10_000;
/// When the first reply comes after the request (virtual time): longer than the shortest
/// physical round trip at 1 Mbit/s (216 us), which the loop's reply matching requires.
const TURNAROUND: Duration = Duration::from_micros(250);
/// Between the canned bus's replies (about one 8-byte frame at 1 Mbit/s).
const REPLY_GAP: Duration = Duration::from_micros(120);

/// The controller is excluded: it does nothing (every command stays zero).
struct NoOp;

impl Controller for NoOp {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        Flow::Continue
    }
}

fn robot(buses: usize) -> rmd_rt::Robot {
    let mut robot = RobotConfig::new(RATE_HZ);
    for b in 0..buses {
        let mut bus = BusConfig::new(&format!("bench{b}"));
        for id in 1..=MOTORS {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        robot = robot.with_bus(bus);
    }
    rmd_rt::Robot::try_from(robot).expect("valid robot")
}

/// A bus that answers each 0x280 frame with the pre-encoded 0xA1 replies of motors 1..=4, the
/// first [`TURNAROUND`] after it and then one every [`REPLY_GAP`] (virtual time: the receive
/// moves the clock to each arrival). No allocation: a fixed ring of pending replies.
struct CannedBus {
    clock: VirtualClock,
    replies: [CanFrame; MOTORS as usize],
    pending: [Option<Received>; 8],
    head: usize,
    len: usize,
}

impl CannedBus {
    fn new(clock: VirtualClock) -> Self {
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
                .unwrap()
        });
        Self {
            clock,
            replies,
            pending: [None; 8],
            head: 0,
            len: 0,
        }
    }

    /// When the oldest pending reply arrives.
    fn first_arrival(&self) -> Option<Timestamp> {
        if self.len == 0 {
            return None;
        }
        self.pending[self.head].as_ref().map(|r| r.at)
    }
}

impl CanBus for CannedBus {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if frame.id() == rmd_rt::protocol::MULTI_TORQUE_CAN_ID {
            let mut at = self.clock.now() + TURNAROUND;
            for reply in self.replies {
                if self.len == self.pending.len() {
                    return Err(BusError::TxQueueFull);
                }
                let slot = (self.head + self.len) % self.pending.len();
                self.pending[slot] = Some(Received {
                    at,
                    message: BusMessage::Frame(reply),
                });
                self.len += 1;
                at += REPLY_GAP;
            }
        }
        Ok(())
    }

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
        let item = self.pending[self.head].take();
        self.head = (self.head + 1) % self.pending.len();
        self.len -= 1;
        Ok(item)
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

/// A started loop over `buses` publishing telemetry (to a receiver nobody drains: the queue
/// overwrites), warmed up, after printing its allocations per tick.
fn started<B: CanBus>(
    name: &str,
    clock: VirtualClock,
    buses: Vec<B>,
) -> (Running<B, VirtualClock, NoOp>, TelemetryReceiver) {
    let n = buses.len();
    let mut rt = RtLoop::new(robot(n), clock, buses, NoOp).expect("valid robot");
    let telemetry = rt.telemetry();
    let Ok(mut rt) = rt.start() else {
        panic!("every motor answers the start-up probe")
    };
    for _ in 0..1_000 {
        assert!(rt.step().is_continue());
    }
    let ((), allocations) = support::allocations_during(|| {
        for _ in 0..COUNTED_TICKS {
            assert!(rt.step().is_continue());
        }
    });
    println!(
        "{name}: {allocations} allocations in {COUNTED_TICKS} ticks ({} per tick)",
        allocations as f64 / COUNTED_TICKS as f64
    );
    (rt, telemetry)
}

fn sim_buses(clock: &VirtualClock, n: usize) -> Vec<SimBus<VirtualClock>> {
    (0..n)
        .map(|b| {
            SimBus::new(clock.clone(), {
                let mut config = SimConfig::with_motors(MOTORS).seed(b as u64).instant();
                for motor in &mut config.motors {
                    motor.turnaround = TURNAROUND;
                }
                config
            })
            .expect("valid simulator")
        })
        .collect()
}

fn tick(c: &mut Criterion) {
    let mut group = c.benchmark_group("tick");
    for buses in [1usize, 4] {
        let label = format!("{buses}x{MOTORS}");

        let clock = VirtualClock::new();
        let (mut rt, _telemetry) = started(
            &format!("loop+sim {label}"),
            clock.clone(),
            sim_buses(&clock, buses),
        );
        group.bench_function(format!("loop+sim {label}"), |b| {
            b.iter(|| black_box(rt.step()))
        });

        let clock = VirtualClock::new();
        let mut sims = sim_buses(&clock, buses);
        let frame = MultiTorque::new([IqControl::default().into(); 4]).encode();
        let period = Duration::from_secs_f64(1.0 / RATE_HZ);
        group.bench_function(format!("sim alone {label}"), |b| {
            b.iter(|| {
                let start = clock.now();
                for sim in &mut sims {
                    sim.send(black_box(&frame)).expect("sent");
                }
                let replies_by = start + TURNAROUND;
                let mut replies = 0;
                for sim in &mut sims {
                    while let Some(rx) = sim.recv_until(replies_by).expect("received") {
                        black_box(rx);
                        replies += 1;
                    }
                }
                assert_eq!(replies, buses * usize::from(MOTORS));
                clock.sleep_until(start + period);
            })
        });

        let clock = VirtualClock::new();
        let canned = (0..buses).map(|_| CannedBus::new(clock.clone())).collect();
        let (mut rt, _telemetry) = started(&format!("loop alone {label}"), clock, canned);
        group.bench_function(format!("loop alone {label}"), |b| {
            b.iter(|| black_box(rt.step()))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = tick
}
criterion_main!(benches);
