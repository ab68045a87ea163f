//! Decodes arbitrary bytes as a request and as a reply (to every possible pending command);
//! whatever decodes must re-encode and decode again to the same value. Any panic is a bug.
//!
//! Input layout: bytes 0..2 = CAN ID (little-endian, masked to 11 bits), byte 2 = DLC (mod 9),
//! the rest = data (zero-padded to 8 bytes).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rmd_protocol::{CanFrame, Command, decode_reply, decode_reply_to, decode_request};

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
            assert_eq!(decode_reply_to(&reply.encode(motor), pending), Ok((motor, reply)));
        }
    }
});
