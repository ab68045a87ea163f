//! Golden vectors written by hand from the spec (gyems-can-v1.61 + reading notes): the bytes in
//! this file were worked out on paper from the tables, not produced by the encoder. Each vector is
//! checked both ways: the typed value encodes to exactly these bytes, and these bytes decode to
//! exactly this typed value.

use rmd_protocol::*;

const V161: Dialect = Dialect::V161;

fn frame(id: u16, data: [u8; 8]) -> CanFrame {
    CanFrame::new(id, &data).unwrap()
}

fn motor(id: u8) -> MotorId {
    MotorId::new(id).unwrap()
}

/// Checks a request vector both ways.
fn request_vector(id: u16, data: [u8; 8], motor_id: u8, request: Request) {
    let f = frame(id, data);
    assert_eq!(
        V161.encode(motor(motor_id), &request),
        Ok(f),
        "encode {request:?}"
    );
    assert_eq!(
        V161.decode_request(&f),
        Ok(DecodedRequest::Single {
            motor: motor(motor_id),
            request
        }),
        "decode {f}"
    );
}

/// Checks a reply vector both ways (with and without the pending command).
fn reply_vector(id: u16, data: [u8; 8], motor_id: u8, reply: Reply) {
    let f = frame(id, data);
    assert_eq!(
        V161.encode_reply(motor(motor_id), &reply),
        Ok(f),
        "encode {reply:?}"
    );
    assert_eq!(
        V161.decode_reply(&f),
        Ok((motor(motor_id), reply)),
        "decode {f}"
    );
    assert_eq!(
        V161.decode_reply_to(&f, reply.command()),
        Ok((motor(motor_id), reply)),
        "decode_reply_to {f}"
    );
}

fn pid(v: [u8; 6]) -> PidParams {
    PidParams {
        angle_pid_kp: v[0],
        angle_pid_ki: v[1],
        speed_pid_kp: v[2],
        speed_pid_ki: v[3],
        iq_pid_kp: v[4],
        iq_pid_ki: v[5],
    }
}

fn status2(temperature: i64, iq: i64, speed: i64, encoder: u16) -> Status2 {
    Status2 {
        temperature: Temperature::new(temperature).unwrap(),
        iq: Iq::new(iq).unwrap().into(),
        speed: Speed::new(speed).unwrap(),
        position: StatusPosition::Encoder(EncoderValue::from_raw(encoder)),
    }
}

#[test]
fn issue_example_torque_request() {
    let req = Request::Torque {
        iq_control: IqControl::new(100).unwrap().into(),
    };
    assert_eq!(
        V161.encode(motor(1), &req).unwrap().to_string(),
        "141#A100000064000000"
    );
}

#[test]
fn requests_without_fields() {
    // DATA[0] = command byte, DATA[1..=7] = NULL (0x00).
    let cases: [(u8, Request); 13] = [
        (0x30, Request::ReadPid),
        (0x33, Request::ReadAccel),
        (0x90, Request::ReadEncoder),
        (0x19, Request::WriteZeroRom),
        (0x92, Request::ReadMultiTurnAngle),
        (0x94, Request::ReadSingleTurnAngle),
        (0x9A, Request::ReadStatus1),
        (0x9B, Request::ClearError),
        (0x9C, Request::ReadStatus2),
        (0x9D, Request::ReadStatus3),
        (0x80, Request::MotorOff),
        (0x81, Request::MotorStop),
        (0x88, Request::MotorRun),
    ];
    for (code, request) in cases {
        request_vector(0x144, [code, 0, 0, 0, 0, 0, 0, 0], 4, request);
    }
}

#[test]
fn write_pid_requests() {
    // DATA[2..=7] = anglePidKp, anglePidKi, speedPidKp, speedPidKi, iqPidKp, iqPidKi.
    request_vector(
        0x142,
        [0x31, 0x00, 0x64, 0x32, 0x28, 0x1E, 0x14, 0x0A],
        2,
        Request::WritePidRam(pid([100, 50, 40, 30, 20, 10])),
    );
    request_vector(
        0x143,
        [0x32, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0xFF],
        3,
        Request::WritePidRom(pid([1, 2, 3, 4, 5, 255])),
    );
}

#[test]
fn write_accel_request() {
    // Accel = 10000 dps/s = 0x00002710 in DATA[4..=7] (reading notes), DATA[1..=3] = 0.
    request_vector(
        0x141,
        [0x34, 0x00, 0x00, 0x00, 0x10, 0x27, 0x00, 0x00],
        1,
        Request::WriteAccelRam {
            accel: Accel::new(10_000).unwrap(),
        },
    );
}

#[test]
fn write_encoder_offset_request() {
    // encoderOffset = 0x1234 in DATA[6..=7].
    request_vector(
        0x141,
        [0x91, 0x00, 0x00, 0x00, 0x00, 0x00, 0x34, 0x12],
        1,
        Request::WriteEncoderOffset {
            encoder_offset: EncoderValue::new(0x1234, EncoderWidth::DEFAULT).unwrap(),
        },
    );
}

#[test]
fn torque_requests() {
    // iqControl in DATA[4..=5]: 100 = 0x0064, -100 = 0xFF9C.
    request_vector(
        0x141,
        [0xA1, 0, 0, 0, 0x64, 0x00, 0, 0],
        1,
        Request::Torque {
            iq_control: IqControl::new(100).unwrap().into(),
        },
    );
    request_vector(
        0x160,
        [0xA1, 0, 0, 0, 0x9C, 0xFF, 0, 0],
        32,
        Request::Torque {
            iq_control: IqControl::new(-100).unwrap().into(),
        },
    );
    request_vector(
        0x141,
        [0xA1, 0, 0, 0, 0x30, 0xF8, 0, 0],
        1,
        Request::Torque {
            iq_control: IqControl::MIN.into(),
        },
    );
}

#[test]
fn speed_request() {
    // speedControl = 36000 (360 dps) = 0x00008CA0, and -1 = 0xFFFFFFFF, in DATA[4..=7].
    request_vector(
        0x141,
        [0xA2, 0, 0, 0, 0xA0, 0x8C, 0x00, 0x00],
        1,
        Request::Speed {
            speed_control: SpeedControl::from_dps(360.0).unwrap(),
            max_torque: MaxTorquePercent::NONE,
        },
    );
    request_vector(
        0x141,
        [0xA2, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF],
        1,
        Request::Speed {
            speed_control: SpeedControl::new(-1).unwrap(),
            max_torque: MaxTorquePercent::NONE,
        },
    );
}

#[test]
fn position_requests() {
    // 0xA3: angleControl = -9000 (-90°) = 0xFFFFDCD8 in DATA[4..=7].
    request_vector(
        0x141,
        [0xA3, 0, 0, 0, 0xD8, 0xDC, 0xFF, 0xFF],
        1,
        Request::Position1 {
            angle_control: AngleControl::new(-9000).unwrap(),
        },
    );
    // 0xA4: maxSpeed = 500 = 0x01F4 in DATA[2..=3], angleControl = 18000 = 0x4650 in DATA[4..=7].
    request_vector(
        0x141,
        [0xA4, 0, 0xF4, 0x01, 0x50, 0x46, 0x00, 0x00],
        1,
        Request::Position2 {
            max_speed: MaxSpeed::new(500).unwrap(),
            angle_control: AngleControl::new(18_000).unwrap(),
        },
    );
    // 0xA5: spinDirection = 1 (ccw) in DATA[1], angleControl = 35999 = 0x8C9F in DATA[4..=5].
    request_vector(
        0x141,
        [0xA5, 0x01, 0, 0, 0x9F, 0x8C, 0, 0],
        1,
        Request::Position3 {
            spin_direction: SpinDirection::CounterClockwise,
            angle_control: SingleTurnAngle::new(35_999).unwrap(),
        },
    );
    // 0xA6: spinDirection = 0 (cw), maxSpeed = 360 = 0x0168 in DATA[2..=3],
    // angleControl = 9000 = 0x2328 in DATA[4..=5].
    request_vector(
        0x141,
        [0xA6, 0x00, 0x68, 0x01, 0x28, 0x23, 0, 0],
        1,
        Request::Position4 {
            spin_direction: SpinDirection::Clockwise,
            max_speed: MaxSpeed::new(360).unwrap(),
            angle_control: SingleTurnAngle::new(9000).unwrap(),
        },
    );
}

#[test]
fn multi_torque_request() {
    let iq = |raw| ScaledCurrent::from(IqControl::new(raw).unwrap());
    let cases = [
        // 100 = 0x0064, -100 = 0xFF9C, 0, 2000 = 0x07D0.
        (
            [0x64, 0x00, 0x9C, 0xFF, 0x00, 0x00, 0xD0, 0x07],
            [iq(100), iq(-100), iq(0), iq(2000)],
        ),
        // -2000 = 0xF830, 1, -1 = 0xFFFF, 500 = 0x01F4.
        (
            [0x30, 0xF8, 0x01, 0x00, 0xFF, 0xFF, 0xF4, 0x01],
            [iq(-2000), iq(1), iq(-1), iq(500)],
        ),
    ];
    for (data, iq_control) in cases {
        let f = frame(0x280, data);
        let m = MultiTorque::new(iq_control);
        assert_eq!(V161.encode_multi_torque(&m), Ok(f));
        assert_eq!(V161.decode_request(&f), Ok(DecodedRequest::Multi(m)));
    }
    assert_eq!(
        V161.encode_multi_torque(&MultiTorque::new([iq(100), iq(-100), iq(0), iq(2000)]))
            .unwrap()
            .to_string(),
        "280#64009CFF0000D007"
    );
}

#[test]
fn pid_and_accel_replies() {
    let p = pid([100, 50, 40, 30, 20, 10]);
    let data = |code| [code, 0x00, 0x64, 0x32, 0x28, 0x1E, 0x14, 0x0A];
    reply_vector(0x141, data(0x30), 1, Reply::ReadPid(p));
    reply_vector(0x141, data(0x31), 1, Reply::WritePidRam(p));
    reply_vector(0x141, data(0x32), 1, Reply::WritePidRom(p));
    // Accel = 10000 = 0x00002710 in DATA[4..=7]; -1 = 0xFFFFFFFF.
    reply_vector(
        0x141,
        [0x33, 0, 0, 0, 0x10, 0x27, 0x00, 0x00],
        1,
        Reply::ReadAccel {
            accel: Accel::new(10_000).unwrap(),
        },
    );
    reply_vector(
        0x141,
        [0x34, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF],
        1,
        Reply::WriteAccelRam {
            accel: Accel::new(-1).unwrap(),
        },
    );
}

#[test]
fn encoder_replies() {
    // encoder = 1000 = 0x03E8, encoderRaw = 5000 = 0x1388, encoderOffset = 4000 = 0x0FA0.
    reply_vector(
        0x141,
        [0x90, 0x00, 0xE8, 0x03, 0x88, 0x13, 0xA0, 0x0F],
        1,
        Reply::ReadEncoder {
            encoder: EncoderValue::from_raw(1000),
            encoder_raw: EncoderValue::from_raw(5000),
            encoder_offset: EncoderValue::from_raw(4000),
        },
    );
    reply_vector(
        0x141,
        [0x91, 0, 0, 0, 0, 0, 0x34, 0x12],
        1,
        Reply::WriteEncoderOffset {
            encoder_offset: EncoderValue::from_raw(0x1234),
        },
    );
    // 0x19 replies with the offset written: 16383 = 0x3FFF.
    reply_vector(
        0x141,
        [0x19, 0, 0, 0, 0, 0, 0xFF, 0x3F],
        1,
        Reply::WriteZeroRom {
            encoder_offset: EncoderValue::from_raw(16_383),
        },
    );
}

#[test]
fn angle_replies() {
    // motorAngle = 360000 (3600°) = 0x057E40 in DATA[1..=7].
    reply_vector(
        0x141,
        [0x92, 0x40, 0x7E, 0x05, 0x00, 0x00, 0x00, 0x00],
        1,
        Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::new(360_000).unwrap(),
        },
    );
    // motorAngle = -36000 (-360°): 56-bit two's complement 0xFF_FFFF_FFFF_7360, sign-extended.
    let (_, reply) = V161
        .decode_reply(&frame(
            0x141,
            [0x92, 0x60, 0x73, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF],
        ))
        .unwrap();
    let Reply::ReadMultiTurnAngle { motor_angle } = reply else {
        panic!("{reply:?}")
    };
    assert_eq!(motor_angle.raw(), -36_000);
    assert_eq!(motor_angle.degrees(), -360.0);
    reply_vector(
        0x141,
        [0x92, 0x60, 0x73, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF],
        1,
        reply,
    );
    // Extremes of the 56-bit range.
    reply_vector(
        0x141,
        [0x92, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F],
        1,
        Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::MAX,
        },
    );
    reply_vector(
        0x141,
        [0x92, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80],
        1,
        Reply::ReadMultiTurnAngle {
            motor_angle: MotorAngle::MIN,
        },
    );
    // circleAngle = 27000 (270°) = 0x6978 in DATA[6..=7].
    reply_vector(
        0x141,
        [0x94, 0, 0, 0, 0, 0, 0x78, 0x69],
        1,
        Reply::ReadSingleTurnAngle {
            circle_angle: CircleAngle::from_degrees(270.0).unwrap(),
        },
    );
}

#[test]
fn status1_replies() {
    // temperature 45 °C = 0x2D in DATA[1], voltage 24.2 V = 242 = 0x00F2 in DATA[3..=4],
    // errorState 0x09 (low voltage + over temperature) in DATA[7].
    let f = [0x9A, 0x2D, 0x00, 0xF2, 0x00, 0x00, 0x00, 0x09];
    let s = V161Status1 {
        temperature: Temperature::new(45).unwrap(),
        voltage: Voltage::from_volts(24.2).unwrap(),
        error_state: ErrorState::LOW_VOLTAGE | ErrorState::OVER_TEMPERATURE,
    };
    reply_vector(0x141, f, 1, Reply::ReadStatus1(Status1::V161(s)));
    // Negative temperature (int8_t, reading notes): -10 °C = 0xF6; 48.0 V = 480 = 0x01E0.
    let s = V161Status1 {
        temperature: Temperature::new(-10).unwrap(),
        voltage: Voltage::new(480).unwrap(),
        error_state: ErrorState::NONE,
    };
    reply_vector(
        0x141,
        [0x9A, 0xF6, 0x00, 0xE0, 0x01, 0x00, 0x00, 0x00],
        1,
        Reply::ReadStatus1(Status1::V161(s)),
    );
    assert_eq!(s.temperature.celsius(), -10.0);
    assert_eq!(s.voltage.volts(), 48.0);
    // 0x9B reply with its own command byte (echo of the request).
    let s = V161Status1 {
        temperature: Temperature::new(30).unwrap(),
        voltage: Voltage::new(240).unwrap(),
        error_state: ErrorState::from_raw(0x80),
    };
    reply_vector(
        0x141,
        [0x9B, 0x1E, 0x00, 0xF0, 0x00, 0x00, 0x00, 0x80],
        1,
        Reply::ClearError(Status1::V161(s)),
    );
    // The spec's table for the 0x9B reply shows DATA[0] = 0x9A: tolerated as the reply to 0x9B.
    let as_9a = frame(0x141, [0x9A, 0x1E, 0x00, 0xF0, 0x00, 0x00, 0x00, 0x80]);
    assert_eq!(
        V161.decode_reply_to(&as_9a, Command::ClearError),
        Ok((motor(1), Reply::ClearError(Status1::V161(s))))
    );
    assert_eq!(
        V161.decode_reply(&as_9a),
        Ok((motor(1), Reply::ReadStatus1(Status1::V161(s))))
    );
}

#[test]
fn status2_and_control_replies() {
    // temperature 50 = 0x32, iq -1024 (-16.5 A) = 0xFC00, speed 720 dps = 0x02D0,
    // encoder 8192 = 0x2000.
    let s = status2(50, -1024, 720, 8192);
    reply_vector(
        0x141,
        [0x9C, 0x32, 0x00, 0xFC, 0xD0, 0x02, 0x00, 0x20],
        1,
        Reply::ReadStatus2(s),
    );
    assert_eq!(s.iq.amps(), -16.5);
    // temperature 25 = 0x19, iq 2048 (33 A) = 0x0800, speed -1 = 0xFFFF, encoder 16383 = 0x3FFF.
    let s = status2(25, 2048, -1, 16_383);
    let cases: [(u8, Reply); 6] = [
        (0xA1, Reply::Torque(s)),
        (0xA2, Reply::Speed(s)),
        (0xA3, Reply::Position1(s)),
        (0xA4, Reply::Position2(s)),
        (0xA5, Reply::Position3(s)),
        (0xA6, Reply::Position4(s)),
    ];
    for (code, reply) in cases {
        reply_vector(
            0x142,
            [code, 0x19, 0x00, 0x08, 0xFF, 0xFF, 0xFF, 0x3F],
            2,
            reply,
        );
    }
    assert_eq!(s.iq.amps(), 33.0);
    assert_eq!(s.speed.dps(), -1.0);
}

#[test]
fn status3_reply() {
    // iA = 64 (1 A) = 0x0040, iB = -32 (-0.5 A) = 0xFFE0, iC = -32.
    let s = Status3 {
        i_a: PhaseCurrent::new(64).unwrap(),
        i_b: PhaseCurrent::new(-32).unwrap(),
        i_c: PhaseCurrent::new(-32).unwrap(),
    };
    reply_vector(
        0x141,
        [0x9D, 0x00, 0x40, 0x00, 0xE0, 0xFF, 0xE0, 0xFF],
        1,
        Reply::ReadStatus3(s),
    );
    assert_eq!((s.i_a.amps(), s.i_b.amps()), (1.0, -0.5));
}

#[test]
fn echo_replies() {
    for (code, reply) in [
        (0x80, Reply::MotorOff),
        (0x81, Reply::MotorStop),
        (0x88, Reply::MotorRun),
    ] {
        reply_vector(0x141, [code, 0, 0, 0, 0, 0, 0, 0], 1, reply);
    }
}

#[test]
fn multi_torque_exchange() {
    // One 0x280 frame, then motors 1..=4 answer on 0x141..=0x144 with the 0xA1 layout.
    let request = frame(0x280, [0x64, 0x00, 0x9C, 0xFF, 0x00, 0x00, 0xD0, 0x07]);
    let DecodedRequest::Multi(m) = V161.decode_request(&request).unwrap() else {
        panic!()
    };
    assert_eq!(m.iq_control_for(motor(4)).unwrap().amps(), 32.0);
    assert_eq!(m.iq_control_for(motor(5)), None);
    let replies = [
        frame(0x141, [0xA1, 0x1E, 0x3E, 0x00, 0x0A, 0x00, 0x00, 0x10]),
        frame(0x142, [0xA1, 0x1F, 0xC2, 0xFF, 0xF6, 0xFF, 0x00, 0x20]),
        frame(0x143, [0xA1, 0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x30]),
        frame(0x144, [0xA1, 0x21, 0xE0, 0x07, 0x64, 0x00, 0xFF, 0x3F]),
    ];
    let expected = [
        (1, status2(30, 62, 10, 0x1000)),
        (2, status2(31, -62, -10, 0x2000)),
        (3, status2(32, 0, 0, 0x3000)),
        (4, status2(33, 2016, 100, 0x3FFF)),
    ];
    for (f, (id, s)) in replies.iter().zip(expected) {
        assert_eq!(
            V161.decode_reply_to(f, Command::Torque),
            Ok((motor(id), Reply::Torque(s)))
        );
    }
}
