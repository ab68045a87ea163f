//! What the simulator costs per 0x280 exchange (send + four replies received), in virtual
//! time: the "instant" configuration (no wire time, no turnaround: the code path only), the
//! default bus at a 1 kHz tick (wire model plus 1 ms of physics for four motors), and the
//! firmware side alone (`SimMotors::handle`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rmd_bus::{CanBus, Clock, Timestamp, VirtualClock};
use rmd_protocol::{IqControl, MultiTorque};
use rmd_sim::{SimBus, SimConfig, SimMotors};

fn exchange(c: &mut Criterion) {
    let frame = MultiTorque::new([IqControl::new(40).unwrap().into(); 4]).encode();

    let clock = VirtualClock::new();
    let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(4).instant()).unwrap();
    c.bench_function("simbus_instant_exchange", |b| {
        b.iter(|| {
            bus.send(black_box(&frame)).unwrap();
            let now = clock.now();
            let mut n = 0;
            while let Some(rx) = bus.recv_until(now).unwrap() {
                black_box(rx);
                n += 1;
            }
            assert_eq!(n, 4);
        })
    });

    let clock = VirtualClock::new();
    let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(4)).unwrap();
    c.bench_function("simbus_default_1khz_tick", |b| {
        b.iter(|| {
            let tick = clock.now() + Duration::from_millis(1);
            bus.send(black_box(&frame)).unwrap();
            let mut n = 0;
            while let Some(rx) = bus.recv_until(tick).unwrap() {
                black_box(rx);
                n += 1;
            }
            assert_eq!(n, 4);
        })
    });

    let mut motors = SimMotors::new(&SimConfig::with_motors(4), Timestamp::ZERO).unwrap();
    let mut t = Timestamp::ZERO;
    c.bench_function("simmotors_handle_0x280_1khz", |b| {
        b.iter(|| {
            t += Duration::from_millis(1);
            black_box(motors.handle(black_box(&frame), t).count())
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = exchange
}
criterion_main!(benches);
