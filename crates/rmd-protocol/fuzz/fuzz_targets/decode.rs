//! Decodes arbitrary bytes as a request and as a reply (to every possible pending command), in
//! v1.61 and in each dialect, and as a MyActuator V3 reply, and offers them to the family
//! identification; whatever decodes must re-encode and decode again to the same value. Any panic
//! is a bug.
//!
//! Input layout: bytes 0..2 = CAN ID (little-endian, masked to 11 bits), byte 2 = DLC (mod 9),
//! the rest = data (zero-padded to 8 bytes).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rmd_protocol::identify::{ProbeAnswers, identify};
use rmd_protocol::v3::V3Reply;
use rmd_protocol::{
    CanFrame, Command, Dialect, LkSeries, MotorId, decode_reply, decode_reply_to,
    decode_reply_with, decode_request, decode_request_with,
};

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

    if let Ok(request) = decode_request(&frame) {
        let again = request.encode();
        assert_eq!(again.id(), frame.id());
        assert_eq!(decode_request(&again), Ok(request));
    }
    if let Ok((motor, reply)) = decode_reply(&frame) {
        assert_eq!(motor.can_id(), frame.id());
        assert_eq!(decode_reply(&reply.encode(motor)), Ok((motor, reply)));
    }
    for pending in Command::ALL {
        if let Ok((motor, reply)) = decode_reply_to(&frame, pending) {
            assert_eq!(reply.command(), pending);
            assert_eq!(
                decode_reply_to(&reply.encode(motor), pending),
                Ok((motor, reply))
            );
        }
    }
    for dialect in [
        Dialect::V161,
        Dialect::LkV23x(LkSeries::Mf),
        Dialect::LkV23x(LkSeries::Mg),
    ] {
        if let Ok(request) = decode_request_with(dialect, &frame) {
            assert_eq!(decode_request_with(dialect, &request.encode()), Ok(request));
        }
        if let Ok((motor, reply)) = decode_reply_with(dialect, &frame) {
            assert_eq!(
                decode_reply_with(dialect, &reply.encode(motor)),
                Ok((motor, reply))
            );
        }
    }
    if let Ok((motor, reply)) = V3Reply::decode(&frame) {
        assert_eq!(V3Reply::decode(&reply.encode(motor)), Ok((motor, reply)));
    }
    for id in [1u8, 32] {
        if let Ok(motor) = MotorId::new(id) {
            let mut answers = ProbeAnswers::new();
            answers.offer(motor, &frame);
            let _ = identify(motor, &answers);
        }
    }
});
