//! The protocol's share of one control tick: encode one 0x280 multi-motor torque frame and
//! decode the four 0xA1 replies of motors 1..=4. Target: under 50 ns for the whole set.
//!
//! Run: `cargo bench --bench protocol`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rmd_rt::protocol::{
    CanFrame, Command, Dialect, EncoderValue, Iq, IqControl, MotorId, MultiTorque, Reply, Speed,
    Status2, StatusPosition, Temperature,
};

fn replies() -> [CanFrame; 4] {
    core::array::from_fn(|i| {
        let status = Status2 {
            temperature: Temperature::saturating(30 + i as i64),
            iq: Iq::saturating(100 * i as i64 - 150).into(),
            speed: Speed::saturating(-200 + 37 * i as i64),
            position: StatusPosition::Encoder(EncoderValue::from_raw(4000 * i as u16 + 17)),
        };
        // Ids 1..=4 always exist.
        let motor = MotorId::new(i as u8 + 1).expect("motor ids 1..=4 are valid");
        Dialect::V161
            .encode_reply(motor, &Reply::Torque(status))
            .expect("a v1.61 status reply encodes")
    })
}

fn tick(c: &mut Criterion) {
    let replies = replies();
    let command = MultiTorque::new([
        IqControl::saturating(120).into(),
        IqControl::saturating(-340).into(),
        IqControl::saturating(5).into(),
        IqControl::saturating(2000).into(),
    ]);
    c.bench_function("encode 0x280 + decode 4 replies", |b| {
        b.iter(|| {
            let frame = black_box(&command).encode();
            black_box(&frame);
            for reply in black_box(&replies) {
                // Every decoded reply escapes whole, so no field's decoding can be optimised away.
                let _ = black_box(Dialect::V161.decode_reply_to(reply, Command::Torque));
            }
        })
    });
    c.bench_function("decode 1 reply (0xA1)", |b| {
        b.iter(|| Dialect::V161.decode_reply_to(black_box(&replies[1]), Command::Torque))
    });
    c.bench_function("encode 1 frame (0x280)", |b| {
        b.iter(|| black_box(&command).encode())
    });
}

criterion_group!(benches, tick);
criterion_main!(benches);
