//! The servo on a MyActuator V3 bus in motion mode (`exchange = "motion"`): its position,
//! velocity, trajectory and effort modes go out as motion-mode setpoints (the motors run the
//! PD law with the servo's gains), judged by the simulated firmware's ground truth; the same
//! servo on a per-motor V3 bus still sends currents. Virtual time, 500 Hz.

use crate::common;

use std::time::Duration;

use common::{Bench, SERVO, v3_leg};
use rmd_loop::CommandKind;
use rmd_loop::robot::ExchangeKind;
use rmd_servo::{JointTrajectory, JointTrajectoryPoint, ServoConfig, ServoMode};
use rmd_sim::ControlMode;

const KNEE: usize = 2;
const ANKLE: usize = 3;
/// The joints' zero offsets (the motor's zero is 20 degrees of joint below the joint's).
const ZERO_OFFSET_DEG: f64 = 20.0;

/// What the motors obey is packed in the firmware's ranges (V4.3: 12-bit velocity, kp, kd and
/// torque fields): velocity steps of 0.022 rad/s, torque steps of 0.012 N·m (zero lies
/// half a step off), kp steps of 0.12 N·m/rad.
const V_STEP: f64 = 0.022;
const T_STEP: f64 = 0.012;

/// The motion-mode setpoint joint `i`'s simulated motor obeys: p_des as a joint angle (rad),
/// v_des, kp, kd (output side, per radian), t_ff.
fn obeyed(bench: &Bench, i: usize) -> (f64, f64, f64, f64, f64) {
    match bench.motor(i).mode {
        ControlMode::Motion {
            position_rad,
            velocity_rad_s,
            kp,
            kd,
            torque_nm,
        } => (
            position_rad - ZERO_OFFSET_DEG.to_radians(),
            velocity_rad_s,
            kp,
            kd,
            torque_nm,
        ),
        other => panic!("joint {i}'s motor is in {other:?}, not motion mode"),
    }
}

#[test]
fn a_servo_on_a_motion_bus_asks_for_motion_mode_and_one_on_a_per_motor_bus_does_not() {
    let motion = v3_leg(ExchangeKind::Motion);
    let config = ServoConfig::from_toml(&motion, SERVO).unwrap();
    assert!(
        motion
            .joint_ids()
            .all(|id| config.command_kind(id) == CommandKind::Motion)
    );
    let per_motor = v3_leg(ExchangeKind::PerMotor);
    let config = ServoConfig::from_toml(&per_motor, SERVO).unwrap();
    assert!(
        per_motor
            .joint_ids()
            .all(|id| config.command_kind(id) == CommandKind::Current)
    );
}

#[test]
fn a_servo_on_a_motion_bus_holds_and_moves_its_joints_in_motion_mode_by_ground_truth() {
    let start = [5.0, -5.0, 10.0, 0.0];
    let mut bench = Bench::on(v3_leg(ExchangeKind::Motion), SERVO, start);
    bench.run_s(0.5);
    // Holding where they started, the motors running the servo's law: kp 60 N·m/rad, kd 1.5
    // N·m·s/rad (a joint radian is an output radian), no feed-forward.
    for (i, deg) in start.into_iter().enumerate() {
        let (p, v, kp, kd, t) = obeyed(&bench, i);
        assert!(
            (kp - 60.0).abs() < 0.2 && (kd - 1.5).abs() < 0.01,
            "{kp} {kd}"
        );
        assert!(v.abs() < V_STEP && t.abs() < T_STEP, "{v} {t}");
        assert!((p - deg.to_radians()).abs() < 0.01, "joint {i}: p_des {p}");
        assert!(
            (bench.truth_rad(i) - deg.to_radians()).abs() < 0.01,
            "joint {i} held at {} rad",
            bench.truth_rad(i)
        );
    }
    let state = bench.state().unwrap();
    assert!(state.joints().iter().all(|j| j.mode == ServoMode::Hold));

    // A position with effort feed-forward for the knee, a velocity for the ankle.
    bench.handle.set_position("knee", 0.3, 0.0, 0.5).unwrap();
    bench.handle.set_velocity("ankle", -0.4, 0.0).unwrap();
    bench.run_s(0.5);
    let (p, v, kp, _, t) = obeyed(&bench, KNEE);
    assert!(
        (p - 0.3).abs() < 1e-3 && v.abs() < V_STEP,
        "knee p_des {p} v_des {v}"
    );
    assert!(
        (kp - 60.0).abs() < 0.2 && (t - 0.5).abs() < T_STEP,
        "{kp} {t}"
    );
    // The ankle's moving reference: v_des is the velocity, p_des where the reference is.
    let (p, v, ..) = obeyed(&bench, ANKLE);
    assert!((v + 0.4).abs() < V_STEP, "ankle v_des {v}");
    assert!(
        (p + 0.2).abs() < 0.01,
        "ankle p_des {p} after 0.5 s at -0.4 rad/s"
    );
    assert!(
        (bench.truth_rad_s(ANKLE) + 0.4).abs() < 0.05,
        "{}",
        bench.truth_rad_s(ANKLE)
    );
    bench.run_s(0.5);
    // The knee at its target by the simulator (the feed-forward's 0.5 N·m against kp 60
    // N·m/rad moves it by 8 mrad, the friction a few more).
    assert!(
        (bench.truth_rad(KNEE) - 0.3).abs() < 0.02,
        "{}",
        bench.truth_rad(KNEE)
    );
    let state = bench.state().unwrap();
    assert!((state.joints()[KNEE].position_rad - 0.3).abs() < 0.02);

    // A trajectory back to 0 for the knee, followed by the motors.
    let back = JointTrajectory::new(["knee"])
        .point(JointTrajectoryPoint::at(Duration::from_millis(600), [0.0]));
    bench.handle.send_trajectory(&back).unwrap();
    bench.run_s(0.3);
    let (p, v, ..) = obeyed(&bench, KNEE);
    assert!(
        v < -0.1,
        "the knee's p_des {p} and v_des {v} move with the trajectory"
    );
    bench.run_s(0.6);
    assert!(
        bench.truth_rad(KNEE).abs() < 0.015,
        "{}",
        bench.truth_rad(KNEE)
    );
    assert_eq!(bench.state().unwrap().joints()[KNEE].mode, ServoMode::Hold);

    // Effort: pure torque, zero gains.
    bench.handle.set_effort("hip_aa", 1.5).unwrap();
    bench.step(5);
    let (_, _, kp, kd, t) = obeyed(&bench, 0);
    assert_eq!((kp, kd), (0.0, 0.0));
    assert!((t - 1.5).abs() < T_STEP, "{t}");

    let report = bench.finish().report;
    assert!(report.normal_stop, "{report}");
    assert!(
        report
            .stats
            .motors
            .iter()
            .all(|m| m.counters.rejected_commands == 0),
        "{report}"
    );
}

#[test]
fn a_step_beyond_the_effort_limit_is_bounded_in_motion_mode_too() {
    let servo = format!("{SERVO}\n[joint.knee]\nmax_effort_nm = 4.0\n");
    let mut bench = Bench::on(v3_leg(ExchangeKind::Motion), &servo, [0.0; 4]);
    bench.handle.set_position("knee", 0.6, 0.0, 0.0).unwrap();
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        bench.step(1);
        worst = worst.max(bench.motor(KNEE).output_torque_nm.abs());
    }
    let knee = bench.state().unwrap().joints()[KNEE];
    // kp 60 N·m/rad on 0.6 rad asks 36 N·m: clamped at each tick's measurement.
    assert!(knee.counters.clamped > 10, "{knee:?}");
    // Measured: 4.06 N·m at most (the motor runs the law between ticks).
    assert!(
        worst < 4.0 * 1.05,
        "the knee's true torque reached {worst} N·m"
    );
    bench.run_s(1.0);
    assert!((bench.truth_rad(KNEE) - 0.6).abs() < 0.02);
}

#[test]
fn the_same_servo_on_a_per_motor_v3_bus_sends_currents() {
    let mut bench = Bench::on(v3_leg(ExchangeKind::PerMotor), SERVO, [0.0; 4]);
    bench.handle.set_position("knee", 0.3, 0.0, 0.0).unwrap();
    bench.run_s(0.05);
    for i in 0..4 {
        let mode = bench.motor(i).mode;
        assert!(
            matches!(mode, ControlMode::Torque { .. }),
            "joint {i}: {mode:?}"
        );
    }
    bench.run_s(1.0);
    // V3 replies carry whole degrees: the servo holds within one of the target.
    assert!(
        (bench.truth_rad(KNEE) - 0.3).abs() < 0.03,
        "{}",
        bench.truth_rad(KNEE)
    );
    let outcome = bench.finish();
    assert!(outcome.report.normal_stop, "{}", outcome.report);
}
