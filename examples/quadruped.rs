//! # quadruped: four legs on four buses stand up from a crouch and hold the pose
//!
//! Sixteen RMD motors: four legs of four motors (ids 1..=4 on each leg's bus: hip
//! abduction/adduction, hip flexion, knee, ankle), one CAN bus per leg, all driven by one loop
//! that sends four 0x280 frames per tick (one per bus, the buses exchange in parallel) and
//! collects the sixteen replies.
//!
//! The robot powers up lying on its belly with its legs folded (the crouch, hips 15 cm above the
//! feet). The controller plans one trajectory of all sixteen foot coordinates (x, y, z, pitch of
//! each foot), synchronized so that every foot arrives at the same time, from where the feet are
//! to the standing pose (hips 28 cm above the feet), follows it with a Cartesian impedance law per
//! leg (see the `leg4` example) and then holds the pose.
//!
//! ```sh
//! cargo run --release --example quadruped                                # simulated, real time
//! cargo run --release --example quadruped -- --virtual-time
//! cargo run --release --example quadruped -- --iface can0,can1,can2,can3 # front left, front
//!                                                                        # right, hind left, hind right
//! ```
//!
//! The simulated robot is on a stand: each joint carries its leg's weight, but there is no
//! ground contact, so the body's weight on the feet is not simulated (see docs/simulator.md).

// Each example uses part of the shared code.
#[allow(dead_code)]
pub(crate) mod shared;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use nalgebra::Vector4;
use rmd_rt::connect::{self, Target};
use rmd_rt::sim::SimConfig;
use rmd_rt::traj::{Input, Trajectory, TrajectoryError, calculate};
use rmd_rt::{
    Commands, Controller, Feedback, Flow, LoopReport, RobotConfig, RtLoop, RunLimit, TickContext,
};
use shared::cli::CommonArgs;
use shared::impedance::{self, ErrorStats, Gains, JointState};
use shared::leg::{self, JOINTS, LegModel};
use shared::runner::{self, Monitor, Recorder, Sample};
use shared::{say, say_raw};

/// Legs of the robot.
pub(crate) const LEGS: usize = 4;

/// Leg names, in bus order.
pub(crate) const LEG_NAMES: [&str; LEGS] = ["front_left", "front_right", "hind_left", "hind_right"];

/// Hip height above the feet when crouching (power-up), m.
pub(crate) const CROUCH_HEIGHT_M: f64 = 0.15;

/// Hip height above the feet when standing, m.
pub(crate) const STAND_HEIGHT_M: f64 = 0.28;

/// Axes of the stand-up trajectory: x, y, z, pitch of each foot.
const AXES: usize = 4 * LEGS;

/// Four legs on four buses, standing up from a crouch and holding the pose.
#[derive(Parser, Debug, Clone)]
#[command(name = "quadruped")]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) common: CommonArgs,
    /// How long to run, seconds (standing up takes about 1.5 s, then the robot holds the pose).
    #[arg(long, value_name = "SECONDS", default_value_t = 6.0)]
    pub(crate) duration: f64,
    /// Standing height: hips above the feet, m.
    #[arg(long, value_name = "M", default_value_t = STAND_HEIGHT_M)]
    pub(crate) height: f64,
    /// Where to write the telemetry (CSV).
    #[arg(long, value_name = "FILE", default_value = "target/quadruped.csv")]
    pub(crate) csv: PathBuf,
}

/// The model of each leg (left legs as modelled, right legs mirrored).
pub(crate) fn leg_models() -> [LegModel; LEGS] {
    let left = LegModel::new();
    let right = left.mirrored();
    [left.clone(), right.clone(), left, right]
}

/// A foot under its hip flexion axis, `height` below the hip, vertical.
pub(crate) fn foot_under_hip(model: &LegModel, height: f64) -> Vector4<f64> {
    Vector4::new(0.0, model.hip_offset_m, -height, 0.0)
}

/// The joint angles (degrees) of a leg with its foot `height` below the hip.
pub(crate) fn pose_deg(model: &LegModel, height: f64) -> Result<[f64; JOINTS], String> {
    model
        .inverse(&foot_under_hip(model, height))
        .map(|q| leg::deg(&q))
        .ok_or_else(|| format!("a foot {height} m below the hip is out of the leg's reach"))
}

/// The robot description: leg `i` on `interfaces[i]`, powered up in the crouch.
pub(crate) fn robot(interfaces: &[String], rate_hz: f64) -> Result<RobotConfig, String> {
    let mut robot = RobotConfig::new(rate_hz);
    for (i, model) in leg_models().iter().enumerate() {
        robot = robot.with_bus(leg::leg_bus(
            model,
            &interfaces[i],
            LEG_NAMES[i],
            pose_deg(model, CROUCH_HEIGHT_M)?,
        ));
    }
    Ok(robot)
}

/// The simulated robot: four simulated buses, legs powered up in the crouch, each joint loaded
/// by its leg's weight fitted at the standing pose.
pub(crate) fn sim(robot: &RobotConfig, seed: u64) -> Result<Vec<SimConfig>, String> {
    leg_models()
        .iter()
        .zip(&robot.buses)
        .enumerate()
        .map(|(i, (model, bus))| {
            Ok(leg::leg_sim(
                model,
                bus,
                pose_deg(model, CROUCH_HEIGHT_M)?,
                pose_deg(model, STAND_HEIGHT_M)?,
                seed + i as u64,
            ))
        })
        .collect()
}

/// What the robot is doing.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Standing up.
    Rise,
    /// Holding the standing pose.
    Hold,
}

/// Why the controller stopped the run by itself.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum Halt {
    /// A joint went beyond its limit.
    JointLimit {
        /// The leg.
        leg: usize,
        /// The joint.
        joint: usize,
        /// Its angle, degrees.
        deg: f64,
    },
    /// The stand-up could not be planned.
    Plan(TrajectoryError),
}

impl std::fmt::Display for Halt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Halt::JointLimit { leg, joint, deg } => write!(
                f,
                "{}.{} at {deg:.1} deg is beyond its limit: stopped (check the homing: \
                 zero_offset_deg and the power-up pose)",
                LEG_NAMES[*leg],
                leg::JOINT_NAMES[*joint]
            ),
            Halt::Plan(e) => write!(f, "cannot plan the stand-up: {e}"),
        }
    }
}

/// One tick of the robot, for the live display and the CSV file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct QuadSample {
    /// Seconds since the controller started.
    pub(crate) t: f64,
    /// The phase.
    pub(crate) phase: Phase,
    /// Desired hip height above the feet, m.
    pub(crate) target_height_m: f64,
    /// Each leg's hip height above its foot, m.
    pub(crate) height_m: [f64; LEGS],
    /// Largest foot position error of any leg, m.
    pub(crate) max_error_m: f64,
}

impl QuadSample {
    /// Mean hip height above the feet: the body height, m.
    pub(crate) fn body_height_m(&self) -> f64 {
        self.height_m.iter().sum::<f64>() / LEGS as f64
    }
}

impl Sample for QuadSample {
    fn csv_header() -> &'static str {
        "time_s,phase,target_height_m,body_height_m,front_left_m,front_right_m,hind_left_m,\
         hind_right_m,max_foot_error_mm"
    }

    fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        let phase = match self.phase {
            Phase::Rise => "rise",
            Phase::Hold => "hold",
        };
        write!(out, "{:.4},{phase}", self.t)?;
        runner::write_fields(out, &[self.target_height_m, self.body_height_m()], 5)?;
        runner::write_fields(out, &self.height_m, 5)?;
        runner::write_fields(out, &[self.max_error_m * 1000.0], 3)
    }
}

/// The stand-up controller.
pub(crate) struct StandController {
    models: [LegModel; LEGS],
    gains: Gains,
    stand_height_m: f64,
    input: Input<AXES>,
    plan: Trajectory<AXES>,
    recorder: Recorder<QuadSample>,
    t0: f64,
    /// Each leg's hip height above its foot at the last tick, m.
    pub(crate) heights_m: [f64; LEGS],
    /// When the body height first came within 5 mm of the target, s after the start.
    pub(crate) reached_at_s: Option<f64>,
    /// Foot position error (m) of every leg while holding.
    pub(crate) hold_error: ErrorStats,
    /// Duration of the planned stand-up, s.
    pub(crate) rise_s: f64,
    /// Why the controller stopped the run, if it did.
    pub(crate) halt: Option<Halt>,
}

impl StandController {
    /// A controller that stands the robot up to `stand_height_m`.
    pub(crate) fn new(stand_height_m: f64, recorder: Recorder<QuadSample>) -> Self {
        // A calm stand-up: about 1.5 s.
        let input = Input::with_limits([0.15; AXES], [0.6; AXES], [6.0; AXES]);
        Self {
            models: leg_models(),
            gains: Gains::new(),
            stand_height_m,
            input,
            plan: Trajectory::EMPTY,
            recorder,
            t0: 0.0,
            heights_m: [0.0; LEGS],
            reached_at_s: None,
            hold_error: ErrorStats::default(),
            rise_s: 0.0,
            halt: None,
        }
    }

    /// Telemetry samples overwritten before they were read.
    pub(crate) fn dropped_samples(&self) -> u64 {
        self.recorder.dropped
    }
}

impl Controller for StandController {
    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        for (l, model) in self.models.iter().enumerate() {
            let joints = JointState::read(feedback, l * JOINTS);
            if let Some(joint) = model.limit_violation(&joints.q) {
                self.halt = Some(Halt::JointLimit {
                    leg: l,
                    joint,
                    deg: joints.q[joint].to_degrees(),
                });
                return;
            }
            let from = model.foot(&joints.q);
            let to = foot_under_hip(model, self.stand_height_m);
            for a in 0..4 {
                self.input.current_position[l * 4 + a] = from[a];
                self.input.target_position[l * 4 + a] = to[a];
            }
        }
        // Every foot coordinate arrives at the same time (the default synchronization).
        match calculate(&self.input) {
            Ok(plan) => {
                self.plan = plan;
                self.rise_s = plan.duration();
            }
            Err(e) => self.halt = Some(Halt::Plan(e)),
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        if self.halt.is_some() {
            return Flow::Stop;
        }
        let t = ctx.time_s() - self.t0;
        let plan = self.plan.state_at(t);
        let phase = if t < self.plan.duration() {
            Phase::Rise
        } else {
            Phase::Hold
        };
        let mut max_error: f64 = 0.0;
        for (l, model) in self.models.iter().enumerate() {
            let joints = JointState::read(feedback, l * JOINTS);
            let target = Vector4::from_fn(|a, _| plan[l * 4 + a].position);
            let velocity = Vector4::from_fn(|a, _| plan[l * 4 + a].velocity);
            let out = impedance::impedance(model, &self.gains, &joints, &target, &velocity);
            if let Some(joint) = out.beyond_limit {
                self.halt = Some(Halt::JointLimit {
                    leg: l,
                    joint,
                    deg: joints.q[joint].to_degrees(),
                });
                return Flow::Stop;
            }
            for j in 0..JOINTS {
                let _ = cmd.set_torque(l * JOINTS + j, out.torque[j]);
            }
            self.heights_m[l] = -out.foot.z;
            let error = out.position_error_m(&target);
            max_error = max_error.max(error);
            if phase == Phase::Hold {
                self.hold_error.add(error);
            }
        }
        let sample = QuadSample {
            t,
            phase,
            target_height_m: self.stand_height_m,
            height_m: self.heights_m,
            max_error_m: max_error,
        };
        if self.reached_at_s.is_none()
            && (sample.body_height_m() - self.stand_height_m).abs() < 0.005
        {
            self.reached_at_s = Some(t);
        }
        self.recorder.record(sample);
        Flow::Continue
    }
}

/// The robot's part of the status line: phase, body height, largest foot error.
#[derive(Debug, Default)]
pub(crate) struct QuadStatus;

impl runner::Status<QuadSample> for QuadStatus {
    fn observe(&mut self, _: &QuadSample) {}

    fn line(&self, s: &QuadSample) -> String {
        format!(
            "{} body height {:.3} m (target {:.3})  foot error <= {:4.1} mm",
            if s.phase == Phase::Rise {
                "rise"
            } else {
                "hold"
            },
            s.body_height_m(),
            s.target_height_m,
            s.max_error_m * 1000.0
        )
    }
}

/// What a run of the example produced.
#[derive(Debug)]
pub(crate) struct Summary {
    /// The loop's report.
    pub(crate) report: LoopReport,
    /// Each leg's hip height above its foot at the end, m.
    pub(crate) heights_m: [f64; LEGS],
    /// The target height, m.
    pub(crate) target_m: f64,
    /// When the body height came within 5 mm of the target, s.
    pub(crate) reached_at_s: Option<f64>,
    /// Planned duration of the stand-up, s.
    pub(crate) rise_s: f64,
    /// Foot error while holding, m.
    pub(crate) hold_error: ErrorStats,
    /// Why the controller stopped by itself.
    pub(crate) halt: Option<Halt>,
    /// CSV rows written.
    pub(crate) csv_rows: u64,
    /// Telemetry samples lost.
    pub(crate) dropped_samples: u64,
}

impl Summary {
    /// Whether the run ended as planned with the robot standing.
    pub(crate) fn ok(&self) -> bool {
        self.report.normal_stop && self.halt.is_none() && self.reached_at_s.is_some()
    }
}

/// Builds everything from the options and runs the robot.
pub(crate) fn run(args: &Args) -> Result<Summary, String> {
    let common = &args.common;
    let target = common.target().map_err(|e| e.to_string())?;
    let interfaces: Vec<String> = match &target {
        Target::SocketCan(names) if names.len() != LEGS => {
            return Err(format!(
                "the quadruped has {LEGS} buses (one per leg) but {} interface(s) were given: \
                 --iface can0,can1,can2,can3 (front left, front right, hind left, hind right)",
                names.len()
            ));
        }
        Target::SocketCan(names) => names.clone(),
        Target::Simulator(_) => (0..LEGS).map(|i| format!("sim{i}")).collect(),
    };
    for model in leg_models() {
        pose_deg(&model, args.height)?;
    }
    let mut robot = robot(&interfaces, common.rate_hz)?;
    common.apply(&mut robot);
    robot.validate().map_err(|e| e.to_string())?;
    if !common.quiet {
        say!(
            "quadruped: {} motors on {} buses ({target}), {} Hz: four 0x280 frames per tick; \
             standing up from {:.2} m to {:.2} m, then holding",
            robot.motor_count(),
            robot.buses.len(),
            robot.loop_config.rate_hz,
            CROUCH_HEIGHT_M,
            args.height
        );
    }
    if !common.confirm_motion(
        &target,
        "the robot will stand up from its crouch and hold the pose",
    ) {
        return Err("not started".to_string());
    }
    let limit = RunLimit::Duration(std::time::Duration::from_secs_f64(args.duration.max(0.0)));
    let (recorder, samples) = runner::recorder(runner::capacity_for(limit, common.rate_hz));
    let sims = sim(&robot, common.seed)?;
    let connection = connect::open(&target, &robot, sims).map_err(|e| e.to_string())?;
    let controller = StandController::new(args.height, recorder);
    let rt = RtLoop::new(robot, connection.clock, connection.buses, controller)
        .map_err(|e| e.to_string())?;
    let mut status = QuadStatus;
    let finished = runner::run(
        rt,
        limit,
        Monitor {
            samples,
            csv: Some(&args.csv),
            display: common.display(),
            status: &mut status,
        },
    )
    .map_err(|e| e.to_string())?;
    if let Some(e) = &finished.csv_error {
        eprintln!("warning: writing {} failed: {e}", args.csv.display());
    }
    let k = &finished.outcome.controller;
    Ok(Summary {
        heights_m: k.heights_m,
        target_m: args.height,
        reached_at_s: k.reached_at_s,
        rise_s: k.rise_s,
        hold_error: k.hold_error,
        halt: k.halt,
        dropped_samples: k.dropped_samples(),
        csv_rows: finished.csv_rows,
        report: finished.outcome.report,
    })
}

fn print_summary(s: &Summary, csv: &std::path::Path) {
    say!();
    say_raw!("{}", s.report);
    say!();
    say!("quadruped results");
    match s.reached_at_s {
        Some(t) => say!(
            "  stood up       body height within 5 mm of {:.3} m after {t:.2} s (planned rise {:.2} s)",
            s.target_m,
            s.rise_s
        ),
        None => say!(
            "  DID NOT STAND  body height never came within 5 mm of {:.3} m",
            s.target_m
        ),
    }
    for (name, h) in LEG_NAMES.iter().zip(s.heights_m) {
        say!("  {name:<12}   hip {h:.4} m above the foot");
    }
    say!(
        "  holding        foot error rms {:.2} mm, max {:.2} mm",
        s.hold_error.rms() * 1000.0,
        s.hold_error.max * 1000.0
    );
    let clamped: u64 = s
        .report
        .stats
        .motors
        .iter()
        .map(|m| m.clamped_commands)
        .sum();
    say!("  current limit  {clamped} command(s) clamped by the loop");
    if let Some(halt) = &s.halt {
        say!("  STOPPED        {halt}");
    }
    say!(
        "  telemetry      {} rows in {}{}",
        s.csv_rows,
        csv.display(),
        if s.dropped_samples > 0 {
            format!(" ({} samples lost)", s.dropped_samples)
        } else {
            String::new()
        }
    );
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(summary) => {
            print_summary(&summary, &args.csv);
            if summary.ok() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            eprintln!("quadruped: {e}");
            ExitCode::from(2)
        }
    }
}
