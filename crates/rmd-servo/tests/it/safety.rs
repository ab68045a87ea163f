//! What keeps the servo safe, on simulated motors (virtual time): the stale-setpoint policies,
//! limits (refused setpoints, clamped output), bad input refused on the caller's side and
//! counted, enable / disable, estop, a joint outside its limits at start.

use crate::common;

use std::time::Duration;

use common::{Bench, JOINTS, SERVO};
use rmd_loop::StopReason;
use rmd_servo::{
    JointTrajectory, JointTrajectoryPoint, ServoError, ServoMode, Setpoint, TrajectoryRefusal,
};
use rmd_sim::ControlMode;

fn ms(t: u64) -> Duration {
    Duration::from_millis(t)
}

#[test]
fn a_stale_setpoint_holds_its_position() {
    let servo = format!(
        "{SERVO}\n[joint.knee]\nstale_after_ms = 50\nstale_policy = \"hold\"\n[joint.hip_fe]\nstale_after_ms = 50\nstale_policy = \"hold\"\n"
    );
    let mut bench = Bench::new(&servo, [0.0; 4]);
    bench.handle.set_position("knee", 0.2, 0.0, 0.0).unwrap();
    bench.handle.set_velocity("hip_fe", 0.5, 0.0).unwrap();
    bench.run_s(0.045);
    let s = bench.state().unwrap();
    assert_eq!(s.joints()[2].mode, ServoMode::Position);
    assert!(!s.joints()[2].stale);
    bench.run_s(0.01);
    let s = bench.state().unwrap();
    let (knee, hip) = (s.joints()[2], s.joints()[1]);
    for j in [knee, hip] {
        assert_eq!(j.mode, ServoMode::Hold, "{j:?}");
        assert!(j.stale);
        assert_eq!(j.counters.stale_events, 1);
    }
    // The knee holds its target; the hip where its moving reference was.
    assert_eq!(knee.reference.unwrap().position_rad, 0.2);
    let hip_hold = hip.reference.unwrap().position_rad;
    assert!(hip_hold > 0.02 && hip_hold < 0.03, "{hip_hold}");
    bench.run_s(0.5);
    assert!((bench.truth_rad(2) - 0.2).abs() < 0.01);
    assert!((bench.truth_rad(1) - hip_hold).abs() < 0.01);
    assert!(bench.truth_rad_s(1).abs() < 0.01);
    // A setpoint renewed in time never goes stale; a new one clears the flag.
    for _ in 0..10 {
        bench.handle.set_position("knee", 0.1, 0.0, 0.0).unwrap();
        bench.run_s(0.04);
    }
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::Position);
    assert!(!knee.stale);
    assert_eq!(knee.counters.stale_events, 1);
    // Joints with the default rule ("never" in these tests) keep their setpoint.
    bench.handle.set_position("ankle", 0.1, 0.0, 0.0).unwrap();
    bench.run_s(0.5);
    assert_eq!(bench.state().unwrap().joints()[3].mode, ServoMode::Position);
}

#[test]
fn a_stale_setpoint_goes_to_zero_torque() {
    let servo =
        format!("{SERVO}\n[joint.knee]\nstale_after_ms = 50\nstale_policy = \"zero-torque\"\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    bench.handle.set_velocity("knee", 0.5, 0.0).unwrap();
    bench.run_s(0.06);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::ZeroTorque);
    assert!(knee.stale && knee.reference.is_none());
    assert_eq!(knee.commanded_effort_nm, 0.0);
    assert_eq!(knee.counters.stale_events, 1);
    bench.run_s(0.01);
    // The motor's current follows (0.2 ms current loop): nothing left.
    assert!(
        bench.motor(2).current_a.abs() < 0.02,
        "{:?}",
        bench.motor(2)
    );
    // Friction brings it to rest; nothing pushes it.
    bench.run_s(0.3);
    assert!(bench.truth_rad_s(2).abs() < 0.01);
    // A new setpoint takes over again.
    bench.handle.set_position("knee", 0.0, 0.0, 0.0).unwrap();
    bench.step(1);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::Position);
    assert!(!knee.stale);
}

#[test]
fn setpoints_beyond_the_limits_are_refused_and_counted() {
    let servo = format!(
        "{SERVO}\n[joint.knee]\nposition_min_rad = -0.5\nposition_max_rad = 0.5\nmax_effort_nm = 5.0\n"
    );
    let mut bench = Bench::new(&servo, [0.0; 4]);
    let h = &bench.handle;
    let err = h.set_position("knee", 0.6, 0.0, 0.0).unwrap_err();
    assert!(
        matches!(&err, ServoError::OutOfLimit { joint, field: "position_rad", value, min, max, .. }
            if joint == "knee" && *value == 0.6 && *min == -0.5 && *max == 0.5),
        "{err}"
    );
    assert_eq!(
        err.to_string(),
        "joint `knee`: position_rad is 0.6, outside the joint's limits [-0.5, 0.5] (servo configuration: position_max_rad)"
    );
    assert!(matches!(
        h.set_velocity("knee", 2.5, 0.0),
        Err(ServoError::OutOfLimit {
            field: "velocity_rad_s",
            ..
        })
    ));
    assert!(matches!(
        h.set_effort("knee", -5.5),
        Err(ServoError::OutOfLimit {
            field: "effort_nm",
            ..
        })
    ));
    assert!(matches!(
        h.set_position("knee", 0.1, 0.0, 6.0),
        Err(ServoError::OutOfLimit {
            field: "effort_ff_nm",
            ..
        })
    ));
    assert!(matches!(
        h.set_position("knee", 0.1, -3.0, 0.0),
        Err(ServoError::OutOfLimit {
            field: "velocity_ff_rad_s",
            ..
        })
    ));
    // A trajectory through a point beyond the limit, or whose motion overshoots it.
    let beyond = JointTrajectory::new(["knee"]).point(JointTrajectoryPoint::at(ms(500), [0.7]));
    assert!(matches!(
        h.send_trajectory(&beyond),
        Err(ServoError::Trajectory(TrajectoryRefusal::OutOfLimit {
            point: 0,
            ..
        }))
    ));
    let overshoot = JointTrajectory::new(["knee"])
        .point(JointTrajectoryPoint::at(ms(300), [0.49]).with_velocities([1.5]))
        .point(JointTrajectoryPoint::at(ms(900), [0.0]));
    let err = h.send_trajectory(&overshoot).unwrap_err();
    assert!(
        matches!(&err, ServoError::Trajectory(TrajectoryRefusal::LeavesPositionLimits { point: 1, reached, .. }) if *reached > 0.5),
        "{err}"
    );
    bench.step(1);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.counters.rejected, 7);
    // Nothing reached the loop thread.
    assert_eq!(knee.mode, ServoMode::Hold);
    assert_eq!(knee.counters.setpoints, 0);
    assert_eq!(knee.counters.trajectories, 0);
    assert_eq!(bench.handle.rejected_unattributed(), 0);
    // Within the limits: taken.
    bench.handle.set_position("knee", 0.5, 0.0, 5.0).unwrap();
}

#[test]
fn the_output_is_clamped_to_max_effort() {
    let servo = format!("{SERVO}\n[joint.knee]\nmax_effort_nm = 3.0\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    // 0.4 rad of error at 60 N·m/rad asks for 24 N·m.
    bench.handle.set_position("knee", 0.4, 0.0, 0.0).unwrap();
    bench.step(1);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.commanded_effort_nm, 3.0);
    let mut peak = 0.0f64;
    for _ in 0..300 {
        bench.step(1);
        peak = peak.max(bench.motor(2).output_torque_nm.abs());
    }
    // At most 3 N·m, within one current step (0.034 N·m).
    assert!(peak <= 3.0 + 0.035, "{peak}");
    assert!(peak > 2.9, "{peak}");
    let knee = bench.state().unwrap().joints()[2];
    assert!(knee.counters.clamped > 10, "{knee:?}");
    bench.run_s(1.0);
    assert!((bench.truth_rad(2) - 0.4).abs() < 0.01);
    // The loop itself never had to clamp or reject anything.
    let report = bench.finish().report;
    assert!(
        report
            .stats
            .motors
            .iter()
            .all(|m| m.counters.clamped_commands == 0 && m.counters.rejected_commands == 0),
        "{report}"
    );
}

#[test]
fn bad_input_is_refused_on_the_callers_side_with_typed_errors_and_counted() {
    let servo = format!("{SERVO}\n[servo]\nmax_trajectory_points = 8\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    let h = bench.handle.clone();
    let err = h.set_position("elbow", 0.1, 0.0, 0.0).unwrap_err();
    assert_eq!(
        err.to_string(),
        "no joint named `elbow` (the servo's joints: hip_aa, hip_fe, knee, ankle)"
    );
    assert!(matches!(
        h.set_effort(rmd_loop::JointId::from_index(9), 0.1),
        Err(ServoError::UnknownJointId { count: 4, .. })
    ));
    assert!(matches!(
        h.set_position("knee", f64::NAN, 0.0, 0.0),
        Err(ServoError::NotFinite {
            field: "position_rad",
            ..
        })
    ));
    assert!(matches!(
        h.set_velocity("hip_aa", f64::INFINITY, 0.0),
        Err(ServoError::NotFinite {
            field: "velocity_rad_s",
            ..
        })
    ));
    // A batch is all or nothing: a joint twice, or one bad entry, sends nothing.
    assert!(matches!(
        h.set_many([
            ("hip_aa", Setpoint::position(0.1)),
            ("hip_aa", Setpoint::position(0.2))
        ]),
        Err(ServoError::DuplicateJoint { .. })
    ));
    assert!(matches!(
        h.set_many([
            ("hip_fe", Setpoint::position(0.1)),
            ("ankle", Setpoint::effort(f64::NAN))
        ]),
        Err(ServoError::NotFinite { .. })
    ));
    // Trajectories: shape, times, values, names.
    let t = |points: Vec<JointTrajectoryPoint>| {
        let mut t = JointTrajectory::new(["knee", "ankle"]);
        t.points = points;
        t
    };
    let refused = |traj: &JointTrajectory| match h.send_trajectory(traj) {
        Err(ServoError::Trajectory(r)) => r,
        other => panic!("expected a refusal, got {other:?}"),
    };
    assert_eq!(refused(&t(vec![])), TrajectoryRefusal::NoPoints);
    assert!(matches!(
        refused(&t(vec![JointTrajectoryPoint::at(ms(100), [0.1])])),
        TrajectoryRefusal::LengthMismatch {
            point: 0,
            field: "positions",
            len: 1,
            joints: 2
        }
    ));
    assert!(matches!(
        refused(&t(vec![
            JointTrajectoryPoint::at(ms(100), [0.1, 0.0]).with_velocities([0.0])
        ])),
        TrajectoryRefusal::LengthMismatch {
            field: "velocities",
            ..
        }
    ));
    assert_eq!(
        refused(&t(vec![
            JointTrajectoryPoint::at(ms(100), [0.1, 0.0]),
            JointTrajectoryPoint::at(ms(100), [0.2, 0.0]),
        ])),
        TrajectoryRefusal::TimeNotIncreasing { point: 1 }
    );
    assert!(matches!(
        refused(&t((1..=9)
            .map(|k| JointTrajectoryPoint::at(ms(100 * k), [0.0, 0.0]))
            .collect())),
        TrajectoryRefusal::TooManyPoints { points: 9, max: 8 }
    ));
    assert!(matches!(
        refused(&t(vec![JointTrajectoryPoint::at(ms(100), [0.1, f64::NAN])])),
        TrajectoryRefusal::NotFinite { point: 0, .. }
    ));
    assert!(matches!(
        refused(&t(vec![
            JointTrajectoryPoint::at(ms(100), [0.1, 0.0]).with_velocities([0.2, 0.0])
        ])),
        TrajectoryRefusal::EndsMoving { .. }
    ));
    let mut unknown = t(vec![JointTrajectoryPoint::at(ms(100), [0.1, 0.0])]);
    unknown.joint_names[1] = "wrist".into();
    assert!(matches!(
        h.send_trajectory(&unknown),
        Err(ServoError::UnknownJoint { .. })
    ));
    unknown.joint_names[1] = "knee".into();
    assert!(matches!(
        h.send_trajectory(&unknown),
        Err(ServoError::DuplicateJoint { .. })
    ));
    bench.step(2);
    let state = bench.state().unwrap();
    let rejected: Vec<u64> = state.joints().iter().map(|j| j.counters.rejected).collect();
    // hip_aa: infinity, twice in a batch; hip_fe: none (its batch failed on the ankle);
    // knee: NaN, ends moving, the trajectory's duplicate; ankle: NaN in a batch and in a
    // trajectory.
    assert_eq!(rejected, [2, 0, 3, 2]);
    // elbow, #9, five trajectory shapes that name no joint, wrist.
    assert_eq!(h.rejected_unattributed(), 8);
    // Nothing reached the loop thread.
    for j in state.joints() {
        assert_eq!(j.mode, ServoMode::Hold);
        assert_eq!(j.counters.setpoints + j.counters.trajectories, 0);
    }
    // Errors say what to do.
    assert!(
        ServoError::QueueFull { capacity: 64 }
            .to_string()
            .contains("servo.queue_capacity")
    );
}

#[test]
fn disable_zeroes_the_torque_and_enable_holds_where_the_joint_is() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_velocity("knee", 1.0, 0.0).unwrap();
    bench.run_s(0.3);
    // A setpoint sent just before the disable never applies, even after an enable.
    bench.handle.set_position("hip_aa", 0.3, 0.0, 0.0).unwrap();
    bench.handle.disable();
    assert!(!bench.handle.is_enabled());
    assert_eq!(
        bench.handle.set_position("knee", 0.0, 0.0, 0.0),
        Err(ServoError::Disabled)
    );
    bench.step(1);
    let s = bench.state().unwrap();
    assert!(!s.enabled);
    assert_eq!(s.dropped_messages, 1);
    for j in s.joints() {
        assert_eq!(j.mode, ServoMode::Disabled);
        assert_eq!(j.commanded_effort_nm, 0.0);
        assert!(j.reference.is_none());
    }
    // The loop runs on, the motors at zero torque: the knee coasts to rest under friction.
    bench.run_s(0.5);
    assert!(bench.motor(2).current_a.abs() < 0.02);
    assert_eq!(bench.motor(2).mode, ControlMode::Torque { current_a: 0.0 });
    assert!(bench.truth_rad_s(2).abs() < 0.01);
    let coasted = bench.truth_rad(2);
    bench.handle.enable();
    bench.step(1);
    let s = bench.state().unwrap();
    assert!(s.enabled);
    for (i, j) in s.joints().iter().enumerate() {
        assert_eq!(j.mode, ServoMode::Hold);
        // Where it is, not where an old setpoint wanted it.
        assert!((j.reference.unwrap().position_rad - bench.truth_rad(i)).abs() < 0.002);
    }
    bench.run_s(0.3);
    assert!((bench.truth_rad(2) - coasted).abs() < 0.005);
    assert!(bench.truth_rad(0).abs() < 0.005, "hip_aa never went to 0.3");
    // A trajectory running at a disable is dropped and does not resume.
    let t = JointTrajectory::new(["ankle"]).point(JointTrajectoryPoint::at(ms(800), [0.3]));
    bench.handle.send_trajectory(&t).unwrap();
    bench.run_s(0.2);
    bench.handle.set_enabled(false);
    bench.step(1);
    bench.handle.set_enabled(true);
    bench.run_s(1.0);
    let ankle = bench.state().unwrap().joints()[3];
    assert_eq!(ankle.mode, ServoMode::Hold);
    assert!(bench.truth_rad(3) < 0.2, "{}", bench.truth_rad(3));
    assert!(bench.finish().report.normal_stop);
}

#[test]
fn estop_ends_the_run_with_every_motor_off() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_velocity("knee", 1.0, 0.0).unwrap();
    bench.run_s(0.2);
    assert!(bench.motor(2).energising);
    bench.handle.estop();
    assert_eq!(
        bench.handle.set_effort("knee", 0.0),
        Err(ServoError::EStopped)
    );
    bench.step(5);
    assert!(bench.running.is_none(), "the loop ended");
    let outcome = bench.outcome.take().unwrap();
    assert_eq!(
        outcome.report.stop_reason,
        StopReason::ControllerHalted("estop")
    );
    assert!(
        outcome.report.safe_stop.all_off_confirmed(),
        "{}",
        outcome.report
    );
    for i in 0..JOINTS.len() {
        assert_eq!(bench.motor(i).mode, ControlMode::Off);
    }
    assert!(bench.handle.has_stopped() && bench.handle.is_estopped());
    let last = bench.handle.state().unwrap();
    assert!(last.estopped);
    assert!(last.joints().iter().all(|j| j.commanded_effort_nm == 0.0));
}

#[test]
fn a_joint_outside_its_limits_at_start_halts_the_loop() {
    let servo = format!("{SERVO}\n[joint.ankle]\nposition_min_rad = 0.1\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    assert!(bench.running.is_none());
    let outcome = bench.outcome.take().unwrap();
    assert_eq!(
        outcome.report.stop_reason,
        StopReason::ControllerHalted("a joint is outside its position limits at start")
    );
    bench.step(1);
    assert_eq!(bench.motor(3).mode, ControlMode::Off);
    assert_eq!(
        bench.handle.set_effort("knee", 0.0),
        Err(ServoError::Stopped)
    );
}

#[test]
fn a_servo_disabled_at_start_waits_for_enable() {
    let servo = format!("{SERVO}\n[servo]\nenabled_at_start = false\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    let s = bench.state().unwrap();
    assert!(!s.enabled);
    assert!(s.joints().iter().all(|j| j.mode == ServoMode::Disabled));
    assert_eq!(
        bench.handle.set_position("knee", 0.1, 0.0, 0.0),
        Err(ServoError::Disabled)
    );
    bench.handle.enable();
    bench.handle.set_position("knee", 0.1, 0.0, 0.0).unwrap();
    bench.step(1);
    let s = bench.state().unwrap();
    assert_eq!(s.joints()[2].mode, ServoMode::Position);
    assert_eq!(s.joints()[0].mode, ServoMode::Hold);
    bench.run_s(1.0);
    assert!((bench.truth_rad(2) - 0.1).abs() < 0.01);
}

#[test]
fn a_servo_configured_for_another_robot_halts_the_loop() {
    use rmd_loop::robot::Robot;
    use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
    use rmd_servo::{ServoConfig, ServoController};
    // Two joints named differently: the loop's robot has four.
    let other = Robot::try_from(
        RobotConfig::new(1000.0).with_bus(
            BusConfig::new("sim")
                .with_motor(MotorConfig::new(1).name("a").torque_constant(2.09))
                .with_motor(MotorConfig::new(2).name("b").torque_constant(2.09)),
        ),
    )
    .unwrap();
    let (servo, handle) = ServoController::new(ServoConfig::defaults(&other).unwrap());
    let mut bench = Bench::with(common::robot(), servo, handle, [0.0; 4]);
    let outcome = bench.outcome.take().expect("the loop halted");
    assert_eq!(
        outcome.report.stop_reason,
        StopReason::ControllerHalted("the servo's configuration was built for another robot")
    );
    bench.step(1);
    for i in 0..JOINTS.len() {
        assert_eq!(bench.motor(i).mode, ControlMode::Off);
    }
}

/// The leg with the joint limits of the examples' leg in its robot description (degrees), its
/// power-up windows centred on the pose `pose_deg`.
fn limited_leg(pose_deg: [f64; 4]) -> rmd_loop::robot::Robot {
    use rmd_loop::mapping::centred_zero_offset_deg;
    use rmd_loop::robot::Mounting;
    let limits = [(-25.0, 25.0), (-100.0, 40.0), (5.0, 165.0), (-110.0, 30.0)];
    common::leg(|i, motor| {
        motor
            .zero_offset_deg(centred_zero_offset_deg(9.0, Mounting::Normal, pose_deg[i]))
            .position_limits(limits[i].0, limits[i].1)
            .velocity_limit(180.0)
    })
}

#[test]
fn a_target_beyond_the_robot_descriptions_limits_is_refused_before_anything_moves() {
    // The finding behind the limits: `loop.set_position("knee", 100.0)` (radians, where the CLI
    // speaks degrees) spun the simulated knee to 73 rad in 3 s. The description's knee turns
    // from 5 to 165 degrees; the servo configuration has no position limits of its own.
    let pose = [0.0, -30.0, 60.0, -30.0];
    let robot = limited_leg(pose);
    let config = rmd_servo::ServoConfig::from_toml(&robot, SERVO).unwrap();
    let (servo, handle) = rmd_servo::ServoController::new(config);
    let mut bench = Bench::with(robot, servo, handle, pose);
    let h = &bench.handle;
    let err = h.set_position("knee", 100.0, 0.0, 0.0).unwrap_err();
    let (min, max) = (5f64.to_radians(), 165f64.to_radians());
    assert!(
        matches!(&err, ServoError::OutOfLimit { joint, field: "position_rad", value, min: lo, max: hi, .. }
            if joint == "knee" && *value == 100.0 && *lo == min && *hi == max),
        "{err}"
    );
    assert_eq!(
        err.to_string(),
        "joint `knee`: position_rad is 100, outside the joint's limits [0.087266, 2.879793] \
         (robot description: position_max_deg)"
    );
    // A trajectory there too; a velocity beyond the servo's 2 rad/s (within the description's
    // 180 deg/s).
    let far = JointTrajectory::new(["knee"]).point(JointTrajectoryPoint::at(ms(3000), [100.0]));
    assert!(matches!(
        h.send_trajectory(&far),
        Err(ServoError::Trajectory(TrajectoryRefusal::OutOfLimit { .. }))
    ));
    assert!(matches!(
        h.set_velocity("knee", 2.5, 0.0),
        Err(ServoError::OutOfLimit {
            field: "velocity_rad_s",
            ..
        })
    ));
    assert_eq!(bench.state().unwrap().joints()[2].counters.rejected, 3);
    // Nothing moved.
    bench.run_s(3.0);
    let knee = bench.truth_rad(2).to_degrees();
    assert!((knee - 60.0).abs() < 0.5, "{knee}");
    // Within the limits it goes: a velocity setpoint stops at the limit (the servo keeps its
    // reference inside), and the knee rests there.
    bench.handle.set_velocity("knee", 1.5, 0.0).unwrap();
    bench.run_s(2.0);
    let knee = bench.truth_rad(2).to_degrees();
    assert!((164.0..=165.5).contains(&knee), "{knee}");
    assert!(bench.finish().report.normal_stop);
}

#[test]
fn an_effort_driving_a_joint_past_its_limit_is_refused_by_the_loop_and_then_a_fault() {
    // Effort setpoints are not positions: the servo passes 15 N*m on. Below the servo the loop
    // refuses the push once the knee is past 165 degrees; the knee's momentum carries it past
    // the 5 degree margin all the same, which stops the run with every motor off.
    let pose = [0.0, -30.0, 60.0, -30.0];
    let robot = limited_leg(pose);
    let config = rmd_servo::ServoConfig::from_toml(&robot, SERVO).unwrap();
    let (servo, handle) = rmd_servo::ServoController::new(config);
    let mut bench = Bench::with(robot, servo, handle, pose);
    bench.handle.set_effort("knee", 15.0).unwrap();
    bench.run_s(3.0);
    let outcome = bench.outcome.take().expect("the loop stopped");
    let r = &outcome.report;
    let StopReason::Fault(rmd_loop::Fault::JointLimit { at, breach }) = r.stop_reason else {
        panic!("{r}");
    };
    assert_eq!(at.joint.index(), 2);
    assert!(
        breach.value > 170.0 || breach.kind == rmd_loop::LimitKind::Velocity,
        "{breach:?}"
    );
    assert!(r.stats.motors[2].counters.limited_commands > 0, "{r}");
    for i in 0..4 {
        assert_eq!(bench.motor(i).mode, ControlMode::Off);
    }
}
