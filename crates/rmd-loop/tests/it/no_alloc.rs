//! The real-time path allocates nothing: a counting global allocator around steady-state ticks.
//!
//! Alone in a process of its own, so that no other test's thread allocates while we count. It runs the loop
//! twice: without sinks, counting every thread (the loop's and the supervisor's); then with every
//! telemetry sink on (an MCAP file, the live Foxglove server on loopback, a CSV file, fed from
//! their own threads as the programs run them), counting the loop's thread alone (the telemetry
//! threads allocate as they like).

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::{RtLoop, StopReason};
use rmd_rig::telemetry::{TelemetryOutputs, TelemetrySinks, spawn_feed};
use rmd_sim::{BusFault, FaultRule, ReplyFault, SharedSimBus};
use rmd_telemetry::LiveOptions;

/// Allocations of the calling thread so far.
fn here() -> u64 {
    rmd_test_support::alloc::this_thread().allocations
}

#[test]
fn steady_state_ticks_allocate_nothing() {
    if rmd_test_support::ran_in_own_process() {
        return;
    }
    // Two buses of four motors, with faults on the way (drops, late and corrupt replies, a
    // full transmit queue, lost and duplicated status replies): the error paths of a tick must
    // not allocate either. At 500 Hz, where the health rotation has room: on.
    let clock = VirtualClock::new();
    let after_start_up = rmd_bus::Timestamp::from_nanos(100_000_000);
    let for_ever = rmd_bus::Timestamp::from_nanos(u64::MAX);
    let faults = [
        FaultRule::new(ReplyFault::DropReply)
            .multi_torque()
            .with_probability(0.02),
        FaultRule::new(ReplyFault::CorruptBytes { count: 3 })
            .multi_torque()
            .with_probability(0.02),
        FaultRule::new(ReplyFault::LateReply {
            delay: core::time::Duration::from_micros(400),
        })
        .multi_torque()
        .with_probability(0.02),
        FaultRule::new(BusFault::TxStall {
            duration: core::time::Duration::from_millis(15),
        })
        .multi_torque()
        .frames_window(700, 1),
        // After the start-up, whose identification reads status 1 too.
        FaultRule::new(ReplyFault::DropReply)
            .command(rmd_protocol::Command::ReadStatus1)
            .during(after_start_up, for_ever)
            .with_probability(0.05),
        FaultRule::new(ReplyFault::DuplicateReply)
            .command(rmd_protocol::Command::ReadStatus1)
            .during(after_start_up, for_ever)
            .with_probability(0.05),
    ];
    // Shared with the supervisor, which watches every tick from its own thread (and must not
    // allocate either: the counting allocator counts every thread).
    let bus0 = SharedSimBus::new(sim(&clock, 4, 21, &faults));
    let bus1 = SharedSimBus::new(sim(&clock, 4, 22, &faults));
    let mut config = robot_config(500.0, 2, 4);
    config.loop_config.missing_reply_fault_after = 1000;
    with_limits(&mut config);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    assert!(robot.buses().iter().all(|b| b.health_rotation));
    let mut rt = RtLoop::unsupervised(
        robot,
        clock.clone(),
        vec![bus0.clone(), bus1.clone()],
        PdTo::new(&[10.0; 8]),
    )
    .unwrap()
    .supervise(vec![Box::new(bus0), Box::new(bus1)])
    .unwrap();
    let telemetry = rt.telemetry();
    let mut rt = rt.start().unwrap();
    for _ in 0..100 {
        let step = rt.step();
        assert!(step.is_continue(), "{step:?}");
    }
    rmd_test_support::alloc::count_every_thread(true);
    for _ in 0..2_000 {
        assert!(rt.step().is_continue());
        let _ = telemetry.try_recv();
    }
    rmd_test_support::alloc::count_every_thread(false);
    let allocations = rmd_test_support::alloc::counted().allocations;
    let stats = rt.stats().summary();
    assert!(
        stats.missing_replies > 0 && stats.buses[0].tx_errors > 0,
        "faults happened: {stats}"
    );
    assert!(
        stats.motors.iter().all(|m| m.counters.limited_commands > 0),
        "the joint limits refused torque: {stats}"
    );
    assert!(
        stats.motors.iter().all(|m| m.counters.status_replies > 400)
            && stats
                .motors
                .iter()
                .any(|m| m.counters.missing_status_replies > 0)
            && stats
                .motors
                .iter()
                .any(|m| m.counters.unexpected_replies > 0),
        "the health rotation ran, with lost and duplicated status replies: {stats}"
    );
    assert_eq!(allocations, 0, "allocations in 2000 steady-state ticks");
    drop(rt);

    per_motor_v3_bus();
    motion_v3_bus();
    every_sink_on();
}

/// A per-motor bus of MyActuator V3 motors (one 0xA1 request each per tick) beside a
/// multi-torque v1.61 bus of six motors (ids 5 and 6 by 0xA1 requests of their own), with
/// faults on the per-motor requests: nothing allocates either.
fn per_motor_v3_bus() {
    rmd_test_support::alloc::reset_counted();
    let clock = VirtualClock::new();
    let torque = rmd_protocol::Command::Torque;
    let faults = [
        FaultRule::new(ReplyFault::DropReply)
            .command(torque)
            .with_probability(0.02),
        FaultRule::new(ReplyFault::WrongDlc { dlc: 5 })
            .command(torque)
            .with_probability(0.02),
        FaultRule::new(ReplyFault::LateReply {
            delay: core::time::Duration::from_micros(400),
        })
        .command(torque)
        .with_probability(0.02),
        FaultRule::new(BusFault::TxStall {
            duration: core::time::Duration::from_millis(15),
        })
        .command(torque)
        .frames_window(2100, 1),
    ];
    let mut v3 = rmd_sim::SimConfig::with_motors(3).seed(41);
    for f in faults {
        v3 = v3.fault(f);
    }
    let v3 = v3.firmware_family(rmd_sim::FirmwareFamily::MyActuatorV3);
    let bus0 = SharedSimBus::new(rmd_sim::SimBus::new(clock.clone(), v3).unwrap());
    // Bus 1: six v1.61 motors, the 0x280 frame for ids 1..=4 and 0xA1 requests for 5 and 6.
    let bus1 = SharedSimBus::new(sim(&clock, 6, 42, &[]));
    // At 500 Hz, where the health rotation has room on both buses.
    let mut config = robot_config(500.0, 2, 4);
    config.buses[0].motors.truncate(3);
    for id in [5, 6] {
        let mut motor = config.buses[1].motors[0].clone();
        motor.id = id;
        motor.name = Some(format!("extra{id}"));
        config.buses[1].motors.push(motor);
    }
    config.buses[0].protocol = Some("myactuator-v3".to_string());
    config.loop_config.missing_reply_fault_after = 1000;
    with_limits(&mut config);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    assert_eq!(
        robot.buses()[0].exchange,
        rmd_loop::robot::ExchangeKind::PerMotor
    );
    assert_eq!(robot.buses()[1].requests_per_exchange(), 3);
    assert!(robot.buses().iter().all(|b| b.health_rotation));
    assert_eq!(robot.buses()[1].requests_per_exchange(), 3);
    let mut rt = RtLoop::unsupervised(
        robot,
        clock.clone(),
        vec![bus0.clone(), bus1.clone()],
        PdTo::new(&[10.0; 9]),
    )
    .unwrap()
    .supervise(vec![Box::new(bus0), Box::new(bus1)])
    .unwrap();
    let telemetry = rt.telemetry();
    let mut rt = rt.start().unwrap();
    for _ in 0..100 {
        let step = rt.step();
        assert!(step.is_continue(), "{step:?}");
    }
    rmd_test_support::alloc::count_every_thread(true);
    for _ in 0..2_000 {
        assert!(rt.step().is_continue());
        let _ = telemetry.try_recv();
    }
    rmd_test_support::alloc::count_every_thread(false);
    let allocations = rmd_test_support::alloc::counted().allocations;
    let stats = rt.stats().summary();
    let v3_motors = &stats.motors[..3];
    assert!(
        v3_motors.iter().any(|m| m.counters.missing_replies > 0)
            && v3_motors.iter().any(|m| m.counters.bad_frames > 0)
            && stats.buses[0].tx_errors > 0
            // Six motors on bus 1: each asked every sixth tick, 333 times in 2000.
            && stats.motors.iter().all(|m| m.counters.status_replies > 300),
        "faults happened on the per-motor bus, and the health rotation ran: {stats}"
    );
    assert_eq!(
        allocations, 0,
        "allocations in 2000 steady-state ticks with a per-motor V3 bus"
    );
}

/// Holds every joint where it started, in motion mode.
#[derive(Debug)]
struct HoldInMotionMode(Option<[f64; 3]>);

impl rmd_loop::Controller for HoldInMotionMode {
    fn command_kind(&self, _: &rmd_loop::robot::JointSpec) -> rmd_loop::CommandKind {
        rmd_loop::CommandKind::Motion
    }

    fn update(
        &mut self,
        _: &rmd_loop::TickContext,
        feedback: &rmd_loop::Feedback<'_>,
        cmd: &mut rmd_loop::Commands<'_>,
    ) -> rmd_loop::Flow {
        let hold = *self.0.get_or_insert_with(|| {
            let mut at = [0.0; 3];
            for (j, f) in feedback.iter() {
                at[j.index()] = f.joint.angle_deg;
            }
            at
        });
        for (j, _) in feedback.iter() {
            cmd.set_motion(
                j,
                rmd_loop::MotionCommand::hold(hold[j.index()] + 5.0, 0.5, 0.01),
            );
        }
        rmd_loop::Flow::Continue
    }
}

/// A `motion` bus of MyActuator V3 motors (one motion-mode command each per tick, the health
/// rotation's status requests between), with dropped and truncated replies: nothing allocates.
fn motion_v3_bus() {
    rmd_test_support::alloc::reset_counted();
    let clock = VirtualClock::new();
    let mut v3 = rmd_sim::SimConfig::with_motors(3)
        .seed(43)
        .firmware_family(rmd_sim::FirmwareFamily::MyActuatorV3);
    for f in [
        FaultRule::new(ReplyFault::DropReply).with_probability(0.02),
        // Truncated, not corrupted: random bytes in a status reply's error flags would be a
        // motor error, a fault.
        FaultRule::new(ReplyFault::WrongDlc { dlc: 5 }).with_probability(0.02),
    ] {
        v3 = v3.fault(f);
    }
    let bus = SharedSimBus::new(rmd_sim::SimBus::new(clock.clone(), v3).unwrap());
    let mut config = robot_config(500.0, 1, 3);
    config.buses[0].protocol = Some("myactuator-v3".to_string());
    config.buses[0].exchange = Some(rmd_loop::robot::ExchangeKind::Motion);
    config.loop_config.missing_reply_fault_after = 1000;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    assert!(robot.buses()[0].health_rotation);
    let mut rt = RtLoop::unsupervised(
        robot,
        clock.clone(),
        vec![bus.clone()],
        HoldInMotionMode(None),
    )
    .unwrap()
    .supervise(vec![Box::new(bus)])
    .unwrap();
    let telemetry = rt.telemetry();
    let mut rt = rt.start().unwrap();
    for _ in 0..100 {
        let step = rt.step();
        assert!(step.is_continue(), "{step:?}");
    }
    rmd_test_support::alloc::count_every_thread(true);
    for _ in 0..2_000 {
        let step = rt.step();
        assert!(step.is_continue(), "{step:?}");
        let _ = telemetry.try_recv();
    }
    rmd_test_support::alloc::count_every_thread(false);
    let allocations = rmd_test_support::alloc::counted().allocations;
    let stats = rt.stats().summary();
    assert!(
        stats.motors.iter().any(|m| m.counters.missing_replies > 0)
            && stats.motors.iter().any(|m| m.counters.bad_frames > 0)
            && stats.motors.iter().all(|m| m.counters.status_replies > 400),
        "faults happened on the motion bus, and the health rotation ran: {stats}"
    );
    assert_eq!(
        allocations, 0,
        "allocations in 2000 steady-state ticks with a motion bus"
    );
}

/// The loop with every sink on: its own thread allocates nothing in steady ticks, and every
/// sink gets every tick.
fn every_sink_on() {
    let probe = here();
    drop(std::hint::black_box(Box::new(1_u8)));
    assert_eq!(here(), probe + 1, "the per-thread counter counts");

    let clock = VirtualClock::new();
    let faults = [FaultRule::new(ReplyFault::DropReply)
        .multi_torque()
        .with_probability(0.02)];
    let bus0 = SharedSimBus::new(sim(&clock, 4, 31, &faults));
    let bus1 = SharedSimBus::new(sim(&clock, 4, 32, &faults));
    let mut config = robot_config(1000.0, 2, 4);
    config.loop_config.missing_reply_fault_after = 1000;
    // A small mailbox: the loop waits for the feed thread now and then (virtual time).
    config.loop_config.telemetry_capacity = 64;
    with_limits(&mut config);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let mut rt = RtLoop::unsupervised(
        robot,
        clock.clone(),
        vec![bus0.clone(), bus1.clone()],
        PdTo::new(&[10.0; 8]),
    )
    .unwrap()
    .supervise(vec![Box::new(bus0), Box::new(bus1)])
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let outputs = TelemetryOutputs {
        csv: Some(dir.path().join("run.csv")),
        mcap: Some(dir.path().join("run.mcap")),
        live: Some(LiveOptions {
            addr: "127.0.0.1:0".parse().unwrap(),
            ..LiveOptions::default()
        }),
    };
    let sinks = TelemetrySinks::attach(&mut rt, &outputs)
        .unwrap()
        .expect("three sinks");
    let feed = spawn_feed(sinks).unwrap();
    let mut rt = rt.start().unwrap();
    for _ in 0..100 {
        assert!(rt.step().is_continue());
    }
    let before = here();
    for _ in 0..2_000 {
        assert!(rt.step().is_continue());
    }
    let allocations = here() - before;
    let outcome = rt.finish(StopReason::TickLimit);
    let stats = &outcome.report.stats;
    assert_eq!(stats.ticks, 2100);
    assert!(stats.missing_replies > 0, "faults happened: {stats}");
    let telemetry = feed.finish(stats.telemetry_drops);
    assert_eq!(telemetry.samples, 2100, "{telemetry}");
    assert_eq!(telemetry.sinks().len(), 3);
    for sink in telemetry.sinks() {
        assert_eq!(
            (sink.written, sink.dropped, sink.errors),
            (2100, 0, 0),
            "{sink:?}"
        );
    }
    assert_eq!(
        allocations, 0,
        "allocations on the loop thread in 2000 steady-state ticks with every sink on"
    );
}

/// Joint limits the controller's 10 degree targets push against (the loop refuses the push
/// past 5 degrees) without a fault.
fn with_limits(config: &mut rmd_loop::robot::RobotConfig) {
    for motor in config.buses.iter_mut().flat_map(|b| b.motors.iter_mut()) {
        motor.position_min_deg = Some(-5.0);
        motor.position_max_deg = Some(5.0);
        // Corrupt replies (injected above) can show any angle step or speed the frame holds:
        // margins wider than that, so that the limits refuse torque but never fault.
        motor.limit_margin_deg = Some(90.0);
        motor.velocity_limit_dps = Some(60.0);
        motor.velocity_margin_dps = Some(5000.0);
    }
}
