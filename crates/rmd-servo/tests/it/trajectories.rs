//! Trajectories on simulated motors (virtual time): points reached on time, the limits of
//! velocity and acceleration kept, trajectories that start later or while moving, points too
//! close, trajectories that replace others, the buffer pool.

use crate::common;

use std::time::Duration;

use common::{Bench, DT, JOINTS, SERVO};
use rmd_servo::{
    JointTrajectory, JointTrajectoryPoint, ServoError, ServoMode, ServoState, TrajectoryStart,
};

fn ms(t: u64) -> Duration {
    Duration::from_millis(t)
}

/// Steps until every joint of the trajectory left `Trajectory` (at most `max_s`), checking
/// every tick's reference against the limits and its continuity; returns the loop time the
/// trajectory started at and the states of every tick.
fn follow(bench: &mut Bench, joints: &[usize], max_s: f64) -> (f64, Vec<ServoState>) {
    let mut states: Vec<ServoState> = Vec::new();
    let mut started = None;
    for _ in 0..(max_s / DT) as usize {
        bench.step(1);
        let state = bench.state().unwrap();
        let on = joints
            .iter()
            .any(|&i| state.joints()[i].mode == ServoMode::Trajectory);
        if on && started.is_none() {
            started = Some(state.time_s);
        }
        for &i in joints {
            let r = state.joints()[i].reference.unwrap();
            assert!(r.velocity_rad_s.abs() <= 2.0 + 1e-9, "joint {i}: {r:?}");
            assert!(
                r.acceleration_rad_s2.abs() <= 10.0 + 1e-9,
                "joint {i}: {r:?}"
            );
            if let Some(previous) = states.last() {
                let p = previous.joints()[i].reference.unwrap();
                // Continuous: no step beyond what the velocity limit allows in a tick, and the
                // velocity changes by no more than the acceleration limit allows.
                assert!(
                    (r.position_rad - p.position_rad).abs() <= 2.0 * DT + 1e-9,
                    "joint {i} jumps: {p:?} -> {r:?}"
                );
                assert!(
                    (r.velocity_rad_s - p.velocity_rad_s).abs() <= 10.0 * DT + 1e-6,
                    "joint {i} jerks: {p:?} -> {r:?}"
                );
            }
        }
        let done = started.is_some()
            && joints
                .iter()
                .all(|&i| state.joints()[i].mode != ServoMode::Trajectory);
        states.push(state);
        if done {
            break;
        }
    }
    (started.expect("the trajectory started"), states)
}

/// The state at loop time `t` (the first tick at or after it).
fn at(states: &[ServoState], t: f64) -> &ServoState {
    states
        .iter()
        .find(|s| s.time_s >= t - 1e-9)
        .expect("a tick at that time")
}

#[test]
fn a_multi_point_trajectory_is_followed_on_time_within_the_limits() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    let points = [
        (600, [0.20, -0.10, 0.30, -0.20]),
        (1200, [-0.10, 0.15, 0.45, 0.00]),
        (1800, [0.15, 0.20, 0.10, 0.25]),
        (2400, [0.00, 0.00, 0.00, 0.00]),
    ];
    let mut trajectory = JointTrajectory::new(JOINTS);
    for (t, p) in points {
        trajectory = trajectory.point(JointTrajectoryPoint::at(ms(t), p));
    }
    let receipt = bench.handle.send_trajectory(&trajectory).unwrap();
    assert_eq!(receipt.max_lateness_s, 0.0, "{receipt:?}");
    assert!((receipt.duration_s - 2.4).abs() < 1e-9);
    let mut truth_speed_max = [0.0f64; 4];
    let mut checks = Vec::new();
    // Follow tick by tick, reading the ground truth at each point's time.
    let (start, states) = {
        let mut states = Vec::new();
        let mut start = None;
        for _ in 0..3000 {
            bench.step(1);
            let s = bench.state().unwrap();
            if start.is_none() && s.joints()[0].mode == ServoMode::Trajectory {
                start = Some(s.time_s);
            }
            for (i, max) in truth_speed_max.iter_mut().enumerate() {
                *max = max.max(bench.truth_rad_s(i).abs());
            }
            if let Some(t0) = start {
                for (k, (t, p)) in points.iter().enumerate() {
                    let due = t0 + *t as f64 / 1000.0;
                    if (s.time_s - due).abs() < DT / 2.0 {
                        checks.push((
                            k,
                            (0..4)
                                .map(|i| bench.truth_rad(i) - p[i])
                                .collect::<Vec<_>>(),
                        ));
                    }
                }
            }
            states.push(s);
        }
        (start.unwrap(), states)
    };
    assert_eq!(checks.len(), points.len());
    for (k, errors) in &checks {
        for (i, e) in errors.iter().enumerate() {
            // Tracking with kp = 60 N·m/rad against 0.36 N·m of friction, 1 ms of delay.
            assert!(e.abs() < 0.02, "point {k}, joint {i}: off by {e} rad");
        }
    }
    // The reference kept the limits, every tick, and was continuous.
    for pair in states.windows(2) {
        for i in 0..4 {
            let (a, b) = (pair[0].joints()[i], pair[1].joints()[i]);
            let (ra, rb) = (a.reference.unwrap(), b.reference.unwrap());
            assert!(
                rb.velocity_rad_s.abs() <= 2.0 + 1e-9
                    && rb.acceleration_rad_s2.abs() <= 10.0 + 1e-9
            );
            assert!((rb.position_rad - ra.position_rad).abs() <= 2.0 * DT + 1e-9);
            assert!((rb.velocity_rad_s - ra.velocity_rad_s).abs() <= 10.0 * DT + 1e-6);
        }
    }
    // The joints themselves stayed near the velocity limit (2 rad/s) too.
    for (i, v) in truth_speed_max.iter().enumerate() {
        assert!(*v < 2.2, "joint {i} reached {v} rad/s");
        assert!(*v > 0.3, "joint {i} hardly moved: {v} rad/s");
    }
    // Afterwards every joint holds the last point.
    let last = states.last().unwrap();
    assert!(last.time_s > start + 2.4);
    for j in last.joints() {
        assert_eq!(j.mode, ServoMode::Hold);
        assert_eq!(j.reference.unwrap().position_rad, 0.0);
        assert_eq!(j.counters.trajectories, 1);
        // Planned from the published hold state, which the joint was still in: no re-plan.
        assert_eq!(j.counters.replans, 0);
    }
    for i in 0..4 {
        assert!(bench.truth_rad(i).abs() < 0.01);
    }
}

#[test]
fn velocities_and_accelerations_given_at_points_are_met() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    let trajectory = JointTrajectory::new(["knee"])
        .point(
            JointTrajectoryPoint::at(ms(500), [0.3])
                .with_velocities([0.8])
                .with_accelerations([2.0]),
        )
        .point(JointTrajectoryPoint::at(ms(1200), [0.6]));
    bench.handle.send_trajectory(&trajectory).unwrap();
    let (start, states) = follow(&mut bench, &[2], 2.0);
    let s = at(&states, start + 0.5);
    let r = s.joints()[2].reference.unwrap();
    assert!((r.position_rad - 0.3).abs() < 1e-6, "{r:?}");
    assert!((r.velocity_rad_s - 0.8).abs() < 1e-6, "{r:?}");
    assert!((r.acceleration_rad_s2 - 2.0).abs() < 1e-6, "{r:?}");
    // The joint itself: close behind.
    let seen = s.joints()[2];
    assert!((seen.velocity_rad_s - 0.8).abs() < 0.15, "{seen:?}");
    let end = at(&states, start + 1.2).joints()[2].reference.unwrap();
    assert!((end.position_rad - 0.6).abs() < 1e-9 && end.velocity_rad_s == 0.0);
}

#[test]
fn a_trajectory_starting_later_while_the_joint_moves_starts_from_where_it_is() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    bench.handle.set_velocity("knee", 0.5, 0.0).unwrap();
    bench.run_s(0.2);
    let now = bench.handle.loop_time_s().unwrap();
    let start_at = now + 0.1;
    let trajectory = JointTrajectory::new(["knee"])
        .point(JointTrajectoryPoint::at(ms(800), [-0.2]))
        .starting(TrajectoryStart::AtLoopTime(start_at));
    let receipt = bench.handle.send_trajectory(&trajectory).unwrap();
    assert_eq!(receipt.max_lateness_s, 0.0);
    // Until its start the knee goes on at 0.5 rad/s.
    bench.run_s(0.05);
    let knee = bench.state().unwrap().joints()[2];
    assert_eq!(knee.mode, ServoMode::Velocity);
    let (started, states) = follow(&mut bench, &[2], 2.0);
    assert!(
        started >= start_at - 1e-9 && started < start_at + DT,
        "started at {started}, due at {start_at}"
    );
    // The joint had moved on since the plan: its first segment was planned again.
    let knee = states.last().unwrap().joints()[2];
    assert_eq!(knee.counters.replans, 1);
    assert_eq!(knee.counters.trajectory_failures, 0);
    assert_eq!(knee.mode, ServoMode::Hold);
    // The switch from the moving velocity reference was smooth (checked in `follow`), and the
    // point was reached on time.
    let due = at(&states, started + 0.8).joints()[2].reference.unwrap();
    assert!((due.position_rad + 0.2).abs() < 1e-9, "{due:?}");
    bench.run_s(0.3);
    assert!((bench.truth_rad(2) + 0.2).abs() < 0.01);
}

#[test]
fn points_too_close_for_the_limits_are_reached_as_early_as_the_limits_allow() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    // 1 rad in 0.2 s would need 5 rad/s: at 2 rad/s it takes well over half a second.
    let trajectory = JointTrajectory::new(["hip_fe"])
        .point(JointTrajectoryPoint::at(ms(200), [1.0]))
        .point(JointTrajectoryPoint::at(ms(1400), [0.5]));
    let receipt = bench.handle.send_trajectory(&trajectory).unwrap();
    assert!(receipt.max_lateness_s > 0.3, "{receipt:?}");
    assert_eq!(receipt.latest, Some(("hip_fe".to_string(), 0)));
    let (start, states) = follow(&mut bench, &[1], 3.0);
    // The reference went at the velocity limit for a while.
    let fastest = states
        .iter()
        .map(|s| s.joints()[1].reference.unwrap().velocity_rad_s.abs())
        .fold(0.0, f64::max);
    assert!((fastest - 2.0).abs() < 1e-9, "{fastest}");
    // The point after the late one is still due at its own time (the late segment's delay is
    // caught up), or as soon after as the limits allow: by the planned duration.
    let end = states.last().unwrap();
    assert!(
        end.time_s - start <= receipt.duration_s + 2.0 * DT,
        "{} vs {receipt:?}",
        end.time_s - start
    );
    assert!((end.joints()[1].reference.unwrap().position_rad - 0.5).abs() < 1e-12);
}

#[test]
fn a_newer_trajectory_replaces_an_older_one_for_its_joints_only() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    let older = JointTrajectory::new(["knee", "ankle"])
        .point(JointTrajectoryPoint::at(ms(1000), [0.4, -0.3]))
        .point(JointTrajectoryPoint::at(ms(2000), [0.1, 0.2]));
    bench.handle.send_trajectory(&older).unwrap();
    bench.step(1);
    let t_older = bench.handle.loop_time_s().unwrap();
    bench.run_s(0.5);
    let newer = JointTrajectory::new(["knee"]).point(JointTrajectoryPoint::at(ms(700), [-0.3]));
    bench.handle.send_trajectory(&newer).unwrap();
    bench.step(1);
    let t_newer = bench.handle.loop_time_s().unwrap();
    let (_, states) = follow(&mut bench, &[2, 3], 2.5);
    let knee_due = at(&states, t_newer + 0.7).joints()[2];
    assert!(
        (knee_due.reference.unwrap().position_rad + 0.3).abs() < 1e-9,
        "{knee_due:?}"
    );
    // The ankle went on with the older one, on time.
    let ankle_mid = at(&states, t_older + 1.0).joints()[3].reference.unwrap();
    assert!((ankle_mid.position_rad + 0.3).abs() < 1e-9, "{ankle_mid:?}");
    let end = states.last().unwrap();
    assert!((end.joints()[3].reference.unwrap().position_rad - 0.2).abs() < 1e-12);
    assert!((end.joints()[2].reference.unwrap().position_rad + 0.3).abs() < 1e-12);
    assert_eq!(end.joints()[2].counters.trajectories, 2);
    assert_eq!(end.joints()[3].counters.trajectories, 1);
    // The knee switched while it moved: planned again from where it was.
    assert_eq!(end.joints()[2].counters.replans, 1);
}

#[test]
fn trajectory_buffers_go_back_to_the_pool() {
    let servo = format!("{SERVO}\n[servo]\ntrajectory_buffers = 2\n");
    let mut bench = Bench::new(&servo, [0.0; 4]);
    let now = bench.handle.loop_time_s().unwrap();
    let later = |joint: &str| {
        JointTrajectory::new([joint])
            .point(JointTrajectoryPoint::at(ms(300), [0.1]))
            .starting(TrajectoryStart::AtLoopTime(now + 0.2))
    };
    bench.handle.send_trajectory(&later("hip_aa")).unwrap();
    bench.handle.send_trajectory(&later("hip_fe")).unwrap();
    bench.step(1);
    // Both wait for their start: no buffer left.
    let err = bench.handle.send_trajectory(&later("knee")).unwrap_err();
    assert_eq!(err, ServoError::NoTrajectoryBuffer { count: 2 });
    assert_eq!(bench.handle.rejected_unattributed(), 1);
    // Once they ran, their buffers are back.
    bench.run_s(0.6);
    let state = bench.state().unwrap();
    assert_eq!(state.joints()[0].mode, ServoMode::Hold);
    assert_eq!(state.joints()[0].counters.trajectories, 1);
    for _ in 0..3 {
        let t = JointTrajectory::new(["knee"]).point(JointTrajectoryPoint::at(ms(100), [0.0]));
        bench.handle.send_trajectory(&t).unwrap();
        bench.handle.send_trajectory(&t).unwrap();
        bench.run_s(0.2);
    }
    // A waiting trajectory is cancelled by a newer one for the same joint (its buffer back).
    let now = bench.handle.loop_time_s().unwrap();
    let waiting = JointTrajectory::new(["ankle"])
        .point(JointTrajectoryPoint::at(ms(100), [0.2]))
        .starting(TrajectoryStart::AtLoopTime(now + 1.0));
    bench.handle.send_trajectory(&waiting).unwrap();
    let at_once = JointTrajectory::new(["ankle"]).point(JointTrajectoryPoint::at(ms(100), [-0.1]));
    bench.handle.send_trajectory(&at_once).unwrap();
    bench.run_s(1.5);
    let ankle = bench.state().unwrap().joints()[3];
    assert_eq!(ankle.counters.trajectories, 1, "{ankle:?}");
    assert_eq!(ankle.reference.unwrap().position_rad, -0.1);
    bench.handle.send_trajectory(&later("knee")).unwrap();
    bench.handle.send_trajectory(&later("ankle")).unwrap();
}

#[test]
fn a_first_segment_planned_again_shifts_the_later_points_without_a_jump() {
    let mut bench = Bench::new(SERVO, [0.0; 4]);
    // Moving away from the first point, fast: the plan made now is already late, and by the
    // start (0.2 s later, 0.3 rad further away) later still.
    bench.handle.set_velocity("knee", -1.5, 0.0).unwrap();
    bench.run_s(0.05);
    let now = bench.handle.loop_time_s().unwrap();
    let trajectory = JointTrajectory::new(["knee"])
        .point(JointTrajectoryPoint::at(ms(200), [0.0]))
        .point(JointTrajectoryPoint::at(ms(900), [0.3]))
        .point(JointTrajectoryPoint::at(ms(1500), [0.1]))
        .starting(TrajectoryStart::AtLoopTime(now + 0.2));
    let receipt = bench.handle.send_trajectory(&trajectory).unwrap();
    assert!(receipt.max_lateness_s > 0.0);
    let (start, states) = follow(&mut bench, &[2], 4.0);
    let knee = states.last().unwrap().joints()[2];
    assert_eq!(knee.counters.replans, 1);
    assert_eq!(knee.mode, ServoMode::Hold);
    // Every point was passed through (the reference within one tick of motion of it), in order.
    let mut k = 0;
    let targets = [0.0, 0.3, 0.1];
    for s in &states {
        let r = s.joints()[2].reference.unwrap();
        if k < 3 && (r.position_rad - targets[k]).abs() <= 2.0 * DT + 1e-9 {
            k += 1;
        }
    }
    assert_eq!(k, 3, "points passed through");
    // Later than planned by the caller: it started further away.
    assert!(states.last().unwrap().time_s - start > receipt.duration_s);
    bench.run_s(0.3);
    assert!((bench.truth_rad(2) - 0.1).abs() < 0.01);
}
