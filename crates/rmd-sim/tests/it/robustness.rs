//! Whatever arrives on the bus, the simulated motors never panic and only ever answer with
//! well-formed frames from their own IDs.

use proptest::prelude::*;
use rmd_bus::Timestamp;
use rmd_protocol::CanFrame;
use rmd_sim::{SimConfig, SimMotors};

/// Frames biased towards the RMD IDs and command bytes, so that many of them are valid.
fn frame() -> impl Strategy<Value = CanFrame> {
    let id = prop_oneof![0x140u16..=0x146, Just(0x280u16), 0u16..=0x7FF,];
    let command = prop_oneof![
        prop::sample::select(vec![
            0x30u8, 0x31, 0x32, 0x33, 0x34, 0x90, 0x91, 0x19, 0x92, 0x94, 0x9A, 0x9B, 0x9C, 0x9D,
            0x80, 0x81, 0x88, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6,
        ]),
        any::<u8>(),
    ];
    (id, command, prop::collection::vec(any::<u8>(), 0..=7)).prop_map(|(id, command, rest)| {
        let mut data = vec![command];
        data.extend(rest);
        CanFrame::new(id, &data).unwrap()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn arbitrary_traffic_never_panics(
        frames in prop::collection::vec((frame(), 0u64..5_000_000), 1..60),
    ) {
        let mut motors = SimMotors::new(&SimConfig::with_motors(4), Timestamp::ZERO).unwrap();
        let mut t = Timestamp::ZERO;
        for (frame, gap_ns) in frames {
            t += core::time::Duration::from_nanos(gap_ns);
            for reply in motors.handle(&frame, t) {
                prop_assert!((0x141..=0x144).contains(&reply.frame.id()));
                prop_assert_eq!(reply.frame.dlc(), 8);
                prop_assert!(reply.at >= t);
            }
        }
        for m in motors.iter() {
            let s = m.snapshot();
            prop_assert!(s.motor_angle_deg.is_finite() && s.temperature_c.is_finite());
        }
    }
}
