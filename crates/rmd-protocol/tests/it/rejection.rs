//! Every error kind, each with the exact error value it must produce.

use rmd_protocol::*;

const V161: Dialect = Dialect::V161;

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

#[test]
fn non_standard_can_id() {
    assert_eq!(
        CanFrame::new(0x800, &[0; 8]),
        Err(ProtocolError::InvalidCanId { can_id: 0x800 })
    );
    assert_eq!(
        CanFrame::with_data(0xFFFF, [0; 8]),
        Err(ProtocolError::InvalidCanId { can_id: 0xFFFF })
    );
}

#[test]
fn wrong_dlc() {
    for len in [0usize, 1, 7] {
        let data = [0x9C; 8];
        let f = frame(0x141, &data[..len]);
        let err = ProtocolError::WrongDlc {
            can_id: 0x141,
            dlc: len as u8,
        };
        assert_eq!(V161.decode_request(&f), Err(err));
        assert_eq!(V161.decode_reply(&f), Err(err));
        assert_eq!(V161.decode_reply_to(&f, Command::ReadStatus2), Err(err));
    }
    assert_eq!(
        V161.decode_request(&frame(0x280, &[0; 6])),
        Err(ProtocolError::WrongDlc {
            can_id: 0x280,
            dlc: 6
        })
    );
    assert_eq!(
        CanFrame::new(0x141, &[0; 9]),
        Err(ProtocolError::WrongDlc {
            can_id: 0x141,
            dlc: 9
        })
    );
}

#[test]
fn can_id_outside_the_protocol() {
    for id in [0x000, 0x140, 0x161, 0x27F, 0x281, 0x7FF] {
        let f = frame(id, &[0x9C, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            V161.decode_request(&f),
            Err(ProtocolError::UnexpectedCanId {
                can_id: id,
                expected: ExpectedIds::MotorOrMultiTorque
            })
        );
        assert_eq!(
            V161.decode_reply(&f),
            Err(ProtocolError::UnexpectedCanId {
                can_id: id,
                expected: ExpectedIds::Motor
            })
        );
    }
    // 0x280 is a request ID only: motors answer on their own ID.
    let f = frame(0x280, &[0xA1, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        V161.decode_reply(&f),
        Err(ProtocolError::UnexpectedCanId {
            can_id: 0x280,
            expected: ExpectedIds::Motor
        })
    );
    assert_eq!(
        MotorId::from_can_id(0x161),
        Err(ProtocolError::UnexpectedCanId {
            can_id: 0x161,
            expected: ExpectedIds::Motor
        })
    );
    // The CAN ID is checked before the DLC.
    assert!(matches!(
        V161.decode_reply(&frame(0x100, &[])),
        Err(ProtocolError::UnexpectedCanId { .. })
    ));
}

#[test]
fn unknown_command_byte() {
    for code in [0x00u8, 0x35, 0x93, 0x9E, 0xA0, 0xA7, 0xFF] {
        let f = frame(0x143, &[code, 0, 0, 0, 0, 0, 0, 0]);
        let err = ProtocolError::UnknownCommand {
            can_id: 0x143,
            code,
        };
        assert_eq!(V161.decode_request(&f), Err(err));
        assert_eq!(V161.decode_reply(&f), Err(err));
        assert_eq!(V161.decode_reply_to(&f, Command::Torque), Err(err));
    }
}

#[test]
fn reply_not_matching_the_pending_request() {
    let status2 = frame(0x141, &[0x9C, 0x20, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        V161.decode_reply_to(&status2, Command::Torque),
        Err(ProtocolError::ReplyMismatch {
            can_id: 0x141,
            expected: Command::Torque,
            got: Command::ReadStatus2
        })
    );
    // The 0x9A-for-0x9B tolerance is one-way: a 0x9B is not the reply to a pending 0x9A.
    let clear = frame(0x141, &[0x9B, 0x20, 0, 0, 0, 0, 0, 0]);
    assert_eq!(
        V161.decode_reply_to(&clear, Command::ReadStatus1),
        Err(ProtocolError::ReplyMismatch {
            can_id: 0x141,
            expected: Command::ReadStatus1,
            got: Command::ClearError
        })
    );
    // The mismatch is reported before the field ranges (iq 0x7FFF would be out of range).
    let bad_iq = frame(0x141, &[0xA2, 0x20, 0xFF, 0x7F, 0, 0, 0, 0]);
    assert!(matches!(
        V161.decode_reply_to(&bad_iq, Command::Torque),
        Err(ProtocolError::ReplyMismatch { .. })
    ));
    assert_eq!(
        ProtocolError::ReplyMismatch {
            can_id: 0x141,
            expected: Command::Torque,
            got: Command::ReadStatus2
        }
        .to_string(),
        "CAN ID 0x141: reply read-status-2 (0x9C) does not match the pending request torque (0xA1)"
    );
}

fn out_of_range(field: Field, value: i64, min: i64, max: i64) -> ProtocolError {
    ProtocolError::ValueOutOfRange {
        field,
        value,
        min,
        max,
    }
}

#[test]
fn request_values_out_of_range() {
    // iqControl 2001 = 0x07D1, -2001 = 0xF82F.
    assert_eq!(
        V161.decode_request(&frame(0x141, &[0xA1, 0, 0, 0, 0xD1, 0x07, 0, 0])),
        Err(out_of_range(Field::IqControl, 2001, -2000, 2000))
    );
    assert_eq!(
        V161.decode_request(&frame(0x141, &[0xA1, 0, 0, 0, 0x2F, 0xF8, 0, 0])),
        Err(out_of_range(Field::IqControl, -2001, -2000, 2000))
    );
    // 0x280 with motor 3's value at 32767.
    assert_eq!(
        V161.decode_request(&frame(0x280, &[0, 0, 0, 0, 0xFF, 0x7F, 0, 0])),
        Err(out_of_range(Field::IqControl, 32767, -2000, 2000))
    );
    // Single-turn angleControl 36000 = 0x8CA0.
    assert_eq!(
        V161.decode_request(&frame(0x141, &[0xA5, 0, 0, 0, 0xA0, 0x8C, 0, 0])),
        Err(out_of_range(
            Field::SingleTurnAngleControl,
            36_000,
            0,
            35_999
        ))
    );
    assert_eq!(
        V161.decode_request(&frame(0x141, &[0xA6, 0, 0, 0, 0xA0, 0x8C, 0, 0])),
        Err(out_of_range(
            Field::SingleTurnAngleControl,
            36_000,
            0,
            35_999
        ))
    );
    // spinDirection 2.
    assert_eq!(
        V161.decode_request(&frame(0x141, &[0xA5, 2, 0, 0, 0, 0, 0, 0])),
        Err(out_of_range(Field::SpinDirection, 2, 0, 1))
    );
}

#[test]
fn reply_values_out_of_range() {
    // iq 2049 = 0x0801.
    assert_eq!(
        V161.decode_reply(&frame(0x141, &[0xA1, 0, 0x01, 0x08, 0, 0, 0, 0])),
        Err(out_of_range(Field::Iq, 2049, -2048, 2048))
    );
    assert_eq!(
        V161.decode_reply(&frame(0x141, &[0x9C, 0, 0xFF, 0xF7, 0, 0, 0, 0])),
        Err(out_of_range(Field::Iq, -2049, -2048, 2048))
    );
    // circleAngle 36000.
    assert_eq!(
        V161.decode_reply(&frame(0x141, &[0x94, 0, 0, 0, 0, 0, 0xA0, 0x8C])),
        Err(out_of_range(Field::CircleAngle, 36_000, 0, 35_999))
    );
}

#[test]
fn constructors_out_of_range() {
    assert_eq!(
        IqControl::new(2001),
        Err(out_of_range(Field::IqControl, 2001, -2000, 2000))
    );
    assert_eq!(
        SingleTurnAngle::new(36_000),
        Err(out_of_range(
            Field::SingleTurnAngleControl,
            36_000,
            0,
            35_999
        ))
    );
    assert_eq!(
        SingleTurnAngle::from_degrees(360.0),
        Err(out_of_range(
            Field::SingleTurnAngleControl,
            36_000,
            0,
            35_999
        ))
    );
    assert_eq!(
        MaxSpeed::new(65_536),
        Err(out_of_range(Field::MaxSpeed, 65_536, 0, 65_535))
    );
    assert_eq!(
        SpeedControl::new(i64::from(i32::MAX) + 1),
        Err(out_of_range(
            Field::SpeedControl,
            i64::from(i32::MAX) + 1,
            i64::from(i32::MIN),
            i64::from(i32::MAX)
        ))
    );
    assert_eq!(
        Iq::from_amps(-33.1),
        Err(out_of_range(Field::Iq, -2054, -2048, 2048))
    );
    assert_eq!(
        AngleControl::from_degrees(f64::INFINITY),
        Err(ProtocolError::NotFinite {
            field: Field::AngleControl
        })
    );
    assert_eq!(
        Voltage::from_volts(f64::NAN),
        Err(ProtocolError::NotFinite {
            field: Field::Voltage
        })
    );
}

#[test]
fn encoder_values_beyond_the_width() {
    let w14 = EncoderWidth::DEFAULT;
    assert_eq!(
        EncoderValue::new(16_384, w14),
        Err(out_of_range(Field::EncoderValue, 16_384, 0, 16_383))
    );
    assert_eq!(
        EncoderValue::new(4096, EncoderWidth::new(12).unwrap()),
        Err(out_of_range(Field::EncoderValue, 4096, 0, 4095))
    );
    assert_eq!(
        EncoderValue::new(-1, w14),
        Err(out_of_range(Field::EncoderValue, -1, 0, 16_383))
    );
    assert!(EncoderValue::new(65_535, EncoderWidth::new(17).unwrap()).is_ok());
    assert_eq!(
        EncoderWidth::new(19),
        Err(out_of_range(Field::EncoderWidth, 19, 12, 18))
    );
    // Decoding accepts any u16; the width check is explicit.
    let f = frame(0x141, &[0x91, 0, 0, 0, 0, 0, 0x00, 0x40]); // 16384
    let DecodedRequest::Single { request, .. } = V161.decode_request(&f).unwrap() else {
        panic!()
    };
    assert_eq!(
        request.check_encoder_width(w14),
        Err(out_of_range(Field::EncoderValue, 16_384, 0, 16_383))
    );
    assert_eq!(
        request.check_encoder_width(EncoderWidth::new(15).unwrap()),
        Ok(())
    );
    let f = frame(0x141, &[0x90, 0, 0, 0, 0xFF, 0x3F, 0x00, 0x40]);
    let (_, reply) = V161.decode_reply(&f).unwrap();
    assert_eq!(
        reply.check_encoder_width(w14),
        Err(out_of_range(Field::EncoderValue, 16_384, 0, 16_383))
    );
    let f = frame(0x141, &[0xA1, 0, 0, 0, 0, 0, 0xFF, 0xFF]);
    let (_, reply) = V161.decode_reply(&f).unwrap();
    assert!(reply.check_encoder_width(w14).is_err());
    assert!(
        reply
            .check_encoder_width(EncoderWidth::new(16).unwrap())
            .is_ok()
    );
}

#[test]
fn invalid_motor_id() {
    assert_eq!(
        MotorId::new(0),
        Err(ProtocolError::InvalidMotorId { id: 0 })
    );
    assert_eq!(
        MotorId::new(33),
        Err(ProtocolError::InvalidMotorId { id: 33 })
    );
    assert_eq!(
        ProtocolError::InvalidMotorId { id: 33 }.to_string(),
        "invalid motor id 33: must be 1..=32"
    );
}

#[test]
fn reserved_bytes_are_ignored() {
    // Torque request with junk in every NULL byte.
    let f = frame(0x141, &[0xA1, 0xFF, 0xFF, 0xFF, 0x64, 0x00, 0xEE, 0xEE]);
    assert_eq!(
        V161.decode_request(&f),
        Ok(DecodedRequest::Single {
            motor: MotorId::new(1).unwrap(),
            request: Request::Torque {
                iq_control: IqControl::new(100).unwrap().into()
            }
        })
    );
    // Status 1 reply with data in DATA[2], DATA[5], DATA[6].
    let f = frame(0x141, &[0x9A, 0x20, 0x55, 0xF0, 0x00, 0x66, 0x77, 0x00]);
    let (motor, reply) = V161.decode_reply(&f).unwrap();
    let Some(Status1::V161(status)) = reply.status1() else {
        panic!("{reply:?}")
    };
    assert_eq!(status.voltage.raw(), 240);
    // Re-encoding zeroes them.
    assert_eq!(
        V161.encode_reply(motor, &reply).unwrap().data(),
        [0x9A, 0x20, 0, 0xF0, 0, 0, 0, 0]
    );
    // Read requests with payload junk still decode.
    let f = frame(0x141, &[0x9C, 1, 2, 3, 4, 5, 6, 7]);
    assert!(matches!(
        V161.decode_request(&f),
        Ok(DecodedRequest::Single {
            request: Request::ReadStatus2,
            ..
        })
    ));
}
