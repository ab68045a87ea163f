//! The `quadruped` example on its simulated robot, in virtual time: sixteen motors on four buses,
//! four 0x280 frames per tick, the robot stands up from its crouch to the target height and holds
//! it, and every motor ends off. The example's binary runs end to end.

use crate::support;

use core::time::Duration;

use rmd_demos::leg::JOINTS;
use rmd_demos::quadruped::{self, LEG_NAMES, LEGS, SIGNALS, STAND_HEIGHT_M, StandController};
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::rig::open::sim_buses;
use rmd_rt::sim::{ControlMode, Node};
use rmd_rt::{Robot, RtLoop, RunLimit, StopReason};
use support::{Csv, run, temp_file};

/// The example's robot description.
const ROBOT: &str = include_str!("../../examples/robots/quadruped.toml");

#[test]
fn the_quadruped_stands_up_and_holds_the_pose() {
    let robot = Robot::from_toml(ROBOT).unwrap();
    assert_eq!((robot.buses().len(), robot.joint_count()), (4, 16));
    let clock = VirtualClock::new();
    let mut buses = sim_buses(&clock, quadruped::sims(&robot, 1).unwrap()).unwrap();
    for bus in &mut buses {
        bus.record_trace(20_000);
    }
    let controller = StandController::new(&robot, STAND_HEIGHT_M).unwrap();
    let rt =
        RtLoop::unsupervised(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
    let out = rt.run(RunLimit::Duration(Duration::from_secs(3)));
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    assert_eq!(r.stats.ticks, 3000);
    assert_eq!(r.stats.deadline_misses, 0);
    assert_eq!(r.stats.missing_replies, 0);
    // Every tick had all sixteen replies.
    assert_eq!(r.stats.round_trip_us.count, 3000);

    let k = &out.controller;
    assert_eq!(k.halt, None);
    // Standing up from 0.15 m takes the planned ~1.2 s; the body reaches 0.28 m (within 5 mm)
    // before the plan ends, and each leg ends within 3 mm of it.
    let reached = k.reached_at_s.expect("the robot stood up");
    println!(
        "rise planned {:.2} s, body within 5 mm after {reached:.2} s; heights {:?}; hold error rms {:.2} mm, max {:.2} mm",
        k.rise_s,
        k.heights_m,
        k.hold_error.rms() * 1e3,
        k.hold_error.max * 1e3
    );
    assert!(k.rise_s > 0.5 && reached <= k.rise_s + 0.1, "{reached} s");
    for (name, h) in LEG_NAMES.iter().zip(k.heights_m) {
        assert!((h - STAND_HEIGHT_M).abs() < 0.003, "{name}: {h} m");
    }
    assert!(
        k.hold_error.count > 1000 && k.hold_error.max < 0.003,
        "{:?}",
        k.hold_error
    );
    assert!(k.results(r).ok());

    // Four 0x280 frames per tick, one on each bus, sent at the same instant.
    let starts: Vec<Vec<_>> = buses
        .iter()
        .map(|bus| {
            bus.trace()
                .iter()
                .filter(|t| t.from == Node::Host && t.frame.id() == 0x280)
                .map(|t| t.start)
                .collect()
        })
        .collect();
    for s in &starts {
        // Start-up probe + one per tick + the safe stop's zero torque.
        assert_eq!(s.len(), 3000 + 2);
    }
    // (The safe stop's frames go out bus after bus.)
    for i in 0..=3000 {
        assert!(starts.iter().all(|s| s[i] == starts[0][i]), "frame {i}");
    }
    for bus in &mut buses {
        for id in 1..=JOINTS as u8 {
            let snapshot = bus.snapshot(MotorId::new(id).unwrap()).unwrap();
            assert_eq!(snapshot.mode, ControlMode::Off, "{snapshot:?}");
        }
    }
    assert!(r.safe_stop.all_off_confirmed());
}

#[test]
fn the_example_runs_end_to_end() {
    let csv = temp_file("quadruped.csv");
    let ran = run(
        "quadruped",
        &[
            "--virtual-time",
            "--quiet",
            "--duration",
            "2.5",
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    assert_eq!(ran.code, Some(0), "{}\n{}", ran.stdout, ran.stderr);
    assert!(
        ran.stdout.contains("16 motor(s) on 4 bus(es)"),
        "{}",
        ran.stdout
    );
    assert!(
        ran.stdout.contains("quadruped results\n  stood up"),
        "{}",
        ran.stdout
    );
    let csv = Csv::take(&csv);
    assert_eq!(csv.rows.len(), 2500);
    assert_eq!(csv.header.len(), 2 + 7 * LEGS * JOINTS + SIGNALS.len() + 4);
    assert_eq!(csv.column("hr_ankle.position_rad"), 2 + 7 * 15);
    // The body rises from the crouch to the standing height.
    let body = csv.values("body_height_m");
    assert!(
        (body[0] - quadruped::CROUCH_HEIGHT_M).abs() < 0.01,
        "{}",
        body[0]
    );
    assert!(
        (body[2499] - STAND_HEIGHT_M).abs() < 0.003,
        "{}",
        body[2499]
    );

    // One interface per leg on a real robot.
    let two = run("quadruped", &["--iface", "can0,can1"]);
    assert_eq!(two.code, Some(2));
    assert!(two.stderr.contains("4 bus(es) but 2"), "{}", two.stderr);
    // A height the legs cannot reach is refused before anything moves.
    let tall = run("quadruped", &["--virtual-time", "--height", "0.6"]);
    assert_eq!(tall.code, Some(2));
    assert!(
        tall.stderr.contains("out of the leg's reach"),
        "{}",
        tall.stderr
    );
    assert!(!tall.stdout.contains("loop report"));
}
