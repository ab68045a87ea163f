//! Decodes arbitrary bytes as a request and as a reply (to every possible pending command) in
//! every family — v1.61, LK-TECH V2.3x (MF, MG), MyActuator V3 before and from the V4.4
//! firmware — and as a V3 motion-mode reply, converts every decoded reply to every other family
//! both ways, and offers the frame to the family identification; whatever decodes must re-encode
//! and decode again to the same value. Any panic is a bug.
//!
//! Input layout: bytes 0..2 = CAN ID (little-endian, masked to 11 bits), byte 2 = DLC (mod 9),
//! the rest = data (zero-padded to 8 bytes).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rmd_protocol::{
    CanFrame, Command, Conversion, Dialect, FirmwareDate, LkSeries, MotorId, MotorMaxTorque,
    ProbeAnswers, V3Firmware, identify,
};

/// Every family the codec speaks, V3 on both sides of the V4.4 firmware date.
const DIALECTS: [Dialect; 5] = [
    Dialect::V161,
    Dialect::LkV23x(LkSeries::Mf),
    Dialect::LkV23x(LkSeries::Mg),
    Dialect::MyActuatorV3(V3Firmware::dated(FirmwareDate::from_raw(2_025_070_202))),
    Dialect::MyActuatorV3(
        V3Firmware::dated(FirmwareDate::FIRST_V4_4)
            .with_max_torque(MotorMaxTorque::from_milli_nm(60_000)),
    ),
];

fuzz_target!(|input: &[u8]| {
    let id = u16::from_le_bytes([
        input.first().copied().unwrap_or(0),
        input.get(1).copied().unwrap_or(0),
    ]) & 0x7FF;
    let dlc = usize::from(input.get(2).copied().unwrap_or(8)) % 9;
    let mut data = [0u8; 8];
    for (slot, byte) in data.iter_mut().zip(input.iter().skip(3)) {
        *slot = *byte;
    }
    let Ok(frame) = CanFrame::new(id, &data[..dlc]) else {
        return;
    };

    for dialect in DIALECTS {
        if let Ok(request) = dialect.decode_request(&frame) {
            let again = dialect
                .encode_request(&request)
                .expect("a decoded request re-encodes");
            assert_eq!(again.id(), frame.id());
            assert_eq!(dialect.decode_request(&again), Ok(request));
        }
        if let Ok((motor, reply)) = dialect.decode_reply(&frame) {
            let again = dialect
                .encode_reply(motor, &reply)
                .expect("a decoded reply re-encodes");
            assert_eq!(dialect.decode_reply(&again), Ok((motor, reply)));
            for to in DIALECTS {
                for conversion in [Conversion::Exact, Conversion::Nearest] {
                    if let Ok(converted) = dialect.convert_reply(&reply, to, conversion) {
                        assert_eq!(converted.command(), reply.command());
                        let _ = to.encode_reply(motor, &converted);
                    }
                }
            }
        }
        for pending in Command::ALL {
            if let Ok((motor, reply)) = dialect.decode_reply_to(&frame, pending) {
                assert_eq!(reply.command(), pending);
                let again = dialect
                    .encode_reply(motor, &reply)
                    .expect("a decoded reply re-encodes");
                assert_eq!(dialect.decode_reply_to(&again, pending), Ok((motor, reply)));
                assert_eq!(dialect.decode_answer(&again, motor, pending), Ok(reply));
            }
        }
        if let Ok((motor, feedback)) = dialect.decode_mit_reply(&frame) {
            let again = dialect
                .encode_mit_reply(motor, &feedback)
                .expect("a decoded motion reply re-encodes");
            assert_eq!(dialect.decode_mit_reply(&again), Ok((motor, feedback)));
        }
    }
    for id in [1u8, 32] {
        if let Ok(motor) = MotorId::new(id) {
            let mut answers = ProbeAnswers::new();
            answers.offer(motor, &frame);
            let _ = identify(motor, &answers);
        }
    }
});
