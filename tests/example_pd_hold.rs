//! The `pd_hold` example on its simulated motor, in virtual time: the arm turns by the given
//! angle and settles, short of it by what gravity over the PD stiffness predicts, and the motor
//! ends off.

// The tests use part of the example (not its `main`).
#[allow(dead_code)]
#[path = "../examples/pd_hold.rs"]
mod pd_hold;

use core::time::Duration;

use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::sim::ControlMode;
use rmd_rt::{RtLoop, RunLimit, StopReason, connect};

fn settle(move_deg: f64) {
    let mut robot = pd_hold::robot("sim");
    robot.loop_config.telemetry_capacity = 4096;
    let sims = pd_hold::sim(&robot);
    let link = sims[0].motors[0].load.gravity.clone().unwrap();
    let clock = VirtualClock::new();
    let mut buses = connect::sim_buses(&clock, sims).unwrap();
    let controller = pd_hold::controller(move_deg);
    let (kp, kd) = (controller.kp, controller.kd);
    let rt = RtLoop::new(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
    let telemetry = rt.telemetry();
    let out = rt.run(RunLimit::Duration(Duration::from_secs(3)));
    assert_eq!(out.report.stop_reason, StopReason::TickLimit);
    assert_eq!(out.report.stats.deadline_misses, 0);
    assert_eq!(out.report.stats.missing_replies, 0);
    // The simulated arm starts at joint 0: the target is the move.
    let target_deg = out.controller.targets[0];
    assert!((target_deg - move_deg).abs() < 0.05, "{target_deg}");
    let samples: Vec<_> = telemetry.drain().collect();
    assert_eq!(samples.len(), 3000);
    let last = samples.last().unwrap().joints()[0];

    // A PD law against gravity stops short by gravity torque / stiffness, give or take the
    // gearbox's friction (0.36 N*m at the output) over the stiffness.
    let stiffness = kp * 2.09; // N*m per degree
    let gravity = -link.torque_nm(target_deg.to_radians());
    let predicted = target_deg - gravity / stiffness;
    let friction_band = 0.36 / stiffness;
    let error = last.joint_angle_deg - predicted;
    println!(
        "target {target_deg}: final {:.3} deg, predicted {predicted:.3} +- {friction_band:.3} deg (kd {kd})",
        last.joint_angle_deg
    );
    assert!(error.abs() <= friction_band + 0.05, "error {error} deg");
    assert!(last.joint_velocity_dps.abs() < 0.5);
    // Settled within 0.8 s: from then on within 0.2 degrees of the final angle.
    let settled = samples
        .iter()
        .rposition(|s| (s.joints()[0].joint_angle_deg - last.joint_angle_deg).abs() > 0.2)
        .map_or(0.0, |i| samples[i].time_s);
    println!("settled after {settled:.3} s");
    assert!(settled < 0.8, "settled after {settled} s");
    // The loop's joint angle is the simulated arm's true angle.
    let snapshot = buses[0].snapshot(MotorId::new(1).unwrap()).unwrap();
    assert_eq!(snapshot.mode, ControlMode::Off);
    assert!((snapshot.output_angle_deg - last.joint_angle_deg).abs() < 0.5);
}

#[test]
fn pd_hold_settles_above_horizontal() {
    settle(30.0);
}

#[test]
fn pd_hold_settles_below_horizontal() {
    settle(-20.0);
}
