//! The LK-TECH dialect of the codec: golden vectors (worked out by hand from the documents named
//! at each vector, not produced by the encoder), round trips, conversions to v1.61, and no
//! dialect panicking on any frame.

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
fn reply_vector(dialect: Dialect, f: CanFrame, expected: Reply) {
    let (m, r) = dialect.decode_reply(&f).unwrap();
    assert_eq!(r, expected, "decode {f} as {dialect}");
    assert_eq!(dialect.encode_reply(m, &r), Ok(f), "encode {r:?}");
    assert_eq!(
        dialect.decode_reply_to(&f, r.command()),
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
    let expected = Reply::ReadStatus1(Status1::Lk(LkStatus1 {
        temperature: Temperature::new(30).unwrap(),
        voltage: LkVoltage::new(4870).unwrap(),
        bus_current: LkBusCurrent::new(0).unwrap(),
        motor_state: LkMotorState::ON,
        error_state: ErrorState::NONE,
    }));
    reply_vector(MG, f, expected);
    let (_, lk) = MF.decode_reply(&f).unwrap();
    assert_eq!(lk.status1().unwrap().volts(), 48.7);
    // The trap: a v1.61 decoder reads DATA[3..=4] = 0x0013.
    let (_, v161) = Dialect::V161.decode_reply(&f).unwrap();
    assert_eq!(v161.status1().unwrap().volts(), 1.9);
}

/// LK status 1 with every field set: 24.00 V (0x0960), -1.50 A (0xFF6A), motor off (0x10),
/// low-voltage and over-temperature flags (0x09), -5 °C (0xFB); and 0x9B answered with 0x9B or
/// with 0x9A.
#[test]
fn lk_status1_every_field_and_clear_error() {
    let status = Status1::Lk(LkStatus1 {
        temperature: Temperature::new(-5).unwrap(),
        voltage: LkVoltage::new(2400).unwrap(),
        bus_current: LkBusCurrent::new(-150).unwrap(),
        motor_state: LkMotorState::OFF,
        error_state: ErrorState::LOW_VOLTAGE | ErrorState::OVER_TEMPERATURE,
    });
    let data = [0x9A, 0xFB, 0x60, 0x09, 0x6A, 0xFF, 0x10, 0x09];
    reply_vector(MF, frame(0x143, data), Reply::ReadStatus1(status));
    let mut clear = data;
    clear[0] = 0x9B;
    reply_vector(MF, frame(0x143, clear), Reply::ClearError(status));
    // A 0x9A-coded answer to a pending 0x9B, as for v1.61.
    let (_, r) = MF
        .decode_reply_to(&frame(0x143, data), Command::ClearError)
        .unwrap();
    assert_eq!(r.command(), Command::ClearError);
    let s = r.status1().unwrap();
    assert_eq!((s.volts(), s.temperature().celsius()), (24.0, -5.0));
    let flags = s.error_state().unwrap();
    assert!(flags.low_voltage() && flags.over_temperature());
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
        let request = torque(dialect, 2, amps).unwrap();
        assert_eq!(
            dialect.encode_request(&request),
            Ok(f),
            "{dialect} {amps} A"
        );
        assert_eq!(dialect.decode_request(&f), Ok(request));
    }
    // 2001..=2048 are valid LK torques but out of v1.61's range.
    let f = frame(0x141, [0xA1, 0, 0, 0, 0x00, 0x08, 0, 0]);
    assert!(Dialect::V161.decode_request(&f).is_err());
    assert!(Dialect::V161.decode_request(&f).is_err());
    assert!(torque(MF, 1, 16.6).is_err());
}

/// The LK-TECH multi-motor torque frame: 0x280, four iqControl values, LK scale (MF here:
/// 16.5, -16.5, 0, 8.25 A = 2048, -2048, 0, 1024).
#[test]
fn lk_multi_torque() {
    let f = frame(0x280, [0x00, 0x08, 0x00, 0xF8, 0x00, 0x00, 0x00, 0x04]);
    let request = DecodedRequest::Multi(
        MultiTorque::from_amps([16.5, -16.5, 0.0, 8.25], MF.iq_control_scale()).unwrap(),
    );
    assert_eq!(MF.encode_request(&request), Ok(f));
    let decoded = MF.decode_request(&f).unwrap();
    assert_eq!(decoded, request);
    let DecodedRequest::Multi(m) = decoded else {
        panic!("{decoded:?}")
    };
    assert_eq!(m.iq_control_for(motor(4)).unwrap().amps(), 8.25);
    assert_eq!(m.iq_control_for(motor(5)), None);
    // The same frame under v1.61 is rejected (2048 > 2000).
    assert!(Dialect::V161.decode_request(&f).is_err());
}

/// Status-2 replies (0x9C and the control replies): same layout, LK scales (LK-TECH CAN
/// protocol V2.35, reply of 0xA1: "iq ... -2048~2048, MF -16.5A~16.5A, MG -33A~33A").
#[test]
fn lk_status2_scales() {
    // 40 °C, iq 0x0400 = 1024, speed 300 dps (0x012C), encoder 0x8000 (16-bit encoder, half a turn).
    let data = [0xA1, 40, 0x00, 0x04, 0x2C, 0x01, 0x00, 0x80];
    for (dialect, amps) in [(MF, 8.25), (MG, 16.5)] {
        let (_, r) = dialect.decode_reply(&frame(0x144, data)).unwrap();
        let s = r.status2().unwrap();
        assert_eq!(r.command(), Command::Torque);
        assert_eq!(s.iq.amps(), amps, "{dialect}");
        assert_eq!(s.iq.scale(), dialect.iq_scale());
        assert_eq!((s.speed.dps(), s.encoder().unwrap().raw()), (300.0, 0x8000));
        assert_eq!(
            s.encoder().unwrap().degrees(EncoderWidth::new(16).unwrap()),
            180.0,
            "16-bit encoders"
        );
    }
    // MG replies use v1.61's reply scale exactly (33 A over 2048), so they convert to v1.61's
    // Status2; MF replies do not.
    assert_eq!(CurrentScale::LK_MG_IQ, CurrentScale::V161_IQ);
    let (_, mg) = MG.decode_reply(&frame(0x144, data)).unwrap();
    assert!(matches!(
        MG.convert_reply(&mg, Dialect::V161, Conversion::Exact),
        Ok(Reply::Torque(_))
    ));
    let (_, mf) = MF.decode_reply(&frame(0x144, data)).unwrap();
    assert!(matches!(
        MF.convert_reply(&mf, Dialect::V161, Conversion::Exact),
        Err(ProtocolError::ScaleMismatch { .. })
    ));
    // iq beyond ±2048 is rejected in both LK series.
    let bad = frame(0x144, [0x9C, 40, 0x01, 0x08, 0, 0, 0, 0]);
    assert!(matches!(
        MF.decode_reply(&bad),
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
    let r = MF.decode_request(&f).unwrap();
    let DecodedRequest::Single { request, .. } = r else {
        panic!("{r:?}")
    };
    assert_eq!(
        request,
        Request::Speed {
            speed_control: SpeedControl::from_dps(90.0).unwrap(),
            max_torque: MaxTorquePercent::NONE,
        }
    );
    assert_eq!(MF.encode_request(&r), Ok(f));
    assert_eq!(Dialect::V161.decode_request(&f), Ok(r));
}

/// LK 0x94: circleAngle as u32 in DATA[4..=7] (LK-TECH V2.35 §2.27): 900.00° = 90000 = 0x00015F90.
#[test]
fn lk_single_turn_angle() {
    let f = frame(0x141, [0x94, 0, 0, 0, 0x90, 0x5F, 0x01, 0x00]);
    reply_vector(
        MG,
        f,
        Reply::LkSingleTurnAngle {
            circle_angle: LkCircleAngle::new(90_000).unwrap(),
        },
    );
    // v1.61 reads DATA[6..=7] = 1 (0.01°).
    let (_, v161) = Dialect::V161.decode_reply(&f).unwrap();
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

fn dialect_reply(dialect: Dialect) -> impl Strategy<Value = Reply> {
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
                let status = if lk {
                    Status1::Lk(LkStatus1 {
                        temperature: Temperature::new(t.into()).unwrap(),
                        voltage: LkVoltage::new(v.into()).unwrap(),
                        bus_current: LkBusCurrent::new(c.into()).unwrap(),
                        motor_state: LkMotorState::from_raw(state),
                        error_state: ErrorState::from_raw(err),
                    })
                } else {
                    Status1::V161(V161Status1 {
                        temperature: Temperature::new(t.into()).unwrap(),
                        voltage: Voltage::new(v.into()).unwrap(),
                        error_state: ErrorState::from_raw(err),
                    })
                };
                if clear {
                    Reply::ClearError(status)
                } else {
                    Reply::ReadStatus1(status)
                }
            }),
        (
            status2_command(),
            any::<i8>(),
            i64::from(scale.min_raw())..=i64::from(scale.max_raw()),
            any::<i16>(),
            any::<u16>()
        )
            .prop_map(move |(command, t, iq, s, e)| status2_reply(
                command,
                Status2 {
                    temperature: Temperature::new(t.into()).unwrap(),
                    iq: ScaledCurrent::new(iq, scale).unwrap(),
                    speed: Speed::new(s.into()).unwrap(),
                    position: StatusPosition::Encoder(EncoderValue::from_raw(e)),
                }
            )),
        any::<u32>().prop_map(move |a| if lk {
            Reply::LkSingleTurnAngle {
                circle_angle: LkCircleAngle::new(a.into()).unwrap(),
            }
        } else {
            Reply::ReadSingleTurnAngle {
                circle_angle: CircleAngle::saturating(a),
            }
        }),
        (-(1i64 << 55)..(1i64 << 55)).prop_map(|a| Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::new(a).unwrap()
        }),
        any::<[u16; 3]>().prop_map(|e| Reply::ReadEncoder {
            encoder: EncoderValue::from_raw(e[0]),
            encoder_raw: EncoderValue::from_raw(e[1]),
            encoder_offset: EncoderValue::from_raw(e[2]),
        }),
        Just(Reply::MotorOff),
    ]
}

fn dialect_and_reply() -> impl Strategy<Value = (Dialect, Reply)> {
    dialect().prop_flat_map(|d| (Just(d), dialect_reply(d)))
}

proptest! {
    /// Every dialect reply survives encoding and decoding in its dialect.
    #[test]
    fn replies_round_trip((dialect, reply) in dialect_and_reply(), id in 1u8..=32) {
        let f = dialect.encode_reply(motor(id), &reply).unwrap();
        prop_assert_eq!(dialect.decode_reply(&f), Ok((motor(id), reply)));
        prop_assert_eq!(dialect.decode_reply_to(&f, reply.command()), Ok((motor(id), reply)));
    }

    /// Torque requests in the LK dialects round-trip, and their amperes round-trip to within half
    /// a step.
    #[test]
    fn lk_torque_round_trip(dialect in lk_dialect(), amps in -40.0f64..40.0, id in 1u8..=32) {
        let scale = dialect.iq_control_scale();
        let iq = ScaledCurrent::from_amps_saturating(amps, scale);
        let request = DecodedRequest::Single {
            motor: motor(id),
            request: Request::Torque { iq_control: iq },
        };
        let f = dialect.encode_request(&request).unwrap();
        prop_assert_eq!(dialect.decode_request(&f), Ok(request));
        if amps.abs() <= scale.max_amps() {
            prop_assert!((iq.amps() - amps).abs() <= scale.amps_per_lsb() / 2.0 + 1e-12);
        }
    }

    /// LK 0x280 frames round-trip.
    #[test]
    fn lk_multi_torque_round_trip(dialect in lk_dialect(), raw in any::<[i16; 4]>()) {
        let scale = dialect.iq_control_scale();
        let m = MultiTorque::new(raw.map(|r| ScaledCurrent::saturating(r.into(), scale)));
        let f = dialect.encode_multi_torque(&m).unwrap();
        prop_assert_eq!(dialect.decode_request(&f), Ok(DecodedRequest::Multi(m)));
    }

    /// No dialect panics on any frame, and each re-encodes what it decodes (the codec is one
    /// API for every family; v1.61's own vectors are in golden.rs and rejection.rs).
    #[test]
    fn nothing_panics_and_decoded_frames_re_encode(
        id in 0u16..=0x7FF,
        data in any::<[u8; 8]>(),
        len in 0usize..=8,
        d in any_dialect(),
    ) {
        let id = match id % 11 {
            0 => 0x140 + id % 34,
            1 => 0x240 + id % 34,
            2 => 0x400 + id % 34,
            3 => 0x500 + id % 34,
            4 => 0x280,
            _ => id,
        };
        let f = CanFrame::new(id, &data[..len]).unwrap();
        if let Ok((m, r)) = d.decode_reply(&f) {
            prop_assert_eq!(d.decode_reply(&d.encode_reply(m, &r).unwrap()), Ok((m, r)));
        }
        if let Ok(r) = d.decode_request(&f) {
            prop_assert_eq!(d.decode_request(&d.encode_request(&r).unwrap()), Ok(r));
        }
        if let Ok((m, feedback)) = d.decode_mit_reply(&f) {
            let again = d.encode_mit_reply(m, &feedback).unwrap();
            prop_assert_eq!(d.decode_mit_reply(&again), Ok((m, feedback)));
        }
        for pending in Command::ALL {
            let _ = d.decode_reply_to(&f, pending);
        }
    }
}

/// Every dialect: v1.61, both LK series, V3 of both manual revisions.
fn any_dialect() -> impl Strategy<Value = Dialect> {
    prop_oneof![
        Just(Dialect::V161),
        Just(MF),
        Just(MG),
        Just(Dialect::MyActuatorV3(V3Firmware::default())),
        Just(Dialect::MyActuatorV3(
            V3Firmware::dated(FirmwareDate::from_raw(2026042402))
                .with_max_torque(MotorMaxTorque::from_milli_nm(60_000))
        )),
    ]
}

/// A torque request of `amps` to motor `id` in `dialect`'s scale.
fn torque(dialect: Dialect, id: u8, amps: f64) -> Result<DecodedRequest, ProtocolError> {
    Ok(DecodedRequest::Single {
        motor: motor(id),
        request: Request::Torque {
            iq_control: ScaledCurrent::from_amps(amps, dialect.iq_control_scale())?,
        },
    })
}

/// The reply of `command` carrying status 2.
fn status2_reply(command: Command, s: Status2) -> Reply {
    match command {
        Command::ReadStatus2 => Reply::ReadStatus2(s),
        Command::Torque => Reply::Torque(s),
        Command::Speed => Reply::Speed(s),
        Command::Position1 => Reply::Position1(s),
        Command::Position2 => Reply::Position2(s),
        Command::Position3 => Reply::Position3(s),
        _ => Reply::Position4(s),
    }
}
