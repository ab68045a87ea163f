//! The per-motor exchange: one 0xA1 request per motor per tick, in the motor's own family, all of
//! a tick's requests before any reply; MyActuator V3 motors driven this way (never a 0x280
//! frame on their bus, the safe stop included), and v1.61 motors beyond id 4. Judged by the
//! simulated firmware's ground truth, in virtual time.

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, ExchangeKind, MotorConfig, RobotConfig};
use rmd_loop::{Robot, RtLoop, RunLimit};
use rmd_protocol::{Dialect, ProtocolFamily, V3Firmware};
use rmd_sim::{ControlMode, FaultKind, FaultRule, Node, SimBus, SimConfig};

const V3: Dialect = Dialect::MyActuatorV3(V3Firmware {
    date: None,
    max_torque: None,
});

/// A bus of motors `ids`, each speaking `dialects[i]`, RMD-X8-class (1:9, 2.09 N*m/A).
fn motors(mut bus: BusConfig, ids: &[u8], dialects: &[Dialect]) -> BusConfig {
    for (&n, d) in ids.iter().zip(dialects) {
        bus = bus.with_motor(
            MotorConfig::new(n)
                .protocol(d.name(), None)
                .gear_ratio(GEAR)
                .torque_constant(KT)
                .current_limit(10.0),
        );
    }
    bus
}

fn sim_of(
    clock: &VirtualClock,
    ids: &[u8],
    dialects: &[Dialect],
    faults: &[FaultRule],
) -> SimBus<VirtualClock> {
    let mut config = SimConfig::with_motors(0).seed(11);
    config.motors = ids
        .iter()
        .zip(dialects)
        .map(|(&n, d)| {
            let mut m = rmd_sim::MotorConfig::new(id(n));
            m.firmware.speak(*d);
            m
        })
        .collect();
    for f in faults {
        config = config.fault(*f);
    }
    let mut bus = SimBus::new(clock.clone(), config).unwrap();
    bus.record_trace(1_000_000);
    bus
}

#[test]
fn v3_motors_are_driven_per_motor_and_never_see_a_0x280_frame() {
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    let mut bus = sim_of(&clock, &ids, &[V3; 3], &[]);
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &[V3; 3],
    )))
    .unwrap();
    assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
    let mut rt = RtLoop::new(robot, clock, vec![&mut bus], Constant(1.0)).unwrap();
    let telemetry = rt.telemetry();
    let mut running = started(rt);
    for _ in 0..300 {
        assert!(running.step().is_continue());
    }
    let sample = telemetry.latest().unwrap();
    // The loop reads 1 A back in V3's 0.01 A scale.
    for j in sample.joints() {
        assert!(j.feedback.freshness.is_fresh(), "{:?}", j.feedback);
        assert!(
            (j.feedback.motor.current_amps - 1.0).abs() < 0.02,
            "{:?}",
            j.feedback
        );
    }
    let out = running.finish(rmd_loop::StopReason::Requested);
    let r = &out.report;
    assert!(
        r.identified
            .iter()
            .all(|m| m.family == ProtocolFamily::MyActuatorV3)
    );
    assert_eq!(r.stats.missing_replies, 0, "{r}");
    assert_eq!(r.stats.late_replies, 0, "{r}");
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    // Ground truth: the firmware applied 1 A (V3's 0.01 A/LSB, not v1.61's 32/2000 A), the
    // output turned, the loop's joint angle (output degrees, whole) followed it; then off.
    drop(out);
    assert!(
        !sent_multi_torque(&bus),
        "a 0x280 frame went out on a V3 bus"
    );
    for &m in &ids {
        let snap = bus.snapshot(id(m)).unwrap();
        assert_eq!(snap.mode, ControlMode::Off, "motor {m}: {snap:?}");
        assert!(!snap.energising);
    }
    // Every tick's three requests went out before the first of its replies.
    let frames: Vec<_> = bus
        .trace()
        .iter()
        .filter(|t| t.frame.data()[0] == 0xA1)
        .collect();
    let ticks = frames.chunks(6).filter(|c| c.len() == 6);
    let mut checked = 0;
    for tick in ticks.take(200) {
        let from: Vec<Node> = tick.iter().map(|t| t.from).collect();
        if from[..3].iter().all(|f| *f == Node::Host) {
            assert!(from[3..].iter().all(|f| *f != Node::Host), "{from:?}");
            let mut req: Vec<u16> = tick[..3].iter().map(|t| t.frame.id()).collect();
            let mut rep: Vec<u16> = tick[3..].iter().map(|t| t.frame.id()).collect();
            req.sort_unstable();
            rep.sort_unstable();
            assert_eq!(req, [0x141, 0x142, 0x143]);
            assert_eq!(rep, [0x241, 0x242, 0x243]);
            checked += 1;
        }
    }
    assert!(
        checked > 150,
        "only {checked} ticks in request-then-reply order"
    );
}

#[test]
fn v3_feedback_follows_the_output_shaft_in_whole_degrees() {
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    let mut bus = sim_of(&clock, &ids, &[V3; 3], &[]);
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &[V3; 3],
    )))
    .unwrap();
    let targets = [20.0, -35.0, 60.0];
    let out = RtLoop::new(robot, clock, vec![&mut bus], PdTo::new(&targets))
        .unwrap()
        .run(RunLimit::Ticks(2000));
    let r = &out.report;
    assert_eq!(r.stats.missing_replies, 0, "{r}");
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    for (&m, target) in ids.iter().zip(targets) {
        let snap = bus.snapshot(id(m)).unwrap();
        // The joint is the output shaft (direction normal, zero offset 0): held at the target
        // within the resolution of V3's status (1 degree) and the PD's steady error.
        assert!(
            (snap.output_angle_deg - target).abs() < 2.0,
            "motor {m}: output at {} deg, target {target}",
            snap.output_angle_deg
        );
    }
}

#[test]
fn v161_motors_beyond_id_4_are_driven_per_motor() {
    let clock = VirtualClock::new();
    let ids = [1, 2, 5, 6, 7, 32];
    let d = [Dialect::V161; 6];
    let bus = rmd_sim::SharedSimBus::new(sim_of(&clock, &ids, &d, &[]));
    let bus_config = motors(BusConfig::new("can0"), &ids, &d).exchange(ExchangeKind::PerMotor);
    let robot = Robot::try_from(RobotConfig::new(500.0).with_bus(bus_config)).unwrap();
    let mut rt = RtLoop::new(robot, clock, vec![bus.clone()], Constant(1.5)).unwrap();
    let telemetry = rt.telemetry();
    let mut running = started(rt);
    for _ in 0..100 {
        assert!(running.step().is_continue());
    }
    for j in telemetry.latest().unwrap().joints() {
        assert!(j.feedback.freshness.is_fresh(), "{:?}", j.feedback);
    }
    let commanded: Vec<(u8, f64)> = ids
        .iter()
        .filter_map(|&m| match bus.lock().snapshot(id(m)).unwrap().mode {
            ControlMode::Torque { current_a } => Some((m, current_a)),
            _ => None,
        })
        .collect();
    let out = running.finish(rmd_loop::StopReason::Requested);
    assert_eq!(out.report.stats.missing_replies, 0);
    // Ground truth, before the stop: each firmware ran the commanded 1.5 A in v1.61's scale
    // (32 A / 2000: 94 steps, 1.504 A).
    assert_eq!(commanded.len(), ids.len());
    for (m, amps) in &commanded {
        assert!((amps - 1.5).abs() < 0.01, "motor {m} commanded {amps} A");
    }
    assert!(
        out.report.safe_stop.all_off_confirmed(),
        "{}",
        out.report.safe_stop
    );
    let mut sim = bus.lock();
    assert!(!sent_multi_torque(&sim));
    for &m in &ids {
        assert_eq!(
            sim.snapshot(id(m)).unwrap().mode,
            ControlMode::Off,
            "motor {m}"
        );
    }
}

#[test]
fn a_bus_mixing_families_drives_each_motor_in_its_own_scale() {
    let clock = VirtualClock::new();
    let ids = [1, 2];
    let d = [Dialect::V161, V3];
    let bus = rmd_sim::SharedSimBus::new(sim_of(&clock, &ids, &d, &[]));
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &d,
    )))
    .unwrap();
    let rt = RtLoop::new(robot, clock, vec![bus.clone()], Constant(2.0)).unwrap();
    let mut running = started(rt);
    for _ in 0..100 {
        assert!(running.step().is_continue());
    }
    for m in ids {
        let applied = bus.lock().snapshot(id(m)).unwrap().current_a;
        assert!(
            (applied - 2.0).abs() < 0.03,
            "motor {m} applies {applied} A"
        );
    }
    let out = running.finish(rmd_loop::StopReason::Requested);
    assert!(
        out.report.safe_stop.all_off_confirmed(),
        "{}",
        out.report.safe_stop
    );
    let mut sim = bus.lock();
    assert!(!sent_multi_torque(&sim));
    for m in ids {
        assert_eq!(sim.snapshot(id(m)).unwrap().mode, ControlMode::Off);
    }
}

#[test]
fn lost_and_late_v3_replies_are_counted_against_their_own_motor_only() {
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    // Motor 2 drops 5 replies, motor 3 answers 5 replies 1.5 ms late.
    let faults = [
        FaultRule::new(FaultKind::DropReply)
            .motor(id(2))
            .frames_window(100, 5),
        FaultRule::new(FaultKind::LateReply {
            delay: core::time::Duration::from_micros(1500),
        })
        .motor(id(3))
        .frames_window(200, 5),
    ];
    let mut bus = sim_of(&clock, &ids, &[V3; 3], &faults);
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &[V3; 3],
    )))
    .unwrap();
    let out = RtLoop::new(robot, clock, vec![&mut bus], PdTo::hold(3))
        .unwrap()
        .run(RunLimit::Ticks(500));
    let r = &out.report;
    let m: Vec<_> = r.stats.motors.iter().map(|j| j.counters).collect();
    assert_eq!((m[0].missing_replies, m[0].late_replies), (0, 0), "{r}");
    // Five lost replies: five ticks missing, then the matching resynchronises (late while in
    // doubt); nothing it receives is unexpected.
    assert!(m[1].missing_replies >= 5, "{r}");
    assert_eq!(m[1].unexpected_replies, 0, "{r}");
    // Late replies count late (their tick missing), whatever came in their place.
    assert!(m[2].late_replies >= 1, "{r}");
    assert!(m[2].missing_replies >= 2, "{r}");
    assert_eq!(
        r.stats.late_replies,
        m.iter().map(|c| c.late_replies).sum::<u64>()
    );
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    drop(out);
    assert!(!sent_multi_torque(&bus));
    assert_safe(&mut bus, 3);
}

#[test]
fn an_unreadable_probe_reply_does_not_skew_the_round_trip_and_a_lost_reply_resynchronises() {
    // Motor 2's answer to the first start-up probe comes unreadable (5 bytes), so the probe asks
    // again; its 31st torque reply is lost. The probe's round trip must be the second probe's,
    // not the first request's (a whole probe timeout), or the matching could not tell a lost
    // reply for hundreds of ticks.
    let clock = VirtualClock::new();
    let torque = rmd_protocol::Command::Torque;
    let faults = [
        FaultRule::new(FaultKind::WrongDlc { dlc: 5 })
            .command(torque)
            .motor(id(2))
            .frames_window(0, 1),
        FaultRule::new(FaultKind::DropReply)
            .command(torque)
            .motor(id(2))
            .frames_window(31, 1),
    ];
    let ids = [1, 2, 3];
    let mut bus = sim_of(&clock, &ids, &[V3; 3], &faults);
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &[V3; 3],
    )))
    .unwrap();
    let out = RtLoop::new(robot, clock, vec![&mut bus], PdTo::hold(3))
        .unwrap()
        .run(RunLimit::Ticks(300));
    let r = &out.report;
    let m2 = r.stats.motors[1].counters;
    assert_eq!(m2.bad_frames, 1, "{r}");
    // One tick missing for the lost reply, then two late while in doubt.
    assert!(m2.missing_replies <= 3 && m2.late_replies <= 2, "{r}");
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
}

#[test]
fn braked_v3_motors_are_released_before_torque_and_locked_after_motor_off() {
    let clock = VirtualClock::new();
    let ids = [1, 2];
    let mut config = SimConfig::with_motors(0).seed(5);
    config.motors = ids
        .iter()
        .map(|&n| {
            let mut m = rmd_sim::MotorConfig::new(id(n));
            m.firmware.speak(V3);
            m.firmware.v3.has_brake = true;
            m
        })
        .collect();
    let mut sim = SimBus::new(clock.clone(), config).unwrap();
    sim.record_trace(100_000);
    let bus = rmd_sim::SharedSimBus::new(sim);
    assert!(
        bus.lock().snapshot(id(1)).unwrap().brake_locked,
        "locked at power-up"
    );
    let mut bus_config = motors(BusConfig::new("can0"), &ids, &[V3; 2]);
    for m in &mut bus_config.motors {
        m.brake = true;
    }
    let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(bus_config)).unwrap();
    let rt = RtLoop::new(robot, clock, vec![bus.clone()], Constant(1.0)).unwrap();
    let mut running = started(rt);
    for _ in 0..50 {
        assert!(running.step().is_continue());
    }
    for m in ids {
        let snap = bus.lock().snapshot(id(m)).unwrap();
        assert!(!snap.brake_locked, "motor {m}: brake still locked");
        assert!(snap.energising, "motor {m} does not apply torque: {snap:?}");
    }
    let out = running.finish(rmd_loop::StopReason::Requested);
    let report = &out.report.safe_stop;
    assert!(report.all_off_confirmed(), "{report}");
    assert!(
        report.motors.iter().all(|m| m.brake_locked == Some(true)),
        "{report:?}"
    );
    let mut sim = bus.lock();
    for m in ids {
        let snap = sim.snapshot(id(m)).unwrap();
        assert_eq!(snap.mode, ControlMode::Off, "motor {m}");
        assert!(
            snap.brake_locked,
            "motor {m}: brake not locked after the stop"
        );
    }
    // The lock went out after the motor-off, and no 0x280 frame ever did.
    assert!(!sent_multi_torque(&sim));
    let host: Vec<u8> = sim
        .trace()
        .iter()
        .filter(|t| t.from == Node::Host && t.frame.id() == 0x141)
        .map(|t| t.frame.data()[0])
        .collect();
    let off = host.iter().rposition(|&c| c == 0x80).unwrap();
    let lock = host.iter().rposition(|&c| c == 0x78).unwrap();
    let release = host.iter().position(|&c| c == 0x77).unwrap();
    let first_torque = host.iter().position(|&c| c == 0xA1).unwrap();
    assert!(release < first_torque && off < lock, "{host:02X?}");
}
