//! Setpoints on simulated motors (virtual time): position, velocity and effort modes, batches
//! applied in one tick, the feed-forward terms, against the simulator's ground truth.

use crate::common;

use common::{Bench, JOINTS, SERVO};
use rmd_bus::Clock;
use rmd_servo::{ServoMode, Setpoint};

#[test]
fn position_setpoints_by_name_in_one_batch_are_applied_in_one_tick_and_reached() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    let targets = [0.2, -0.15, 0.3, -0.25];
    let before = bench.state().unwrap();
    assert!(before.joints().iter().all(|j| j.mode == ServoMode::Hold));
    bench
        .handle
        .set_many(
            JOINTS
                .iter()
                .zip(targets)
                .map(|(&name, x)| (name, Setpoint::position(x))),
        )
        .unwrap();
    bench.step(1);
    let after = bench.state().unwrap();
    assert_eq!(after.tick, before.tick + 1);
    for j in after.joints() {
        assert_eq!(j.mode, ServoMode::Position, "{j:?}");
        assert_eq!(j.counters.setpoints, 1);
    }
    bench.run_s(1.5);
    let state = bench.state().unwrap();
    for (i, target) in targets.iter().enumerate() {
        let truth = bench.truth_rad(i);
        // Coulomb friction (0.36 N·m at the output) over kp = 60 N·m/rad: 6 mrad at most.
        assert!(
            (truth - target).abs() < 0.01,
            "joint {i}: {truth} vs {target}"
        );
        // The servo's measurement agrees with the simulator.
        let seen = state.joints()[i];
        assert!(
            (seen.position_rad - truth).abs() < 0.002,
            "{seen:?} vs {truth}"
        );
        assert!(seen.position_error_rad.unwrap().abs() < 0.01);
        assert!(seen.velocity_rad_s.abs() < 0.01);
    }
    assert!(bench.finish().report.normal_stop);
}

#[test]
fn the_servo_writes_each_joints_position_error_as_a_user_signal() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_position("knee", 0.3, 0.0, 0.0).unwrap();
    bench.step(5);
    let sample = bench.telemetry.latest().unwrap();
    let state = bench.state().unwrap();
    assert_eq!(sample.tick, state.tick);
    let errors: Vec<f64> = state
        .joints()
        .iter()
        .map(|j| j.position_error_rad.unwrap())
        .collect();
    assert_eq!(sample.signals(), errors.as_slice());
    assert!(errors[2] > 0.2, "{errors:?}");
    let outcome = bench.finish();
    assert_eq!(
        rmd_loop::Controller::signals(&outcome.controller),
        JOINTS.map(|j| format!("servo_{j}_error_rad"))
    );
}

#[test]
fn the_feed_forward_terms_enter_the_law() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_position("knee", 0.05, 0.4, 0.7).unwrap();
    for _ in 0..20 {
        bench.step(1);
        let knee = bench.state().unwrap().joints()[2];
        // τ = kp (x* - x) + kd (v_ff - v) + τ_ff with the tick's measurement.
        let expected = 60.0 * (0.05 - knee.position_rad) + 1.5 * (0.4 - knee.velocity_rad_s) + 0.7;
        assert!(
            (knee.commanded_effort_nm - expected).abs() < 1e-9,
            "{knee:?}: expected {expected}"
        );
        assert_eq!(knee.effort_ff_nm, 0.7);
        let r = knee.reference.unwrap();
        assert_eq!((r.position_rad, r.velocity_rad_s), (0.05, 0.4));
    }
}

#[test]
fn velocity_setpoints_are_tracked_and_stop_at_the_position_limit() {
    let servo = format!("{SERVO}\n[joint.knee]\nposition_max_rad = 0.5\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    bench.handle.set_velocity("knee", 0.8, 0.0).unwrap();
    bench.handle.set_velocity("ankle", -0.3, 0.0).unwrap();
    bench.run_s(0.2);
    let (knee0, ankle0) = (bench.truth_rad(2), bench.truth_rad(3));
    bench.run_s(0.2);
    let knee_v = (bench.truth_rad(2) - knee0) / 0.2;
    let ankle_v = (bench.truth_rad(3) - ankle0) / 0.2;
    assert!((knee_v - 0.8).abs() < 0.02, "knee at {knee_v} rad/s");
    assert!((ankle_v + 0.3).abs() < 0.02, "ankle at {ankle_v} rad/s");
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::Velocity);
    assert_eq!(knee.reference.unwrap().velocity_rad_s, 0.8);
    // 0.5 rad at 0.8 rad/s: at the limit after about 0.63 s; then it stays there.
    bench.run_s(1.2);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::Velocity);
    let r = knee.reference.unwrap();
    assert_eq!((r.position_rad, r.velocity_rad_s), (0.5, 0.0));
    let truth = bench.truth_rad(2);
    assert!((truth - 0.5).abs() < 0.01, "knee at {truth}");
    assert!(bench.truth_rad_s(2).abs() < 0.01);
    // Going back down from the limit works.
    bench.handle.set_velocity("knee", -0.5, 0.0).unwrap();
    bench.run_s(0.3);
    assert!(bench.truth_rad(2) < 0.4, "{}", bench.truth_rad(2));
}

/// A velocity setpoint is a speed in loop time: when the host runs the loop late and it skips
/// ticks, the joint still turns at that speed (its reference advances by the time since the
/// previous tick, not by one period).
#[test]
fn velocity_setpoints_keep_their_speed_when_the_loop_skips_ticks() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_velocity("knee", 0.4, 0.0).unwrap();
    bench.run_s(0.2);
    let period = bench.robot.settings().period.get();
    let (knee0, t0) = (bench.truth_rad(2), bench.clock.now());
    for _ in 0..100 {
        // Each tick runs three periods late: the loop skips the two it missed.
        bench.clock.sleep_until(bench.clock.now() + period * 3);
        bench.step(1);
    }
    assert!(
        bench.outcome.is_none(),
        "{:?}",
        bench.outcome.map(|o| o.report)
    );
    let elapsed = (bench.clock.now() - t0).as_secs_f64();
    let speed = (bench.truth_rad(2) - knee0) / elapsed;
    assert!(elapsed > 0.35, "only {elapsed} s of loop time passed");
    assert!(
        (speed - 0.4).abs() < 0.04,
        "knee at {speed} rad/s over {elapsed} s"
    );
}

#[test]
fn effort_setpoints_apply_their_torque() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench
        .handle
        .set_many([
            ("hip_fe", Setpoint::effort(1.2)),
            ("knee", Setpoint::effort(-0.8)),
        ])
        .unwrap();
    bench.run_s(0.05);
    let state = bench.state().unwrap();
    for (i, effort) in [(1, 1.2), (2, -0.8)] {
        let j = state.joints()[i];
        assert_eq!(j.mode, ServoMode::Effort);
        assert_eq!(j.commanded_effort_nm, effort);
        // The simulated motor's output torque: within one current step (33/2048 A, 0.034 N·m).
        let truth = bench.motor(i).output_torque_nm;
        assert!((truth - effort).abs() < 0.05, "joint {i}: {truth} N·m");
        // The servo's measured effort agrees.
        assert!((j.effort_nm - effort).abs() < 0.05, "{j:?}");
        // Beyond the friction (0.36 N·m) it accelerates the way it is pushed.
        assert!(bench.truth_rad_s(i) * effort > 0.0);
    }
    // The joints left out of the batch hold where they were.
    assert_eq!(state.joints()[0].mode, ServoMode::Hold);
    assert_eq!(state.joints()[0].counters.setpoints, 0);
}
