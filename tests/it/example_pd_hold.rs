//! The `pd_hold` example on its simulated motor, in virtual time: the arm turns by the given
//! angle and settles, short of it by what gravity over the PD stiffness predicts, and the motor
//! ends off. The example's binary runs end to end.

use crate::support;

use core::time::Duration;
use std::io::{BufRead, BufReader};

use rmd_demos::pd_hold::{self, PdHold};
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::rig::open::sim_buses;
use rmd_rt::sim::ControlMode;
use rmd_rt::{Robot, RtLoop, RunLimit, StopReason};
use support::{Csv, Ran, example, run, temp_file};

/// The example's robot description.
const ROBOT: &str = include_str!("../../examples/robots/pd_hold.toml");

fn settle(move_deg: f64) {
    let robot = Robot::from_toml(ROBOT).unwrap();
    let arm = robot.joint("arm").unwrap();
    let torque_constant = robot.spec(arm).torque_constant_nm_per_amp.unwrap();
    let sims = pd_hold::sims(&robot, 1);
    let link = sims[0].motors[0].load.gravity.clone().unwrap();
    let clock = VirtualClock::new();
    let mut buses = sim_buses(&clock, sims).unwrap();
    let controller = PdHold::new(&robot, move_deg);
    let (kp, kd) = (controller.kp, controller.kd);
    let mut rt =
        RtLoop::unsupervised(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
    let telemetry = rt.telemetry();
    let out = rt.run(RunLimit::Duration(Duration::from_secs(3)));
    assert_eq!(out.report.stop_reason, StopReason::TickLimit);
    assert_eq!(out.report.stats.deadline_misses, 0);
    assert_eq!(out.report.stats.missing_replies, 0);
    // The simulated arm starts at joint 0: the target is the move.
    let target_deg = out.controller.targets[arm];
    assert!((target_deg - move_deg).abs() < 0.05, "{target_deg}");
    let samples: Vec<_> = telemetry.drain().collect();
    assert_eq!(samples.len(), 3000);
    let last = samples.last().unwrap().joints()[arm.index()].feedback.joint;

    // A PD law against gravity stops short by gravity torque / stiffness, give or take the
    // gearbox's friction (0.36 N*m at the output) over the stiffness.
    let stiffness = kp * torque_constant; // N*m per degree
    let gravity = -link.torque_nm(target_deg.to_radians());
    let predicted = target_deg - gravity / stiffness;
    let friction_band = 0.36 / stiffness;
    let error = last.angle_deg - predicted;
    println!(
        "target {target_deg}: final {:.3} deg, predicted {predicted:.3} +- {friction_band:.3} deg (kd {kd})",
        last.angle_deg
    );
    assert!(error.abs() <= friction_band + 0.05, "error {error} deg");
    assert!(last.velocity_dps.abs() < 0.5);
    // Settled within 0.8 s: from then on within 0.2 degrees of the final angle.
    let settled = samples
        .iter()
        .rposition(|s| {
            (s.joints()[arm.index()].feedback.joint.angle_deg - last.angle_deg).abs() > 0.2
        })
        .map_or(0.0, |i| samples[i].time_s);
    println!("settled after {settled:.3} s");
    assert!(settled < 0.8, "settled after {settled} s");
    // The loop's joint angle is the simulated arm's true angle.
    let snapshot = buses[0].snapshot(MotorId::new(1).unwrap()).unwrap();
    assert_eq!(snapshot.mode, ControlMode::Off);
    assert!((snapshot.output_angle_deg - last.angle_deg).abs() < 0.5);
}

#[test]
fn pd_hold_settles_above_horizontal() {
    settle(30.0);
}

#[test]
fn pd_hold_settles_below_horizontal() {
    settle(-20.0);
}

#[test]
fn the_example_runs_end_to_end() {
    let csv = temp_file("pd_hold.csv");
    let ran = run(
        "pd_hold",
        &[
            "--virtual-time",
            "--move-deg",
            "-20",
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    assert_eq!(ran.code, Some(0), "{}\n{}", ran.stdout, ran.stderr);
    for line in [
        "rmd-rt loop report: 1 motor(s) on 1 bus(es) at 1000 Hz",
        "ticks 3000 ",
        "1/1 motors confirmed off",
        "pd_hold results",
    ] {
        assert!(
            ran.stdout.contains(line),
            "{line:?} missing in:\n{}",
            ran.stdout
        );
    }
    // The target is the start angle (the arm hangs still for the few milliseconds of the
    // start-up identification) moved by -20 degrees.
    let target: f64 = ran
        .stdout
        .split("(target ")
        .nth(1)
        .and_then(|rest| rest.split(" deg").next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no target in:\n{}", ran.stdout));
    assert!((target + 20.0).abs() < 0.05, "{target}");
    let csv = Csv::take(&csv);
    assert_eq!(csv.rows.len(), 3000);
    assert_eq!(csv.header.len(), 2 + 7 + 4);
    let angle: Vec<f64> = csv
        .values("arm.position_rad")
        .into_iter()
        .map(f64::to_degrees)
        .collect();
    // It turned from 0 to about -20 degrees (short of it by gravity, see above).
    assert!(
        angle[0].abs() < 0.5 && (angle[2999] + 20.0).abs() < 1.5,
        "{} .. {}",
        angle[0],
        angle[2999]
    );
    // The commands stay within the description's 3 A limit (to the nearest iqControl step,
    // 32/2000 A: the loop rounds the limit to the nearest raw value).
    let command = csv.column("arm.commanded_a");
    let largest = csv
        .rows
        .iter()
        .map(|r| r[command].parse::<f64>().unwrap().abs())
        .fold(0.0, f64::max);
    assert!(largest > 2.9 && largest <= 3.0 + 0.016, "{largest} A");
    // A move that is not a number never starts.
    let ran = run("pd_hold", &["--virtual-time", "--move-deg", "NaN"]);
    assert_eq!(ran.code, Some(2));
    assert!(ran.stderr.contains("not a finite number"), "{}", ran.stderr);
}

/// Starts the example `name` with `args` (standard input closed, output captured) and lets it
/// run: the caller signals or waits for it.
fn spawn(name: &str, args: &[&str]) -> std::process::Child {
    std::process::Command::new(example(name))
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("starting example {name}: {e}"))
}

/// Ctrl-C (SIGINT) stops the example the project's way: zero torque, motor off, the report,
/// exit status 130.
#[test]
fn ctrl_c_stops_the_example_safely_with_status_130() {
    // Real time, so that it is still running when the signal comes; a loaded machine may not
    // run the loop for more than the default 50 ms stall bound now and then, which is not what
    // this test is about.
    let mut child = spawn("pd_hold", &["--duration", "20", "--stall-bound", "60s"]);
    // Its first status line (on standard error, once a second) says the loop is running.
    let stderr = BufReader::new(child.stderr.take().unwrap());
    let (lines_tx, lines) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in stderr.lines().map_while(Result::ok) {
            let _ = lines_tx.send(line);
        }
    });
    let mut seen = Vec::new();
    while !seen.iter().any(|l: &String| l.contains("misses")) {
        match lines.recv_timeout(Duration::from_secs(30)) {
            Ok(line) => seen.push(line),
            Err(e) => panic!("no status line ({e}): {seen:?}"),
        }
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let mut ran = Ran::from(child.wait_with_output().unwrap());
    reader.join().unwrap();
    seen.extend(lines.try_iter());
    ran.stderr = seen.join("\n");
    assert_eq!(ran.code, Some(130), "{}\n{}", ran.stdout, ran.stderr);
    assert!(
        ran.stdout.contains("stopped: stop requested"),
        "{}",
        ran.stdout
    );
    assert!(
        ran.stdout.contains("1/1 motors confirmed off"),
        "{}",
        ran.stdout
    );
    assert!(ran.stderr.contains("interrupted"), "{}", ran.stderr);
}

/// The examples take the loop's CPU latency request (`--cpu-dma-latency US|off`, default 0 us
/// with `--cpu` or `--fifo`) and the report's real-time line says whether it was held (as root,
/// with the device) or why not; a bad value is a usage error naming the flag.
#[test]
fn the_example_takes_the_cpu_latency_request() {
    let realtime = |args: &[&str]| {
        let mut all = vec!["--virtual-time", "--duration", "0.1"];
        all.extend_from_slice(args);
        let ran = run("pd_hold", &all);
        assert_eq!(
            ran.code,
            Some(0),
            "{args:?}: {}\n{}",
            ran.stdout,
            ran.stderr
        );
        ran.stdout
            .lines()
            .find(|l| l.starts_with("real-time:"))
            .unwrap_or_else(|| panic!("{args:?}: no real-time line in:\n{}", ran.stdout))
            .to_string()
    };
    for (args, said) in [
        (&["--cpu", "0"][..], "cpu_dma_latency: 0 us "),
        (
            &["--cpu", "0", "--cpu-dma-latency", "5"][..],
            "cpu_dma_latency: 5 us ",
        ),
        (
            &["--cpu", "0", "--cpu-dma-latency", "off"][..],
            "cpu_dma_latency: not requested",
        ),
        (&[][..], "cpu_dma_latency: not requested"),
    ] {
        let line = realtime(args);
        assert!(line.contains(said), "{args:?}: {line}");
        if said.ends_with("us ") {
            assert!(
                line.contains(&format!("{said}held")) || line.contains(&format!("{said}FAILED (")),
                "{args:?}: {line}"
            );
        }
    }
    let ran = run("pd_hold", &["--virtual-time", "--cpu-dma-latency", "soon"]);
    assert_eq!(ran.code, Some(2));
    assert!(ran.stderr.contains("--cpu-dma-latency"), "{}", ran.stderr);
}
