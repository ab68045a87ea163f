//! The loop on simulated motors in virtual time: fast, deterministic, exact.

use crate::common;

use core::ops::ControlFlow;
use core::time::Duration;

use common::*;
use rmd_bus::{Clock, Timestamp, VirtualClock};
use rmd_loop::{Fault, RtLoop, RunLimit, StopReason};
use rmd_sim::{BusFault, FaultRule, PhysicalFault, ReplyFault};

#[test]
fn ten_thousand_ticks_of_four_motors_without_faults() {
    let (out, mut bus) = run_leg(1, &[], PdTo::hold(4), 10_000);
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    assert!(r.normal_stop);
    assert_eq!(r.stats.ticks, 10_000);
    assert_eq!(r.stats.deadline_misses, 0);
    assert_eq!(r.stats.missing_replies, 0);
    assert_eq!(r.stats.late_replies, 0);
    // Nothing received the telemetry: nothing was published, nothing dropped.
    assert_eq!(r.stats.telemetry_drops, 0);
    for m in &r.stats.motors {
        let c = &m.counters;
        assert_eq!((c.unexpected_replies, c.bad_frames), (0, 0), "{m:?}");
    }
    // Every tick's exchange was measured; it takes the wire time of 5 frames plus turnaround.
    assert_eq!(r.stats.round_trip_us.count, 10_000);
    assert!(
        (700.0..900.0).contains(&r.stats.round_trip_us.p50),
        "{:?}",
        r.stats.round_trip_us
    );
    assert!(out.controller.started);
    assert_eq!(out.controller.updates, 10_000);
    assert_eq!(out.controller.stale_seen, 0);
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    assert_safe(&mut bus, 4);
}

#[test]
fn the_pd_controller_brings_every_joint_to_its_target() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 2, &[]);
    let targets = [20.0, -35.0, 50.0, -90.0];
    let mut rt = RtLoop::unsupervised(
        robot(1000.0, 1, 4),
        clock.clone(),
        vec![&mut bus],
        PdTo::new(&targets),
    )
    .unwrap();
    let telemetry = rt.telemetry();
    let out = rt.run(RunLimit::Duration(Duration::from_secs(3)));
    assert_eq!(out.report.stats.ticks, 3000);
    let last = telemetry.latest().unwrap();
    for (i, target) in targets.iter().enumerate() {
        let got = last.joints()[i].feedback.joint;
        assert!(
            (got.angle_deg - target).abs() < 0.5,
            "joint {i}: {} deg, target {target}",
            got.angle_deg
        );
        assert!(got.velocity_dps.abs() < 2.0);
    }
    // The loop's unwrapped joint angles agree with the simulated truth (motor -90 deg joint =
    // -810 deg of motor: more than two motor turns).
    for (i, target) in targets.iter().enumerate() {
        let truth = bus.snapshot(id(i as u8 + 1)).unwrap().output_angle_deg;
        assert!((truth - target).abs() < 0.6, "motor {i}: truth {truth}");
    }
}

#[test]
fn a_dropped_reply_is_counted_missing_and_the_loop_rides_through() {
    let drop = FaultRule::new(ReplyFault::DropReply)
        .motor(id(2))
        .multi_torque()
        .frames_window(100, 3);
    let (out, mut bus) = run_leg(3, &[drop], PdTo::hold(4), 1000);
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    // Three replies lost. The next two replies could be this tick's or, first in first out,
    // the lost ones arriving late: when in doubt, not fresh (counted late); then the link gives
    // the lost requests up and every reply is fresh again.
    let missing: Vec<_> = r
        .stats
        .motors
        .iter()
        .map(|m| m.counters.missing_replies)
        .collect();
    assert_eq!(missing, [0, 5, 0, 0]);
    assert_eq!(r.stats.motors[1].counters.max_consecutive_missing, 5);
    assert_eq!(r.stats.late_replies, 2);
    assert_eq!(r.stats.motors[1].counters.unexpected_replies, 0);
    assert_eq!(out.controller.stale_seen, 5);
    assert_safe(&mut bus, 4);
}

#[test]
fn a_late_reply_is_recognised_and_never_taken_as_this_ticks() {
    // Motor 3's reply to one 0x280 frame is 500 us late: past the 900 us reply deadline, so it
    // arrives in the next tick, before that tick's own reply.
    let late = FaultRule::new(ReplyFault::LateReply {
        delay: Duration::from_micros(500),
    })
    .motor(id(3))
    .multi_torque()
    .frames_window(200, 1);
    let (out, _) = run_leg(4, &[late], PdTo::hold(4), 1000);
    let m3 = out.report.stats.motors[2].counters;
    assert_eq!(m3.late_replies, 1, "{m3:?}");
    assert_eq!(m3.missing_replies, 1, "{m3:?}");
    assert_eq!(m3.unexpected_replies, 0, "{m3:?}");
    assert_eq!(out.report.stats.late_replies, 1);
    assert_eq!(out.report.stats.missing_replies, 1);
}

#[test]
fn a_corrupted_or_short_reply_is_a_bad_frame_of_its_motor() {
    let corrupt = FaultRule::new(ReplyFault::WrongDlc { dlc: 5 })
        .motor(id(4))
        .multi_torque()
        .frames_window(50, 2);
    let (out, _) = run_leg(5, &[corrupt], PdTo::hold(4), 300);
    let m4 = out.report.stats.motors[3].counters;
    assert_eq!(m4.bad_frames, 2);
    // Two ticks without a good reply, then two whose replies could be late ones (when in
    // doubt, not fresh) until the link gives the two unanswered requests up.
    assert_eq!(m4.missing_replies, 4);
    assert_eq!(m4.late_replies, 2);
    assert_eq!(out.report.stats.missing_replies, 4);
    assert_eq!(out.report.stop_reason, StopReason::TickLimit);
}

#[test]
fn corrupted_bytes_never_reach_the_controller_as_fresh_feedback() {
    let corrupt = FaultRule::new(ReplyFault::CorruptBytes { count: 8 })
        .motor(id(1))
        .multi_torque()
        .with_probability(0.2);
    // One reply in five lost: the loop would rightly stop for want of fresh feedback at times;
    // this test is about what reaches the controller, so it lets the run go on.
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 6, &[corrupt]);
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.missing_reply_fault_after = 1000;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let rt = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::hold(4)).unwrap();
    let out = rt.run(RunLimit::Ticks(2000));
    let m1 = out.report.stats.motors[0].counters;
    // Whatever garbage decoded (or not), it was counted, and nothing else was disturbed.
    assert!(
        m1.bad_frames + m1.unexpected_replies + m1.missing_replies > 0,
        "{m1:?}"
    );
    for m in &out.report.stats.motors[1..] {
        assert_eq!(m.counters.missing_replies, 0);
    }
    assert_eq!(out.report.stop_reason, StopReason::TickLimit);
}

#[test]
fn a_silent_motor_is_a_fault_and_every_motor_is_made_safe() {
    let silent = FaultRule::new(ReplyFault::Silent).motor(id(2)).during(
        Timestamp::ZERO + Duration::from_millis(500),
        Timestamp::from_nanos(u64::MAX),
    );
    let (out, mut bus) = run_leg(7, &[silent], PdTo::hold(4), 5000);
    let r = &out.report;
    assert!(
        matches!(r.stop_reason, StopReason::Fault(Fault::NoFreshFeedback { at, ticks: 20 }) if at.bus == 0 && at.motor == id(2)),
        "{}",
        r.stop_reason
    );
    // The report names the joint.
    assert!(
        r.stop_description
            .contains("joint bus0_motor2 (motor 2 on bus 0)"),
        "{}",
        r.stop_description
    );
    assert!(!r.normal_stop);
    assert_eq!(out.controller.faults.len(), 1);
    assert_eq!(out.controller.stop, Some(r.stop_reason.clone()));
    // The silent motor cannot confirm; the three others did. The silent one was sent motor-off
    // again and again until the stop's deadline, and the report says it may still be energised.
    let confirmed: Vec<_> = r.safe_stop.motors.iter().map(|m| m.off_confirmed).collect();
    assert_eq!(confirmed, [true, false, true, true]);
    assert!(r.safe_stop.motors.iter().all(|m| m.zero_torque_sent));
    assert_eq!(r.safe_stop.motors[0].off_attempts, 1);
    assert!(r.safe_stop.motors[1].off_attempts > 10, "{:?}", r.safe_stop);
    let text = r.safe_stop.to_string();
    assert!(
        text.contains(
            "joint bus0_motor2 (motor 2 on bus 0) NOT CONFIRMED OFF: it may still be energised"
        ),
        "{text}"
    );
    for m in [1, 3, 4] {
        assert_eq!(bus.snapshot(id(m)).unwrap().mode, rmd_sim::ControlMode::Off);
    }
}

#[test]
fn bus_off_on_one_bus_stops_every_bus_and_the_safe_stop_waits_for_its_restart() {
    let clock = VirtualClock::new();
    let bus_off = FaultRule::new(BusFault::BusOff {
        duration: Duration::from_millis(50),
    })
    .multi_torque()
    .frames_window(300, 1);
    let mut bus0 = sim(&clock, 4, 8, &[]);
    let mut bus1 = sim(&clock, 4, 9, &[bus_off]);
    let rt = RtLoop::unsupervised(
        robot(1000.0, 2, 4),
        clock.clone(),
        vec![&mut bus0, &mut bus1],
        PdTo::hold(8),
    )
    .unwrap();
    let out = rt.run(RunLimit::Ticks(2000));
    assert_eq!(
        out.report.stop_reason,
        StopReason::Fault(Fault::BusOff { bus: 1 })
    );
    assert_eq!(out.report.stats.buses[1].bus_off, 1);
    // Bus 0 was made safe at once; bus 1 once its controller restarted (50 ms later).
    assert_safe(&mut bus0, 4);
    assert_safe(&mut bus1, 4);
    assert!(
        out.report.safe_stop.all_off_confirmed(),
        "{}",
        out.report.safe_stop
    );
    let after: Vec<f64> = out
        .report
        .safe_stop
        .buses
        .iter()
        .map(|b| match b.outcome {
            rmd_loop::BusStopOutcome::Confirmed { after_ms } => after_ms,
            other => panic!("{other:?}"),
        })
        .collect();
    assert!(
        after[0] < 5.0 && (45.0..60.0).contains(&after[1]),
        "{after:?}"
    );
}

#[test]
fn a_controller_panic_is_caught_reported_and_made_safe() {
    let mut ctrl = PdTo::hold(4);
    ctrl.panic_at = Some(123);
    let (out, mut bus) = run_leg(10, &[], ctrl, 1000);
    assert_eq!(
        out.report.stop_reason,
        StopReason::ControllerPanic("controller bug at tick 123".to_string())
    );
    // Ticks 0..=123 started; the 124th panicked.
    assert_eq!(out.report.stats.ticks, 124);
    // The panic was recorded (not printed) and reported after the safe stop, with its place.
    let panic = out.report.panic.as_ref().expect("a panic report");
    assert_eq!(panic.message, "controller bug at tick 123");
    assert!(
        panic
            .location
            .as_deref()
            .is_some_and(|l| l.contains("common/mod.rs")),
        "{panic:?}"
    );
    assert!(
        out.report
            .to_string()
            .contains("panic: controller bug at tick 123 at")
    );
    assert!(out.report.safe_stop.all_off_confirmed());
    assert_safe(&mut bus, 4);
}

#[test]
fn the_controller_can_end_the_run() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 11, &[]);
    let mut ctrl = PdTo::hold(4);
    ctrl.finish_at = Some(49);
    let rt =
        RtLoop::unsupervised(robot(1000.0, 1, 4), clock.clone(), vec![&mut bus], ctrl).unwrap();
    let out = rt.run(RunLimit::Forever);
    assert_eq!(out.report.stop_reason, StopReason::ControllerFinished);
    assert_eq!(out.report.stats.ticks, 50);
    assert_safe(&mut bus, 4);
}

/// Halts at its 30th tick, for its own safety.
struct Halting;

impl rmd_loop::Controller for Halting {
    fn update(
        &mut self,
        ctx: &rmd_loop::TickContext,
        _: &rmd_loop::Feedback<'_>,
        _: &mut rmd_loop::Commands<'_>,
    ) -> rmd_loop::Flow {
        if ctx.index == 29 {
            rmd_loop::Flow::Halt("the knee went beyond its limit")
        } else {
            rmd_loop::Flow::Continue
        }
    }
}

#[test]
fn a_controller_halt_is_an_abnormal_end_with_its_reason() {
    let (out, mut bus) = run_leg(17, &[], Halting, 1000);
    let r = &out.report;
    assert_eq!(
        r.stop_reason,
        StopReason::ControllerHalted("the knee went beyond its limit")
    );
    assert!(!r.normal_stop);
    assert_eq!(r.stats.ticks, 30);
    assert!(
        r.stop_description
            .contains("HALTED by the controller: the knee")
    );
    assert_safe(&mut bus, 4);
}

#[test]
fn an_emergency_stop_takes_effect_within_one_tick() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 12, &[]);
    let rt = RtLoop::unsupervised(
        robot(1000.0, 1, 4),
        clock.clone(),
        vec![&mut bus],
        PdTo::hold(4),
    )
    .unwrap();
    let stopper = rt.stopper();
    let mut rt = rt.start().unwrap();
    for _ in 0..10 {
        assert!(rt.step().is_continue());
    }
    stopper.emergency_stop();
    let stopped_at = clock.now();
    let ControlFlow::Break(reason) = rt.step() else {
        panic!("the next tick stops")
    };
    assert_eq!(reason, StopReason::EmergencyStop);
    let out = rt.finish(reason);
    assert_eq!(out.report.stats.ticks, 10);
    // The zero-torque frame went out within one period of the request.
    assert!(clock.now() - stopped_at <= MS + Duration::from_millis(60));
    assert!(out.report.safe_stop.all_off_confirmed());
    assert_safe(&mut bus, 4);
}

#[test]
fn a_transmit_queue_that_fills_is_counted_not_fatal() {
    // 15 ms: the transmit queue fills (refused frames counted) and the frames queued meanwhile
    // go out late; with patience for stale feedback the loop rides through and catches up.
    let stall = FaultRule::new(BusFault::TxStall {
        duration: Duration::from_millis(15),
    })
    .multi_torque()
    .frames_window(100, 1);
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 13, &[stall]);
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.missing_reply_fault_after = 100;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let rt = RtLoop::unsupervised(robot, clock, vec![&mut bus], PdTo::hold(4)).unwrap();
    let out = rt.run(RunLimit::Ticks(500));
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    assert!(r.stats.buses[0].tx_errors > 0, "{:?}", r.stats.buses[0]);
    assert!(r.stats.missing_replies > 0);
}

#[test]
fn a_long_transmit_stall_ends_in_an_honest_fault() {
    // 15 ms: the backlog of frames queued meanwhile drains over many ticks, every reply in it
    // is counted late with its true age, and after 20 ticks without fresh feedback the loop
    // stops (motors made safe) rather than run on stale feedback.
    let stall = FaultRule::new(BusFault::TxStall {
        duration: Duration::from_millis(15),
    })
    .multi_torque()
    .frames_window(100, 1);
    let (out, mut bus) = run_leg(13, &[stall], PdTo::hold(4), 500);
    let r = &out.report;
    assert!(
        matches!(
            r.stop_reason,
            StopReason::Fault(Fault::NoFreshFeedback { ticks: 20, .. })
        ),
        "{r}"
    );
    assert!(r.stats.late_replies > 0, "{r}");
    assert!(r.stop_description.contains("missing or late"), "{r}");
    assert_safe(&mut bus, 4);
}

#[test]
fn a_motor_that_never_answers_stops_the_start_and_names_it() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 3, 14, &[]); // motor 4 is configured but absent
    let rt = RtLoop::unsupervised(
        robot(1000.0, 1, 4),
        clock.clone(),
        vec![&mut bus],
        PdTo::hold(4),
    )
    .unwrap();
    let out = rt.run(RunLimit::Ticks(100));
    assert!(
        matches!(
            out.report.stop_reason,
            StopReason::Fault(Fault::StartupTimeout { at, missing: 1 }) if at.bus == 0 && at.motor == id(4)
        ),
        "{}",
        out.report.stop_reason
    );
    assert!(out.report.stop_description.contains("motor 4"));
    assert_eq!(out.report.stats.ticks, 0);
    assert!(!out.controller.started);
    assert_safe(&mut bus, 3);
}

#[test]
fn the_same_seed_gives_the_same_run() {
    let run = |seed| {
        let clock = VirtualClock::new();
        let flaky = FaultRule::new(ReplyFault::DropReply)
            .multi_torque()
            .with_probability(0.01);
        let mut bus = sim(&clock, 4, seed, &[flaky]);
        let mut rt = RtLoop::unsupervised(
            robot(1000.0, 1, 4),
            clock.clone(),
            vec![&mut bus],
            PdTo::new(&[10.0, 20.0, 30.0, 40.0]),
        )
        .unwrap();
        let telemetry = rt.telemetry();
        let out = rt.run(RunLimit::Ticks(1000));
        let last = telemetry.latest().unwrap();
        (out.report.stats.motors.clone(), last.joints().to_vec())
    };
    assert_eq!(run(77), run(77));
    assert_ne!(run(77).0, run(78).0);
}

#[test]
fn pipelined_mode_accepts_one_tick_old_feedback_from_slow_motors() {
    // Motors with a 1.2 ms turnaround at 1 kHz: every reply arrives in the next tick.
    let clock = VirtualClock::new();
    let mut config = rmd_sim::SimConfig::with_motors(4).seed(15);
    for m in &mut config.motors {
        m.turnaround = Duration::from_micros(1200);
    }
    let mut slow = rmd_sim::SimBus::new(clock.clone(), config).unwrap();
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.reply_mode = rmd_loop::robot::ReplyMode::Pipelined;
    config.loop_config.allow_over_budget = true;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let mut rt =
        RtLoop::unsupervised(robot, clock.clone(), vec![&mut slow], PdTo::new(&[5.0; 4])).unwrap();
    let telemetry = rt.telemetry();
    let out = rt.run(RunLimit::Ticks(2000));
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    // Tick 0's replies cannot be in before tick 1: one miss per motor at most, then none.
    assert!(r.stats.missing_replies <= 4, "{}", r.stats);
    assert_eq!(r.stats.late_replies, 0);
    let last = telemetry.latest().unwrap();
    assert!(last.joints().iter().all(|j| j.feedback.is_fresh()));
    assert!(
        last.joints()
            .iter()
            .all(|j| (j.feedback.joint.angle_deg - 5.0).abs() < 1.0),
        "{last:?}"
    );
}

/// A controller that takes `cost` of (virtual) time in `count` consecutive updates, from the
/// first tick with index `from`.
struct Slow {
    clock: VirtualClock,
    from: u64,
    count: u64,
    cost: Duration,
}

impl rmd_loop::Controller for Slow {
    fn update(
        &mut self,
        ctx: &rmd_loop::TickContext,
        _: &rmd_loop::Feedback<'_>,
        _: &mut rmd_loop::Commands<'_>,
    ) -> rmd_loop::Flow {
        if ctx.index >= self.from && self.count > 0 {
            self.count -= 1;
            self.clock.advance(self.cost);
        }
        rmd_loop::Flow::Continue
    }
}

fn run_slow(policy: rmd_loop::schedule::OverrunPolicy, count: u64) -> rmd_loop::LoopReport {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 16, &[]);
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.overrun = policy;
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let slow = Slow {
        clock: clock.clone(),
        from: 100,
        count,
        cost: Duration::from_micros(1500),
    };
    let rt = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], slow).unwrap();
    let out = rt.run(RunLimit::Ticks(300));
    assert_safe(&mut bus, 4);
    out.report
}

#[test]
fn deadline_misses_follow_the_overrun_policy() {
    use rmd_loop::schedule::OverrunPolicy;
    // Skip (default): each slow tick (0.8 ms exchange + 1.5 ms) misses and the two slots whose
    // start passed are skipped; replies still match.
    let r = run_slow(OverrunPolicy::Skip, 5);
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    assert_eq!(r.stats.deadline_misses, 5);
    assert_eq!(r.stats.skipped_ticks, 10);
    assert_eq!(r.stats.missing_replies, 0, "{}", r.stats);
    assert_eq!(
        r.stats.late_replies
            + r.stats
                .motors
                .iter()
                .map(|m| m.counters.unexpected_replies)
                .sum::<u64>(),
        0
    );
    // Continue: the missed ticks run late, back to back; nothing is skipped.
    let r = run_slow(OverrunPolicy::Continue, 5);
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    assert!(r.stats.deadline_misses >= 5, "{}", r.stats);
    assert_eq!(r.stats.skipped_ticks, 0);
    // Fault after 3 consecutive misses: stops at the third, motors made safe.
    let r = run_slow(OverrunPolicy::Fault { after: 3 }, 10);
    assert_eq!(
        r.stop_reason,
        StopReason::Fault(Fault::DeadlineMisses { consecutive: 3 })
    );
    assert!(r.safe_stop.all_off_confirmed());
}

/// `motors` simulated motors (seed `seed`) that answer each request `turnaround_ms` after it,
/// give or take `jitter_ms`: a slow host, as an emulated VM is.
fn slow_motors(motors: u8, seed: u64, turnaround_ms: u64, jitter_ms: u64) -> rmd_sim::SimConfig {
    let mut config = rmd_sim::SimConfig::with_motors(motors).seed(seed);
    for m in &mut config.motors {
        m.turnaround = Duration::from_millis(turnaround_ms);
        m.turnaround_jitter = Duration::from_millis(jitter_ms);
    }
    config
}

/// One bus of `motors` motors at 10 Hz, pipelined.
fn pipelined_at_10_hz(motors: u8) -> rmd_loop::robot::RobotConfig {
    let mut robot = robot_config(10.0, 1, motors);
    robot.loop_config.reply_mode = rmd_loop::robot::ReplyMode::Pipelined;
    robot
}

#[test]
fn pipelined_replies_about_a_period_late_are_all_fresh_from_the_first_tick() {
    // A slow host (an emulated VM answers in ~100 ms) at 10 Hz, pipelined: each tick is
    // answered by the request before it; tick 0 by the start-up probe's replies.
    for (turnaround_ms, jitter_ms) in [(95, 10), (100, 5), (150, 0), (1, 0)] {
        let clock = VirtualClock::new();
        let config = slow_motors(4, 3, turnaround_ms, jitter_ms);
        let mut bus = rmd_sim::SimBus::new(clock.clone(), config).unwrap();
        let robot = pipelined_at_10_hz(4);
        let robot = rmd_loop::robot::Robot::try_from(robot).unwrap();
        let rt = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], PdTo::hold(4)).unwrap();
        let out = rt.run(RunLimit::Ticks(200));
        let r = &out.report;
        assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
        for m in &r.stats.motors {
            let c = &m.counters;
            assert_eq!(
                (
                    c.missing_replies,
                    c.late_replies,
                    c.unexpected_replies,
                    c.bad_frames
                ),
                (0, 0, 0, 0),
                "{turnaround_ms} ms: {r}"
            );
        }
    }
}

/// Runs 50 ticks at 10 Hz of four motors whose start-up probe meets `fault` (on the first
/// 0x280 frame's reply of motor 1), same-tick or pipelined.
fn start_through(fault: ReplyFault, pipelined: bool) -> rmd_loop::LoopReport {
    let rule = FaultRule::new(fault)
        .motor(id(1))
        .multi_torque()
        .frames_window(0, 1);
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, 7, &[rule]);
    let mut config = robot_config(10.0, 1, 4);
    if pipelined {
        config.loop_config.reply_mode = rmd_loop::robot::ReplyMode::Pipelined;
    }
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let rt = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], PdTo::hold(4)).unwrap();
    let report = rt.run(RunLimit::Ticks(50)).report;
    assert_safe(&mut bus, 4);
    report
}

#[test]
fn a_stall_longer_than_the_probe_timeout_leaves_no_reply_unexpected() {
    // Motor 1's answer to the first probe comes 410 ms late (a stalled host or adapter): past
    // the probe's 400 ms timeout at 10 Hz, so the probe asks again and both answers come. Each
    // is taken as the answer to one of the two requests: none is left over to be taken for the
    // first tick's, or counted unexpected. A reply lost at start-up costs nothing either.
    for fault in [
        ReplyFault::LateReply {
            delay: Duration::from_millis(410),
        },
        ReplyFault::DropReply,
    ] {
        for pipelined in [false, true] {
            let r = start_through(fault, pipelined);
            assert_eq!(r.stop_reason, StopReason::TickLimit, "{fault:?}: {r}");
            for m in &r.stats.motors {
                let c = &m.counters;
                assert_eq!(
                    (c.missing_replies, c.late_replies, c.unexpected_replies),
                    (0, 0, 0),
                    "{fault:?}, pipelined {pipelined}: {r}"
                );
            }
            // The round trips were measured afresh after the stall: no tick's is near 400 ms.
            // The round trips were measured afresh after the stall: none near its 400 ms. (The
            // simulator delays that one reply and lets the later ones pass, so matched first in,
            // first out one sample spans the 10 ms between the two requests' answers.)
            assert!(r.stats.round_trip_us.max < 20_000.0, "{fault:?}: {r}");
        }
    }
}

/// A leg of `motors` motors at `rate_hz` on one simulated bus (seed 5, `faults`), its trace
/// recorded, run for `ticks` ticks with `controller`.
fn run_health<K: rmd_loop::Controller>(
    config: rmd_loop::robot::RobotConfig,
    motors: u8,
    faults: &[FaultRule],
    controller: K,
    ticks: u64,
) -> (rmd_loop::LoopOutcome<K>, rmd_sim::SimBus<VirtualClock>) {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, motors, 5, faults);
    bus.record_trace(200_000);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let out = RtLoop::unsupervised(robot, clock, vec![&mut bus], controller)
        .unwrap()
        .run(RunLimit::Ticks(ticks));
    (out, bus)
}

#[test]
fn the_health_rotation_reads_every_motor_within_n_ticks_and_never_disturbs_torque_replies() {
    // Four motors at 500 Hz: one 0x280 frame, one status request, five replies fit the window.
    let config = robot_config(500.0, 1, 4);
    let (out, mut bus) = run_health(config, 4, &[], HealthWatch::from(8), 5000);
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    assert_eq!(r.health_rotation, [true]);
    assert!(r.health_notes.is_empty(), "{:?}", r.health_notes);
    // Every motor's health at most N = 4 ticks old, from the first rotation on.
    assert_eq!(out.controller.without, 0);
    assert!(out.controller.oldest <= 4, "{}", out.controller.oldest);
    // The supply voltage the motors measure (ground truth) reaches the controller.
    for (m, volts) in out.controller.volts.iter().enumerate() {
        let truth = bus.snapshot(id(m as u8 + 1)).unwrap().voltage_v;
        assert!(
            (volts - truth).abs() <= 0.1,
            "motor {}: {volts} V, truth {truth} V",
            m + 1
        );
    }
    // One status request per tick, each motor in turn (and one each by the start-up's
    // identification); every one answered; the torque replies' counters untouched.
    let sent = status_requests(&bus);
    assert_eq!(sent[1..=4], [1251, 1251, 1251, 1251]);
    // The last request may be unanswered when the loop stops.
    assert_rotation_left_torque_alone(r, 1249);
    assert_eq!(r.stats.round_trip_us.count, 5000);
}

#[test]
fn a_lost_status_reply_is_counted_and_the_loop_rides_through() {
    let drop = FaultRule::new(ReplyFault::DropReply)
        .motor(id(2))
        .command(rmd_protocol::Command::ReadStatus1)
        .frames_window(10, 3);
    let (out, _) = run_health(
        robot_config(500.0, 1, 4),
        4,
        &[drop],
        HealthWatch::from(8),
        1000,
    );
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    let m2 = r.stats.motors[1].counters;
    assert_eq!(m2.missing_status_replies, 3, "{m2:?}");
    // Never taken for a torque reply, nor shifting the later status replies.
    assert_eq!(
        (r.stats.missing_replies, r.stats.late_replies),
        (0, 0),
        "{r}"
    );
    assert_eq!((m2.unexpected_replies, m2.bad_frames), (0, 0), "{m2:?}");
    // Three lost replies leave motor 2's reading three rotations older at most once.
    assert!(out.controller.oldest <= 4 * 4, "{}", out.controller.oldest);
}

/// The loop stopped on `flag` from motor `motor`, and every motor is off by ground truth.
fn assert_stopped_on_flag(
    out: &rmd_loop::LoopOutcome<HealthWatch>,
    bus: &mut rmd_sim::SimBus<VirtualClock>,
    motor: u8,
    flag: rmd_loop::MotorFlag,
) {
    let r = &out.report;
    let StopReason::Fault(Fault::MotorError { at, flag: got, .. }) = r.stop_reason else {
        panic!("{r}")
    };
    assert_eq!((at.motor, at.bus, got), (id(motor), 0, flag), "{r}");
    assert!(
        r.stop_description
            .contains(&format!("motor {motor} on bus 0")),
        "{r}"
    );
    assert!(r.stop_description.contains(flag.name()), "{r}");
    assert_safe(bus, 4);
}

#[test]
fn an_under_voltage_or_over_temperature_flag_stops_the_loop_naming_the_motor() {
    let from = Timestamp::from_nanos(300_000_000);
    let until = Timestamp::from_nanos(u64::MAX);
    let low = FaultRule::new(PhysicalFault::LowVoltage { volts: 12.0 })
        .motor(id(3))
        .during(from, until);
    let (out, mut bus) = run_health(
        robot_config(500.0, 1, 4),
        4,
        &[low],
        HealthWatch::default(),
        1000,
    );
    assert_stopped_on_flag(&out, &mut bus, 3, rmd_loop::MotorFlag::UnderVoltage);
    // Within a rotation and a tick of the cause: 300 ms is tick 150 at 500 Hz.
    assert!(out.report.stats.ticks <= 150 + 4 + 2, "{}", out.report);
    let hot = FaultRule::new(PhysicalFault::OverTemperature { celsius: 95.0 })
        .motor(id(2))
        .during(from, until);
    let (out, mut bus) = run_health(
        robot_config(500.0, 1, 4),
        4,
        &[hot],
        HealthWatch::default(),
        1000,
    );
    assert_stopped_on_flag(&out, &mut bus, 2, rmd_loop::MotorFlag::OverTemperature);
}

#[test]
fn without_room_on_the_wire_or_when_switched_off_no_status_request_goes_out() {
    // Four motors at 1 kHz: the 0x280 frame and four replies fill the reply window (875 of
    // 900 us, worst-case stuffing); a status request and reply more would not fit.
    let (out, bus) = run_health(
        robot_config(1000.0, 1, 4),
        4,
        &[],
        HealthWatch::from(0),
        500,
    );
    assert_eq!(out.report.health_rotation, [false]);
    assert!(
        out.report.health_notes[0].contains("no room on the wire"),
        "{:?}",
        out.report.health_notes
    );
    assert!(
        out.report
            .to_string()
            .contains("motor health: not read on bus 0")
    );
    // Only the start-up's identification asked (once each).
    assert_eq!(status_requests(&bus)[1..=4], [1, 1, 1, 1]);
    assert_eq!(out.controller.without, 500 * 4);
    // Room, but switched off.
    let mut config = robot_config(500.0, 1, 4);
    config.loop_config.health_rotation = false;
    let (out, bus) = run_health(config, 4, &[], HealthWatch::from(0), 500);
    assert_eq!(out.report.health_rotation, [false]);
    assert!(out.report.health_notes[0].contains("loop.health_rotation = false"));
    assert_eq!(status_requests(&bus)[1..=4], [1, 1, 1, 1]);
    // Three motors at 1 kHz have room (875 us with the status request and reply).
    let (out, bus) = run_health(
        robot_config(1000.0, 1, 3),
        3,
        &[],
        HealthWatch::from(6),
        3000,
    );
    assert_eq!(out.report.health_rotation, [true]);
    assert_eq!(status_requests(&bus)[1..=3], [1001, 1001, 1001]);
    assert!(out.controller.oldest <= 3, "{}", out.controller.oldest);
    assert_eq!(out.report.stats.missing_replies, 0);
}

#[test]
fn pipelined_status_replies_read_two_ticks_later_still_answer_their_own_requests() {
    // Pipelined, tick N's replies are collected in tick N + 1, which stops at the torque reply:
    // the status reply just behind it is read in tick N + 2. It still answers its request.
    for rate in [10.0, 1000.0] {
        let clock = VirtualClock::new();
        let mut bus = sim(&clock, 1, 3, &[]);
        let mut config = robot_config(rate, 1, 1);
        config.loop_config.reply_mode = rmd_loop::robot::ReplyMode::Pipelined;
        let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
        let out = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], PdTo::hold(1))
            .unwrap()
            .run(RunLimit::Ticks(50));
        let r = &out.report;
        let c = r.stats.motors[0].counters;
        assert_eq!(r.health_rotation, [true], "{r}");
        assert_eq!(
            (
                c.unexpected_replies,
                c.missing_status_replies,
                c.missing_replies
            ),
            (0, 0, 0),
            "{rate} Hz: {r}"
        );
        // 50 requests; the last two were still to be read when the run ended.
        assert_eq!(c.status_replies, 48, "{rate} Hz: {r}");
    }
}

#[test]
fn on_a_link_slower_than_the_period_each_status_reply_answers_its_own_request() {
    // Pipelined at 10 Hz, one motor answering in 100 ms (an emulated VM): each status reply
    // comes after the next status request went out, and still answers its own: none is counted
    // lost or unexpected (the newest-request rule counted half of them lost).
    for (turnaround_ms, jitter_ms) in [(100, 5), (150, 0), (60, 40), (2, 0)] {
        let clock = VirtualClock::new();
        let mut config = slow_motors(1, 4, turnaround_ms, jitter_ms);
        config.bus.motor_mailboxes = 8;
        let mut bus = rmd_sim::SimBus::new(clock.clone(), config).unwrap();
        let mut robot = pipelined_at_10_hz(1);
        robot.buses[0].motors[0].temperature_limit_celsius = Some(70.0);
        let robot = rmd_loop::robot::Robot::try_from(robot).unwrap();
        let rt = RtLoop::unsupervised(robot, clock.clone(), vec![&mut bus], HealthWatch::from(1))
            .unwrap();
        let out = rt.run(RunLimit::Ticks(50));
        let r = &out.report;
        assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
        let c = &r.stats.motors[0].counters;
        assert_eq!(
            (
                c.missing_replies,
                c.late_replies,
                c.unexpected_replies,
                c.bad_frames
            ),
            (0, 0, 0, 0),
            "{turnaround_ms} ms: {r}"
        );
        assert_eq!(c.missing_status_replies, 0, "{turnaround_ms} ms: {r}");
        // 50 requests; the last two are still on their way when the loop stops.
        assert!(c.status_replies >= 47, "{turnaround_ms} ms: {r}");
        // The reading's age: two ticks once read (the reply of a tick's request is read two
        // ticks later), at most three.
        assert!(
            out.controller.oldest >= 2,
            "{turnaround_ms} ms: {}",
            out.controller.oldest
        );
        assert!(
            out.controller.oldest <= 3,
            "{turnaround_ms} ms: {}",
            out.controller.oldest
        );
    }
}

/// Holds every joint at zero torque and writes a signal the controller never declared.
struct UndeclaredSignal;

impl rmd_loop::Controller for UndeclaredSignal {
    fn update(
        &mut self,
        _: &rmd_loop::TickContext,
        fb: &rmd_loop::Feedback<'_>,
        cmd: &mut rmd_loop::Commands<'_>,
    ) -> rmd_loop::Flow {
        for (joint, _) in fb.iter() {
            cmd.set_current(joint, 0.0);
        }
        cmd.set_signal(3, 1.0);
        rmd_loop::Flow::Continue
    }
}

#[test]
fn an_undeclared_signal_is_counted_on_ticks_without_rejected_commands() {
    let (out, mut bus) = run_leg(1, &[], UndeclaredSignal, 200);
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    assert_eq!(r.stats.unknown_signals, 200);
    assert_eq!(r.stats.unknown_joint_commands, 0);
    assert!(
        r.stats
            .motors
            .iter()
            .all(|m| m.counters.rejected_commands == 0),
        "{:?}",
        r.stats.motors
    );
    assert_safe(&mut bus, 4);
}
