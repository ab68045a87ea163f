//! Property tests: every request and reply type round-trips through its frame, physical-unit
//! conversions round-trip, and decoding never panics on any frame.

use proptest::prelude::*;
use proptest::sample::select;
use rmd_protocol::*;

const V161: Dialect = Dialect::V161;

fn motor() -> impl Strategy<Value = MotorId> {
    (1u8..=32).prop_map(|id| MotorId::new(id).unwrap())
}

fn pid() -> impl Strategy<Value = PidParams> {
    any::<[u8; 6]>().prop_map(|v| PidParams {
        angle_pid_kp: v[0],
        angle_pid_ki: v[1],
        speed_pid_kp: v[2],
        speed_pid_ki: v[3],
        iq_pid_kp: v[4],
        iq_pid_ki: v[5],
    })
}

fn iq_control() -> impl Strategy<Value = IqControl> {
    (-2000i64..=2000).prop_map(|v| IqControl::new(v).unwrap())
}

fn single_turn() -> impl Strategy<Value = SingleTurnAngle> {
    (0i64..=35_999).prop_map(|v| SingleTurnAngle::new(v).unwrap())
}

fn spin() -> impl Strategy<Value = SpinDirection> {
    any::<bool>().prop_map(|ccw| {
        if ccw {
            SpinDirection::CounterClockwise
        } else {
            SpinDirection::Clockwise
        }
    })
}

fn request() -> impl Strategy<Value = Request> {
    (
        select(V161.commands().to_vec()),
        pid(),
        any::<i32>(),
        any::<u16>(),
        iq_control(),
        any::<i32>(),
        any::<u16>(),
        spin(),
        single_turn(),
    )
        .prop_map(|(command, pid, int, enc, iq, angle, max, dir, single)| {
            if let Some(r) = Request::without_fields(command) {
                return r;
            }
            match command {
                Command::WritePidRam => Request::WritePidRam(pid),
                Command::WritePidRom => Request::WritePidRom(pid),
                Command::WriteAccelRam => Request::WriteAccelRam {
                    accel: Accel::new(int.into()).unwrap(),
                },
                Command::WriteEncoderOffset => Request::WriteEncoderOffset {
                    encoder_offset: EncoderValue::from_raw(enc),
                },
                Command::Torque => Request::Torque {
                    iq_control: iq.into(),
                },
                Command::Speed => Request::Speed {
                    speed_control: SpeedControl::new(int.into()).unwrap(),
                    max_torque: MaxTorquePercent::NONE,
                },
                Command::Position1 => Request::Position1 {
                    angle_control: AngleControl::new(angle.into()).unwrap(),
                },
                Command::Position2 => Request::Position2 {
                    max_speed: MaxSpeed::new(max.into()).unwrap(),
                    angle_control: AngleControl::new(angle.into()).unwrap(),
                },
                Command::Position3 => Request::Position3 {
                    spin_direction: dir,
                    angle_control: single,
                },
                Command::Position4 => Request::Position4 {
                    spin_direction: dir,
                    max_speed: MaxSpeed::new(max.into()).unwrap(),
                    angle_control: single,
                },
                other => unreachable!("{other} has no fields"),
            }
        })
}

fn status1() -> impl Strategy<Value = Status1> {
    (any::<i8>(), any::<u16>(), any::<u8>()).prop_map(|(t, v, e)| {
        Status1::V161(V161Status1 {
            temperature: Temperature::new(t.into()).unwrap(),
            voltage: Voltage::new(v.into()).unwrap(),
            error_state: ErrorState::from_raw(e),
        })
    })
}

fn status2() -> impl Strategy<Value = Status2> {
    (any::<i8>(), -2048i64..=2048, any::<i16>(), any::<u16>()).prop_map(|(t, iq, s, e)| Status2 {
        temperature: Temperature::new(t.into()).unwrap(),
        iq: Iq::new(iq).unwrap().into(),
        speed: Speed::new(s.into()).unwrap(),
        position: StatusPosition::Encoder(EncoderValue::from_raw(e)),
    })
}

fn status3() -> impl Strategy<Value = Status3> {
    any::<[i16; 3]>().prop_map(|[a, b, c]| Status3 {
        i_a: PhaseCurrent::new(a.into()).unwrap(),
        i_b: PhaseCurrent::new(b.into()).unwrap(),
        i_c: PhaseCurrent::new(c.into()).unwrap(),
    })
}

fn reply() -> impl Strategy<Value = Reply> {
    (
        select(V161.commands().to_vec()),
        pid(),
        any::<i32>(),
        any::<[u16; 3]>(),
        -(1i64 << 55)..(1i64 << 55),
        0i64..=35_999,
        status1(),
        status2(),
        status3(),
    )
        .prop_map(|(command, pid, accel, enc, angle, circle, s1, s2, s3)| {
            let accel = Accel::new(accel.into()).unwrap();
            let offset = EncoderValue::from_raw(enc[2]);
            match command {
                Command::ReadPid => Reply::ReadPid(pid),
                Command::WritePidRam => Reply::WritePidRam(pid),
                Command::WritePidRom => Reply::WritePidRom(pid),
                Command::ReadAccel => Reply::ReadAccel { accel },
                Command::WriteAccelRam => Reply::WriteAccelRam { accel },
                Command::ReadEncoder => Reply::ReadEncoder {
                    encoder: EncoderValue::from_raw(enc[0]),
                    encoder_raw: EncoderValue::from_raw(enc[1]),
                    encoder_offset: offset,
                },
                Command::WriteEncoderOffset => Reply::WriteEncoderOffset {
                    encoder_offset: offset,
                },
                Command::WriteZeroRom => Reply::WriteZeroRom {
                    encoder_offset: offset,
                },
                Command::ReadMultiTurnAngle => Reply::ReadMultiTurnAngle {
                    motor_angle: MotorAngle::new(angle).unwrap(),
                },
                Command::ReadSingleTurnAngle => Reply::ReadSingleTurnAngle {
                    circle_angle: CircleAngle::new(circle).unwrap(),
                },
                Command::ReadStatus1 => Reply::ReadStatus1(s1),
                Command::ClearError => Reply::ClearError(s1),
                Command::ReadStatus2 => Reply::ReadStatus2(s2),
                Command::ReadStatus3 => Reply::ReadStatus3(s3),
                Command::MotorOff => Reply::MotorOff,
                Command::MotorStop => Reply::MotorStop,
                Command::MotorRun => Reply::MotorRun,
                Command::Torque => Reply::Torque(s2),
                Command::Speed => Reply::Speed(s2),
                Command::Position1 => Reply::Position1(s2),
                Command::Position2 => Reply::Position2(s2),
                Command::Position3 => Reply::Position3(s2),
                Command::Position4 => Reply::Position4(s2),
                other => unreachable!("{other} is not a v1.61 command"),
            }
        })
}

/// Any standard frame, biased towards the protocol's identifiers and DLC 8.
fn any_frame() -> impl Strategy<Value = CanFrame> {
    let id = prop_oneof![
        3 => 0x141u16..=0x160,
        1 => Just(0x280u16),
        1 => 0u16..=0x7FF,
    ];
    let len = prop_oneof![4 => Just(8usize), 1 => 0usize..=8];
    (id, len, any::<[u8; 8]>()).prop_map(|(id, len, data)| CanFrame::new(id, &data[..len]).unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn every_request_round_trips(m in motor(), req in request()) {
        let frame = V161.encode(m, &req).unwrap();
        prop_assert_eq!(frame.id(), 0x140 + u16::from(m.get()));
        prop_assert_eq!(frame.dlc(), 8);
        prop_assert_eq!(frame.data()[0], req.command().code());
        prop_assert_eq!(V161.decode_request(&frame), Ok(DecodedRequest::Single { motor: m, request: req }));
    }

    #[test]
    fn every_reply_round_trips(m in motor(), reply in reply()) {
        let frame = V161.encode_reply(m, &reply).unwrap();
        prop_assert_eq!(frame.id(), m.can_id());
        prop_assert_eq!(frame.data()[0], reply.command().code());
        prop_assert_eq!(V161.decode_reply(&frame), Ok((m, reply)));
        prop_assert_eq!(V161.decode_reply_to(&frame, reply.command()), Ok((m, reply)));
    }

    #[test]
    fn multi_torque_round_trips(iq in proptest::array::uniform4(iq_control())) {
        let iq = iq.map(ScaledCurrent::from);
        let m = MultiTorque::new(iq);
        let frame = V161.encode_multi_torque(&m).unwrap();
        prop_assert_eq!(frame.id(), MULTI_TORQUE_CAN_ID);
        prop_assert_eq!(V161.decode_request(&frame), Ok(DecodedRequest::Multi(m)));
        for (slot, id) in (1u8..=4).enumerate() {
            prop_assert_eq!(m.iq_control_for(MotorId::new(id).unwrap()), Some(iq[slot]));
        }
    }

    #[test]
    fn decoding_never_panics_and_valid_frames_round_trip(frame in any_frame()) {
        if let Ok(decoded) = V161.decode_request(&frame) {
            // Re-encoding normalises reserved bytes only: decoding again gives the same value.
            prop_assert_eq!(V161.decode_request(&V161.encode_request(&decoded).unwrap()), Ok(decoded));
        }
        if let Ok((m, reply)) = V161.decode_reply(&frame) {
            prop_assert_eq!(m.can_id(), frame.id());
            prop_assert_eq!(V161.decode_reply(&V161.encode_reply(m, &reply).unwrap()), Ok((m, reply)));
        }
        for pending in Command::ALL {
            if let Ok((m, reply)) = V161.decode_reply_to(&frame, pending) {
                prop_assert_eq!(reply.command(), pending);
                let again = V161.encode_reply(m, &reply).unwrap();
                prop_assert_eq!(V161.decode_reply_to(&again, pending), Ok((m, reply)));
            }
        }
        // Display never panics either.
        let _ = frame.to_string();
    }

    #[test]
    fn physical_units_round_trip(
        iq in -2000i64..=2000, iq_reply in -2048i64..=2048, phase in any::<i16>(),
        speed in any::<i32>(), angle in any::<i32>(), single in 0i64..=35_999,
        volts in any::<u16>(), temp in any::<i8>(), motor_angle in -(1i64 << 45)..(1i64 << 45),
    ) {
        let v = IqControl::new(iq).unwrap();
        prop_assert_eq!(IqControl::from_amps(v.amps()), Ok(v));
        let v = Iq::new(iq_reply).unwrap();
        prop_assert_eq!(Iq::from_amps(v.amps()), Ok(v));
        let v = PhaseCurrent::new(phase.into()).unwrap();
        prop_assert_eq!(PhaseCurrent::from_amps(v.amps()), Ok(v));
        let v = SpeedControl::new(speed.into()).unwrap();
        prop_assert_eq!(SpeedControl::from_dps(v.dps()), Ok(v));
        let v = AngleControl::new(angle.into()).unwrap();
        prop_assert_eq!(AngleControl::from_degrees(v.degrees()), Ok(v));
        let v = SingleTurnAngle::new(single).unwrap();
        prop_assert_eq!(SingleTurnAngle::from_degrees(v.degrees()), Ok(v));
        prop_assert_eq!(SingleTurnAngle::from_degrees_wrapping(v.degrees() + 720.0), v);
        let v = Voltage::new(volts.into()).unwrap();
        prop_assert_eq!(Voltage::from_volts(v.volts()), Ok(v));
        let v = Temperature::new(temp.into()).unwrap();
        prop_assert_eq!(Temperature::from_celsius(v.celsius()), Ok(v));
        let v = MotorAngle::new(motor_angle).unwrap();
        prop_assert_eq!(MotorAngle::from_degrees(v.degrees()), Ok(v));
    }

    #[test]
    fn saturating_constructors_stay_in_range(x in any::<f64>(), raw in any::<i64>()) {
        let v = IqControl::from_amps_saturating(x);
        prop_assert!((-2000..=2000).contains(&v.raw()));
        let v = IqControl::saturating(raw);
        prop_assert!((-2000..=2000).contains(&v.raw()));
        prop_assert!(SingleTurnAngle::from_degrees_saturating(x).raw() <= 35_999);
        prop_assert!(SingleTurnAngle::from_degrees_wrapping(x).raw() <= 35_999);
        prop_assert!((-2048..=2048).contains(&Iq::from_amps_saturating(x).raw()));
        // Checked constructors agree with the range.
        prop_assert_eq!(IqControl::new(raw).is_ok(), (-2000..=2000).contains(&raw));
    }

    #[test]
    fn encoder_values_respect_the_width(bits in 12u8..=18, raw in -10i64..70_000) {
        let w = EncoderWidth::new(bits).unwrap();
        let max = if bits >= 16 { 65_535 } else { (1i64 << bits) - 1 };
        prop_assert_eq!(EncoderValue::new(raw, w).is_ok(), (0..=max).contains(&raw));
        if let Ok(v) = EncoderValue::new(raw, w) {
            prop_assert_eq!(EncoderValue::from_degrees(v.degrees(w), w), Ok(v));
        }
    }
}
