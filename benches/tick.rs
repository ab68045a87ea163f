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
//!   replies, [`TURNAROUND`] later and then one every `REPLY_GAP` (no simulator at all): the
//!   framework's own overhead. The bus can be waited on with others (`CanBus::readiness`), so
//!   the loop collects from every bus at once, as it does on SocketCAN and on threaded
//!   simulators. The scenario lives in `crates/rmd-tick-bench`, which
//!   `benches/tick-instructions.sh` also runs under callgrind to count its instructions per tick
//!   (the deterministic figure; this benchmark gives the time the machine took for them).
//!
//! Before measuring, each loop runs 10 000 ticks under a counting allocator and prints the
//! allocations per tick (zero: the real-time path never allocates).
//!
//! Run: `cargo bench --bench tick`

mod support;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rmd_rt::bus::{CanBus, Clock, VirtualClock};
use rmd_rt::protocol::{IqControl, MultiTorque};
use rmd_rt::rt::{Running, telemetry::TelemetryReceiver};
use rmd_rt::sim::{SimBus, SimConfig};
use rmd_tick_bench::{MOTORS, NoOp, RATE_HZ, TURNAROUND};

/// Ticks run under the counting allocator.
const COUNTED_TICKS: u64 = 10_000;

/// A started loop over `buses` publishing telemetry (to a receiver nobody drains: the queue
/// overwrites), warmed up, after printing its allocations per tick.
fn started<B: CanBus>(
    name: &str,
    clock: VirtualClock,
    buses: Vec<B>,
) -> (Running<B, VirtualClock, NoOp>, TelemetryReceiver) {
    let n = buses.len();
    let (mut rt, telemetry) = rmd_tick_bench::started(rmd_tick_bench::robot(n), clock, buses);
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
        let canned = (0..buses)
            .map(|_| rmd_tick_bench::CannedBus::new(clock.clone()))
            .collect();
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
