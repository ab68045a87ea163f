//! The LK-TECH dialect and the dialect-aware decoders: golden vectors (worked out by hand from
//! the documents named at each vector, not produced by the encoder), round trips, and the v1.61
//! dialect matching the v1.61 decoders on every frame.

use proptest::prelude::*;
use rmd_protocol::*;

const MF: Dialect = Dialect::LkV23x(LkSeries::Mf);
const MG: Dialect = Dialect::LkV23x(LkSeries::Mg);

fn frame(id: u16, data: [u8; 8]) -> CanFrame {
    CanFrame::new(id, &data).unwrap()
}

fn motor(id: u8) -> MotorId {
    MotorId::new(id).unwrap()
}

/// A reply vector both ways, in `dialect`.
fn reply_vector(dialect: Dialect, f: CanFrame, expected: DialectReply) {
    let (m, r) = decode_reply_with(dialect, &f).unwrap();
    assert_eq!(r, expected, "decode {f} as {dialect}");
    assert_eq!(r.encode(m), f, "encode {r:?}");
    assert_eq!(
        decode_reply_to_with(dialect, &f, r.command()),
        Ok((m, r)),
        "decode_reply_to_with {f}"
    );
}

/// Issue 14: a real LK motor at 48.7 V whose 0x9A answer a v1.61 decoder reads as 1.9 V. The
/// bytes other than DATA[2..=3] (30 °C, no bus current, motor on, no error) are chosen here; the
/// layout is LK-TECH CAN protocol V2.35 §1 (see rmd_protocol::lk).
#[test]
fn lk_status1_of_the_issue_capture() {
    let f = frame(0x141, [0x9A, 30, 0x06, 0x13, 0x00, 0x00, 0x00, 0x00]);
    let expected = DialectReply::Status1 {
        command: Command::ReadStatus1,
        status: DialectStatus1::Lk(LkStatus1 {
            temperature: Temperature::new(30).unwrap(),
            voltage: LkVoltage::new(4870).unwrap(),
            bus_current: LkBusCurrent::new(0).unwrap(),
            motor_state: LkMotorState::ON,
            error_state: ErrorState::NONE,
        }),
    };
    reply_vector(MG, f, expected);
    let (_, lk) = decode_reply_with(MF, &f).unwrap();
    assert_eq!(lk.status1().unwrap().volts(), 48.7);
    // The trap the issue describes: v1.61 reads DATA[3..=4] = 0x0013.
    let (_, v161) = decode_reply(&f).unwrap();
    assert_eq!(v161.status1().unwrap().voltage.volts(), 1.9);
}

/// LK status 1 with every field set: 24.00 V (0x0960), -1.50 A (0xFF6A), motor off (0x10),
/// low-voltage and over-temperature flags (0x09), -5 °C (0xFB); and 0x9B answered with 0x9B or
/// with 0x9A.
#[test]
fn lk_status1_every_field_and_clear_error() {
    let status = DialectStatus1::Lk(LkStatus1 {
        temperature: Temperature::new(-5).unwrap(),
        voltage: LkVoltage::new(2400).unwrap(),
        bus_current: LkBusCurrent::new(-150).unwrap(),
        motor_state: LkMotorState::OFF,
        error_state: ErrorState::LOW_VOLTAGE | ErrorState::OVER_TEMPERATURE,
    });
    let data = [0x9A, 0xFB, 0x60, 0x09, 0x6A, 0xFF, 0x10, 0x09];
    reply_vector(
        MF,
        frame(0x143, data),
        DialectReply::Status1 {
            command: Command::ReadStatus1,
            status,
        },
    );
    let mut clear = data;
    clear[0] = 0x9B;
    reply_vector(
        MF,
        frame(0x143, clear),
        DialectReply::Status1 {
            command: Command::ClearError,
            status,
        },
    );
    // A 0x9A-coded answer to a pending 0x9B, as for v1.61.
    let (_, r) = decode_reply_to_with(MF, &frame(0x143, data), Command::ClearError).unwrap();
    assert_eq!(r.command(), Command::ClearError);
    let s = r.status1().unwrap();
    assert_eq!((s.volts(), s.temperature().celsius()), (24.0, -5.0));
    assert!(s.error_state().low_voltage() && s.error_state().over_temperature());
}

/// Torque requests with the LK scales (LK-TECH CAN protocol V2.35, 0xA1: iqControl in
/// DATA[4..=5], ±2048 = ±16.5 A on MF, ±33 A on MG).
#[test]
fn lk_torque_requests() {
    let cases = [
        // 16.5 A on MG = 1024 = 0x0400.
        (MG, 16.5, [0xA1, 0, 0, 0, 0x00, 0x04, 0, 0]),
        // -33 A on MG = -2048 = 0xF800.
        (MG, -33.0, [0xA1, 0, 0, 0, 0x00, 0xF8, 0, 0]),
        // 16.5 A on MF = 2048 = 0x0800.
        (MF, 16.5, [0xA1, 0, 0, 0, 0x00, 0x08, 0, 0]),
        // 1 A on MF = 124.1 -> 124 = 0x007C.
        (MF, 1.0, [0xA1, 0, 0, 0, 0x7C, 0x00, 0, 0]),
    ];
    for (dialect, amps, data) in cases {
        let f = frame(0x142, data);
        let request = DialectRequest::torque(dialect, motor(2), amps).unwrap();
        assert_eq!(
            encode_request_with(dialect, &request),
            Ok(f),
            "{dialect} {amps} A"
        );
        assert_eq!(decode_request_with(dialect, &f), Ok(request));
    }
    // 2001..=2048 are valid LK torques but out of v1.61's range.
    let f = frame(0x141, [0xA1, 0, 0, 0, 0x00, 0x08, 0, 0]);
    assert!(decode_request(&f).is_err());
    assert!(decode_request_with(Dialect::V161, &f).is_err());
    assert!(DialectRequest::torque(MF, motor(1), 16.6).is_err());
}

/// The LK-TECH multi-motor torque frame: 0x280, four iqControl values, LK scale (MF here:
/// 16.5, -16.5, 0, 8.25 A = 2048, -2048, 0, 1024).
#[test]
fn lk_multi_torque() {
    let f = frame(0x280, [0x00, 0x08, 0x00, 0xF8, 0x00, 0x00, 0x00, 0x04]);
    let request = DialectRequest::multi_torque(MF, [16.5, -16.5, 0.0, 8.25]).unwrap();
    assert_eq!(encode_request_with(MF, &request), Ok(f));
    let decoded = decode_request_with(MF, &f).unwrap();
    assert_eq!(decoded, request);
    let DialectRequest::MultiTorque(m) = decoded else {
        panic!("{decoded:?}")
    };
    assert_eq!(m.iq_control_for(motor(4)).unwrap().amps(), 8.25);
    assert_eq!(m.iq_control_for(motor(5)), None);
    // The same frame under v1.61 is rejected (2048 > 2000).
    assert!(decode_request(&f).is_err());
}

/// Status-2 replies (0x9C and the control replies): same layout, LK scales (LK-TECH CAN
/// protocol V2.35, reply of 0xA1: "iq ... -2048~2048, MF -16.5A~16.5A, MG -33A~33A").
#[test]
fn lk_status2_scales() {
    // 40 °C, iq 0x0400 = 1024, speed 300 dps (0x012C), encoder 0x8000 (16-bit encoder, half a turn).
    let data = [0xA1, 40, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x80];
    for (dialect, amps) in [(MF, 8.25), (MG, 16.5)] {
        let (_, r) = decode_reply_with(dialect, &frame(0x144, data)).unwrap();
        let s = r.status2().unwrap();
        assert_eq!(r.command(), Command::Torque);
        assert_eq!(s.iq.amps(), amps, "{dialect}");
        assert_eq!(s.iq.scale(), dialect.iq_scale());
        assert_eq!((s.speed.dps(), s.encoder.raw()), (300.0, 0x8000));
        assert_eq!(
            s.encoder.degrees(EncoderWidth::new(16).unwrap()),
            180.0,
            "16-bit encoders"
        );
    }
    // MG replies use v1.61's reply scale exactly (33 A over 2048), so they convert to v1.61's
    // Status2; MF replies do not.
    assert_eq!(CurrentScale::LK_MG_IQ, CurrentScale::V161_IQ);
    let (_, mg) = decode_reply_with(MG, &frame(0x144, data)).unwrap();
    assert!(matches!(mg.to_v161(), Some(Ok(Reply::Torque(_)))));
    let (_, mf) = decode_reply_with(MF, &frame(0x144, data)).unwrap();
    assert!(matches!(
        mf.to_v161(),
        Some(Err(ProtocolError::ScaleMismatch { .. }))
    ));
    // iq beyond ±2048 is rejected in both LK series.
    let bad = frame(0x144, [0x9C, 40, 0x01, 0x08, 0, 0, 0, 0]);
    assert!(matches!(
        decode_reply_with(MF, &bad),
        Err(ProtocolError::ValueOutOfRange {
            field: Field::Iq,
            value: 2049,
            ..
        })
    ));
}

/// A frame from the LK-TECH English "MS MF RMD Motor CAN Protocol V2.35" examples (speed closed
/// loop, motor 1 at 90 dps: `141 8 A2 00 00 00 28 23 00 00`): the same layout in both dialects.
#[test]
fn lk_document_speed_example_is_common() {
    let f = frame(0x141, [0xA2, 0, 0, 0, 0x28, 0x23, 0, 0]);
    let r = decode_request_with(MF, &f).unwrap();
    let DialectRequest::Common(DecodedRequest::Single { request, .. }) = r else {
        panic!("{r:?}")
    };
    assert_eq!(
        request,
        Request::Speed {
            speed_control: SpeedControl::from_dps(90.0).unwrap()
        }
    );
    assert_eq!(r.encode(), f);
}

/// LK 0x94: circleAngle as u32 in DATA[4..=7] (LK-TECH V2.35 §2.27): 900.00° = 90000 = 0x00015F90.
#[test]
fn lk_single_turn_angle() {
    let f = frame(0x141, [0x94, 0, 0, 0, 0x90, 0x5F, 0x01, 0x00]);
    reply_vector(
        MG,
        f,
        DialectReply::LkSingleTurnAngle {
            circle_angle: LkCircleAngle::new(90_000).unwrap(),
        },
    );
    // v1.61 reads DATA[6..=7] = 1 (0.01°).
    let (_, v161) = decode_reply(&f).unwrap();
    assert!(matches!(v161, Reply::ReadSingleTurnAngle { circle_angle } if circle_angle.raw() == 1));
}

fn lk_dialect() -> impl Strategy<Value = Dialect> {
    prop_oneof![Just(MF), Just(MG)]
}

fn dialect() -> impl Strategy<Value = Dialect> {
    prop_oneof![Just(Dialect::V161), Just(MF), Just(MG)]
}

fn status2_command() -> impl Strategy<Value = Command> {
    proptest::sample::select(vec![
        Command::ReadStatus2,
        Command::Torque,
        Command::Speed,
        Command::Position1,
        Command::Position2,
        Command::Position3,
        Command::Position4,
    ])
}

fn dialect_reply(dialect: Dialect) -> impl Strategy<Value = DialectReply> {
    let scale = dialect.iq_scale();
    let lk = matches!(dialect, Dialect::LkV23x(_));
    prop_oneof![
        (
            any::<bool>(),
            any::<i8>(),
            any::<u16>(),
            any::<i16>(),
            any::<u8>(),
            any::<u8>()
        )
            .prop_map(move |(clear, t, v, c, state, err)| {
                let command = if clear {
                    Command::ClearError
                } else {
                    Command::ReadStatus1
                };
                let status = if lk {
                    DialectStatus1::Lk(LkStatus1 {
                        temperature: Temperature::new(t.into()).unwrap(),
                        voltage: LkVoltage::new(v.into()).unwrap(),
                        bus_current: LkBusCurrent::new(c.into()).unwrap(),
                        motor_state: LkMotorState::from_raw(state),
                        error_state: ErrorState::from_raw(err),
                    })
                } else {
                    DialectStatus1::V161(Status1 {
                        temperature: Temperature::new(t.into()).unwrap(),
                        voltage: Voltage::new(v.into()).unwrap(),
                        error_state: ErrorState::from_raw(err),
                    })
                };
                DialectReply::Status1 { command, status }
            }),
        (
            status2_command(),
            any::<i8>(),
            i64::from(scale.min_raw())..=i64::from(scale.max_raw()),
            any::<i16>(),
            any::<u16>()
        )
            .prop_map(move |(command, t, iq, s, e)| DialectReply::Status2 {
                command,
                status: ScaledStatus2 {
                    temperature: Temperature::new(t.into()).unwrap(),
                    iq: ScaledCurrent::new(iq, scale).unwrap(),
                    speed: Speed::new(s.into()).unwrap(),
                    encoder: EncoderValue::from_raw(e),
                },
            }),
        any::<u32>().prop_map(move |a| if lk {
            DialectReply::LkSingleTurnAngle {
                circle_angle: LkCircleAngle::new(a.into()).unwrap(),
            }
        } else {
            DialectReply::Common(Reply::ReadSingleTurnAngle {
                circle_angle: CircleAngle::saturating(a),
            })
        }),
        (-(1i64 << 55)..(1i64 << 55)).prop_map(|a| DialectReply::Common(
            Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::new(a).unwrap()
            }
        )),
        any::<[u16; 3]>().prop_map(|e| DialectReply::Common(Reply::ReadEncoder {
            encoder: EncoderValue::from_raw(e[0]),
            encoder_raw: EncoderValue::from_raw(e[1]),
            encoder_offset: EncoderValue::from_raw(e[2]),
        })),
        Just(DialectReply::Common(Reply::MotorOff)),
    ]
}

fn dialect_and_reply() -> impl Strategy<Value = (Dialect, DialectReply)> {
    dialect().prop_flat_map(|d| (Just(d), dialect_reply(d)))
}

proptest! {
    /// Every dialect reply survives encoding and decoding in its dialect.
    #[test]
    fn replies_round_trip((dialect, reply) in dialect_and_reply(), id in 1u8..=32) {
        let f = reply.encode(motor(id));
        prop_assert_eq!(decode_reply_with(dialect, &f), Ok((motor(id), reply)));
        prop_assert_eq!(decode_reply_to_with(dialect, &f, reply.command()), Ok((motor(id), reply)));
    }

    /// Torque requests in the LK dialects round-trip, and their amperes round-trip to within half
    /// a step.
    #[test]
    fn lk_torque_round_trip(dialect in lk_dialect(), amps in -40.0f64..40.0, id in 1u8..=32) {
        let scale = dialect.iq_control_scale();
        let iq = ScaledCurrent::from_amps_saturating(amps, scale);
        let request = DialectRequest::Torque { motor: motor(id), iq_control: iq };
        let f = encode_request_with(dialect, &request).unwrap();
        prop_assert_eq!(decode_request_with(dialect, &f), Ok(request));
        if amps.abs() <= scale.max_amps() {
            prop_assert!((iq.amps() - amps).abs() <= scale.amps_per_lsb() / 2.0 + 1e-12);
        }
    }

    /// LK 0x280 frames round-trip.
    #[test]
    fn lk_multi_torque_round_trip(dialect in lk_dialect(), raw in any::<[i16; 4]>()) {
        let scale = dialect.iq_control_scale();
        let m = ScaledMultiTorque::new(raw.map(|r| ScaledCurrent::saturating(r.into(), scale)));
        let f = m.encode();
        prop_assert_eq!(decode_request_with(dialect, &f), Ok(DialectRequest::MultiTorque(m)));
    }

    /// The v1.61 dialect accepts and rejects exactly what the v1.61 decoders do, with the same
    /// values; and no dialect panics on any frame, and re-encodes what it decodes.
    #[test]
    fn v161_dialect_is_v161_and_nothing_panics(
        id in 0u16..=0x7FF,
        data in any::<[u8; 8]>(),
        len in 0usize..=8,
        lk in lk_dialect(),
    ) {
        let id = if id % 3 == 0 { 0x140 + id % 34 } else if id % 7 == 0 { 0x280 } else { id };
        let f = CanFrame::new(id, &data[..len]).unwrap();
        match (decode_reply(&f), decode_reply_with(Dialect::V161, &f)) {
            (Ok((m, r)), Ok((m2, r2))) => {
                prop_assert_eq!(m, m2);
                prop_assert_eq!(r2.to_v161(), Some(Ok(r)));
            }
            (Err(e), Err(e2)) => prop_assert_eq!(e, e2),
            (a, b) => prop_assert!(false, "{:?} vs {:?}", a, b),
        }
        match (decode_request(&f), decode_request_with(Dialect::V161, &f)) {
            (Ok(r), Ok(r2)) => prop_assert_eq!(r.encode(), r2.encode()),
            (Err(e), Err(e2)) => prop_assert_eq!(e, e2),
            (a, b) => prop_assert!(false, "{:?} vs {:?}", a, b),
        }
        if let Ok((m, r)) = decode_reply_with(lk, &f) {
            prop_assert_eq!(decode_reply_with(lk, &r.encode(m)), Ok((m, r)));
        }
        if let Ok(r) = decode_request_with(lk, &f) {
            prop_assert_eq!(decode_request_with(lk, &r.encode()), Ok(r));
        }
    }
}
