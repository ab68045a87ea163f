//! What the loop does with the motors it finds at start-up: it identifies every motor on ids
//! 1..=4 of every bus before any torque, refuses undescribed motors and firmware it cannot drive
//! as described, and drives LK-TECH motors with their own current scales. Judged by the simulated
//! firmware's ground truth.

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_loop::{Fault, RtLoop, RunLimit, StopReason, robot::Robot};
use rmd_protocol::{AngleControl, Dialect, LkSeries, MaxSpeed, ProtocolFamily, Request};
use rmd_sim::{ControlMode, FirmwareFamily, SharedSimBus, SimBus, SimConfig};

fn robot_of(bus: BusConfig) -> Robot {
    Robot::try_from(RobotConfig::new(1000.0).with_bus(bus)).unwrap()
}

fn sim_of(clock: &VirtualClock, ids: &[u8], family: FirmwareFamily) -> SimBus<VirtualClock> {
    let mut config = SimConfig::with_motors(0).seed(7);
    config.motors = ids
        .iter()
        .map(|&n| rmd_sim::SimMotorConfig::new(id(n)))
        .collect();
    SimBus::new(clock.clone(), config.firmware_family(family)).unwrap()
}

#[test]
fn a_motor_whose_answers_identify_no_family_is_refused_before_any_torque() {
    // Motor 2's supply has collapsed to 4 V: its status 1 is plausible in no family's layout
    // (4 V in v1.61's, 102.4 V in LK-TECH's; at 3 V the LK reading would be a plausible 76.8 V,
    // and the motor would be refused as LK-TECH).
    let clock = VirtualClock::new();
    let mut config = SimConfig::with_motors(2).seed(7).fault(
        rmd_sim::FaultRule::new(rmd_sim::PhysicalFault::LowVoltage { volts: 4.0 }).motor(id(2)),
    );
    config.motors[0].id = id(1);
    let mut bus = SimBus::new(clock.clone(), config).unwrap();
    bus.record_trace(1000);
    let robot = robot_of(
        BusConfig::new("can0")
            .with_motor(MotorConfig::new(1))
            .with_motor(MotorConfig::new(2)),
    );
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(1.0))
        .unwrap()
        .run(RunLimit::Ticks(100));
    let r = &out.report;
    assert!(
        matches!(
            r.stop_reason,
            StopReason::Fault(Fault::Firmware {
                family: ProtocolFamily::Unknown,
                ..
            })
        ),
        "{}",
        r.stop_description
    );
    assert!(
        r.stop_description.contains("motor 2")
            && r.stop_description.contains("identify no firmware family"),
        "{}",
        r.stop_description
    );
    assert!(!sent_multi_torque(&bus));
}

#[test]
fn a_myactuator_v3_motor_is_refused_before_any_torque() {
    let clock = VirtualClock::new();
    let mut bus = sim_of(&clock, &[1, 2], FirmwareFamily::MyActuatorV3);
    bus.record_trace(1000);
    let robot = robot_of(
        BusConfig::new("can0")
            .with_motor(MotorConfig::new(1))
            .with_motor(MotorConfig::new(2)),
    );
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(1.0))
        .unwrap()
        .run(RunLimit::Ticks(100));
    let r = &out.report;
    assert!(
        matches!(
            r.stop_reason,
            StopReason::Fault(Fault::Firmware {
                family: ProtocolFamily::MyActuatorV3,
                ..
            })
        ),
        "{}",
        r.stop_description
    );
    assert!(
        r.stop_description.contains("MyActuator V3"),
        "{}",
        r.stop_description
    );
    assert!(
        r.safe_stop.to_string().contains("nothing to do"),
        "{}",
        r.safe_stop
    );
    assert!(
        r.stop_description.contains("motor 1 on bus 0"),
        "{}",
        r.stop_description
    );
    assert_eq!(r.stats.ticks, 0);
    // Nothing but read requests (and the safe stop's motor-off) went out: no 0x280 frame, which
    // a V3 motor would execute as a command.
    assert!(!sent_multi_torque(&bus));
    for m in [1, 2] {
        assert_eq!(bus.snapshot(id(m)).unwrap().mode, ControlMode::Off);
    }
}

#[test]
fn an_undescribed_motor_stops_the_start_and_keeps_its_own_state() {
    let clock = VirtualClock::new();
    let mut bus = sim_of(&clock, &[1, 2, 3], FirmwareFamily::V161);
    bus.record_trace(1000);
    // Motor 3 holds a position (another program put it there).
    let hold = Request::Position2 {
        max_speed: MaxSpeed::from_dps(360.0).unwrap(),
        angle_control: AngleControl::from_degrees(90.0).unwrap(),
    };
    use rmd_bus::CanBus as _;
    bus.send(&Dialect::V161.encode(id(3), &hold).unwrap())
        .unwrap();
    let robot = robot_of(
        BusConfig::new("can0")
            .with_motor(MotorConfig::new(1))
            .with_motor(MotorConfig::new(2)),
    );
    let out = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], Constant(1.0))
        .unwrap()
        .run(RunLimit::Ticks(100));
    let r = &out.report;
    assert!(
        matches!(r.stop_reason, StopReason::Fault(Fault::UndescribedMotor { bus: 0, motor, family: ProtocolFamily::V161 }) if motor == id(3)),
        "{}",
        r.stop_description
    );
    assert!(
        r.stop_description.contains("zero_torque_ids"),
        "{}",
        r.stop_description
    );
    assert!(!sent_multi_torque(&bus));
    // The ground truth: motor 3 still holds its position (a 0x280 frame would have switched it to
    // zero torque), and the described motors are off.
    assert!(matches!(
        bus.snapshot(id(3)).unwrap().mode,
        ControlMode::Position { .. }
    ));
    for m in [1, 2] {
        assert_eq!(bus.snapshot(id(m)).unwrap().mode, ControlMode::Off);
    }
}

#[test]
fn a_motor_declared_undriven_is_commanded_zero_torque() {
    let clock = VirtualClock::new();
    let mut bus = sim_of(&clock, &[1, 2, 3], FirmwareFamily::V161);
    let mut bus_config = BusConfig::new("can0")
        .with_motor(MotorConfig::new(1))
        .with_motor(MotorConfig::new(2));
    bus_config.zero_torque_ids = vec![3];
    let out = RtLoop::unsupervised(robot_of(bus_config), clock, vec![&mut bus], Constant(0.5))
        .unwrap()
        .run(RunLimit::Ticks(200));
    let r = &out.report;
    assert_eq!(
        r.stop_reason,
        StopReason::TickLimit,
        "{}",
        r.stop_description
    );
    assert_eq!(r.identified.len(), 3);
    assert_eq!(r.identified[2].joint, None);
    // Motor 3 got zero torque (in torque mode at 0 A); the described motors ended off.
    assert_eq!(
        bus.snapshot(id(3)).unwrap().mode,
        ControlMode::Torque { current_a: 0.0 }
    );
    assert!(!bus.snapshot(id(3)).unwrap().energising);
    assert_safe(&mut bus, 2);
}

#[test]
fn lk_motors_are_driven_with_their_own_current_scales() {
    for (series, name) in [(LkSeries::Mf, "mf"), (LkSeries::Mg, "mg")] {
        let clock = VirtualClock::new();
        let bus = SharedSimBus::new(sim_of(&clock, &[1], FirmwareFamily::LkV23x(series)));
        let robot = robot_of(
            BusConfig::new("can0").with_motor(MotorConfig::new(1).protocol("lk-v2.3x", Some(name))),
        );
        let mut rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], Constant(1.0)).unwrap();
        let telemetry = rt.telemetry();
        let Ok(mut running) = rt.start() else {
            panic!("{name}: the LK motor was refused")
        };
        for _ in 0..50 {
            assert!(running.step().is_continue());
        }
        // The firmware applies 1 A: the command was scaled for this series (v1.61's scale would
        // give about half of it on MF), and the feedback reads it back with the reply scale.
        let applied = bus.lock().snapshot(id(1)).unwrap().current_a;
        assert!(
            (applied - 1.0).abs() < 0.02,
            "{name}: the motor applies {applied} A"
        );
        let seen = telemetry.latest().unwrap().joints()[0]
            .feedback
            .motor
            .current_amps;
        assert!((seen - 1.0).abs() < 0.05, "{name}: the loop reads {seen} A");
        let out = running.finish(StopReason::Requested);
        assert_eq!(
            out.report.identified[0].family,
            ProtocolFamily::LkV23x,
            "{name}"
        );
        assert!(out.report.safe_stop.all_off_confirmed(), "{name}");
        assert!(!bus.lock().snapshot(id(1)).unwrap().energising, "{name}");
    }
}

#[test]
fn an_lk_motor_described_as_v161_is_refused() {
    let clock = VirtualClock::new();
    let mut bus = sim_of(&clock, &[1], FirmwareFamily::LkV23x(LkSeries::Mf));
    bus.record_trace(1000);
    let robot = robot_of(BusConfig::new("can0").with_motor(MotorConfig::new(1)));
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(1.0))
        .unwrap()
        .run(RunLimit::Ticks(10));
    let r = &out.report;
    assert!(
        matches!(
            r.stop_reason,
            StopReason::Fault(Fault::Firmware {
                family: ProtocolFamily::LkV23x,
                described: ProtocolFamily::V161,
                ..
            })
        ),
        "{}",
        r.stop_description
    );
    assert!(
        r.stop_description.contains("lk_series"),
        "{}",
        r.stop_description
    );
    assert!(!sent_multi_torque(&bus));
}
