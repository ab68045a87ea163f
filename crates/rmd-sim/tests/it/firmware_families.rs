//! The other firmware families and the firmware-state traps, end to end through `SimMotors`:
//! identification of each family from the simulated answers to the probe frames, the LK-TECH
//! layouts and scales, MyActuator V3's reply identifiers and 0x280-as-command, and each trap
//! (off by default, on when set).

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_protocol::*;
use rmd_sim::firmware::SIM_V3_MODEL;
use rmd_sim::{
    CommandSet, ControlMode, FaultRule, FirmwareFamily, FirmwareTraps, ReplyFault, ScheduledFrame,
    SimConfig, SimMotors, V3Params,
};

const MF: FirmwareFamily = FirmwareFamily::LkV23x(LkSeries::Mf);
const MG: FirmwareFamily = FirmwareFamily::LkV23x(LkSeries::Mg);

fn id(n: u8) -> MotorId {
    MotorId::new(n).unwrap()
}

/// Simulated motors with one family per id (ids 1, 2, ...), no jitter, and a clock.
struct Bench {
    motors: SimMotors,
    t: Timestamp,
}

impl Bench {
    fn new(families: &[FirmwareFamily]) -> Self {
        Self::with(families, |_| {})
    }

    fn with(families: &[FirmwareFamily], setup: impl FnOnce(&mut SimConfig)) -> Self {
        let mut config = SimConfig::with_motors(families.len() as u8);
        for (m, f) in config.motors.iter_mut().zip(families) {
            m.firmware.family = *f;
            m.turnaround_jitter = Duration::ZERO;
        }
        setup(&mut config);
        Self {
            motors: SimMotors::new(&config, Timestamp::ZERO).unwrap(),
            t: Timestamp::ZERO,
        }
    }

    /// Sends `frame` 1 ms after the last one; the replies.
    fn send(&mut self, frame: CanFrame) -> Vec<ScheduledFrame> {
        self.t += Duration::from_millis(1);
        self.motors.handle(&frame, self.t).collect()
    }

    /// Sends `frame`, expects exactly one reply, returns it.
    fn ask(&mut self, frame: CanFrame) -> CanFrame {
        let replies = self.send(frame);
        assert_eq!(replies.len(), 1, "{frame}: {replies:?}");
        replies[0].frame
    }

    fn wait(&mut self, ms: u64) {
        self.t += Duration::from_millis(ms);
    }

    fn current(&mut self, n: u8) -> f64 {
        self.motors.snapshot_at(id(n), self.t).unwrap().current_a
    }

    fn mode(&mut self, n: u8) -> ControlMode {
        self.motors.snapshot_at(id(n), self.t).unwrap().mode
    }

    /// Probes motor `n` as a start-up check would and identifies it.
    fn identify(&mut self, n: u8) -> Identification {
        let mut answers = ProbeAnswers::new();
        for probe in probe_requests(id(n)) {
            for reply in self.send(probe) {
                answers.offer(id(n), &reply.frame);
            }
        }
        let first = identify(id(n), &answers);
        if first.family != ProtocolFamily::MyActuatorV3 {
            return first;
        }
        for reply in self.send(model_request(id(n))) {
            answers.offer(id(n), &reply.frame);
        }
        identify(id(n), &answers)
    }
}

fn frame(id: u16, d: [u8; 8]) -> CanFrame {
    CanFrame::new(id, &d).unwrap()
}

#[test]
fn identifies_each_family_from_its_answers() {
    for (family, expected, finding) in [
        (
            FirmwareFamily::V161,
            ProtocolFamily::V161,
            Finding::V161Status1,
        ),
        (MG, ProtocolFamily::LkV23x, Finding::LkStatus1),
        (MF, ProtocolFamily::LkV23x, Finding::LkStatus1),
        (
            FirmwareFamily::MyActuatorV3,
            ProtocolFamily::MyActuatorV3,
            Finding::V3ReplyId,
        ),
    ] {
        let mut bench = Bench::new(&[family]);
        let found = bench.identify(1);
        assert_eq!(found.family, expected, "{family}: {found}");
        assert_eq!(found.evidence.finding, finding, "{family}");
        assert!(found.evidence.answered_status1 && found.evidence.answered_status2);
        if expected == ProtocolFamily::MyActuatorV3 {
            assert_eq!(found.evidence.reply_id, Some(0x241));
            assert_eq!(found.evidence.model, Some(SIM_V3_MODEL));
        } else {
            assert_eq!(found.evidence.reply_id, Some(0x141));
            assert_eq!(found.evidence.model, None);
        }
        assert_eq!(
            found.family.multi_torque_is_per_motor_torque(),
            family != FirmwareFamily::MyActuatorV3
        );
    }
}

#[test]
fn identifies_a_mixed_bus_and_absent_or_silent_motors() {
    let mut bench = Bench::with(
        &[FirmwareFamily::V161, MF, FirmwareFamily::MyActuatorV3, MG],
        |c| {
            c.faults
                .push(FaultRule::new(ReplyFault::Silent).motor(id(4)))
        },
    );
    let families: Vec<_> = (1..=5).map(|n| bench.identify(n).family).collect();
    assert_eq!(
        families,
        [
            ProtocolFamily::V161,
            ProtocolFamily::LkV23x,
            ProtocolFamily::MyActuatorV3,
            ProtocolFamily::Unknown,
            ProtocolFamily::Unknown,
        ]
    );
    assert_eq!(bench.identify(5).evidence.finding, Finding::NoAnswer);
}

#[test]
fn identification_at_the_ambiguous_and_sagging_supplies() {
    // v1.61 at 26 V (LK reading plausible too): DATA[2] = 0 decides v1.61. LK at 26 V: its
    // zero bus current at rest keeps the v1.61 reading implausible.
    for (family, expected) in [
        (FirmwareFamily::V161, ProtocolFamily::V161),
        (MG, ProtocolFamily::LkV23x),
    ] {
        let mut bench = Bench::with(&[family], |c| c.motors[0].motor.supply_voltage_v = 26.0);
        let found = bench.identify(1);
        assert_eq!(found.family, expected, "{family} at 26 V: {found}");
    }
}

#[test]
fn lk_status1_layout_on_the_wire() {
    let mut bench = Bench::new(&[MG]);
    // 25 °C (0x19), 48.00 V = 4800 = 0x12C0 in DATA[2..=3], no bus current, motor on.
    let reply = bench.ask(Dialect::V161.encode(id(1), &Request::ReadStatus1).unwrap());
    assert_eq!(reply, frame(0x141, [0x9A, 0x19, 0xC0, 0x12, 0, 0, 0x00, 0]));
    // A v1.61 decoder reads 1.8 V from it (the trap of mixed families).
    let (_, v161) = Dialect::V161.decode_reply(&reply).unwrap();
    assert!((v161.status1().unwrap().volts() - 1.8).abs() < 1e-9);
    let (_, lk) = Dialect::LkV23x(LkSeries::Mg).decode_reply(&reply).unwrap();
    assert_eq!(lk.status1().unwrap().volts(), 48.0);
    // 0x9B answers in the same layout.
    let clear = bench.ask(Dialect::V161.encode(id(1), &Request::ClearError).unwrap());
    assert_eq!(clear.data()[..4], [0x9B, 0x19, 0xC0, 0x12]);
    // 0x94 is the u32 layout: DATA[6..=7] of a v1.61 reply are 0 for small angles.
    let angle = bench.ask(
        Dialect::V161
            .encode(id(1), &Request::ReadSingleTurnAngle)
            .unwrap(),
    );
    let (_, r) = Dialect::LkV23x(LkSeries::Mg).decode_reply(&angle).unwrap();
    assert!(matches!(r, Reply::LkSingleTurnAngle { .. }));
}

#[test]
fn lk_current_scales_per_series() {
    // The same raw iqControl (1024) is 8.25 A on MF, 16.5 A on MG, 16.384 A under v1.61.
    let raw = 1024;
    for (family, amps) in [(MF, 8.25), (MG, 16.5), (FirmwareFamily::V161, 16.384)] {
        let mut bench = Bench::new(&[family]);
        let mut d = [0xA1, 0, 0, 0, 0, 0, 0, 0];
        d[4..6].copy_from_slice(&(raw as i16).to_le_bytes());
        bench.ask(frame(0x141, d));
        bench.wait(2);
        let current = bench.current(1);
        assert!(
            (current - amps).abs() < 0.05,
            "{family}: {current} A, want {amps}"
        );
        // The reply reports it in the family's reply scale.
        let reply = bench.ask(frame(0x141, d));
        let dialect = match family {
            FirmwareFamily::LkV23x(s) => Dialect::LkV23x(s),
            _ => Dialect::V161,
        };
        let (_, r) = dialect.decode_reply(&reply).unwrap();
        let iq = r.status2().unwrap().iq;
        assert!(
            (iq.amps() - current).abs() <= iq.scale().amps_per_lsb(),
            "{family}"
        );
    }
}

#[test]
fn lk_multi_torque_uses_the_series_scale() {
    let mut bench = Bench::new(&[MF, MF, MG]);
    let m =
        MultiTorque::from_amps([8.25, -4.0, 16.5, 0.0], CurrentScale::LK_MF_IQ_CONTROL).unwrap();
    let replies = bench.send(m.encode());
    let ids: Vec<u16> = replies.iter().map(|r| r.frame.id()).collect();
    assert_eq!(ids, [0x141, 0x142, 0x143]);
    assert!(replies.iter().all(|r| r.frame.data()[0] == 0xA1));
    bench.wait(2);
    assert!((bench.current(1) - 8.25).abs() < 0.05);
    assert!((bench.current(2) + 4.0).abs() < 0.05);
    // Motor 3 is MG: raw 2048 is 33 A there, not 16.5 A.
    assert!(
        (bench.current(3) - 33.0).abs() < 0.1,
        "{}",
        bench.current(3)
    );
}

#[test]
fn lk_motor_off_holds_until_motor_run() {
    let mut bench = Bench::new(&[MG]);
    let mg = Dialect::LkV23x(LkSeries::Mg);
    let amps = ScaledCurrent::from_amps(5.0, mg.iq_control_scale()).unwrap();
    let torque = mg
        .encode(id(1), &Request::Torque { iq_control: amps })
        .unwrap();
    bench.ask(Dialect::V161.encode(id(1), &Request::MotorOff).unwrap());
    let status = bench.ask(Dialect::V161.encode(id(1), &Request::ReadStatus1).unwrap());
    assert_eq!(status.data()[6], 0x10, "motor state off");
    // Answered, not obeyed.
    let reply = bench.ask(torque);
    assert_eq!(reply.data()[0], 0xA1);
    bench.wait(2);
    assert_eq!(bench.current(1), 0.0);
    bench.ask(Dialect::V161.encode(id(1), &Request::MotorRun).unwrap());
    assert_eq!(
        bench
            .ask(Dialect::V161.encode(id(1), &Request::ReadStatus1).unwrap())
            .data()[6],
        0x00
    );
    bench.ask(torque);
    bench.wait(2);
    assert!((bench.current(1) - 5.0).abs() < 0.05);
}

/// The V3 dialect of the simulated motors (their default firmware).
fn v3() -> Dialect {
    Dialect::MyActuatorV3(V3Params::default().firmware())
}

/// A V3 torque request of `amps`.
fn v3_torque(amps: f64) -> Request {
    Request::Torque {
        iq_control: ScaledCurrent::from_amps(amps, CurrentScale::MYACTUATOR_V3_IQ_CONTROL).unwrap(),
    }
}

#[test]
fn v3_answers_on_0x240_with_its_scales() {
    let mut bench = Bench::new(&[FirmwareFamily::MyActuatorV3]);
    let reply = bench.ask(v3().encode(id(1), &v3_torque(1.0)).unwrap());
    assert_eq!(reply.id(), 0x241);
    bench.wait(2);
    assert!((bench.current(1) - 1.0).abs() < 0.02);
    let status = bench.ask(v3().encode(id(1), &Request::ReadStatus2).unwrap());
    let (m, r) = v3().decode_reply(&status).unwrap();
    assert_eq!(m, id(1));
    assert!((r.status2().unwrap().iq.amps() - 1.0).abs() < 0.02);
    // Status 1: 25 °C, 48.0 V = 480 = 0x01E0 in DATA[4..=5], brake released, no error.
    let s1 = bench.ask(v3().encode(id(1), &Request::ReadStatus1).unwrap());
    assert_eq!(s1, frame(0x241, [0x9A, 0x19, 0x19, 0x01, 0xE0, 0x01, 0, 0]));
    // Commands V3 does not have (0x88 motor run, 0x33 read acceleration) get no answer.
    assert!(
        bench
            .send(Dialect::V161.encode(id(1), &Request::MotorRun).unwrap())
            .is_empty()
    );
    assert!(
        bench
            .send(Dialect::V161.encode(id(1), &Request::ReadAccel).unwrap())
            .is_empty()
    );
}

#[test]
fn v3_takes_0x280_as_a_command_for_every_motor() {
    let v3m = FirmwareFamily::MyActuatorV3;
    let mut bench = Bench::new(&[v3m, v3m, v3m, v3m, v3m]);
    for n in 1..=5 {
        bench.ask(v3().encode(id(n), &v3_torque(1.0)).unwrap());
    }
    bench.wait(2);
    assert!((1..=5).all(|n| matches!(bench.mode(n), ControlMode::Torque { .. })));
    // 280#80..: every motor off, each answering on its own 0x240 + id.
    let off = frame(0x280, [0x80, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(off, v3().encode_broadcast(&Request::MotorOff).unwrap());
    let replies = bench.send(off);
    let ids: Vec<u16> = replies.iter().map(|r| r.frame.id()).collect();
    assert_eq!(ids, [0x241, 0x242, 0x243, 0x244, 0x245]);
    assert!(
        replies
            .iter()
            .all(|r| r.frame.data() == [0x80, 0, 0, 0, 0, 0, 0, 0])
    );
    assert!((1..=5).all(|n| bench.mode(n) == ControlMode::Off));
}

#[test]
fn a_v161_torque_frame_is_motor_off_on_v3_motors() {
    // Issue 14: 280#80.. is 2.048 A on motor 1 under v1.61 (raw 128 x 0.016 A) and "all motors
    // off" under V3. Motor 1 speaks v1.61, motors 2 and 3 V3 (running at 1 A).
    let v3m = FirmwareFamily::MyActuatorV3;
    let mut bench = Bench::new(&[FirmwareFamily::V161, v3m, v3m]);
    for n in 2..=3 {
        bench.ask(v3().encode(id(n), &v3_torque(1.0)).unwrap());
    }
    let frame = MultiTorque::new([
        IqControl::new(128).unwrap().into(),
        IqControl::new(0).unwrap().into(),
        IqControl::new(0).unwrap().into(),
        IqControl::new(0).unwrap().into(),
    ])
    .encode();
    assert_eq!(frame.to_string(), "280#8000000000000000");
    let replies = bench.send(frame);
    let ids: Vec<u16> = replies.iter().map(|r| r.frame.id()).collect();
    assert_eq!(ids, [0x141, 0x242, 0x243]);
    bench.wait(2);
    assert!((bench.current(1) - 2.048).abs() < 0.05);
    assert_eq!(bench.mode(2), ControlMode::Off);
    assert_eq!(bench.mode(3), ControlMode::Off);
}

/// Moves motor 1 (v1.61) to 720° at the motor with position command 1 and reads 0x92.
fn two_turns_then_off(traps: FirmwareTraps) -> (f64, f64) {
    let mut bench = Bench::with(&[FirmwareFamily::V161], |c| {
        c.motors[0].firmware.traps = traps
    });
    let read = |bench: &mut Bench| -> f64 {
        match Dialect::V161
            .decode_reply(
                &bench.ask(
                    Dialect::V161
                        .encode(id(1), &Request::ReadMultiTurnAngle)
                        .unwrap(),
                ),
            )
            .unwrap()
            .1
        {
            Reply::ReadMultiTurnAngle { motor_angle } => motor_angle.degrees(),
            other => panic!("{other:?}"),
        }
    };
    let go = Request::Position1 {
        angle_control: AngleControl::from_degrees(720.0).unwrap(),
    };
    bench.ask(Dialect::V161.encode(id(1), &go).unwrap());
    bench.wait(1_000);
    let before = read(&mut bench);
    bench.ask(Dialect::V161.encode(id(1), &Request::MotorOff).unwrap());
    (before, read(&mut bench))
}

#[test]
fn trap_motor_off_clears_the_turn_count() {
    let (before, after) = two_turns_then_off(FirmwareTraps::default());
    assert!((before - 720.0).abs() < 1.0, "{before}");
    assert!(
        (after - before).abs() < 1.0,
        "off by default: {before} -> {after}"
    );
    let (before, after) = two_turns_then_off(FirmwareTraps {
        motor_off_clears_turns: true,
        ..FirmwareTraps::default()
    });
    assert!((before - 720.0).abs() < 1.0, "{before}");
    assert!(
        (0.0..360.0).contains(&after),
        "cleared: {before} -> {after}"
    );
    assert!(((before - after) - 720.0).abs() < 1.0);
}

#[test]
fn trap_unanswered_reads() {
    let traps = FirmwareTraps {
        unanswered: CommandSet::of(&[0x9D, 0x9A]),
        ..FirmwareTraps::default()
    };
    let mut bench = Bench::with(&[FirmwareFamily::V161], |c| {
        c.motors[0].firmware.traps = traps
    });
    assert!(
        bench
            .send(Dialect::V161.encode(id(1), &Request::ReadStatus3).unwrap())
            .is_empty()
    );
    assert_eq!(
        bench
            .send(Dialect::V161.encode(id(1), &Request::ReadStatus2).unwrap())
            .len(),
        1
    );
    let stats = bench.motors.motor(id(1)).unwrap().trap_stats();
    assert_eq!(stats.unanswered, 1);
    // A motor that does not answer 0x9A cannot be identified.
    let found = bench.identify(1);
    assert_eq!(
        (found.family, found.evidence.finding),
        (ProtocolFamily::Unknown, Finding::NoStatus1)
    );
    // Off by default.
    let mut plain = Bench::new(&[FirmwareFamily::V161]);
    assert_eq!(
        plain
            .send(Dialect::V161.encode(id(1), &Request::ReadStatus3).unwrap())
            .len(),
        1
    );
}

#[test]
fn trap_motion_ignored_after_motor_run() {
    let traps = FirmwareTraps {
        motion_ignored_after_run: Duration::from_millis(50),
        ..FirmwareTraps::default()
    };
    let torque = Dialect::V161
        .encode(
            id(1),
            &Request::Torque {
                iq_control: IqControl::from_amps(3.0).unwrap().into(),
            },
        )
        .unwrap();
    let mut bench = Bench::with(&[FirmwareFamily::V161], |c| {
        c.motors[0].firmware.traps = traps
    });
    bench.ask(Dialect::V161.encode(id(1), &Request::MotorStop).unwrap());
    bench.ask(Dialect::V161.encode(id(1), &Request::MotorRun).unwrap());
    // 1 ms after 0x88: answered, not obeyed.
    assert_eq!(bench.ask(torque).data()[0], 0xA1);
    bench.wait(2);
    assert_eq!(bench.current(1), 0.0);
    assert_eq!(bench.mode(1), ControlMode::Off);
    // 60 ms after: obeyed.
    bench.wait(60);
    bench.ask(torque);
    bench.wait(2);
    assert!((bench.current(1) - 3.0).abs() < 0.05);
    let stats = bench.motors.motor(id(1)).unwrap().trap_stats();
    assert_eq!(stats.ignored_motion, 1);
    // Off by default: obeyed 1 ms after 0x88.
    let mut plain = Bench::new(&[FirmwareFamily::V161]);
    plain.ask(Dialect::V161.encode(id(1), &Request::MotorStop).unwrap());
    plain.ask(Dialect::V161.encode(id(1), &Request::MotorRun).unwrap());
    plain.ask(torque);
    plain.wait(2);
    assert!((plain.current(1) - 3.0).abs() < 0.05);
}
