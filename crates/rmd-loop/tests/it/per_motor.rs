//! The per-motor exchange: one 0xA1 request per motor per tick, in the motor's own family, all of
//! a tick's requests before any reply; MyActuator V3 motors driven this way (never a 0x280
//! frame on their bus, the safe stop included), and v1.61 motors beyond id 4. Judged by the
//! simulated firmware's ground truth, in virtual time.

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, ExchangeKind, MotorConfig, RobotConfig};
use rmd_loop::{Protection, RtLoop, RunLimit, robot::Robot};
use rmd_protocol::{Dialect, ProtocolFamily, V3Firmware};
use rmd_sim::{ControlMode, FaultRule, Node, PhysicalFault, ReplyFault, SimBus, SimConfig};

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
            let mut m = rmd_sim::SimMotorConfig::new(id(n));
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
    let mut rt = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(1.0)).unwrap();
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
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::new(&targets))
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
    let mut rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], Constant(1.5)).unwrap();
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

/// A `multi-torque` bus beyond id 4: one 0x280 frame for ids 1..=4, an 0xA1 request for each
/// higher id, all before any reply; every motor's current by ground truth; the safe stop's zero
/// torque the same way (one 0x280 frame, then the 0xA1s), every motor off.
#[test]
fn a_multi_torque_bus_drives_ids_beyond_4_with_their_own_requests() {
    let clock = VirtualClock::new();
    let ids = [1, 2, 3, 4, 5, 6, 7, 8];
    let d = [Dialect::V161; 8];
    let mut sim = sim_of(&clock, &ids, &d, &[]);
    sim.record_trace(1_000_000);
    let bus = rmd_sim::SharedSimBus::new(sim);
    // The default exchange of a v1.61 bus with ids 1..=4 among its motors.
    let robot =
        Robot::try_from(RobotConfig::new(400.0).with_bus(motors(BusConfig::new("can0"), &ids, &d)))
            .unwrap();
    let spec = &robot.buses()[0];
    assert_eq!(spec.exchange, ExchangeKind::MultiTorque);
    // One 0x280 frame and four 0xA1 requests, eight replies: 13 frames, not 16.
    assert_eq!(spec.requests_per_exchange(), 5);
    let mut rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], Constant(1.5)).unwrap();
    let telemetry = rt.telemetry();
    let mut running = started(rt);
    for _ in 0..200 {
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
    let r = &out.report;
    assert_eq!(r.stats.missing_replies, 0, "{r}");
    assert_eq!(r.stats.late_replies, 0, "{r}");
    assert!(
        r.stats
            .motors
            .iter()
            .all(|m| m.counters.unexpected_replies == 0),
        "{r}"
    );
    assert_eq!(commanded.len(), ids.len());
    for (m, amps) in &commanded {
        assert!((amps - 1.5).abs() < 0.01, "motor {m} commanded {amps} A");
    }
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    drop(out);
    let mut sim = bus.lock();
    for &m in &ids {
        assert_eq!(
            sim.snapshot(id(m)).unwrap().mode,
            ControlMode::Off,
            "motor {m}"
        );
    }
    // Every tick: the 0x280 frame, then 0xA1 to 0x145..=0x148, before the tick's replies.
    let host: Vec<u16> = sim
        .trace()
        .iter()
        .filter(|t| t.from == Node::Host && (t.frame.id() == 0x280 || t.frame.data()[0] == 0xA1))
        .map(|t| t.frame.id())
        .collect();
    let frames = host.iter().filter(|&&i| i == 0x280).count();
    assert!(frames >= 200, "{frames} 0x280 frames");
    for (i, &frame) in host.iter().enumerate() {
        if frame == 0x280 && i + 5 <= host.len() {
            assert_eq!(
                host[i + 1..i + 5],
                [0x145, 0x146, 0x147, 0x148],
                "{:x?}",
                &host[i..i + 5]
            );
        }
    }
    assert!(
        !host.iter().any(|&i| (0x141..=0x144).contains(&i)),
        "ids 1..=4 are driven by the 0x280 frame only"
    );
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
    let rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], Constant(2.0)).unwrap();
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
        FaultRule::new(ReplyFault::DropReply)
            .motor(id(2))
            .frames_window(100, 5),
        FaultRule::new(ReplyFault::LateReply {
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
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::hold(3))
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
        FaultRule::new(ReplyFault::WrongDlc { dlc: 5 })
            .command(torque)
            .motor(id(2))
            .frames_window(0, 1),
        FaultRule::new(ReplyFault::DropReply)
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
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::hold(3))
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
            let mut m = rmd_sim::SimMotorConfig::new(id(n));
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
    let rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], Constant(1.0)).unwrap();
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

#[test]
fn the_report_says_which_motors_turn_off_by_themselves_if_the_host_dies() {
    // A v1.61 motor (no watchdog), a V3 motor described with a 50 ms watchdog, one without.
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    let d = [Dialect::V161, V3, V3];
    let mut bus = sim_of(&clock, &ids, &d, &[]);
    let mut config = motors(BusConfig::new("can0"), &ids, &d);
    config.motors[1].watchdog_ms = Some(50);
    let robot = Robot::try_from(RobotConfig::new(500.0).with_bus(config)).unwrap();
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(0.0))
        .unwrap()
        .run(RunLimit::Ticks(10));
    let r = &out.report;
    let kinds: Vec<_> = r.protection.iter().map(|p| p.protection).collect();
    assert_eq!(
        kinds,
        [
            Protection::NoWatchdog,
            Protection::Watchdog { millis: 50 },
            Protection::WatchdogOff
        ]
    );
    assert_eq!(
        r.protection
            .iter()
            .map(|p| p.protected())
            .collect::<Vec<_>>(),
        [false, true, false]
    );
    let text = r.to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("motor watchdog:"))
        .unwrap_or_else(|| panic!("{text}"));
    assert_eq!(
        line,
        "motor watchdog: 1/3 motors turn off by themselves if the host dies (bus0_motor2 50 ms; \
         as described: the firmware cannot report it); not set: bus0_motor3 (describe \
         `watchdog_ms`, then `rmd watchdog --robot FILE`); v1.61 and LK-TECH motors have none (1 \
         here: see docs/safety.md)"
    );
    let json = serde_json::to_value(r).unwrap();
    assert_eq!(
        json["protection"][1]["protection"],
        serde_json::json!({"kind": "watchdog", "millis": 50})
    );
    assert_eq!(json["protection"][2]["motor"], 3);
}

#[test]
fn the_start_reads_each_v3_motors_firmware_date_and_model() {
    // Motor 1 runs the simulator's default V4.3 firmware (2025070202); motor 2 a V4.4 one
    // (2026042402), whose model is read five characters at a time; motor 3 speaks v1.61.
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    let d = [V3, V3, Dialect::V161];
    let mut sim = SimConfig::with_motors(0).seed(11);
    sim.motors = ids
        .iter()
        .zip(d)
        .map(|(&n, dialect)| {
            let mut m = rmd_sim::SimMotorConfig::new(id(n));
            m.firmware.speak(dialect);
            m
        })
        .collect();
    sim.motors[1].firmware.v3.firmware_date = rmd_protocol::FirmwareDate::from_raw(2_026_042_402);
    sim.motors[1].firmware.v3.model = *b"RMD-X8-H-48-6\0\0";
    let mut bus = SimBus::new(clock.clone(), sim).unwrap();
    let robot =
        Robot::try_from(RobotConfig::new(500.0).with_bus(motors(BusConfig::new("can0"), &ids, &d)))
            .unwrap();
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], Constant(0.0))
        .unwrap()
        .run(RunLimit::Ticks(10));
    let r = &out.report;
    assert_eq!(r.stop_reason, rmd_loop::StopReason::TickLimit, "{r}");
    let read: Vec<_> = r
        .identified
        .iter()
        .map(|m| (m.motor.get(), m.firmware_date, m.model.as_deref()))
        .collect();
    assert_eq!(
        read,
        [
            (1, Some(2_025_070_202), Some("RMD-SIM")),
            (2, Some(2_026_042_402), Some("RMD-X8-H-48-6")),
            (3, None, None),
        ]
    );
    let json = serde_json::to_value(r).unwrap();
    assert_eq!(json["identified"][1]["model"], "RMD-X8-H-48-6");
}

/// Three V3 motors at `rate_hz` on one simulated bus (with `faults`), run for `ticks` ticks with
/// the health watch.
fn run_v3_health(
    rate_hz: f64,
    faults: &[FaultRule],
    ticks: u64,
) -> (rmd_loop::LoopOutcome<HealthWatch>, SimBus<VirtualClock>) {
    let clock = VirtualClock::new();
    let ids = [1, 2, 3];
    let mut bus = sim_of(&clock, &ids, &[V3; 3], faults);
    let robot = Robot::try_from(RobotConfig::new(rate_hz).with_bus(motors(
        BusConfig::new("can0"),
        &ids,
        &[V3; 3],
    )))
    .unwrap();
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], HealthWatch::from(6))
        .unwrap()
        .run(RunLimit::Ticks(ticks));
    (out, bus)
}

#[test]
fn v3_health_rotation_reads_every_motor_within_n_ticks_on_the_per_motor_exchange() {
    // Three 0xA1 requests, one 0x9A, four replies: room at 500 Hz (not at 1 kHz: 1080 us of a
    // 900 us reply window, worst-case stuffing).
    let (out, bus) = run_v3_health(500.0, &[], 3000);
    let r = &out.report;
    assert_eq!(r.stop_reason, rmd_loop::StopReason::TickLimit, "{r}");
    assert_eq!(r.health_rotation, [true]);
    assert_eq!(out.controller.without, 0);
    assert!(out.controller.oldest <= 3, "{}", out.controller.oldest);
    assert!(
        out.controller.volts.iter().all(|v| *v > 20.0),
        "{:?}",
        out.controller.volts
    );
    // One request per tick, in turn (plus the start-up's identification, once each), never
    // a 0x280 frame; the torque replies' counters untouched.
    assert_eq!(status_requests(&bus)[1..=3], [1001, 1001, 1001]);
    assert!(!sent_multi_torque(&bus));
    assert_rotation_left_torque_alone(r, 999);
    let (out, _) = run_v3_health(1000.0, &[], 10);
    assert_eq!(out.report.health_rotation, [false]);
}

#[test]
fn a_v3_under_voltage_flag_stops_the_loop_naming_the_motor_and_every_motor_ends_off() {
    let low = FaultRule::new(PhysicalFault::LowVoltage { volts: 12.0 })
        .motor(id(2))
        .during(
            rmd_bus::Timestamp::from_nanos(200_000_000),
            rmd_bus::Timestamp::from_nanos(u64::MAX),
        );
    let (out, mut bus) = run_v3_health(500.0, &[low], 1000);
    let r = &out.report;
    let rmd_loop::StopReason::Fault(rmd_loop::Fault::MotorError {
        at,
        flag,
        error_flags,
    }) = r.stop_reason
    else {
        panic!("{r}")
    };
    assert_eq!(
        (at.motor, flag),
        (id(2), rmd_loop::MotorFlag::UnderVoltage),
        "{r}"
    );
    // V3's low-voltage bit.
    assert_eq!(error_flags & 0x0004, 0x0004);
    assert!(r.stop_description.contains("under-voltage"), "{r}");
    drop(out);
    assert!(
        !sent_multi_torque(&bus),
        "a 0x280 frame went out on a V3 bus"
    );
    for m in [1, 2, 3] {
        let snap = bus.snapshot(id(m)).unwrap();
        assert_eq!(snap.mode, ControlMode::Off, "motor {m}: {snap:?}");
        assert!(!snap.energising);
    }
}

#[test]
fn the_health_rotation_reads_every_family_on_a_mixed_bus_and_an_lk_flag_names_its_motor() {
    // v1.61, LK-TECH (MG) and V3 on one per-motor bus at 500 Hz: each family's status reply is
    // read in its own layout; then the LK motor's supply drops below its threshold.
    let dialects = [
        Dialect::V161,
        Dialect::LkV23x(rmd_protocol::LkSeries::Mg),
        V3,
    ];
    let ids = [1, 2, 3];
    let robot = || {
        let mut bus = BusConfig::new("can0");
        for (&n, d) in ids.iter().zip(&dialects) {
            let series = matches!(d, Dialect::LkV23x(_)).then_some("mg");
            bus = bus.with_motor(
                MotorConfig::new(n)
                    .protocol(d.name(), series)
                    .gear_ratio(GEAR)
                    .torque_constant(KT)
                    .current_limit(10.0),
            );
        }
        Robot::try_from(RobotConfig::new(500.0).with_bus(bus)).unwrap()
    };
    let run = |faults: &[FaultRule], ticks| {
        let clock = VirtualClock::new();
        let mut bus = sim_of(&clock, &ids, &dialects, faults);
        let out = RtLoop::unsupervised(robot(), clock, vec![&mut bus], HealthWatch::from(6))
            .unwrap()
            .run(RunLimit::Ticks(ticks));
        (out, bus)
    };
    let (out, _) = run(&[], 600);
    assert_eq!(out.report.health_rotation, [true]);
    assert!(out.controller.oldest <= 3, "{}", out.controller.oldest);
    assert_rotation_left_torque_alone(&out.report, 199);
    let low = FaultRule::new(PhysicalFault::LowVoltage { volts: 12.0 })
        .motor(id(2))
        .during(
            rmd_bus::Timestamp::from_nanos(200_000_000),
            rmd_bus::Timestamp::from_nanos(u64::MAX),
        );
    let (out, mut bus) = run(&[low], 1000);
    let r = &out.report;
    let rmd_loop::StopReason::Fault(rmd_loop::Fault::MotorError { at, flag, .. }) = r.stop_reason
    else {
        panic!("{r}")
    };
    assert_eq!(
        (at.motor, flag),
        (id(2), rmd_loop::MotorFlag::UnderVoltage),
        "{r}"
    );
    drop(out);
    for m in ids {
        let snap = bus.snapshot(id(m)).unwrap();
        assert_eq!(snap.mode, ControlMode::Off, "motor {m}: {snap:?}");
        assert!(!snap.energising);
    }
}
