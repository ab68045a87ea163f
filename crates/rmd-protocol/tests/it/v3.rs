//! MyActuator V3 golden frames: the worked examples of the manufacturer's manuals, byte for byte
//! (MyActuator "Servo Motor Control Protocol", applicable driver V3: V4.3 of 2025.05 and V4.4 of
//! 2025.09; section numbers `V4.3 §n` / `V4.4 §n`). Each example is checked both ways: the typed
//! value encodes to exactly the manual's bytes, and the manual's bytes decode to exactly the
//! typed value the manual describes. Where the manual gives no example (0x77, 0x78, 0x80, 0x81
//! to one motor) the frame follows its field table.

use rmd_protocol::*;

const V43: Dialect = Dialect::MyActuatorV3(V3Firmware {
    date: None,
    max_torque: None,
});

/// V4.4 firmware on a motor of 60 N·m maximum torque (the X6 of axol's table).
fn v44() -> Dialect {
    Dialect::MyActuatorV3(
        V3Firmware::dated(FirmwareDate::from_raw(2026042402))
            .with_max_torque(MotorMaxTorque::from_milli_nm(60_000)),
    )
}

fn frame(id: u16, data: [u8; 8]) -> CanFrame {
    CanFrame::new(id, &data).unwrap()
}

fn m1() -> MotorId {
    MotorId::new(1).unwrap()
}

/// A request example both ways, to motor 1 (`0x141`).
fn request_vector(dialect: Dialect, data: [u8; 8], request: Request) {
    let f = frame(0x141, data);
    assert_eq!(dialect.encode(m1(), &request), Ok(f), "encode {request:?}");
    assert_eq!(
        dialect.decode_request(&f),
        Ok(DecodedRequest::Single {
            motor: m1(),
            request
        }),
        "decode {f}"
    );
}

/// A reply example both ways, from motor 1 (`0x241`), also as the answer to its own request.
fn reply_vector(dialect: Dialect, data: [u8; 8], reply: Reply) {
    let f = frame(0x241, data);
    assert_eq!(
        dialect.encode_reply(m1(), &reply),
        Ok(f),
        "encode {reply:?}"
    );
    assert_eq!(dialect.decode_reply(&f), Ok((m1(), reply)), "decode {f}");
    assert_eq!(
        dialect.decode_answer(&f, m1(), reply.command()),
        Ok(reply),
        "answer {f}"
    );
}

fn status2(temperature: i64, centiamps: i64, dps: i64, degrees: i64) -> Status2 {
    Status2 {
        temperature: Temperature::new(temperature).unwrap(),
        iq: ScaledCurrent::new(centiamps, CurrentScale::MYACTUATOR_V3_IQ).unwrap(),
        speed: Speed::new(dps).unwrap(),
        position: StatusPosition::OutputDegrees(OutputAngle::new(degrees).unwrap()),
    }
}

/// The manuals' reply of 50 °C, 1 A, 500 dps, 45° ...
const PLUS: [u8; 7] = [0x32, 0x64, 0x00, 0xF4, 0x01, 0x2D, 0x00];
/// ... and of 50 °C, -1 A, -500 dps, -45°.
const MINUS: [u8; 7] = [0x32, 0x9C, 0xFF, 0x0C, 0xFE, 0xD3, 0xFF];

fn with(code: u8, rest: [u8; 7]) -> [u8; 8] {
    let mut d = [code, 0, 0, 0, 0, 0, 0, 0];
    d[1..].copy_from_slice(&rest);
    d
}

/// The stable line of issue 25: 1 A to motor 1 is `141#A100000064000000`.
#[test]
fn torque_a1() {
    // V4.3 §2.19 / V4.4 §2.18, example 1: 100 × 0.01 A = 1 A; example 2: -1 A.
    let amps = |a| Request::Torque {
        iq_control: ScaledCurrent::from_amps(a, V43.iq_control_scale()).unwrap(),
    };
    request_vector(V43, [0xA1, 0, 0, 0, 0x64, 0x00, 0, 0], amps(1.0));
    request_vector(V43, [0xA1, 0, 0, 0, 0x9C, 0xFF, 0, 0], amps(-1.0));
    assert_eq!(
        V43.encode(m1(), &amps(1.0)).unwrap().to_string(),
        "141#A100000064000000"
    );
    reply_vector(
        V43,
        with(0xA1, PLUS),
        Reply::Torque(status2(50, 100, 500, 45)),
    );
    reply_vector(
        V43,
        with(0xA1, MINUS),
        Reply::Torque(status2(50, -100, -500, -45)),
    );
    let s = status2(50, 100, 500, 45);
    assert_eq!(
        (s.temperature.celsius(), s.iq.amps(), s.speed.dps()),
        (50.0, 1.0, 500.0)
    );
}

#[test]
fn speed_a2() {
    // V4.3 §2.20 / V4.4 §2.19: 10000 × 0.01 dps = 100 dps, and -100 dps; maxTorque 0.
    let dps = |d| Request::Speed {
        speed_control: SpeedControl::from_dps(d).unwrap(),
        max_torque: MaxTorquePercent::NONE,
    };
    request_vector(V43, [0xA2, 0, 0, 0, 0x10, 0x27, 0x00, 0x00], dps(100.0));
    request_vector(V43, [0xA2, 0, 0, 0, 0xF0, 0xD8, 0xFF, 0xFF], dps(-100.0));
    reply_vector(
        V43,
        with(0xA2, PLUS),
        Reply::Speed(status2(50, 100, 500, 45)),
    );
    reply_vector(
        V43,
        with(0xA2, MINUS),
        Reply::Speed(status2(50, -100, -500, -45)),
    );
    // DATA[1] is maxTorque in V3 (percent of the rated current), reserved in v1.61.
    let limited = Request::Speed {
        speed_control: SpeedControl::from_dps(100.0).unwrap(),
        max_torque: MaxTorquePercent::new(60),
    };
    request_vector(V43, [0xA2, 0x3C, 0, 0, 0x10, 0x27, 0x00, 0x00], limited);
    assert!(matches!(
        Dialect::V161.encode(m1(), &limited),
        Err(ProtocolError::UnsupportedField { .. })
    ));
}

#[test]
fn absolute_position_a4() {
    // V4.3 §2.21 / V4.4 §2.20: maxSpeed 500 dps, angleControl 36000 = 360° (and -360°).
    let at = |deg| Request::Position2 {
        max_speed: MaxSpeed::new(500).unwrap(),
        angle_control: AngleControl::from_degrees(deg).unwrap(),
    };
    request_vector(
        V43,
        [0xA4, 0x00, 0xF4, 0x01, 0xA0, 0x8C, 0x00, 0x00],
        at(360.0),
    );
    request_vector(
        V43,
        [0xA4, 0x00, 0xF4, 0x01, 0x60, 0x73, 0xFF, 0xFF],
        at(-360.0),
    );
    reply_vector(
        V43,
        with(0xA4, PLUS),
        Reply::Position2(status2(50, 100, 500, 45)),
    );
    reply_vector(
        V43,
        with(0xA4, MINUS),
        Reply::Position2(status2(50, -100, -500, -45)),
    );
}

#[test]
fn status_1_9a_and_status_2_9c() {
    request_vector(V43, [0x9A, 0, 0, 0, 0, 0, 0, 0], Request::ReadStatus1);
    request_vector(V43, [0x9C, 0, 0, 0, 0, 0, 0, 0], Request::ReadStatus2);
    // V4.3 §2.14 / V4.4 §2.13: 50 °C, brake released, 485 × 0.1 V = 48.5 V, 0x0004 low voltage.
    let s = V3Status1 {
        temperature: Temperature::new(50).unwrap(),
        mos_temperature: Temperature::new(0).unwrap(),
        brake: BrakeState::RELEASED,
        voltage: Voltage::new(485).unwrap(),
        error_state: V3ErrorState::LOW_VOLTAGE,
    };
    reply_vector(
        V43,
        [0x9A, 0x32, 0x00, 0x01, 0xE5, 0x01, 0x04, 0x00],
        Reply::ReadStatus1(Status1::V3(s)),
    );
    assert_eq!(Status1::V3(s).volts(), 48.5);
    // The manual's combination example: 0x0016 = stall + low voltage + over current.
    assert!(
        V3ErrorState::from_raw(0x0016)
            .contains(V3ErrorState::STALL | V3ErrorState::LOW_VOLTAGE | V3ErrorState::OVER_CURRENT)
    );
    // V4.3 §2.15 / V4.4 §2.14: the same 50 °C, 1 A, 500 dps, 45° as the control replies.
    reply_vector(
        V43,
        with(0x9C, PLUS),
        Reply::ReadStatus2(status2(50, 100, 500, 45)),
    );
}

#[test]
fn multi_turn_angle_92() {
    request_vector(
        V43,
        [0x92, 0, 0, 0, 0, 0, 0, 0],
        Request::ReadMultiTurnAngle,
    );
    // V4.3 §2.12 / V4.4 §2.11: int32 in DATA[4..=7], 0x00008CA0 = 36000 = 360°.
    reply_vector(
        V43,
        [0x92, 0, 0, 0, 0xA0, 0x8C, 0x00, 0x00],
        Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::new(36_000).unwrap(),
        },
    );
    // v1.61 reads the same bytes as a 56-bit value from DATA[1]: another number entirely.
    let (_, v161) = Dialect::V161
        .decode_reply(&frame(0x141, [0x92, 0, 0, 0, 0xA0, 0x8C, 0x00, 0x00]))
        .unwrap();
    assert_ne!(
        v161,
        Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::new(36_000).unwrap()
        }
    );
    // A V3 angle beyond int32 cannot be sent.
    assert!(
        V43.encode_reply(
            m1(),
            &Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::new(1 << 40).unwrap()
            }
        )
        .is_err()
    );
}

#[test]
fn single_turn_angle_94_by_revision() {
    request_vector(
        V43,
        [0x94, 0, 0, 0, 0, 0, 0, 0],
        Request::ReadSingleTurnAngle,
    );
    // V4.3 §2.13: u16 in DATA[6..=7], 0x2710 = 10000 = 100°.
    reply_vector(
        V43,
        [0x94, 0, 0, 0, 0, 0, 0x10, 0x27],
        Reply::ReadSingleTurnAngle {
            circle_angle: CircleAngle::from_degrees(100.0).unwrap(),
        },
    );
    // V4.4 §2.12: int32 in DATA[4..=7], 0x00001D4C = 7500 = 75°, within ±180°.
    reply_vector(
        v44(),
        [0x94, 0, 0, 0, 0x4C, 0x1D, 0x00, 0x00],
        Reply::V3SingleTurnAngle {
            circle_angle: V3CircleAngle::from_degrees(75.0).unwrap(),
        },
    );
    // Read with the other revision's layout, each example says something else.
    let (_, misread) = V43
        .decode_reply(&frame(0x241, [0x94, 0, 0, 0, 0x4C, 0x1D, 0x00, 0x00]))
        .unwrap();
    assert_eq!(
        misread,
        Reply::ReadSingleTurnAngle {
            circle_angle: CircleAngle::new(0).unwrap()
        }
    );
}

#[test]
fn firmware_date_b2() {
    request_vector(V43, [0xB2, 0, 0, 0, 0, 0, 0, 0], Request::ReadFirmwareDate);
    // V4.3 §2.30 / V4.4 §2.31: 0x0134892E = 20220206.
    reply_vector(
        V43,
        [0xB2, 0, 0, 0, 0x2E, 0x89, 0x34, 0x01],
        Reply::ReadFirmwareDate(FirmwareDate::from_raw(20_220_206)),
    );
    assert_eq!(
        FirmwareDate::from_raw(20_220_206).revision(),
        V3Revision::V4_3
    );
    // github.com/2b-t/myactuator_rmd issue 24: an X4-64 answers 0xB2 with `7A 1E B4 78`, i.e.
    // 0x78B41E7A = 2025070202 (ten digits).
    let (_, r) = V43
        .decode_reply(&frame(0x241, [0xB2, 0, 0, 0, 0x7A, 0x1E, 0xB4, 0x78]))
        .unwrap();
    assert_eq!(
        r,
        Reply::ReadFirmwareDate(FirmwareDate::from_raw(2_025_070_202))
    );
}

#[test]
fn model_b5_in_both_forms() {
    // V4.3 §2.33: `B5 00 ..` answered with seven characters, "X8S2V10".
    request_vector(
        V43,
        [0xB5, 0, 0, 0, 0, 0, 0, 0],
        Request::ReadModel {
            part: ModelPart::Whole,
        },
    );
    let whole = Reply::ReadModel(ModelText::Whole(*b"X8S2V10"));
    reply_vector(V43, [0xB5, 0x58, 0x38, 0x53, 0x32, 0x56, 0x31, 0x30], whole);
    // V4.4 §2.34: `B5 01 01 ..` answered with `B5 01 01` and five characters, "X8S2V".
    let first = ModelIndex::new(1).unwrap();
    request_vector(
        v44(),
        [0xB5, 0x01, 0x01, 0, 0, 0, 0, 0],
        Request::ReadModel {
            part: ModelPart::Chars(first),
        },
    );
    let chars = Reply::ReadModel(ModelText::Chars {
        index: first,
        chars: *b"X8S2V",
    });
    reply_vector(
        v44(),
        [0xB5, 0x01, 0x01, 0x58, 0x38, 0x53, 0x32, 0x56],
        chars,
    );
    let Reply::ReadModel(text) = chars else {
        unreachable!()
    };
    assert_eq!(text.text(), Some("X8S2V"));
    assert!(ModelIndex::new(4).is_err());
}

#[test]
fn watchdog_b3() {
    // V4.3 §2.31 / V4.4 §2.32, example 1: 0 disables; the reply echoes.
    let off = Request::SetWatchdog {
        timeout: WatchdogTimeout::OFF,
    };
    request_vector(V43, [0xB3, 0, 0, 0, 0, 0, 0, 0], off);
    reply_vector(
        V43,
        [0xB3, 0, 0, 0, 0, 0, 0, 0],
        Reply::SetWatchdog {
            timeout: WatchdogTimeout::OFF,
        },
    );
    // Example 2: 0x000003E8 = 1000 ms. (The manuals print its reply as zeros although "the frame
    // data is identical to the command sent": the echo is what is encoded.)
    let second = WatchdogTimeout::from_millis(1000);
    request_vector(
        V43,
        [0xB3, 0, 0, 0, 0xE8, 0x03, 0, 0],
        Request::SetWatchdog { timeout: second },
    );
    reply_vector(
        V43,
        [0xB3, 0, 0, 0, 0xE8, 0x03, 0, 0],
        Reply::SetWatchdog { timeout: second },
    );
    assert!(Request::SetWatchdog { timeout: second }.writes_flash());
}

#[test]
fn function_control_20() {
    // V4.3 §2.35 / V4.4 §2.36, example 1: index 1, clear the multi-turn value; example 2:
    // index 2, CAN ID filter on (value 1). Both replies echo the request.
    let clear = FunctionControl {
        function: V3Function::ClearMultiTurn,
        value: 0,
    };
    request_vector(
        V43,
        [0x20, 0x01, 0, 0, 0, 0, 0, 0],
        Request::FunctionControl(clear),
    );
    reply_vector(
        V43,
        [0x20, 0x01, 0, 0, 0, 0, 0, 0],
        Reply::FunctionControl(clear),
    );
    let filter = FunctionControl {
        function: V3Function::CanIdFilter,
        value: 1,
    };
    request_vector(
        V43,
        [0x20, 0x02, 0, 0, 0x01, 0, 0, 0],
        Request::FunctionControl(filter),
    );
    reply_vector(
        V43,
        [0x20, 0x02, 0, 0, 0x01, 0, 0, 0],
        Reply::FunctionControl(filter),
    );
    assert!(Request::FunctionControl(filter).writes_flash());
    assert!(
        !Request::FunctionControl(FunctionControl {
            function: V3Function::ErrorStatusTransmission,
            value: 1
        })
        .writes_flash()
    );
    assert!(
        V43.decode_request(&frame(0x141, [0x20, 0x09, 0, 0, 0, 0, 0, 0]))
            .is_err()
    );
}

#[test]
fn reset_brake_off_stop() {
    // V4.3 §2.26 / V4.4 §2.27: 0x76 resets, and is never answered.
    request_vector(V43, [0x76, 0, 0, 0, 0, 0, 0, 0], Request::Reset);
    assert!(matches!(
        V43.decode_reply(&frame(0x241, [0x76, 0, 0, 0, 0, 0, 0, 0])),
        Err(ProtocolError::UnknownCommand { code: 0x76, .. })
    ));
    // 0x77 / 0x78 (V4.4 §2.28 / §2.29), 0x80 / 0x81 (V4.4 §2.16 / §2.17): no fields; the
    // reply echoes the request.
    for (code, request, reply) in [
        (0x77, Request::BrakeRelease, Reply::BrakeRelease),
        (0x78, Request::BrakeLock, Reply::BrakeLock),
        (0x80, Request::MotorOff, Reply::MotorOff),
        (0x81, Request::MotorStop, Reply::MotorStop),
    ] {
        request_vector(V43, [code, 0, 0, 0, 0, 0, 0, 0], request);
        reply_vector(V43, [code, 0, 0, 0, 0, 0, 0, 0], reply);
    }
}

#[test]
fn broadcast_280_is_one_command_for_every_motor() {
    // V4.3 §3.2 / V4.4 §3.2, example 1: `280#80..` shuts down motors 1..=4, each answering on
    // its own 0x240 + id with the echo.
    let f = frame(0x280, [0x80, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(V43.encode_broadcast(&Request::MotorOff), Ok(f));
    assert_eq!(
        V43.decode_request(&f),
        Ok(DecodedRequest::Broadcast(Request::MotorOff))
    );
    for id in 1..=4u8 {
        let motor = MotorId::new(id).unwrap();
        let reply = frame(0x240 + u16::from(id), [0x80, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            V43.decode_answer(&reply, motor, Command::MotorOff),
            Ok(Reply::MotorOff)
        );
    }
    // No torque-shaped 0x280 on a V3 bus: the encoder refuses it ...
    let torque = MultiTorque::new([ScaledCurrent::new(0, V43.iq_control_scale()).unwrap(); 4]);
    assert_eq!(
        V43.encode_multi_torque(&torque),
        Err(ProtocolError::UnsupportedFrame {
            kind: FrameKind::MultiTorque,
            family: ProtocolFamily::MyActuatorV3
        })
    );
    // ... and v1.61 has no broadcast: its 0x280 is four torque currents.
    assert!(matches!(
        Dialect::V161.encode_broadcast(&Request::MotorOff),
        Err(ProtocolError::UnsupportedFrame { .. })
    ));
    // A v1.61 torque frame of 0x80 in DATA[0] read by a V3 motor is "motor off".
    assert_eq!(
        V43.decode_request(&frame(0x280, [0x80, 0x00, 0x64, 0x00, 0, 0, 0, 0])),
        Ok(DecodedRequest::Broadcast(Request::MotorOff))
    );
}

#[test]
fn motion_mode_400_and_500() {
    // V4.3 §5.4: p_des 0xE666 = 10 rad, v_des 0x82E = 1.021 rad/s, kp 0x052 = 10.012,
    // kd 0x333 = 1, t_ff 0xB55 = 10.004 N·m, over ±12.5 rad, ±45 rad/s, 0..500, 0..5, ±24 N·m.
    let f = frame(0x401, [0xE6, 0x66, 0x82, 0xE0, 0x52, 0x33, 0x3B, 0x55]);
    let c = MitCommand::from_si(MitRanges::V4_3, 10.0, 1.021, 10.012, 1.0, 10.004).unwrap();
    assert_eq!(V43.encode_mit(m1(), &c), Ok(f));
    let Ok(DecodedRequest::Mit { motor, command }) = V43.decode_request(&f) else {
        panic!("{f}")
    };
    assert_eq!((motor, command), (m1(), c));
    let near = |a: f64, b: f64, step: f64| (a - b).abs() <= step;
    assert!(near(command.position_rad(), 10.0, 25.0 / 65535.0));
    assert!(near(command.velocity_rad_s(), 1.021, 90.0 / 4095.0));
    assert!(near(command.kp(), 10.012, 500.0 / 4095.0));
    assert!(near(command.kd(), 1.0, 1e-12));
    assert!(near(command.torque_nm(), 10.004, 48.0 / 4095.0));
    // Its reply: DATA[0] = CAN ID 1, then p, v, t packed big-endian.
    let reply = frame(0x501, [0x01, 0xE6, 0x66, 0x82, 0xEB, 0x55, 0x00, 0x00]);
    let feedback = MitFeedback::from_raw(MitRanges::V4_3, [0xE666, 0x82E, 0xB55]).unwrap();
    assert_eq!(V43.encode_mit_reply(m1(), &feedback), Ok(reply));
    assert_eq!(V43.decode_mit_reply(&reply), Ok((m1(), feedback)));
    assert!(near(feedback.torque_nm(), 10.004, 48.0 / 4095.0));
    // DATA[0] naming another motor is refused.
    assert!(matches!(
        V43.decode_mit_reply(&frame(0x501, [0x02, 0xE6, 0x66, 0x82, 0xEB, 0x55, 0, 0])),
        Err(ProtocolError::MotorIdMismatch { data_id: 2, .. })
    ));

    // V4.4 §4.4: the same bytes, kd over 0..50 = 10, t_ff = 0.416 × the motor's maximum torque.
    let Ok(DecodedRequest::Mit { command, .. }) = v44().decode_request(&f) else {
        panic!("{f}")
    };
    assert!(near(command.kd(), 10.0, 1e-12));
    assert!(near(command.torque_nm(), 0.4168 * 60.0, 0.01));
    // A command packed with V4.3's ranges is refused by V4.4 firmware (its t_ff would be 2.5
    // times larger there), and V4.4 firmware without its maximum torque cannot be spoken to.
    assert!(matches!(
        v44().encode_mit(m1(), &c),
        Err(ProtocolError::MitRangesMismatch { .. })
    ));
    let v44_no_max = Dialect::MyActuatorV3(V3Firmware::dated(FirmwareDate::from_raw(2026042402)));
    assert_eq!(
        v44_no_max.mit_ranges(),
        Err(ProtocolError::MissingMaxTorque)
    );
    // No motion mode in v1.61.
    assert!(Dialect::V161.encode_mit(m1(), &c).is_err());
}

#[test]
fn replies_must_match_id_and_command() {
    let reply = frame(0x241, [0xB2, 0, 0, 0, 0x7A, 0x1E, 0xB4, 0x78]);
    // A V3 motor answers a command it does not know with its previous reply (myactuator_rmd
    // issue 24: a stale 0xB2 to a 0x79): not the answer to the model request.
    assert_eq!(
        V43.decode_answer(&reply, m1(), Command::ReadModel),
        Err(ProtocolError::ReplyMismatch {
            can_id: 0x241,
            expected: Command::ReadModel,
            got: Command::ReadFirmwareDate
        })
    );
    // Not motor 2's answer either, whatever the command.
    assert!(matches!(
        V43.decode_answer(&reply, MotorId::new(2).unwrap(), Command::ReadFirmwareDate),
        Err(ProtocolError::UnexpectedCanId { can_id: 0x241, .. })
    ));
    // Replies come on 0x240 + id: the request's own identifier is not a reply.
    assert!(matches!(
        V43.decode_reply(&frame(0x141, [0x9A, 0x32, 0, 1, 0xE5, 1, 4, 0])),
        Err(ProtocolError::UnexpectedCanId {
            expected: ExpectedIds::MyActuatorV3Reply,
            ..
        })
    ));
}

#[test]
fn families_refuse_each_others_commands() {
    let v3_only = [
        Request::ReadFirmwareDate,
        Request::Reset,
        Request::BrakeRelease,
        Request::BrakeLock,
    ];
    for request in v3_only {
        assert!(matches!(
            Dialect::V161.encode(m1(), &request),
            Err(ProtocolError::UnsupportedCommand { .. })
        ));
        let f = V43.encode(m1(), &request).unwrap();
        assert!(matches!(
            Dialect::V161.decode_request(&f),
            Err(ProtocolError::UnknownCommand { .. })
        ));
    }
    for request in [Request::ClearError, Request::MotorRun, Request::ReadPid] {
        assert_eq!(
            V43.encode(m1(), &request),
            Err(ProtocolError::UnsupportedCommand {
                command: request.command(),
                family: ProtocolFamily::MyActuatorV3
            })
        );
    }
    // A v1.61 current sent to a V3 motor would run at 1.6 times the current meant.
    let v161_amp = Request::Torque {
        iq_control: IqControl::new(100).unwrap().into(),
    };
    assert!(matches!(
        V43.encode(m1(), &v161_amp),
        Err(ProtocolError::ScaleMismatch { .. })
    ));
}

#[test]
fn v3_replies_convert_to_v161_only_where_meaningful() {
    let (_, status1) = V43
        .decode_reply(&frame(
            0x241,
            [0x9A, 0x32, 0x00, 0x01, 0xE5, 0x01, 0x04, 0x00],
        ))
        .unwrap();
    assert!(matches!(
        V43.convert_reply(&status1, Dialect::V161, Conversion::Exact),
        Err(ProtocolError::NotRepresentable { .. })
    ));
    let near = V43
        .convert_reply(&status1, Dialect::V161, Conversion::Nearest)
        .unwrap();
    let Some(Status1::V161(s)) = near.status1() else {
        panic!("{near:?}")
    };
    assert_eq!(
        (s.voltage.volts(), s.error_state),
        (48.5, ErrorState::LOW_VOLTAGE)
    );
    // The output shaft's angle has no v1.61 form (the gear ratio is not in the frame).
    let (_, torque) = V43.decode_reply(&frame(0x241, with(0xA1, PLUS))).unwrap();
    assert!(matches!(
        V43.convert_reply(&torque, Dialect::V161, Conversion::Nearest),
        Err(ProtocolError::NotRepresentable { .. })
    ));
}
