//! The `trajectory_follow` example on the simulated leg, in virtual time: every waypoint is
//! reached, the joints move together, and the motors end off.

// The tests use part of the example (not its `main`).
#[allow(dead_code)]
#[path = "../examples/trajectory_follow.rs"]
mod trajectory_follow;

use core::time::Duration;

use clap::Parser;
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::sim::ControlMode;
use rmd_rt::{RtLoop, RunLimit, StopReason, connect};
use trajectory_follow::shared::leg::{JOINTS, LegModel};
use trajectory_follow::shared::runner;

#[test]
fn every_waypoint_is_reached() {
    let model = LegModel::new();
    let robot = trajectory_follow::robot(&model, "sim", 1000.0);
    let clock = VirtualClock::new();
    let mut buses = connect::sim_buses(&clock, trajectory_follow::sim(&model, &robot, 1)).unwrap();
    let waypoints = trajectory_follow::WAYPOINTS_DEG.to_vec();
    let (recorder, samples) = runner::recorder(20_000);
    let follower =
        trajectory_follow::Follower::new(model, waypoints.clone(), 0.4, 0.001, recorder).unwrap();
    let rt = RtLoop::new(robot, clock.clone(), buses.iter_mut().collect(), follower).unwrap();
    let out = rt.run(RunLimit::Duration(Duration::from_secs(20)));
    let r = &out.report;
    // The follower ends the run itself after the last waypoint.
    assert_eq!(r.stop_reason, StopReason::ControllerFinished, "{r}");
    assert!(r.normal_stop);
    assert_eq!(r.stats.deadline_misses, 0);
    assert_eq!(r.stats.missing_replies, 0);
    let k = &out.controller;
    assert_eq!(k.error, None);
    assert_eq!(k.reached.len(), waypoints.len());
    for (n, reached) in k.reached.iter().enumerate() {
        println!(
            "waypoint {}: move {:.2} s, error {:?} deg",
            n + 1,
            reached.move_s,
            reached.error_deg
        );
        assert_eq!(reached.waypoint, n);
        assert!(
            reached.max_error_deg() < 0.6,
            "waypoint {}: {reached:?}",
            n + 1
        );
    }
    // Synchronized: within each move, every joint that moves starts and stops together, so the
    // desired angles all change over the same ticks.
    let samples: Vec<_> = samples.drain().collect();
    assert_eq!(samples.len() as u64, r.stats.ticks - 1);
    for w in 0..waypoints.len() {
        let of_w: Vec<_> = samples.iter().filter(|s| s.waypoint == w).collect();
        let moving = |j: usize| -> Vec<bool> {
            of_w.windows(2)
                .map(|p| (p[1].q_des_deg[j] - p[0].q_des_deg[j]).abs() > 1e-9)
                .collect()
        };
        let first = moving(1); // hip flexion moves in every leg of the tour
        for j in 0..JOINTS {
            let m = moving(j);
            if m.iter().any(|x| *x) {
                let start = |v: &[bool]| v.iter().position(|x| *x).unwrap();
                let end = |v: &[bool]| v.iter().rposition(|x| *x).unwrap();
                assert!(
                    start(&m).abs_diff(start(&first)) <= 1,
                    "waypoint {w}, joint {j}"
                );
                assert!(
                    end(&m).abs_diff(end(&first)) <= 1,
                    "waypoint {w}, joint {j}"
                );
            }
        }
    }
    for id in 1..=JOINTS as u8 {
        let snapshot = buses[0].snapshot(MotorId::new(id).unwrap()).unwrap();
        assert_eq!(snapshot.mode, ControlMode::Off);
    }
}

#[test]
fn waypoints_are_checked_before_anything_moves() {
    let model = LegModel::new();
    let parse = |v: &[&str]| {
        trajectory_follow::parse_waypoints(
            &model,
            &v.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
        )
    };
    assert_eq!(
        parse(&[]).unwrap().len(),
        trajectory_follow::WAYPOINTS_DEG.len()
    );
    assert_eq!(
        parse(&["0,-40,80,-40"]).unwrap(),
        vec![[0.0, -40.0, 80.0, -40.0]]
    );
    assert!(parse(&["0,-40,80"]).unwrap_err().contains("needs 4"));
    assert!(parse(&["0,-40,x,-40"]).unwrap_err().contains("waypoint 1"));
    assert!(
        parse(&["0,-40,80,-40", "0,-40,170,-40"])
            .unwrap_err()
            .contains("knee")
    );
}

#[test]
fn the_example_runs_end_to_end() {
    let csv = std::env::temp_dir().join(format!("rmd-rt-trajectory-{}.csv", std::process::id()));
    let args = trajectory_follow::Args::parse_from([
        "trajectory_follow",
        "--virtual-time",
        "--quiet",
        "--waypoint=0,-50,100,-50",
        "--waypoint=0,-30,60,-30",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let summary = trajectory_follow::run(&args).unwrap();
    std::fs::remove_file(&csv).ok();
    assert!(summary.ok(), "{}", summary.report);
    assert_eq!(summary.reached.len(), 2);
    assert_eq!(summary.csv_rows + 1, summary.report.stats.ticks);
}
