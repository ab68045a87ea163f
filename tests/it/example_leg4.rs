//! The `leg4` example on its simulated leg, in virtual time: the foot tracks the step cycle,
//! gravity compensation removes the sag, joint and current limits hold, the loop keeps time, and
//! the motors end off. The example's binary runs end to end: its report, its results, its CSV
//! file with the joints' and the controller's columns, its exit statuses.

use crate::support;

use core::time::Duration;

use nalgebra::Vector4;
use rmd_demos::impedance::ImpedanceGains;
use rmd_demos::leg::{self, JOINTS, LegModel};
use rmd_demos::leg4::{self, Halt, SIGNALS, StepController};
use rmd_demos::step_cycle::{StepCycle, StepParams, StepPhase};
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::rig::open::sim_buses;
use rmd_rt::rt::robot::RobotConfig;
use rmd_rt::rt::telemetry::TelemetrySample;
use rmd_rt::sim::{ControlMode, SimBus};
use rmd_rt::{LoopOutcome, Robot, RtLoop, RunLimit, StopReason};
use support::{Csv, run, temp_file};

/// The example's robot description.
const ROBOT: &str = include_str!("../../examples/robots/leg4.toml");

fn description() -> RobotConfig {
    let mut config = RobotConfig::from_toml(ROBOT).unwrap();
    config.loop_config.telemetry_capacity = 8192;
    config
}

/// Runs the leg's controller (believing the leg is `controller_model`) for `seconds` of virtual
/// time on the simulated leg described by `config`; returns the outcome, the simulated bus (to
/// look at the motors) and the loop's telemetry.
fn run_leg(
    controller_model: LegModel,
    gains: ImpedanceGains,
    config: RobotConfig,
    seconds: f64,
) -> (
    LoopOutcome<StepController>,
    SimBus<VirtualClock>,
    Vec<TelemetrySample>,
) {
    let robot = Robot::try_from(config).unwrap();
    let clock = VirtualClock::new();
    let mut buses = sim_buses(&clock, leg4::sims(&robot, 1).unwrap()).unwrap();
    // The first frames on the wire (the start-up and the first ticks).
    buses[0].record_trace(256);
    let cycle = StepCycle::plan(StepParams::new(leg4::step_center(&LegModel::new()))).unwrap();
    let controller = StepController::new(&robot, controller_model, gains, cycle).unwrap();
    let mut rt =
        RtLoop::unsupervised(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
    let telemetry = rt.telemetry();
    let outcome = rt.run(RunLimit::Duration(Duration::from_secs_f64(seconds)));
    let samples = telemetry.drain().collect();
    (outcome, buses.pop().unwrap(), samples)
}

fn assert_motors_off(bus: &mut SimBus<VirtualClock>) {
    for id in 1..=JOINTS as u8 {
        let snapshot = bus.snapshot(MotorId::new(id).unwrap()).unwrap();
        assert_eq!(snapshot.mode, ControlMode::Off, "motor {id}: {snapshot:?}");
    }
}

fn knee() -> usize {
    Robot::from_toml(ROBOT)
        .unwrap()
        .joint("knee")
        .unwrap()
        .index()
}

#[test]
fn the_foot_tracks_the_step_cycle() {
    let (out, mut bus, samples) =
        run_leg(LegModel::new(), ImpedanceGains::new(), description(), 5.0);
    let r = &out.report;
    assert_eq!(r.stop_reason, StopReason::TickLimit, "{r}");
    assert_eq!(r.stats.ticks, 5000);
    assert_eq!(r.stats.deadline_misses, 0);
    assert_eq!(r.stats.missing_replies, 0);
    assert_eq!(r.stats.late_replies, 0);
    let k = &out.controller;
    assert_eq!(k.halt, None);
    assert_eq!(k.stale_ticks, 0);
    // Approach (about 0.5 s), then 1 s cycles.
    assert!(k.cycles >= 4, "{} cycles", k.cycles);
    // The stated tracking error: the foot stays within 12 mm of the planned step cycle, 4 mm rms;
    // within 5 mm in the stance (2.5 mm rms).
    let (rms, max) = (k.tracking.rms() * 1e3, k.tracking.max * 1e3);
    let (stance_rms, stance_max) = (k.stance_tracking.rms() * 1e3, k.stance_tracking.max * 1e3);
    println!(
        "tracking: rms {rms:.2} mm, max {max:.2} mm; stance rms {stance_rms:.2} mm, max {stance_max:.2} mm"
    );
    assert!(rms < 4.0 && max < 12.0, "rms {rms} mm, max {max} mm");
    assert!(
        stance_rms < 2.5 && stance_max < 5.0,
        "stance rms {stance_rms}, max {stance_max}"
    );
    // The tracking error is not trivially zero: the leg really moves through a 12 cm step.
    assert!(k.tracking.count > 4000 && rms > 0.1);
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    assert_motors_off(&mut bus);
    // The user signals carry the controller's view: the error signal is the distance between
    // the desired and measured foot, and its largest value after the approach is the max.
    assert_eq!(samples.len(), 5000);
    let signal = |s: &TelemetrySample, i: usize| s.signals()[i];
    let mut max_signal: f64 = 0.0;
    for s in &samples {
        let d = (0..3)
            .map(|a| signal(s, leg4::signal::FOOT_DESIRED + a) - signal(s, leg4::signal::FOOT + a))
            .map(|x| x * x)
            .sum::<f64>()
            .sqrt();
        let e = signal(s, leg4::signal::FOOT_ERROR_MM);
        assert!((d * 1000.0 - e).abs() < 1e-9, "tick {}", s.tick);
        if StepPhase::from_code(signal(s, leg4::signal::PHASE)) != Some(StepPhase::Approach) {
            max_signal = max_signal.max(e);
        }
    }
    assert!((max_signal - max).abs() < 1e-9, "{max_signal} vs {max}");
}

#[test]
fn gravity_compensation_removes_the_sag() {
    let model = LegModel::new();
    let mut without = ImpedanceGains::new();
    without.gravity_compensation = false;
    let run = |gains| {
        let (out, mut bus, _) = run_leg(model.clone(), gains, description(), 4.0);
        assert_motors_off(&mut bus);
        out.controller
    };
    let with_bias = run(ImpedanceGains::new()).stance_z_bias_m();
    let without_bias = run(without).stance_z_bias_m();
    // The sag the model predicts at the middle of the stance: the impedance spring carries the
    // leg's weight, dz = (K^-1 J^-T tau_gravity)_z.
    let q = leg::rad(leg4::working_pose_deg(&model).unwrap());
    let (_, j) = model.foot_and_jacobian(&q);
    let force = j.transpose().try_inverse().unwrap() * model.gravity_torques(&q);
    let predicted = force.component_div(&ImpedanceGains::new().stiffness)[2];
    println!(
        "stance height error: {:.3} mm with, {:.3} mm without gravity compensation (predicted {:.3} mm)",
        with_bias * 1e3,
        without_bias * 1e3,
        predicted * 1e3
    );
    assert!(predicted < -0.002, "the leg's weight matters: {predicted}");
    assert!(
        (without_bias - predicted).abs() < 0.3 * predicted.abs(),
        "sag {without_bias}, predicted {predicted}"
    );
    assert!(
        with_bias.abs() < 0.2 * predicted.abs(),
        "with compensation: {with_bias}"
    );
}

#[test]
fn current_limits_hold_even_when_the_controller_asks_for_more() {
    let mut config = description();
    // A knee motor limited to 0.5 A: the step needs more.
    let knee_limit = 0.5;
    let knee = knee();
    config.buses[0].motors[knee].current_limit_amps = knee_limit;
    let (out, mut bus, samples) = run_leg(LegModel::new(), ImpedanceGains::new(), config, 3.0);
    assert_eq!(samples.len(), 3000);
    let clamped = out.report.stats.motors[knee].counters.clamped_commands;
    assert!(clamped > 100, "clamped {clamped}");
    let (commanded, measured) = samples.iter().fold((0.0f64, 0.0f64), |(c, m), s| {
        let sample = s.joints()[knee];
        (
            c.max(sample.command_amps.abs()),
            m.max(sample.feedback.motor.current_amps.abs()),
        )
    });
    // iqControl resolution 0.016 A, iq resolution 0.016 A.
    assert!(commanded <= knee_limit + 1e-9, "commanded {commanded} A");
    assert!(measured <= knee_limit + 0.02, "measured {measured} A");
    assert_motors_off(&mut bus);
}

#[test]
fn a_joint_beyond_its_limit_stops_the_run_safely() {
    // The controller believes the knee may not bend beyond 80 degrees; the step needs ~100.
    let mut strict = LegModel::new();
    strict.limits[2].max_deg = 80.0;
    let (out, mut bus, _) = run_leg(strict, ImpedanceGains::new(), description(), 3.0);
    assert_eq!(
        out.report.stop_reason,
        StopReason::ControllerHalted("a joint went beyond its limit")
    );
    assert!(!out.report.normal_stop);
    match out.controller.halt {
        Some(Halt::JointLimit { joint, name, deg }) => {
            assert_eq!((joint.index(), name), (knee(), "knee"));
            assert!(deg > 80.0, "{deg}");
        }
        other => panic!("expected a knee limit halt, got {other:?}"),
    }
    assert!(!out.controller.results(&out.report).ok());
    assert!(out.report.stats.ticks < 3000);
    assert!(out.report.safe_stop.all_off_confirmed());
    assert_motors_off(&mut bus);
}

#[test]
fn a_joint_out_of_range_at_start_is_never_moved() {
    // The controller believes the knee must be above 70 degrees: it powers up at 60.
    let mut strict = LegModel::new();
    strict.limits[2].min_deg = 70.0;
    let (out, mut bus, samples) = run_leg(strict, ImpedanceGains::new(), description(), 3.0);
    assert!(matches!(
        out.controller.halt,
        Some(Halt::JointLimit { name: "knee", .. })
    ));
    assert_eq!(out.report.stats.ticks, 1);
    assert!(samples.is_empty());
    // Every 0x280 frame on the wire (start-up probe, tick 0, safe stop) carried zero torque.
    let frames: Vec<_> = bus
        .trace()
        .iter()
        .filter(|t| t.frame.id() == 0x280)
        .map(|t| t.frame)
        .collect();
    assert!(frames.len() >= 2, "{frames:?}");
    assert!(
        frames.iter().all(|f| f.data().iter().all(|b| *b == 0)),
        "{frames:?}"
    );
    assert_motors_off(&mut bus);
}

#[test]
fn a_step_beyond_the_joint_limits_is_refused_before_anything_moves() {
    let model = LegModel::new();
    let mut params = StepParams::new(leg4::step_center(&model));
    // 15 cm to the side: the hip abduction would need about 27 degrees (limit 25).
    params.center = Vector4::new(0.0, model.hip_offset_m + 0.15, -0.30, 0.0);
    let cycle = StepCycle::plan(params).unwrap();
    let err = leg4::check_cycle(&model, &cycle, 5.0).unwrap_err();
    assert!(err.to_string().contains("hip_aa"), "{err}");
    leg4::plan_cycle(&model).unwrap();
}

#[test]
fn the_controller_needs_every_joint_with_a_torque_constant() {
    let model = LegModel::new();
    let cycle = leg4::plan_cycle(&model).unwrap();
    let renamed = Robot::from_toml(&ROBOT.replace("\"knee\"", "\"shin\"")).unwrap();
    let err =
        StepController::new(&renamed, model.clone(), ImpedanceGains::new(), cycle).unwrap_err();
    assert!(err.to_string().contains("no joint named `knee`"), "{err}");
    let mut config = description();
    config.buses[0].motors[knee()].torque_constant_nm_per_amp = None;
    let robot = Robot::try_from(config).unwrap();
    let err = StepController::new(&robot, model, ImpedanceGains::new(), cycle).unwrap_err();
    assert!(
        err.to_string()
            .contains("joint knee has no torque_constant"),
        "{err}"
    );
}

/// The binary, as the README runs it (in virtual time, 2 s, CSV to a file of the test's).
#[test]
fn the_example_runs_end_to_end_and_writes_every_tick() {
    let csv = temp_file("leg4.csv");
    let ran = run(
        "leg4",
        &[
            "--virtual-time",
            "--duration",
            "2",
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    assert_eq!(ran.code, Some(0), "{}\n{}", ran.stdout, ran.stderr);
    for line in [
        "leg4: 4-motor leg on simulated motors, virtual time, 1000 Hz",
        "rmd-rt loop report: 4 motor(s) on 1 bus(es) at 1000 Hz",
        "stopped: tick limit reached",
        "ticks 2000 ",
        "4/4 motors confirmed off",
        "leg4 results",
        "foot tracking  rms",
    ] {
        assert!(
            ran.stdout.contains(line),
            "{line:?} missing in:\n{}",
            ran.stdout
        );
    }
    assert!(
        ran.stderr.contains(&format!(
            "telemetry: csv {}: 2000 written, 0 failed, 0 dropped, 0 errors",
            csv.display()
        )),
        "{}",
        ran.stderr
    );

    let csv = Csv::take(&csv);
    // time, tick, seven columns per joint (named after it), the controller's signals, four of
    // loop timing.
    assert_eq!(csv.header.len(), 2 + 7 * JOINTS + SIGNALS.len() + 4);
    assert_eq!(csv.header[..2], ["time_s", "tick"]);
    assert_eq!(csv.header[2], "hip_aa.position_rad");
    assert_eq!(
        csv.header[2 + 7 * JOINTS..2 + 7 * JOINTS + SIGNALS.len()],
        SIGNALS
    );
    assert_eq!(csv.rows.len(), 2000);
    assert!(csv.rows.iter().all(|r| r.len() == csv.header.len()));
    assert_eq!(
        csv.values("tick"),
        (0..2000).map(f64::from).collect::<Vec<_>>()
    );
    let phases = csv.values("phase");
    assert!(phases.iter().all(|p| StepPhase::from_code(*p).is_some()));
    assert!(
        phases.contains(&StepPhase::Stance.code()) && phases.contains(&StepPhase::Swing.code())
    );
    // The knee bends through the step: its angle column moves.
    let knee: Vec<f64> = csv
        .values("knee.position_rad")
        .into_iter()
        .map(f64::to_degrees)
        .collect();
    let (low, high) = knee
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), k| (l.min(*k), h.max(*k)));
    assert!(high - low > 10.0 && low > 5.0, "knee {low}..{high} deg");
    // The error column is the distance between the desired and measured foot positions.
    let error = csv.values("foot_error_mm");
    let axis = |name: &str| {
        (
            csv.values(&format!("foot_{name}_des_m")),
            csv.values(&format!("foot_{name}_m")),
        )
    };
    let (x, y, z) = (axis("x"), axis("y"), axis("z"));
    for i in (0..2000).step_by(97) {
        let d = ((x.0[i] - x.1[i]).powi(2) + (y.0[i] - y.1[i]).powi(2) + (z.0[i] - z.1[i]).powi(2))
            .sqrt();
        assert!((d * 1000.0 - error[i]).abs() < 0.01, "row {i}");
    }
}

#[test]
fn bad_options_are_refused_with_a_message_before_anything_moves() {
    for (args, message) in [
        (&["--iface", "can0", "--virtual-time"][..], "--virtual-time"),
        (&["--duration", "inf"], "not a finite duration"),
        (&["--duration", "NaN"], "not a finite duration"),
        (&["--duration=-1"], "cannot be negative"),
        (&["--stiffness", "inf"], "not a finite number"),
        (
            &["--stiffness=-5", "--virtual-time"],
            "give zero or a positive number",
        ),
        (
            &["--robot", "/nonexistent/leg.toml"],
            "/nonexistent/leg.toml",
        ),
        (&["--stall-bound", "0"], "above 0"),
        (&["--stall-bound", "2m"], "too long"),
        // Checked against the period by the description: 1 ms is one 1 kHz period.
        (
            &["--stall-bound", "1ms", "--virtual-time"],
            "loop.stall_bound_ms",
        ),
    ] {
        let ran = run("leg4", args);
        assert_eq!(ran.code, Some(2), "{args:?}: {}", ran.stderr);
        assert!(ran.stderr.contains(message), "{args:?}: {}", ran.stderr);
        assert!(
            !ran.stdout.contains("loop report"),
            "{args:?}: {}",
            ran.stdout
        );
    }
}

#[test]
fn a_robot_file_replaces_the_description() {
    // The same leg at 500 Hz with its knee named "shin": the controller does not find its knee.
    let renamed = temp_file("leg4-renamed.toml");
    std::fs::write(&renamed, ROBOT.replace("\"knee\"", "\"shin\"")).unwrap();
    let ran = run(
        "leg4",
        &["--virtual-time", "--robot", renamed.to_str().unwrap()],
    );
    std::fs::remove_file(&renamed).ok();
    assert_eq!(ran.code, Some(2), "{}", ran.stderr);
    assert!(
        ran.stderr.contains("no joint named `knee`"),
        "{}",
        ran.stderr
    );
    // A file at 500 Hz runs at 500 Hz.
    let slow = temp_file("leg4-500hz.toml");
    std::fs::write(&slow, ROBOT.replace("rate_hz = 1000.0", "rate_hz = 500.0")).unwrap();
    let csv = temp_file("leg4-500hz.csv");
    let ran = run(
        "leg4",
        &[
            "--virtual-time",
            "--quiet",
            "--seconds",
            "1",
            "--robot",
            slow.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ],
    );
    std::fs::remove_file(&slow).ok();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(ran.stdout.contains("at 500 Hz"), "{}", ran.stdout);
    assert_eq!(Csv::take(&csv).rows.len(), 500);
}
