//! The motion exchange (`exchange = "motion"`, MyActuator V3): one motion-mode command per motor
//! per tick on `0x400 + id`, answered on `0x500 + id`; the controller's setpoints in joint units;
//! judged by the simulated firmware's ground truth, in virtual time.

use crate::common;

use common::*;
use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, ExchangeKind, MotorConfig, Mounting, RobotConfig};
use rmd_loop::{
    BuildError, CommandKind, Commands, Controller, Feedback, Flow, MotionCommand, RawReply,
    Rejection, RtLoop, StopReason, TickContext, robot::Robot,
};
use rmd_protocol::{DecodedRequest, Dialect, MitRanges, V3_MOTION_BASE_ID, V3Firmware};
use rmd_sim::{ControlMode, Node, SimBus, SimConfig};

const V3: Dialect = Dialect::MyActuatorV3(V3Firmware {
    date: None,
    max_torque: None,
});

/// Joint zero offsets and directions of the three motors.
const JOINTS: [(f64, Mounting); 3] = [
    (20.0, Mounting::Normal),
    (-10.0, Mounting::Reversed),
    (0.0, Mounting::Normal),
];

fn robot(exchange: Option<ExchangeKind>) -> Robot {
    let mut bus = BusConfig::new("can0").protocol("myactuator-v3");
    if let Some(kind) = exchange {
        bus = bus.exchange(kind);
    }
    for (n, (zero, direction)) in (1..=3).zip(JOINTS) {
        bus = bus.with_motor(
            MotorConfig::new(n)
                .gear_ratio(GEAR)
                .torque_constant(KT)
                .current_limit(10.0)
                .zero_offset_deg(zero)
                .direction(direction)
                .position_limits(-120.0, 120.0),
        );
    }
    Robot::try_from(RobotConfig::new(500.0).with_bus(bus)).unwrap()
}

fn sim(clock: &VirtualClock) -> SimBus<VirtualClock> {
    let mut config = SimConfig::with_motors(0).seed(5);
    config.motors = (1..=3)
        .map(|n| {
            let mut m = rmd_sim::SimMotorConfig::new(id(n));
            m.firmware.speak(V3);
            m
        })
        .collect();
    let mut bus = SimBus::new(clock.clone(), config).unwrap();
    bus.record_trace(2_000_000);
    bus
}

/// Moves each joint along a smooth path to its target in motion mode, with velocity feed-
/// forward; records the largest tracking error after the first second.
struct Follow {
    targets: [f64; 3],
    start: Option<[f64; 3]>,
    worst_error_deg: f64,
    motion: bool,
}

impl Follow {
    fn new(targets: [f64; 3], motion: bool) -> Self {
        Self {
            targets,
            start: None,
            worst_error_deg: 0.0,
            motion,
        }
    }

    /// Position and velocity at `t` s of a 1 s cosine blend from `a` to `b`.
    fn path(a: f64, b: f64, t: f64) -> (f64, f64) {
        let s = t.clamp(0.0, 1.0);
        let blend = 0.5 - 0.5 * (core::f64::consts::PI * s).cos();
        let rate = if t < 1.0 {
            0.5 * core::f64::consts::PI * (core::f64::consts::PI * s).sin()
        } else {
            0.0
        };
        (a + (b - a) * blend, (b - a) * rate)
    }
}

impl Controller for Follow {
    fn command_kind(&self, _: &rmd_loop::robot::JointSpec) -> CommandKind {
        if self.motion {
            CommandKind::Motion
        } else {
            CommandKind::Current
        }
    }

    fn start(&mut self, _: &TickContext, feedback: &Feedback<'_>) {
        let mut start = [0.0; 3];
        for (j, f) in feedback.iter() {
            start[j.index()] = f.joint.angle_deg;
        }
        self.start = Some(start);
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        let start = self.start.unwrap_or_default();
        for (j, f) in feedback.iter() {
            let i = j.index();
            let (p, v) = Self::path(start[i], self.targets[i], ctx.time_s());
            if ctx.time_s() > 1.5 {
                self.worst_error_deg = self.worst_error_deg.max((f.joint.angle_deg - p).abs());
            }
            if self.motion {
                cmd.set_motion(
                    j,
                    MotionCommand {
                        position_deg: p,
                        velocity_dps: v,
                        kp_nm_per_deg: 1.0,
                        kd_nm_per_dps: 0.02,
                        torque_nm: 0.0,
                    },
                );
            } else {
                let torque = 1.0 * (p - f.joint.angle_deg) + 0.02 * (v - f.joint.velocity_dps);
                cmd.set_torque(j, torque);
            }
        }
        Flow::Continue
    }
}

#[test]
fn a_v3_leg_follows_its_path_in_motion_mode_by_ground_truth() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock);
    let robot = robot(Some(ExchangeKind::Motion));
    assert_eq!(robot.buses()[0].exchange, ExchangeKind::Motion);
    let targets = [30.0, -45.0, 60.0];
    let rt =
        RtLoop::unsupervised(robot, clock, vec![&mut bus], Follow::new(targets, true)).unwrap();
    let telemetry = {
        let mut rt = rt;
        let t = rt.telemetry();
        let mut running = started(rt);
        for _ in 0..1500 {
            assert!(running.step().is_continue());
        }
        let out = running.finish(StopReason::Requested);
        let r = &out.report;
        assert_eq!(r.stats.missing_replies, 0, "{r}");
        assert_eq!(r.stats.late_replies, 0, "{r}");
        assert!(
            r.stats
                .motors
                .iter()
                .all(|m| m.counters.rejected_commands == 0),
            "{r}"
        );
        assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
        assert!(
            out.controller.worst_error_deg < 1.0,
            "tracking error {} deg",
            out.controller.worst_error_deg
        );
        t
    };
    let sample = telemetry.latest().unwrap();
    for j in sample.joints() {
        assert!(
            matches!(j.feedback.raw, RawReply::Motion(_)),
            "{:?}",
            j.feedback
        );
    }
    assert!(
        !sent_multi_torque(&bus),
        "a 0x280 frame went out on a V3 bus"
    );
    // Ground truth: each output shaft ended where the joint's target puts it
    // (`output = sign * (joint + zero)`), and the motor is off.
    for (n, ((zero, direction), target)) in (1..=3).zip(JOINTS.into_iter().zip(targets)) {
        let snap = bus.snapshot(id(n)).unwrap();
        let output = direction.sign() * (target + zero);
        assert!(
            (snap.output_angle_deg - output).abs() < 1.0,
            "motor {n}: output {} deg, expected {output}",
            snap.output_angle_deg
        );
        assert_eq!(snap.mode, ControlMode::Off, "motor {n}");
    }
    // Every tick's three motion commands (0x401..=0x403) went out before any of its replies
    // (0x501..=0x503), and they carried the packing of the manual's ranges.
    // (The health rotation's status requests and replies, on 0x140 + id and 0x240 + id, go
    // between them.)
    let motion: Vec<_> = bus
        .trace()
        .iter()
        .filter(|t| (0x400..0x600).contains(&t.frame.id()))
        .collect();
    let mut ticks = 0;
    for (i, t) in motion.iter().enumerate() {
        if t.from == Node::Host && t.frame.id() == V3_MOTION_BASE_ID + 1 && i + 6 <= motion.len() {
            let next: Vec<u16> = motion[i..i + 6].iter().map(|t| t.frame.id()).collect();
            let (mut req, mut rep) = (next[..3].to_vec(), next[3..].to_vec());
            req.sort_unstable();
            rep.sort_unstable();
            if req == [0x401, 0x402, 0x403] {
                assert_eq!(rep, [0x501, 0x502, 0x503], "{next:x?}");
                ticks += 1;
            }
        }
    }
    assert!(ticks >= 1400, "{ticks} motion exchanges");
}

#[test]
fn motion_mode_and_torque_per_motor_reach_the_same_targets_by_ground_truth() {
    let targets = [10.0, 15.0, -20.0];
    for (exchange, motion) in [
        (ExchangeKind::Motion, true),
        (ExchangeKind::PerMotor, false),
    ] {
        let clock = VirtualClock::new();
        let mut bus = sim(&clock);
        let rt = RtLoop::unsupervised(
            robot(Some(exchange)),
            clock,
            vec![&mut bus],
            Follow::new(targets, motion),
        )
        .unwrap();
        let mut running = started(rt);
        for _ in 0..1200 {
            assert!(running.step().is_continue());
        }
        let out = running.finish(StopReason::Requested);
        assert_eq!(out.report.stats.missing_replies, 0, "{}", out.report);
        // The loop's view: within 2 degrees of the path after 1.5 s (V3's status replies
        // carry whole output degrees; motion replies 16 bits over +-12.5 rad).
        assert!(
            out.controller.worst_error_deg < 2.0,
            "{exchange}: {}",
            out.controller.worst_error_deg
        );
        drop(out);
        // Ground truth (the motors are off and unloaded: they stay where they were held).
        for (n, ((zero, direction), target)) in (1..=3).zip(JOINTS.into_iter().zip(targets)) {
            let output = bus.snapshot(id(n)).unwrap().output_angle_deg;
            let expected = direction.sign() * (target + zero);
            assert!(
                (output - expected).abs() < 1.0,
                "{exchange} motor {n}: output {output} deg, expected {expected}"
            );
        }
    }
}

#[test]
fn motion_mode_is_refused_where_a_bus_has_none() {
    // A torque bus: the controller's motion mode is refused when the loop is built.
    let clock = VirtualClock::new();
    let mut bus = sim(&clock);
    let err = RtLoop::unsupervised(
        robot(None),
        clock,
        vec![&mut bus],
        Follow::new([0.0; 3], true),
    )
    .err()
    .unwrap();
    assert!(
        matches!(&err, BuildError::NoMotionMode { joint, exchange: ExchangeKind::PerMotor } if joint == "bus0_motor1"),
        "{err}"
    );
    assert!(err.to_string().contains("exchange = \"motion\""), "{err}");
    // A v1.61 motor on a motion bus: refused by the description.
    let v161 = RobotConfig::new(500.0).with_bus(
        BusConfig::new("can0")
            .exchange(ExchangeKind::Motion)
            .with_motor(MotorConfig::new(1).torque_constant(KT)),
    );
    let err = Robot::try_from(v161).unwrap_err().to_string();
    assert!(err.contains("no motion mode"), "{err}");
    // A V3 motor without a torque constant: refused too.
    let no_kt = RobotConfig::new(500.0).with_bus(
        BusConfig::new("can0")
            .protocol("myactuator-v3")
            .exchange(ExchangeKind::Motion)
            .with_motor(MotorConfig::new(1)),
    );
    let err = Robot::try_from(no_kt).unwrap_err().to_string();
    assert!(err.contains("torque constant"), "{err}");
    // A temperature limit on a motion bus is watched through the health rotation's status
    // replies (motion replies carry no temperature): refused where the rotation has no room.
    let hot = |rate_hz: f64| {
        let mut bus = BusConfig::new("can0")
            .protocol("myactuator-v3")
            .exchange(ExchangeKind::Motion);
        for n in 1..=3 {
            bus = bus.with_motor(
                MotorConfig::new(n)
                    .torque_constant(KT)
                    .temperature_limit(70.0),
            );
        }
        Robot::try_from(RobotConfig::new(rate_hz).with_bus(bus))
    };
    let err = hot(1000.0).unwrap_err().to_string();
    assert!(
        err.contains("carry no temperature") && err.contains("no room"),
        "{err}"
    );
    assert!(hot(500.0).unwrap().buses()[0].health_rotation);
}

/// Commands joint 0 with a setpoint beyond its limits once, at tick 100.
struct BeyondOnce;

impl Controller for BeyondOnce {
    fn command_kind(&self, _: &rmd_loop::robot::JointSpec) -> CommandKind {
        CommandKind::Motion
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        for (j, f) in feedback.iter() {
            let position = if ctx.index == 100 && j.index() == 0 {
                500.0
            } else {
                f.joint.angle_deg
            };
            cmd.set_motion(j, MotionCommand::hold(position, 0.5, 0.01));
        }
        Flow::Continue
    }
}

#[test]
fn a_setpoint_beyond_the_limits_is_refused_and_the_run_stops_safe() {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock);
    let rt = RtLoop::unsupervised(
        robot(Some(ExchangeKind::Motion)),
        clock,
        vec![&mut bus],
        BeyondOnce,
    )
    .unwrap();
    let out = rt.run(rmd_loop::RunLimit::Ticks(1000));
    let r = &out.report;
    match &r.stop_reason {
        StopReason::Fault(rmd_loop::Fault::RejectedCommand { joint, reason }) => {
            assert_eq!(joint.map(|j| j.index()), Some(0));
            assert_eq!(*reason, Rejection::BeyondJointLimits);
        }
        other => panic!("{other:?}"),
    }
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    drop(out);
    // No motion command ever carried a position beyond the joint's limit (output 120 + 20
    // degrees at most for joint 0).
    let mut commands = 0;
    for t in bus.trace() {
        if t.from == Node::Host
            && let Ok(DecodedRequest::Mit { motor, command }) = V3.decode_request(&t.frame)
            && motor == id(1)
        {
            assert_eq!(command.ranges(), MitRanges::V4_3);
            assert!(command.position_rad().to_degrees() < 140.5, "{command:?}");
            commands += 1;
        }
    }
    assert!(commands >= 100, "{commands}");
    let snap = bus.snapshot(id(1)).unwrap();
    assert_eq!(snap.mode, ControlMode::Off);
}
