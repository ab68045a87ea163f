//! The `leg4` example on its simulated leg, in virtual time: the foot tracks the step cycle,
//! gravity compensation removes the sag, joint and current limits hold, the loop keeps time, and
//! the motors end off.

// The tests use part of the example (not its `main`).
#[allow(dead_code)]
#[path = "../examples/leg4.rs"]
mod leg4;

use core::time::Duration;

use clap::Parser;
use leg4::shared::impedance::Gains;
use leg4::shared::leg::{self, JOINTS, LegModel};
use leg4::shared::runner;
use leg4::shared::step_cycle::{StepCycle, StepParams};
use nalgebra::Vector4;
use rmd_rt::bus::VirtualClock;
use rmd_rt::protocol::MotorId;
use rmd_rt::sim::{ControlMode, SimBus};
use rmd_rt::{LoopOutcome, RobotConfig, RtLoop, RunLimit, StopReason, connect};

/// Runs the leg's controller for `seconds` of virtual time on the simulated leg; returns the
/// outcome, the simulated bus (to look at the motors) and the loop's telemetry.
fn run_leg(
    model: &LegModel,
    controller_model: LegModel,
    gains: Gains,
    robot: RobotConfig,
    seconds: f64,
) -> (
    LoopOutcome<leg4::StepController>,
    SimBus<VirtualClock>,
    Vec<rmd_rt::rt::TelemetrySample>,
) {
    let clock = VirtualClock::new();
    let sims = leg4::sim(model, &robot, 1).unwrap();
    let mut buses = connect::sim_buses(&clock, sims).unwrap();
    // The first frames on the wire (the start-up and the first ticks).
    buses[0].record_trace(256);
    let cycle = StepCycle::plan(StepParams::new(leg4::step_center(model))).unwrap();
    let (recorder, _samples) = runner::recorder(16);
    let controller = leg4::StepController::new(controller_model, gains, cycle, recorder);
    let rt = RtLoop::new(robot, clock.clone(), buses.iter_mut().collect(), controller).unwrap();
    let telemetry = rt.telemetry();
    let outcome = rt.run(RunLimit::Duration(Duration::from_secs_f64(seconds)));
    let samples = telemetry.drain().collect();
    (outcome, buses.pop().unwrap(), samples)
}

fn robot_with_telemetry(model: &LegModel) -> RobotConfig {
    let mut robot = leg4::robot(model, "sim", 1000.0);
    robot.loop_config.telemetry_capacity = 8192;
    robot
}

fn assert_motors_off(bus: &mut SimBus<VirtualClock>) {
    for id in 1..=JOINTS as u8 {
        let snapshot = bus.snapshot(MotorId::new(id).unwrap()).unwrap();
        assert_eq!(snapshot.mode, ControlMode::Off, "motor {id}: {snapshot:?}");
    }
}

#[test]
fn the_foot_tracks_the_step_cycle() {
    let model = LegModel::new();
    let (out, mut bus, _) = run_leg(
        &model,
        model.clone(),
        Gains::new(),
        robot_with_telemetry(&model),
        5.0,
    );
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
}

#[test]
fn gravity_compensation_removes_the_sag() {
    let model = LegModel::new();
    let mut without = Gains::new();
    without.gravity_compensation = false;
    let run = |gains| {
        let (out, mut bus, _) = run_leg(
            &model,
            model.clone(),
            gains,
            leg4::robot(&model, "sim", 1000.0),
            4.0,
        );
        assert_motors_off(&mut bus);
        out.controller
    };
    let with_bias = run(Gains::new()).stance_z_bias_m();
    let without_bias = run(without).stance_z_bias_m();
    // The sag the model predicts at the middle of the stance: the impedance spring carries the
    // leg's weight, dz = (K^-1 J^-T tau_gravity)_z.
    let q = leg::rad(leg4::working_pose_deg(&model).unwrap());
    let (_, j) = model.foot_and_jacobian(&q);
    let force = j.transpose().try_inverse().unwrap() * model.gravity_torques(&q);
    let predicted = force.component_div(&Gains::new().stiffness)[2];
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
    let model = LegModel::new();
    let mut robot = robot_with_telemetry(&model);
    // A knee motor limited to 0.5 A: the step needs more.
    let knee_limit = 0.5;
    robot.buses[0].motors[2].current_limit_amps = knee_limit;
    let (out, mut bus, samples) = run_leg(&model, model.clone(), Gains::new(), robot, 3.0);
    assert_eq!(samples.len(), 3000);
    let clamped = out.report.stats.motors[2].clamped_commands;
    assert!(clamped > 100, "clamped {clamped}");
    let (commanded, measured) = samples.iter().fold((0.0f64, 0.0f64), |(c, m), s| {
        let knee = s.joints()[2];
        (c.max(knee.command_amps.abs()), m.max(knee.iq_amps.abs()))
    });
    // iqControl resolution 0.016 A, iq resolution 0.016 A.
    assert!(commanded <= knee_limit + 1e-9, "commanded {commanded} A");
    assert!(measured <= knee_limit + 0.02, "measured {measured} A");
    assert_motors_off(&mut bus);
}

#[test]
fn a_joint_beyond_its_limit_stops_the_run_safely() {
    let model = LegModel::new();
    // The controller believes the knee may not bend beyond 80 degrees; the step needs ~100.
    let mut strict = model.clone();
    strict.limits[2].max_deg = 80.0;
    let (out, mut bus, _) = run_leg(
        &model,
        strict,
        Gains::new(),
        robot_with_telemetry(&model),
        3.0,
    );
    assert_eq!(out.report.stop_reason, StopReason::ControllerFinished);
    match out.controller.halt {
        Some(leg4::Halt::JointLimit { joint: 2, deg }) => assert!(deg > 80.0, "{deg}"),
        other => panic!("expected a knee limit halt, got {other:?}"),
    }
    assert!(out.report.stats.ticks < 3000);
    assert!(out.report.safe_stop.all_off_confirmed());
    assert_motors_off(&mut bus);
}

#[test]
fn a_joint_out_of_range_at_start_is_never_moved() {
    let model = LegModel::new();
    // The controller believes the knee must be above 70 degrees: it powers up at 60.
    let mut strict = model.clone();
    strict.limits[2].min_deg = 70.0;
    let (out, mut bus, samples) = run_leg(
        &model,
        strict,
        Gains::new(),
        robot_with_telemetry(&model),
        3.0,
    );
    assert!(matches!(
        out.controller.halt,
        Some(leg4::Halt::JointLimit { joint: 2, .. })
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
    assert!(err.contains("hip_aa"), "{err}");
    let ok = StepCycle::plan(StepParams::new(leg4::step_center(&model))).unwrap();
    leg4::check_cycle(&model, &ok, 5.0).unwrap();
}

#[test]
fn the_example_runs_end_to_end_and_writes_its_telemetry() {
    let csv = std::env::temp_dir().join(format!("rmd-rt-leg4-{}.csv", std::process::id()));
    let args = leg4::Args::parse_from([
        "leg4",
        "--virtual-time",
        "--quiet",
        "--duration",
        "2",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let summary = leg4::run(&args).unwrap();
    assert!(summary.ok(), "{}", summary.report);
    assert_eq!(summary.report.stats.ticks, 2000);
    assert_eq!(summary.dropped_samples, 0);
    assert_eq!(summary.csv_rows, 2000);
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::remove_file(&csv).ok();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[0], "time_s");
    assert_eq!(header.len(), 19);
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2000);
    assert!(rows.iter().all(|r| r.len() == header.len()));
    assert!(rows.iter().any(|r| r[1] == "stance") && rows.iter().any(|r| r[1] == "swing"));
    // The error column is the distance between the desired and measured foot positions.
    let error_col = header.iter().position(|h| *h == "error_mm").unwrap();
    for r in rows.iter().step_by(97) {
        let v: Vec<f64> = r[2..10].iter().map(|x| x.parse().unwrap()).collect();
        let d = ((v[0] - v[4]).powi(2) + (v[1] - v[5]).powi(2) + (v[2] - v[6]).powi(2)).sqrt();
        let e: f64 = r[error_col].parse().unwrap();
        assert!((d * 1000.0 - e).abs() < 0.02, "{r:?}");
    }
    // Bad options are refused with a message.
    let bad = leg4::Args::parse_from(["leg4", "--iface", "can0", "--virtual-time"]);
    assert!(leg4::run(&bad).unwrap_err().contains("--virtual-time"));
}
