//! The `trajectory_follow` example on the simulated leg, in virtual time: every waypoint is
//! reached, the joints move together, and the motors end off. The example's binary runs end to
//! end.

use crate::support;

use core::time::Duration;

use rmd_demos::leg::{JOINTS, LegModel};
use rmd_demos::trajectory_follow::{self, Follower, WAYPOINTS_DEG, signal};
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::rig::open::sim_buses;
use rmd_rt::sim::ControlMode;
use rmd_rt::{Robot, RtLoop, RunLimit, StopReason};
use support::{Csv, run, temp_file};

/// The example's robot description (the leg of `leg4`).
const ROBOT: &str = include_str!("../../examples/robots/leg4.toml");

#[test]
fn every_waypoint_is_reached() {
    let mut config = rmd_rt::rt::robot::RobotConfig::from_toml(ROBOT).unwrap();
    config.loop_config.telemetry_capacity = 20_000;
    let robot = Robot::try_from(config).unwrap();
    let clock = VirtualClock::new();
    let mut buses = sim_buses(&clock, trajectory_follow::sims(&robot, 1).unwrap()).unwrap();
    let waypoints = WAYPOINTS_DEG.to_vec();
    let follower = Follower::new(&robot, LegModel::new(), waypoints.clone(), 0.4).unwrap();
    let mut rt =
        RtLoop::unsupervised(robot, clock.clone(), buses.iter_mut().collect(), follower).unwrap();
    let telemetry = rt.telemetry();
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
    assert!(k.results().ok());
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
    // desired angles (the controller's signals) all change over the same ticks.
    let samples: Vec<_> = telemetry.drain().collect();
    assert_eq!(samples.len() as u64, r.stats.ticks - 1);
    for w in 0..waypoints.len() {
        let of_w: Vec<_> = samples
            .iter()
            .filter(|s| s.signals()[signal::WAYPOINT] == (w + 1) as f64)
            .collect();
        let moving = |j: usize| -> Vec<bool> {
            let desired =
                |s: &rmd_rt::rt::telemetry::TelemetrySample| s.signals()[signal::DESIRED_DEG + j];
            of_w.windows(2)
                .map(|p| (desired(p[1]) - desired(p[0])).abs() > 1e-9)
                .collect()
        };
        let first = moving(1); // hip flexion moves in every leg of the tour
        assert!(first.iter().any(|m| *m), "waypoint {w}");
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
        .map_err(|e| e.to_string())
    };
    assert_eq!(parse(&[]).unwrap().len(), WAYPOINTS_DEG.len());
    assert_eq!(
        parse(&["0,-40,80,-40"]).unwrap(),
        vec![[0.0, -40.0, 80.0, -40.0]]
    );
    assert!(parse(&["0,-40,80"]).unwrap_err().contains("needs 4"));
    assert!(parse(&["0,-40,x,-40"]).unwrap_err().contains("waypoint 1"));
    assert!(
        parse(&["0,-40,inf,-40"])
            .unwrap_err()
            .contains("waypoint 1")
    );
    assert!(
        parse(&["0,-40,80,-40", "0,-40,170,-40"])
            .unwrap_err()
            .contains("waypoint 2: knee")
    );
}

#[test]
fn the_example_runs_end_to_end() {
    let csv = temp_file("trajectory.csv");
    let ran = run(
        "trajectory_follow",
        &[
            "--virtual-time",
            "--quiet",
            "--waypoint=0,-50,100,-50",
            "--waypoint=0,-30,60,-30",
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    assert_eq!(ran.code, Some(0), "{}\n{}", ran.stdout, ran.stderr);
    assert!(
        ran.stdout.contains("stopped: controller finished"),
        "{}",
        ran.stdout
    );
    assert!(!ran.stdout.contains("only"), "{}", ran.stdout);
    let ticks: u64 = ran
        .stdout
        .lines()
        .find_map(|l| l.strip_prefix("ticks "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("the report's tick count");
    let csv = Csv::take(&csv);
    // Every tick but the last (the one that ended the run) is a row.
    assert_eq!(csv.rows.len() as u64 + 1, ticks);
    let waypoint = csv.values("waypoint");
    assert_eq!((waypoint[0], waypoint[waypoint.len() - 1]), (1.0, 2.0));
    // A waypoint beyond a joint's limit is refused before anything moves.
    let ran = run(
        "trajectory_follow",
        &["--virtual-time", "--waypoint=0,-40,170,-40"],
    );
    assert_eq!(ran.code, Some(2));
    assert!(ran.stderr.contains("knee at 170 deg"), "{}", ran.stderr);
}
