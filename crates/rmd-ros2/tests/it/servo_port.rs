//! The servo port on the real-time loop with the joint servo and simulated motors, in virtual
//! time (the loop stepped tick by tick here): validated messages move the simulated joints,
//! the servo's own refusals come back typed and counted by kind, diagnostics carry the servo's
//! state, the loop's statistics and how it ended, and the estop actions do what they say; on a
//! MyActuator V3 bus in motion mode, a position command goes out as a motion setpoint.
//! (The node over DDS on top of it: `tests/it/no_alloc.rs` here, and `tests/ros2/run.sh` against
//! Cyclone DDS.)

use std::ops::ControlFlow;
use std::time::Duration;

use rmd_bus::VirtualClock;
use rmd_loop::{LoopOutcome, RtLoop, Running, StopReason, robot::Robot};
use rmd_protocol::MotorId;
use rmd_ros2::msg;
use rmd_ros2::servo::{EstopAction, LoopFeed, ServoPort};
use rmd_ros2::{CommandMode, Enable, PortError, RejectionKind, RobotPort, Validator};
use rmd_servo::{ServoConfig, ServoController};
use rmd_sim::{ControlMode, SharedSimBus, SimBus};

const ROBOT: &str = r#"
[loop]
rate_hz = 1000.0
[[bus]]
name = "leg"
interface = "can0"
[[bus.motor]]
id = 1
name = "hip"
gear_ratio = 9.0
torque_constant_nm_per_amp = 2.09
current_limit_amps = 8.0
temperature_limit_celsius = 70.0
zero_offset_deg = 20.0
[[bus.motor]]
id = 2
name = "knee"
gear_ratio = 9.0
torque_constant_nm_per_amp = 2.09
current_limit_amps = 8.0
zero_offset_deg = 20.0
"#;

const SERVO: &str = r#"
[defaults]
kp_nm_per_rad = 60.0
kd_nm_s_per_rad = 1.5
position_min_rad = -0.6
position_max_rad = 0.6
stale_policy = "never"
"#;

/// How close a joint comes to a commanded position: the simulated motors' friction (about
/// 0.34 N·m at the joint) against kp = 60 N·m/rad leaves up to 6 mrad.
const TOL: f64 = 0.01;

static HOOK: std::sync::Once = std::sync::Once::new();

type Loop<'a> = Running<&'a mut SimBus<VirtualClock>, VirtualClock, ServoController>;

struct Rig {
    robot: Robot,
    clock: VirtualClock,
    buses: Vec<SimBus<VirtualClock>>,
    controller: Option<ServoController>,
    feed: LoopFeed,
}

/// The loop's parts, and the port (apart: the loop borrows the buses while the test uses the
/// port).
fn rig(estop: EstopAction) -> (Rig, ServoPort) {
    let robot = Robot::from_toml(ROBOT).unwrap();
    let (servo, handle) = ServoController::new(ServoConfig::from_toml(&robot, SERVO).unwrap());
    let clock = VirtualClock::new();
    let buses = rmd_rig::open::sim_buses(&clock, rmd_rig::sim::sim_configs(&robot, 3)).unwrap();
    let feed = LoopFeed::new();
    let port = ServoPort::new(handle, &robot, clock.clone())
        .unwrap()
        .with_feed(feed.clone())
        .with_estop(estop);
    let rig = Rig {
        robot,
        clock,
        buses,
        controller: Some(servo),
        feed,
    };
    (rig, port)
}

impl Rig {
    fn start(&mut self) -> Loop<'_> {
        let rt = RtLoop::unsupervised(
            self.robot.clone(),
            self.clock.clone(),
            self.buses.iter_mut().collect(),
            self.controller.take().unwrap(),
        )
        .unwrap();
        let mut running = rt.start().map_err(|o| o.report.to_string()).unwrap();
        // The loop's panic hook keeps panics of its thread quiet until the run ends; this
        // thread steps the loop, so let the assertions' messages through.
        HOOK.call_once(|| std::panic::set_hook(Box::new(|info| eprintln!("{info}"))));
        let _ = running.step();
        running
    }
}

/// Steps `ticks` ticks; the reason if the loop stopped.
fn step(running: &mut Loop<'_>, ticks: usize) -> Option<StopReason> {
    for _ in 0..ticks {
        if let ControlFlow::Break(reason) = running.step() {
            return Some(reason);
        }
    }
    None
}

fn finish(running: Loop<'_>, reason: StopReason) -> LoopOutcome<ServoController> {
    running.finish(reason)
}

fn command(names: &[&str], position: &[f64]) -> msg::JointState {
    msg::JointState {
        name: names.iter().map(|s| s.to_string()).collect(),
        position: position.to_vec(),
        ..Default::default()
    }
}

fn point(seconds: f64, positions: &[f64], velocities: &[f64]) -> msg::JointTrajectoryPoint {
    msg::JointTrajectoryPoint {
        positions: positions.to_vec(),
        velocities: velocities.to_vec(),
        time_from_start: msg::Duration {
            sec: seconds.trunc() as i32,
            nanosec: (seconds.fract() * 1e9).round() as u32,
        },
        ..Default::default()
    }
}

fn trajectory(names: &[&str], points: Vec<msg::JointTrajectoryPoint>) -> msg::JointTrajectory {
    msg::JointTrajectory {
        joint_names: names.iter().map(|s| s.to_string()).collect(),
        points,
        ..Default::default()
    }
}

#[test]
fn validated_commands_and_trajectories_move_the_simulated_joints() {
    let (mut rig, mut port) = rig(EstopAction::Disable);
    let validator = Validator::new(port.joints(), CommandMode::Auto);
    let mut running = rig.start();

    let first = port.latest_state().expect("a state after the first tick");
    assert_eq!(first.position_rad.len(), 2);
    assert!(
        first.position_rad.iter().all(|p| p.abs() < 0.01),
        "{first:?}"
    );
    // Once per tick: no new tick, nothing to publish.
    assert!(port.latest_state().is_none());
    assert!(step(&mut running, 10).is_none());
    let later = port.latest_state().unwrap();
    let dt = later.stamp.duration_since(first.stamp).unwrap();
    assert!(
        (dt.as_secs_f64() - 0.010).abs() < 0.0015,
        "stamps follow the loop's clock: {dt:?}"
    );

    // A position command, as topic_based_ros2_control sends it (all three arrays).
    let both = msg::JointState {
        velocity: vec![0.0, 0.0],
        effort: vec![0.0, 0.0],
        ..command(&["hip", "knee"], &[0.3, -0.2])
    };
    port.send_setpoints(&validator.joint_command(&both).unwrap())
        .unwrap();
    assert!(step(&mut running, 600).is_none());
    let s = port.latest_state().unwrap();
    assert!((s.position_rad[0] - 0.3).abs() < TOL, "{s:?}");
    assert!((s.position_rad[1] + 0.2).abs() < TOL, "{s:?}");
    assert!(s.effort_nm.iter().all(|e| e.is_finite()));

    // A trajectory through a point and back (from -0.2: 0.4 rad up in 0.5 s, within the
    // default limits of 2 rad/s, 10 rad/s², 100 rad/s³).
    let wave = trajectory(
        &["knee"],
        vec![point(0.5, &[0.2], &[]), point(1.0, &[0.0], &[])],
    );
    port.send_trajectory(&validator.trajectory(&wave).unwrap())
        .unwrap();
    let mut peak: f64 = -1.0;
    for _ in 0..1300 {
        assert!(step(&mut running, 1).is_none());
        if let Some(s) = port.latest_state() {
            peak = peak.max(s.position_rad[1]);
        }
    }
    let s = port.handle().state().unwrap();
    let (hip, knee) = (s.joints()[0], s.joints()[1]);
    assert!((peak - 0.2).abs() < TOL, "peak {peak}");
    assert!(knee.position_rad.abs() < TOL, "{knee:?}");
    assert_eq!(knee.mode, rmd_servo::ServoMode::Hold, "{knee:?}");
    assert_eq!(knee.counters.trajectories, 1);
    assert_eq!(hip.counters.setpoints, 1);
    let outcome = finish(running, StopReason::Requested);
    assert!(outcome.report.normal_stop);
}

#[test]
fn the_servos_own_refusals_come_back_typed_and_counted_by_kind() {
    let (mut rig, mut port) = rig(EstopAction::Disable);
    let validator = Validator::new(port.joints(), CommandMode::Auto);
    let mut running = rig.start();

    // The node's validator and the servo agree on the limits: the validator refuses first.
    assert!(
        validator
            .joint_command(&command(&["knee"], &[0.7]))
            .is_err()
    );
    // Beyond the node's checks: a trajectory must end at rest (the servo's rule).
    let moving = trajectory(&["knee"], vec![point(0.5, &[0.3], &[0.4])]);
    let e = port
        .send_trajectory(&validator.trajectory(&moving).unwrap())
        .unwrap_err();
    assert_eq!(e.kind(), RejectionKind::Infeasible, "{e}");
    assert!(e.to_string().contains("end at rest"), "{e}");
    // A fast point near a limit whose motion overshoots it.
    let overshoot = trajectory(
        &["knee"],
        vec![point(0.2, &[0.55], &[2.0]), point(2.0, &[0.0], &[])],
    );
    let e = port
        .send_trajectory(&validator.trajectory(&overshoot).unwrap())
        .unwrap_err();
    assert_eq!(e.kind(), RejectionKind::OutOfLimit, "{e}");
    // Refused messages never reached the loop; the servo counted them on the knee.
    assert!(step(&mut running, 5).is_none());
    let knee = port.handle().state().unwrap().joints()[1];
    assert_eq!(knee.counters.trajectories, 0);
    assert_eq!(knee.counters.rejected, 2);

    // Estop (disable): the servo refuses until enabled; the refusal is the port's.
    port.set_enable(Enable::Estop).unwrap();
    let e = port
        .send_setpoints(
            &validator
                .joint_command(&command(&["knee"], &[0.1]))
                .unwrap(),
        )
        .unwrap_err();
    assert_eq!(e, PortError::Estopped);
    assert_eq!(e.kind(), RejectionKind::PortRefused);
    assert!(step(&mut running, 5).is_none());
    let s = port.handle().state().unwrap();
    assert!(!s.enabled);
    assert!(s.joints().iter().all(|j| j.commanded_effort_nm == 0.0));
    port.set_enable(Enable::Enabled).unwrap();
    port.send_setpoints(
        &validator
            .joint_command(&command(&["knee"], &[0.1]))
            .unwrap(),
    )
    .unwrap();
    assert!(step(&mut running, 400).is_none());
    let knee = port.latest_state().unwrap().position_rad[1];
    assert!((knee - 0.1).abs() < TOL, "{knee}");
    finish(running, StopReason::Requested);
}

#[test]
fn diagnostics_carry_the_servo_state_loop_statistics_and_the_end() {
    let (mut rig, mut port) = rig(EstopAction::Disable);
    let feed = rig.feed.clone();
    let robot = rig.robot.clone();
    let mut running = rig.start();
    assert!(step(&mut running, 200).is_none());
    feed.set_stats(running.stats().summary());

    let d = port.diagnostics();
    assert!(d.enabled);
    assert!(d.stopped.is_none());
    assert_eq!(d.timing.period, Duration::from_millis(1));
    assert!(d.timing.cycles >= 200, "{:?}", d.timing);
    assert!(d.timing.wake_latency_p99.is_some());
    let value = |values: &[(String, String)], key: &str| {
        values
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| panic!("no {key} in {values:?}"))
    };
    assert!(value(&d.values, "work_p99_us").parse::<f64>().is_ok());
    assert_eq!(d.motors.len(), 2);
    let hip = &d.motors[0];
    assert_eq!(hip.joint, "hip");
    assert_eq!(hip.hardware_id, "leg (can0) motor 1 (0x141)");
    assert!(
        hip.temperature_c.is_some_and(|t| t > 0.0 && t < 70.0),
        "{hip:?}"
    );
    // Two motors at 1 kHz leave room for the health rotation: the supply voltage the
    // simulated motors measure (the simulator's default supply) is read every other tick.
    let supply = rmd_sim::MotorParams::default().supply_voltage_v;
    assert!(
        hip.voltage_v.is_some_and(|v| (v - supply).abs() < 0.5),
        "{hip:?}"
    );
    assert!(value(&hip.values, "voltage").ends_with(" V"), "{hip:?}");
    assert_eq!(value(&hip.values, "mode"), "hold");
    assert_eq!(value(&hip.values, "missing_replies"), "0");
    assert!(hip.faults.is_empty() && hip.warnings.is_empty(), "{hip:?}");

    // Disabled: the loop's status says so, every joint at zero torque.
    port.set_enable(Enable::Estop).unwrap();
    assert!(step(&mut running, 2).is_none());
    let d = port.diagnostics();
    assert!(!d.enabled);
    assert_eq!(value(&d.motors[1].values, "mode"), "disabled");

    let outcome = finish(running, StopReason::Requested);
    feed.set_ended(&outcome.report, &robot);
    let d = port.diagnostics();
    let end = d.stopped.expect("the end is reported");
    assert!(end.normal);
    assert_eq!(end.reason, "stop requested");
    assert!(d.motors.iter().all(|m| m.faults.is_empty()));
}

#[test]
fn estop_can_end_the_run_and_nothing_enables_it_again() {
    let (mut rig, mut port) = rig(EstopAction::EndRun);
    let feed = rig.feed.clone();
    let robot = rig.robot.clone();
    let mut running = rig.start();
    assert!(step(&mut running, 5).is_none());
    port.set_enable(Enable::Estop).unwrap();
    let reason = step(&mut running, 5).expect("the loop halts");
    assert_eq!(reason, StopReason::ControllerHalted("estop"));
    let outcome = finish(running, reason);
    assert!(outcome.report.safe_stop.all_off_confirmed());
    assert!(matches!(
        port.set_enable(Enable::Enabled),
        Err(PortError::NotRunning(_))
    ));
    feed.set_ended(&outcome.report, &robot);
    let end = port.diagnostics().stopped.unwrap();
    assert!(!end.normal);
    assert!(end.reason.contains("estop"), "{end:?}");
}

#[test]
fn a_position_command_on_a_motion_bus_goes_out_as_a_motion_setpoint() {
    // The same joints on MyActuator V3 motors, their bus in motion mode; the simulated bus
    // shared, so that the test reads the motors while the loop runs.
    let toml = ROBOT.replace(
        "interface = \"can0\"\n",
        "interface = \"can0\"\nprotocol = \"myactuator-v3\"\nexchange = \"motion\"\n",
    );
    let robot = Robot::from_toml(&toml).unwrap();
    let (servo, handle) = ServoController::new(ServoConfig::from_toml(&robot, SERVO).unwrap());
    let clock = VirtualClock::new();
    let bus = rmd_rig::open::sim_buses(&clock, rmd_rig::sim::sim_configs(&robot, 3))
        .unwrap()
        .remove(0);
    let bus = SharedSimBus::new(bus);
    let mut port = ServoPort::new(handle, &robot, clock.clone()).unwrap();
    let validator = Validator::new(port.joints(), CommandMode::Auto);
    let rt = RtLoop::unsupervised(robot, clock, vec![bus.clone()], servo).unwrap();
    let mut running = rt.start().map_err(|o| o.report.to_string()).unwrap();
    HOOK.call_once(|| std::panic::set_hook(Box::new(|info| eprintln!("{info}"))));
    let _ = running.step();

    let both = command(&["hip", "knee"], &[0.3, -0.2]);
    port.send_setpoints(&validator.joint_command(&both).unwrap())
        .unwrap();
    for _ in 0..600 {
        assert!(running.step().is_continue());
    }
    let s = port.latest_state().unwrap();
    assert!((s.position_rad[0] - 0.3).abs() < TOL, "{s:?}");
    assert!((s.position_rad[1] + 0.2).abs() < TOL, "{s:?}");
    // By the simulated firmware: each motor runs the servo's law on the commanded position
    // (p_des at the output, from the motor's zero 20 degrees below the joint's), with the
    // servo's gains (kp 60 N·m/rad, kd 1.5 N·m·s/rad), and the joint is there.
    for (id, target) in [(1, 0.3), (2, -0.2)] {
        let snapshot = bus.lock().snapshot(MotorId::new(id).unwrap()).unwrap();
        match snapshot.mode {
            ControlMode::Motion {
                position_rad,
                kp,
                kd,
                ..
            } => {
                assert!((position_rad - 20f64.to_radians() - target).abs() < 1e-3);
                assert!(
                    (kp - 60.0).abs() < 0.2 && (kd - 1.5).abs() < 0.01,
                    "{kp} {kd}"
                );
            }
            other => panic!("motor {id} is in {other:?}, not motion mode"),
        }
        let truth = snapshot.output_angle_deg.to_radians();
        assert!((truth - target).abs() < TOL, "motor {id} at {truth} rad");
    }
    let outcome = running.finish(StopReason::Requested);
    assert!(outcome.report.normal_stop, "{}", outcome.report);
}
