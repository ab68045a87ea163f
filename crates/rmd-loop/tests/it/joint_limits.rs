//! The joint limits of the description, enforced by the loop below the controller, judged by
//! the simulated joint's ground truth (its output shaft), in virtual time: a controller pushing
//! past a limit is held at it, within the margin; a joint carried past the margin is a fault
//! that leaves every motor off.

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_loop::{
    Commands, Controller, Fault, Feedback, Flow, LimitKind, RtLoop, StopReason, TickContext,
    robot::Robot,
};
use rmd_sim::{ControlMode, GravityLink, SharedSimBus, SimBus};

/// One RMD-X8-class joint (1:9, 2.09 N*m/A), its power-up window centred on 0 degrees, with
/// the limits `motor` adds.
fn arm(limits: impl FnOnce(MotorConfig) -> MotorConfig) -> Robot {
    let motor = MotorConfig::new(1)
        .name("elbow")
        .gear_ratio(GEAR)
        .torque_constant(KT)
        .current_limit(3.0)
        .zero_offset_deg(20.0);
    Robot::try_from(
        RobotConfig::new(1000.0).with_bus(BusConfig::new("sim").with_motor(limits(motor))),
    )
    .unwrap()
}

/// A simulated bus matching `robot`, the joint powered up at `start_deg`, with `load`.
fn sim_for(
    robot: &Robot,
    clock: &VirtualClock,
    start_deg: f64,
    gravity: Option<GravityLink>,
) -> SharedSimBus<VirtualClock> {
    let mut config = rmd_rig::sim::sim_configs(robot, 3).remove(0);
    config.motors[0].initial_output_angle_deg = start_deg;
    config.motors[0].load.gravity = gravity;
    SharedSimBus::new(SimBus::new(clock.clone(), config).unwrap())
}

/// A 2 kg link 0.3 m long, horizontal at 0 degrees: it falls towards -90 without torque.
const FALLING_LINK: GravityLink = GravityLink {
    mass_kg: 2.0,
    length_m: 0.3,
    angle_offset_deg: 90.0,
};

/// Commands a fixed joint current, whatever the joint does.
struct Push(f64);

impl Controller for Push {
    fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        for (joint, _) in fb.iter() {
            cmd.set_current(joint, self.0);
        }
        Flow::Continue
    }
}

/// Runs `controller` on `robot` over `bus` for `ticks` ticks, one by one; returns the outcome,
/// and the ground truth's extremes over the run: the lowest and highest output angle and the
/// fastest output speed.
fn run<K: Controller>(
    robot: Robot,
    clock: VirtualClock,
    bus: &SharedSimBus<VirtualClock>,
    controller: K,
    ticks: u64,
) -> (rmd_loop::LoopOutcome<K>, (f64, f64, f64)) {
    let rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], controller).unwrap();
    let mut running = rt.start().map_err(|o| o.report.to_string()).unwrap();
    let (mut low, mut high, mut fastest) = (f64::INFINITY, f64::NEG_INFINITY, 0.0_f64);
    let mut reason = StopReason::TickLimit;
    for _ in 0..ticks {
        let step = running.step();
        let truth = bus.lock().snapshot(id(1)).unwrap();
        low = low.min(truth.output_angle_deg);
        high = high.max(truth.output_angle_deg);
        fastest = fastest.max((truth.motor_speed_dps / GEAR).abs());
        if let core::ops::ControlFlow::Break(why) = step {
            reason = why;
            break;
        }
    }
    (running.finish(reason), (low, high, fastest))
}

#[test]
fn a_controller_driving_far_past_a_limit_is_held_at_it_within_the_margin() {
    // The finding behind the limits: a position target of 100 rad (meant as degrees?) spun an
    // unlimited joint round and round. Here: a PD controller asks for 5730 degrees (100 rad).
    let robot = arm(|m| {
        m.position_limits(-20.0, 30.0)
            .velocity_limit(30.0)
            .current_limit(1.0)
    });
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 0.0, None);
    let mut pd = PdTo::new(&[100f64.to_degrees()]);
    pd.kp = 0.05;
    pd.kd = 0.002;
    let (out, (low, high, fastest)) = run(robot, clock, &bus, pd, 3000);
    let r = &out.report;
    let rest = bus.lock().snapshot(id(1)).unwrap().output_angle_deg;
    let limited = r.stats.motors[0].counters.limited_commands;
    println!(
        "PD to 100 rad, limits -20..30 deg: highest {high:.2} deg, resting {rest:.2} deg, \
         fastest {fastest:.1} deg/s, {limited} commands refused"
    );
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    // Ground truth: it reached the limit and stayed within the margin above it, never faster
    // than the velocity limit plus its margin.
    assert!(high > 29.0, "never reached the limit: {high}");
    assert!(high <= 35.0, "beyond the limit plus margin: {high}");
    assert!(low > -25.0, "{low}");
    assert!(fastest <= 45.0, "{fastest}");
    // Where it rests: at the limit, give or take the joint's coast.
    assert!((29.0..=35.0).contains(&rest), "{rest}");
    // Counted per joint and shown in the report.
    assert!(limited > 100, "{limited}");
    assert!(
        r.to_string().contains(&format!("limited {limited} ")),
        "{r}"
    );
    assert!(r.safe_stop.all_off_confirmed());
}

#[test]
fn torque_back_inside_passes_past_a_limit() {
    // Powered up past the top limit (within the margin): pushing further up is refused, pushing
    // back down is obeyed.
    let robot = arm(|m| m.position_limits(-20.0, 10.0).limit_margin(10.0));
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 15.0, None);
    let (up, (_, high, _)) = run(robot.clone(), clock, &bus, Push(0.5), 100);
    assert_eq!(
        up.report.stop_reason,
        StopReason::TickLimit,
        "{}",
        up.report
    );
    assert!(high < 15.5, "it was pushed further out: {high}");
    assert_eq!(up.report.stats.motors[0].counters.limited_commands, 100);
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 15.0, None);
    // 100 ms of 1 N*m: about 14 degrees down, nowhere near the lower limit.
    let (down, (low, _, _)) = run(robot, clock, &bus, Push(-0.5), 100);
    assert!(low < 10.0, "it was not let back in: {low}");
    assert_eq!(down.report.stats.motors[0].counters.limited_commands, 0);
}

#[test]
fn a_joint_carried_past_its_margin_is_a_fault_and_every_motor_ends_off() {
    // A 2 kg link 0.3 m long, horizontal at 0 degrees, falling towards -90: a limp controller,
    // the lower limit at -30 with 5 degrees of margin. Zero torque cannot hold it: past -35 the
    // loop stops with a fault naming the joint, where it was and the limit.
    let robot = arm(|m| m.position_limits(-30.0, 30.0));
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 0.0, Some(FALLING_LINK));
    let (out, (low, _, _)) = run(robot, clock, &bus, Push(0.0), 3000);
    let r = &out.report;
    let StopReason::Fault(Fault::JointLimit { at, breach }) = r.stop_reason else {
        panic!("expected a joint-limit fault: {r}");
    };
    println!(
        "falling link, lower limit -30 deg: fault at {:.2} deg, lowest {low:.2} deg before the \
         stop",
        breach.value
    );
    assert_eq!(at.joint.index(), 0);
    assert_eq!(breach.kind, LimitKind::PositionMin);
    assert_eq!((breach.limit, breach.margin), (-30.0, 5.0));
    assert!(breach.value < -35.0 && breach.value > -40.0, "{breach:?}");
    assert!(low < -35.0);
    assert!(
        r.stop_description
            .starts_with("FAULT: joint elbow (motor 1 on bus 0) is at -3")
            && r.stop_description
                .contains("past its position_min_deg of -30 deg by more than its 5 deg margin"),
        "{}",
        r.stop_description
    );
    // Ground truth: the motor is off.
    assert_eq!(bus.lock().snapshot(id(1)).unwrap().mode, ControlMode::Off);
    assert!(r.safe_stop.all_off_confirmed());
}

#[test]
fn a_joint_that_powers_up_beyond_its_margin_never_gets_torque() {
    let robot = arm(|m| m.position_limits(-10.0, 10.0).limit_margin(2.0));
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 15.0, None);
    let (out, _) = run(robot, clock, &bus, Push(1.0), 100);
    assert!(
        matches!(
            out.report.stop_reason,
            StopReason::Fault(Fault::JointLimit { breach, .. }) if breach.kind == LimitKind::PositionMax
        ),
        "{}",
        out.report
    );
    assert_eq!(out.report.stats.ticks, 1);
    let truth = bus.lock().snapshot(id(1)).unwrap();
    assert_eq!(truth.mode, ControlMode::Off);
    assert!((truth.output_angle_deg - 15.0).abs() < 0.01, "{truth:?}");
}

#[test]
fn a_joint_spun_faster_than_its_velocity_limit_is_held_and_then_a_fault() {
    // Pushing with 1 A: the loop refuses the push above 60 deg/s (braking passes), so the joint
    // turns at about 60 deg/s.
    let robot = arm(|m| m.velocity_limit(60.0));
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 0.0, None);
    let (out, (_, high, fastest)) = run(robot, clock, &bus, Push(1.0), 2000);
    println!("1 A pushing, 60 deg/s limit: fastest {fastest:.1} deg/s");
    assert_eq!(
        out.report.stop_reason,
        StopReason::TickLimit,
        "{}",
        out.report
    );
    assert!(fastest > 55.0 && fastest <= 90.0, "{fastest}");
    assert!(high > 80.0, "it did not turn: {high}");
    assert!(out.report.stats.motors[0].counters.limited_commands > 0);
    // A link falling freely is faster than 60 + 30 deg/s: a fault, every motor off.
    let robot = arm(|m| m.velocity_limit(60.0));
    let clock = VirtualClock::new();
    let bus = sim_for(&robot, &clock, 0.0, Some(FALLING_LINK));
    let (out, _) = run(robot, clock, &bus, Push(0.0), 3000);
    let StopReason::Fault(Fault::JointLimit { breach, .. }) = out.report.stop_reason else {
        panic!("expected a joint-limit fault: {}", out.report);
    };
    println!(
        "falling link, 60 deg/s limit: fault at {:.1} deg/s",
        breach.value
    );
    assert_eq!(
        (breach.kind, breach.limit, breach.margin),
        (LimitKind::Velocity, 60.0, 30.0)
    );
    assert!(breach.value < -90.0, "{breach:?}");
    assert_eq!(bus.lock().snapshot(id(1)).unwrap().mode, ControlMode::Off);
}
