//! The `quadruped` example on its simulated robot, in virtual time: sixteen motors on four buses,
//! four 0x280 frames per tick, the robot stands up from its crouch to the target height and holds
//! it, and every motor ends off.

// The tests use part of the example (not its `main`).
#[allow(dead_code)]
#[path = "../examples/quadruped.rs"]
mod quadruped;

use core::time::Duration;

use clap::Parser;
use quadruped::shared::leg::JOINTS;
use quadruped::shared::runner;
use quadruped::{LEG_NAMES, LEGS};
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::sim::{ControlMode, Node};
use rmd_rt::{RtLoop, RunLimit, StopReason, connect};

#[test]
fn the_quadruped_stands_up_and_holds_the_pose() {
    let names: Vec<String> = (0..LEGS).map(|i| format!("sim{i}")).collect();
    let robot = quadruped::robot(&names, 1000.0).unwrap();
    assert_eq!((robot.buses.len(), robot.motor_count()), (4, 16));
    let clock = VirtualClock::new();
    let mut buses = connect::sim_buses(&clock, quadruped::sim(&robot, 1).unwrap()).unwrap();
    for bus in &mut buses {
        bus.record_trace(20_000);
    }
    let (recorder, _samples) = runner::recorder(16);
    let controller = quadruped::StandController::new(quadruped::STAND_HEIGHT_M, recorder);
    let rt = RtLoop::new(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
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
        assert!(
            (h - quadruped::STAND_HEIGHT_M).abs() < 0.003,
            "{name}: {h} m"
        );
    }
    assert!(
        k.hold_error.count > 1000 && k.hold_error.max < 0.003,
        "{:?}",
        k.hold_error
    );

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
    let csv = std::env::temp_dir().join(format!("rmd-rt-quadruped-{}.csv", std::process::id()));
    let args = quadruped::Args::parse_from([
        "quadruped",
        "--virtual-time",
        "--quiet",
        "--duration",
        "2.5",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let summary = quadruped::run(&args).unwrap();
    std::fs::remove_file(&csv).ok();
    assert!(summary.ok(), "{}", summary.report);
    assert_eq!(summary.csv_rows, 2500);
    // One interface per leg on a real robot.
    let two = quadruped::Args::parse_from(["quadruped", "--iface", "can0,can1"]);
    assert!(quadruped::run(&two).unwrap_err().contains("4 buses"));
    // A height the legs cannot reach is refused before anything moves.
    let tall = quadruped::Args::parse_from(["quadruped", "--virtual-time", "--height", "0.6"]);
    assert!(
        quadruped::run(&tall)
            .unwrap_err()
            .contains("out of the leg's reach")
    );
}
