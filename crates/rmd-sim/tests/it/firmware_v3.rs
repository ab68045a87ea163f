//! The simulated MyActuator V3 motor against the manuals (V4.3 2025.05, V4.4 2025.09) and
//! against ground truth, through a `SimBus` in virtual time: the manuals' example frames as the
//! motor answers them, the scales (commanded current = asked amps, output-shaft speeds and
//! angles), the 0xA2 torque limit, motion mode with the ranges of each firmware date, the 0xB3
//! watchdog (output off, brake locked, the first frame after a trip echoed, not executed), the
//! brake, the 0x9A error flags, 0x76 reset (no reply, deaf while rebooting), the CAN ID filter
//! and the "previous reply to an unsupported command" trap.

use crate::common;

use core::time::Duration;

use common::{collect, frames, id, ms, sim_bus, wait_until};
use rmd_bus::{CanBus, Clock, VirtualClock};
use rmd_protocol::{
    CanFrame, Command, CurrentScale, Dialect, FirmwareDate, FunctionControl, MaxTorquePercent,
    MitCommand, MotorMaxTorque, OutputAngle, Reply, Request, ScaledCurrent, SpeedControl, Status1,
    StatusPosition, V3ErrorState, V3Firmware, V3Function, V3Status1, WatchdogTimeout,
};
use rmd_sim::{
    BusFault, ControlMode, FaultRule, FirmwareFamily, FirmwareTraps, MotorSnapshot, PhysicalFault,
    SimBus, SimConfig, V3Params,
};

/// The default motor's output torque constant: 2.09 N·m/A (`MotorParams::default`).
const KT_OUT: f64 = 2.09;
/// The default motor's gear ratio.
const RATIO: f64 = 9.0;

/// `count` V3 motors with `v3`'s parameters, no jitter, on a bus in virtual time.
struct V3Bus {
    bus: SimBus<VirtualClock>,
    dialect: Dialect,
}

impl V3Bus {
    fn new(count: u8, v3: V3Params) -> Self {
        Self::with(count, v3, |_| {})
    }

    fn with(count: u8, v3: V3Params, setup: impl FnOnce(&mut SimConfig)) -> Self {
        let mut config = SimConfig::with_motors(count);
        for m in &mut config.motors {
            m.firmware.family = FirmwareFamily::MyActuatorV3;
            m.firmware.v3 = v3;
            m.turnaround_jitter = Duration::ZERO;
        }
        setup(&mut config);
        let (_, bus) = sim_bus(config);
        Self {
            bus,
            dialect: Dialect::MyActuatorV3(v3.firmware()),
        }
    }

    /// Sends `frame`; every frame received within 5 ms.
    fn send(&mut self, frame: CanFrame) -> Vec<CanFrame> {
        self.bus.send(&frame).unwrap();
        let deadline = self.bus.clock().now() + ms(5);
        frames(&collect(&mut self.bus, deadline))
            .into_iter()
            .map(|(_, f)| f)
            .collect()
    }

    /// Sends `frame`, expects exactly one reply, returns it.
    fn ask_frame(&mut self, frame: CanFrame) -> CanFrame {
        let replies = self.send(frame);
        assert_eq!(replies.len(), 1, "{frame}: {replies:?}");
        replies[0]
    }

    /// Sends `request` to motor `n`; its decoded answer (id and command byte both match).
    fn ask(&mut self, n: u8, request: Request) -> Reply {
        let reply = self.ask_frame(self.dialect.encode(id(n), &request).unwrap());
        self.dialect
            .decode_answer(&reply, id(n), request.command())
            .unwrap_or_else(|e| panic!("{request:?} -> {reply}: {e}"))
    }

    fn torque(&mut self, n: u8, amps: f64) -> Reply {
        let iq_control =
            ScaledCurrent::from_amps(amps, CurrentScale::MYACTUATOR_V3_IQ_CONTROL).unwrap();
        self.ask(n, Request::Torque { iq_control })
    }

    fn wait(&mut self, d: Duration) {
        let t = self.bus.clock().now() + d;
        wait_until(&self.bus, t);
    }

    /// Motor `n`'s status 1 (0x9A).
    fn status1(&mut self, n: u8) -> V3Status1 {
        match self.ask(n, Request::ReadStatus1).status1() {
            Some(Status1::V3(s)) => s,
            other => panic!("{other:?}"),
        }
    }

    fn truth(&mut self, n: u8) -> MotorSnapshot {
        self.bus.snapshot(id(n)).unwrap()
    }

    fn stats(&self, n: u8) -> rmd_sim::MotorStats {
        self.bus.motors().motor(id(n)).unwrap().stats()
    }
}

fn frame(id: u16, d: [u8; 8]) -> CanFrame {
    CanFrame::new(id, &d).unwrap()
}

/// A V4.4 firmware (the first date with V4.4's layouts) of a 60 N·m motor.
fn v44() -> V3Params {
    V3Params {
        firmware_date: FirmwareDate::FIRST_V4_4,
        max_torque_nm: 60.0,
        ..V3Params::default()
    }
}

#[test]
fn the_motor_answers_in_the_manuals_layouts() {
    let mut model = [0u8; 15];
    model[..7].copy_from_slice(b"X8S2V10");
    let mut bus = V3Bus::new(
        1,
        V3Params {
            firmware_date: FirmwareDate::from_raw(20_220_206),
            model,
            ..V3Params::default()
        },
    );
    let m = |d| frame(0x141, d);
    let r = |d| frame(0x241, d);
    // V4.3 §2.30: firmware date 20220206 = 0x0134892E.
    assert_eq!(
        bus.ask_frame(m([0xB2, 0, 0, 0, 0, 0, 0, 0])),
        r([0xB2, 0, 0, 0, 0x2E, 0x89, 0x34, 0x01])
    );
    // V4.3 §2.33: the model, seven ASCII characters; V4.4 §2.34: five per index.
    assert_eq!(
        bus.ask_frame(m([0xB5, 0, 0, 0, 0, 0, 0, 0])),
        r([0xB5, b'X', b'8', b'S', b'2', b'V', b'1', b'0'])
    );
    assert_eq!(
        bus.ask_frame(m([0xB5, 0x01, 0x01, 0, 0, 0, 0, 0])),
        r([0xB5, 0x01, 0x01, 0x58, 0x38, 0x53, 0x32, 0x56])
    );
    // Echoed: 0x80, 0x81, 0x77, 0x78 (V4.3 §2.17, §2.18, §2.27, §2.28), 0xB3 (§2.31, 1000 ms)
    // and 0x20 (§2.35 example 2, the CAN ID filter, switched off again below).
    for d in [
        [0x80, 0, 0, 0, 0, 0, 0, 0],
        [0x81, 0, 0, 0, 0, 0, 0, 0],
        [0x78, 0, 0, 0, 0, 0, 0, 0],
        [0x77, 0, 0, 0, 0, 0, 0, 0],
        [0xB3, 0, 0, 0, 0xE8, 0x03, 0, 0],
        [0xB3, 0, 0, 0, 0, 0, 0, 0],
        [0x20, 0x02, 0, 0, 0x01, 0, 0, 0],
        [0x20, 0x02, 0, 0, 0, 0, 0, 0],
    ] {
        assert_eq!(bus.ask_frame(m(d)), r(d));
    }
    // V4.3 §2.19 example 1: `141#A100000064000000` (1 A); its reply is status 2 with iq = 100.
    bus.ask_frame(m([0xA1, 0, 0, 0, 0x64, 0, 0, 0]));
    bus.wait(ms(5));
    let reply = bus.ask_frame(m([0xA1, 0, 0, 0, 0x64, 0, 0, 0]));
    assert_eq!(reply.id(), 0x241);
    assert_eq!(reply.data()[..4], [0xA1, 0x19, 0x64, 0x00]);
    // V4.3 §2.15: status 2, the same layout.
    let status = bus.ask_frame(m([0x9C, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(status.data()[..4], [0x9C, 0x19, 0x64, 0x00]);
    // V4.3 §2.14: status 1: 25 °C, MOS 25 °C, brake released (no brake fitted), 48.0 V, no
    // error.
    assert_eq!(
        bus.ask_frame(m([0x9A, 0, 0, 0, 0, 0, 0, 0])),
        r([0x9A, 0x19, 0x19, 0x01, 0xE0, 0x01, 0, 0])
    );
    // V4.3 §2.26: 0x76 is never answered.
    assert!(bus.send(m([0x76, 0, 0, 0, 0, 0, 0, 0])).is_empty());
}

#[test]
fn commanded_current_equals_the_asked_amps() {
    let mut bus = V3Bus::new(2, V3Params::default());
    for amps in [1.0, -1.0, 2.5, 0.37] {
        bus.torque(1, amps);
        bus.wait(ms(5));
        let truth = bus.truth(1);
        assert!((truth.current_a - amps).abs() < 0.01, "{amps}: {truth:?}");
        assert!((truth.output_torque_nm - amps * KT_OUT).abs() < 0.03);
        // The reply reports it at 0.01 A per LSB.
        let reply = bus.torque(1, amps);
        let iq = reply.status2().unwrap().iq;
        assert_eq!(iq.scale(), CurrentScale::MYACTUATOR_V3_IQ);
        assert!((iq.amps() - amps).abs() <= 0.011, "{amps}: {iq:?}");
        bus.ask(1, Request::MotorOff);
    }
    // V4.3 §3: 0x280 is one command for every motor: 1 A on both, each answering on 0x240 + id.
    let all = bus
        .dialect
        .encode_broadcast(&Request::Torque {
            iq_control: ScaledCurrent::from_amps(1.0, CurrentScale::MYACTUATOR_V3_IQ_CONTROL)
                .unwrap(),
        })
        .unwrap();
    assert_eq!(all.to_string(), "280#A100000064000000");
    let ids: Vec<u16> = bus.send(all).iter().map(CanFrame::id).collect();
    assert_eq!(ids, [0x241, 0x242]);
    bus.wait(ms(5));
    for n in 1..=2 {
        assert!((bus.truth(n).current_a - 1.0).abs() < 0.01);
    }
}

#[test]
fn speeds_and_angles_are_the_output_shafts() {
    let mut bus = V3Bus::new(1, V3Params::default());
    // 0xA2: 100 dps at the output (V4.3 §2.20) is 900 dps at the rotor.
    bus.ask(
        1,
        Request::Speed {
            speed_control: SpeedControl::from_dps(100.0).unwrap(),
            max_torque: MaxTorquePercent::NONE,
        },
    );
    bus.wait(ms(1500));
    let truth = bus.truth(1);
    assert!(
        (truth.motor_speed_dps - 100.0 * RATIO).abs() < 5.0,
        "{truth:?}"
    );
    let status = bus.ask(1, Request::ReadStatus2).status2().unwrap();
    assert!((status.speed.dps() - 100.0).abs() <= 1.0, "{status:?}");
    // 0xA4: 90 degrees at the output at up to 500 dps (V4.3 §2.21).
    bus.ask(
        1,
        Request::Position2 {
            max_speed: rmd_protocol::MaxSpeed::from_dps(500.0).unwrap(),
            angle_control: rmd_protocol::AngleControl::from_degrees(90.0).unwrap(),
        },
    );
    bus.wait(ms(3000));
    let truth = bus.truth(1);
    assert!((truth.output_angle_deg - 90.0).abs() < 0.5, "{truth:?}");
    let status = bus.ask(1, Request::ReadStatus2).status2().unwrap();
    assert_eq!(
        status.position,
        StatusPosition::OutputDegrees(OutputAngle::saturating(90))
    );
    // 0x92: the output's multi-turn angle, 0.01 degree per LSB (V4.3 §2.12).
    match bus.ask(1, Request::ReadMultiTurnAngle) {
        Reply::ReadMultiTurnAngle { motor_angle } => {
            assert!((motor_angle.degrees() - 90.0).abs() < 0.5)
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn speed_max_torque_limits_the_current() {
    // 0xA2's maxTorque, DATA[1], is a percentage of the rated current (V4.3 §2.20): 10 % of
    // 4.3 A caps the acceleration current at 0.43 A.
    let mut bus = V3Bus::new(1, V3Params::default());
    let request = Request::Speed {
        speed_control: SpeedControl::from_dps(300.0).unwrap(),
        max_torque: MaxTorquePercent::new(10),
    };
    let f = bus.dialect.encode(id(1), &request).unwrap();
    assert_eq!(f.data()[..2], [0xA2, 10]);
    bus.ask_frame(f);
    let mut peak: f64 = 0.0;
    for _ in 0..50 {
        bus.wait(ms(2));
        peak = peak.max(bus.truth(1).current_a.abs());
    }
    assert!(peak > 0.3 && peak <= 0.43 + 1e-6, "peak {peak} A");
    // Without a limit the same step draws more (the speed loop's own acceleration limit).
    let mut free = V3Bus::new(1, V3Params::default());
    free.ask(
        1,
        Request::Speed {
            speed_control: SpeedControl::from_dps(300.0).unwrap(),
            max_torque: MaxTorquePercent::NONE,
        },
    );
    let mut free_peak: f64 = 0.0;
    for _ in 0..50 {
        free.wait(ms(2));
        free_peak = free_peak.max(free.truth(1).current_a.abs());
    }
    assert!(free_peak > 1.5 * 0.43, "{free_peak} A");
}

#[test]
fn the_watchdog_cuts_the_output_and_locks_the_brake() {
    let mut bus = V3Bus::new(1, V3Params::default());
    // V4.3 §2.31: 100 ms.
    bus.ask(
        1,
        Request::SetWatchdog {
            timeout: WatchdogTimeout::from_millis(100),
        },
    );
    bus.torque(1, 1.0);
    // Traffic every 50 ms keeps it alive.
    for _ in 0..6 {
        bus.wait(ms(50));
        bus.ask(1, Request::ReadStatus2);
    }
    let truth = bus.truth(1);
    assert!(!truth.watchdog_tripped, "{truth:?}");
    assert_eq!(truth.mode, ControlMode::Torque { current_a: 1.0 });
    // Silence for longer than the protection time: output off, brake locked.
    bus.wait(ms(150));
    let truth = bus.truth(1);
    assert!(truth.watchdog_tripped, "{truth:?}");
    assert!(truth.brake_locked);
    assert_eq!(truth.mode, ControlMode::Off);
    assert!(truth.current_a.abs() < 0.01, "{truth:?}");
    assert_eq!(bus.stats(1).watchdog_trips, 1);
    // The first frame after the trip is echoed, not executed (myactuator_rmd_ros PR 4).
    let torque = bus
        .dialect
        .encode(
            id(1),
            &Request::Torque {
                iq_control: ScaledCurrent::from_amps(2.0, CurrentScale::MYACTUATOR_V3_IQ_CONTROL)
                    .unwrap(),
            },
        )
        .unwrap();
    let echo = bus.ask_frame(torque);
    assert_eq!((echo.id(), echo.data()), (0x241, torque.data()));
    bus.wait(ms(5));
    assert!(bus.truth(1).current_a.abs() < 0.01);
    assert_eq!(bus.stats(1).echoed_after_trip, 1);
    // The echo has the command byte of a reply: it decodes as a status 2 (0 °C, 0 A, 200 dps, the
    // request's iqControl read as a speed). Only its bytes being the request's tell it apart.
    let misread = bus
        .dialect
        .decode_answer(&echo, id(1), Command::Torque)
        .unwrap();
    assert_eq!(misread.status2().unwrap().speed.dps(), 200.0);
    // A second frame within the protection time re-establishes communication and is executed.
    let reply = bus.ask_frame(torque);
    assert!(
        bus.dialect
            .decode_answer(&reply, id(1), Command::Torque)
            .is_ok()
    );
    bus.wait(ms(5));
    let truth = bus.truth(1);
    assert!(!truth.watchdog_tripped);
    // (Still coasting fast, so back-EMF keeps the current a little under the 2 A asked.)
    assert_eq!(truth.mode, ControlMode::Torque { current_a: 2.0 });
    assert!(truth.current_a > 1.5, "{truth:?}");
    // Without a brake fitted, the locked state is only reported (0x9A DATA[3] = 0).
    assert!(!bus.status1(1).brake.is_released());
    // 0 switches it off (V4.3 §2.31): no trip however long the silence.
    bus.ask(
        1,
        Request::SetWatchdog {
            timeout: WatchdogTimeout::OFF,
        },
    );
    bus.wait(ms(1000));
    assert!(!bus.truth(1).watchdog_tripped);
    assert_eq!(bus.stats(1).watchdog_trips, 1);
}

#[test]
fn a_fitted_brake_holds_the_output_until_released() {
    let mut bus = V3Bus::new(
        1,
        V3Params {
            has_brake: true,
            ..V3Params::default()
        },
    );
    let brake_released = |bus: &mut V3Bus| bus.status1(1).brake.is_released();
    // Locked at power-up: 0xA1 is answered, the output stays off.
    assert!(!brake_released(&mut bus));
    assert!(bus.truth(1).brake_locked);
    bus.torque(1, 1.0);
    bus.wait(ms(5));
    assert!(bus.truth(1).current_a.abs() < 0.01);
    // 0x77 releases it (V4.3 §2.27): the torque now flows.
    assert_eq!(bus.ask(1, Request::BrakeRelease), Reply::BrakeRelease);
    assert!(brake_released(&mut bus));
    bus.torque(1, 1.0);
    bus.wait(ms(5));
    assert!((bus.truth(1).current_a - 1.0).abs() < 0.01);
    // 0x78 locks it (V4.3 §2.28): the output is off again.
    assert_eq!(bus.ask(1, Request::BrakeLock), Reply::BrakeLock);
    bus.wait(ms(5));
    let truth = bus.truth(1);
    assert!(
        truth.brake_locked && truth.current_a.abs() < 0.01,
        "{truth:?}"
    );
}

#[test]
fn status_1_reports_error_flags_that_clear_with_their_cause() {
    let t0 = rmd_bus::Timestamp::from_nanos(1_000_000);
    let mut bus = V3Bus::with(1, V3Params::default(), |c| {
        c.faults.push(
            FaultRule::new(PhysicalFault::LowVoltage { volts: 30.0 })
                .during(t0 + ms(20), t0 + ms(40)),
        )
    });
    let error = |bus: &mut V3Bus| bus.status1(1).error_state;
    assert_eq!(error(&mut bus), V3ErrorState::NONE);
    bus.wait(ms(25));
    // V4.3 §2.14: 0x0004 undervoltage, with the voltage in DATA[4..=5].
    let s1 = bus.status1(1);
    assert_eq!(s1.error_state, V3ErrorState::LOW_VOLTAGE);
    assert!((s1.voltage.volts() - 30.0).abs() < 0.2, "{s1:?}");
    // The supply back, the flag clears by itself (a level-2 error, V4.4 §7): V3 has no 0x9B.
    bus.wait(ms(30));
    assert_eq!(error(&mut bus), V3ErrorState::NONE);
}

#[test]
fn reset_answers_nothing_and_the_motor_is_deaf_while_it_reboots() {
    let mut bus = V3Bus::new(1, V3Params::default());
    bus.ask(
        1,
        Request::FunctionControl(FunctionControl {
            function: V3Function::CanIdFilter,
            value: 1,
        }),
    );
    bus.torque(1, 1.0);
    assert!(
        bus.send(bus.dialect.encode(id(1), &Request::Reset).unwrap())
            .is_empty()
    );
    let truth = bus.truth(1);
    assert!(truth.rebooting);
    assert_eq!(truth.mode, ControlMode::Off);
    // Deaf for the reboot time (1.12 s, measured by almond-bot/axol).
    bus.wait(ms(500));
    let status = bus.dialect.encode(id(1), &Request::ReadStatus2).unwrap();
    assert!(bus.send(status).is_empty());
    assert_eq!(bus.stats(1).unheard_while_rebooting, 1);
    bus.wait(ms(700));
    assert!(!bus.truth(1).rebooting);
    // Up again as after a power-up: RAM lost (no torque), ROM kept (the CAN ID filter: the
    // 0x280 frame is still not heard).
    let s2 = bus.ask(1, Request::ReadStatus2).status2().unwrap();
    assert!(s2.iq.amps().abs() < 0.01);
    let off = bus.dialect.encode_broadcast(&Request::MotorOff).unwrap();
    assert!(bus.send(off).is_empty());
}

#[test]
fn the_can_id_filter_makes_the_motor_deaf_to_0x280() {
    let mut bus = V3Bus::new(2, V3Params::default());
    for n in 1..=2 {
        bus.torque(n, 1.0);
    }
    // V4.3 §2.35 example 2: filter on for motor 1.
    bus.ask(
        1,
        Request::FunctionControl(FunctionControl {
            function: V3Function::CanIdFilter,
            value: 1,
        }),
    );
    let off = bus.dialect.encode_broadcast(&Request::MotorOff).unwrap();
    let ids: Vec<u16> = bus.send(off).iter().map(CanFrame::id).collect();
    assert_eq!(ids, [0x242]);
    bus.wait(ms(5));
    assert!((bus.truth(1).current_a - 1.0).abs() < 0.01);
    assert_eq!(bus.truth(2).mode, ControlMode::Off);
    // Its own 0x141 still reaches it.
    bus.ask(1, Request::MotorOff);
    assert_eq!(bus.truth(1).mode, ControlMode::Off);
}

#[test]
fn trap_an_unsupported_command_gets_the_previous_reply() {
    // github.com/2b-t/myactuator_rmd issue 24: an X4-64 answers 0x79 with its last 0xB2 reply.
    let traps = FirmwareTraps {
        stale_reply_to_unknown: true,
        ..FirmwareTraps::default()
    };
    let mut bus = V3Bus::with(1, V3Params::default(), |c| {
        c.motors[0].firmware.traps = traps
    });
    let date = bus.ask_frame(
        bus.dialect
            .encode(id(1), &Request::ReadFirmwareDate)
            .unwrap(),
    );
    let stale = bus.ask_frame(frame(0x141, [0x79, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(stale, date);
    // Matching on id AND command byte refuses it as the answer to anything but 0xB2.
    assert!(
        bus.dialect
            .decode_answer(&stale, id(1), Command::ReadModel)
            .is_err()
    );
    assert_eq!(
        bus.bus
            .motors()
            .motor(id(1))
            .unwrap()
            .trap_stats()
            .stale_replies,
        1
    );
    // Off by default: no reply at all.
    let mut plain = V3Bus::new(1, V3Params::default());
    assert!(
        plain
            .send(frame(0x141, [0x79, 0, 0, 0, 0, 0, 0, 0]))
            .is_empty()
    );
}

/// Motion mode: `t_ff` alone is a current of `t_ff / KT_OUT`; the reply on 0x500 + id.
fn motion_torque(v3: V3Params) {
    let mut bus = V3Bus::new(1, v3);
    let ranges = bus.dialect.mit_ranges().unwrap();
    let command = MitCommand::from_si(ranges, 0.0, 0.0, 0.0, 0.0, KT_OUT).unwrap();
    let f = bus.dialect.encode_mit(id(1), &command).unwrap();
    assert_eq!(f.id(), 0x401);
    let reply = bus.ask_frame(f);
    assert_eq!((reply.id(), reply.data()[0]), (0x501, 1));
    assert!(bus.dialect.decode_mit_reply(&reply).is_ok());
    bus.wait(ms(5));
    let truth = bus.truth(1);
    assert!(matches!(truth.mode, ControlMode::Motion { .. }));
    // One step of t_ff is 48/4095 N·m (V4.3) or 120/4095 N·m (V4.4, ±60 N·m).
    assert!((truth.current_a - 1.0).abs() < 0.02, "{truth:?}");
    // The reply reports the output torque the current makes.
    let (_, feedback) = bus.dialect.decode_mit_reply(&bus.ask_frame(f)).unwrap();
    assert!((feedback.torque_nm() - KT_OUT).abs() < 0.05, "{feedback:?}");
}

#[test]
fn motion_mode_torque_with_each_firmwares_ranges() {
    motion_torque(V3Params::default());
    motion_torque(v44());
    // A command packed with V4.3's ranges cannot be sent to V4.4 firmware.
    let v44_dialect = Dialect::MyActuatorV3(v44().firmware());
    let v43_command =
        MitCommand::from_si(rmd_protocol::MitRanges::V4_3, 0.0, 0.0, 0.0, 0.0, 1.0).unwrap();
    assert!(v44_dialect.encode_mit(id(1), &v43_command).is_err());
    // Nor can V4.4 firmware be spoken to without its maximum torque.
    let unknown = Dialect::MyActuatorV3(V3Firmware::dated(FirmwareDate::FIRST_V4_4));
    assert!(unknown.mit_ranges().is_err());
    let with = Dialect::MyActuatorV3(
        V3Firmware::dated(FirmwareDate::FIRST_V4_4)
            .with_max_torque(MotorMaxTorque::from_milli_nm(60_000)),
    );
    assert_eq!(with.mit_ranges(), v44_dialect.mit_ranges());
}

#[test]
fn motion_mode_holds_a_position() {
    let mut bus = V3Bus::new(1, V3Params::default());
    let ranges = bus.dialect.mit_ranges().unwrap();
    let command = MitCommand::from_si(ranges, 0.5, 0.0, 20.0, 1.0, 0.0).unwrap();
    bus.ask_frame(bus.dialect.encode_mit(id(1), &command).unwrap());
    bus.wait(ms(2000));
    let truth = bus.truth(1);
    let output_rad = truth.output_angle_deg.to_radians();
    assert!((output_rad - 0.5).abs() < 0.01, "{truth:?}");
    let (_, feedback) = bus
        .dialect
        .decode_mit_reply(&bus.ask_frame(bus.dialect.encode_mit(id(1), &command).unwrap()))
        .unwrap();
    assert!((feedback.position_rad() - 0.5).abs() < 0.01, "{feedback:?}");
    assert!(feedback.velocity_rad_s().abs() < 0.05);
}

#[test]
fn single_turn_angle_by_firmware_date() {
    // V4.3 §2.13: u16 in DATA[6..=7]; V4.4 §2.12: the output's i32 in DATA[4..=7], ±180°.
    for (v3, expected) in [(V3Params::default(), false), (v44(), true)] {
        let mut bus = V3Bus::new(1, v3);
        let reply = bus.ask(1, Request::ReadSingleTurnAngle);
        assert_eq!(
            matches!(reply, Reply::V3SingleTurnAngle { .. }),
            expected,
            "{reply:?}"
        );
    }
}

/// A watchdog in ROM at power-up (`V3Params::watchdog`), and a host that falls silent
/// (`BusFault::HostSilent`): the host's frames vanish while `send` still succeeds, and only the
/// motor's own watchdog turns the output off, within its protection time. Without the watchdog
/// the motor keeps its last current.
#[test]
fn a_silent_host_leaves_only_the_motors_watchdog_to_stop_it() {
    for (watchdog_ms, expect_off) in [(50, true), (0, false)] {
        let v3 = V3Params {
            watchdog: WatchdogTimeout::from_millis(watchdog_ms),
            ..V3Params::default()
        };
        let mut bus = V3Bus::with(1, v3, |c| {
            c.faults.push(
                FaultRule::new(BusFault::HostSilent)
                    .first_after(rmd_bus::Timestamp::ZERO + ms(20), 1),
            );
        });
        let heard_last = bus.bus.clock().now();
        bus.torque(1, 1.0);
        bus.wait(ms(20));
        // The frame that meets the fault, and every one after it, never reaches the motor.
        let off = Dialect::MyActuatorV3(v3.firmware())
            .encode(id(1), &Request::MotorOff)
            .unwrap();
        assert!(bus.send(off).is_empty());
        assert!(bus.send(off).is_empty());
        assert_eq!(bus.bus.stats().lost_to_host_silent, 2);
        // The protection time counts from the last frame the motor heard: the torque request.
        let now = bus.bus.clock().now();
        bus.wait((heard_last + ms(45)).checked_duration_since(now).unwrap());
        assert_eq!(bus.truth(1).mode, ControlMode::Torque { current_a: 1.0 });
        bus.wait(ms(30));
        let truth = bus.truth(1);
        if expect_off {
            assert!(truth.watchdog_tripped, "{truth:?}");
            assert_eq!(truth.mode, ControlMode::Off);
            let since = truth.safe_since.expect("safe");
            let after = since.checked_duration_since(heard_last).unwrap();
            assert!(after <= ms(52), "{after:?}");
        } else {
            assert!(!truth.watchdog_tripped);
            assert_eq!(truth.mode, ControlMode::Torque { current_a: 1.0 });
        }
    }
}
