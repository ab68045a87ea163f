//! # leg4: one 4-motor leg stepping under Cartesian impedance control
//!
//! A leg of four RMD motors on one CAN bus (ids 1..=4: hip abduction/adduction, hip flexion,
//! knee, ankle), mounted on a stand with its foot in the air. The controller moves the foot
//! through a step cycle planned with the trajectory generator (a stance at constant ground speed,
//! a swing that lifts the foot 6 cm), with a Cartesian impedance law:
//!
//! ```text
//! torque = J^T (K (x_d - x) + D (v_d - v)) + gravity compensation
//! ```
//!
//! Joint limits are enforced (the planned cycle is checked against them; a spring acts near
//! each limit; a joint beyond its limit stops the run) and so are current limits (the loop clamps
//! every command to the motor's `current_limit_amps`).
//!
//! ```sh
//! cargo run --release --example leg4                    # simulated leg, real time, 10 s
//! cargo run --release --example leg4 -- --virtual-time  # as fast as the CPU allows
//! cargo run --release --example leg4 -- --iface can0    # a real leg on can0 (see below)
//! ```
//!
//! It prints a live status line, then the loop report and the tracking error, and writes every
//! tick's foot target, foot position, joint angles and torques to `target/leg4.csv`.
//!
//! On a real leg: switch the motors on with the leg in its rest pose ([`POWER_UP_DEG`], each joint
//! within 20 degrees: that is how the loop knows the joint angles of geared motors, see
//! docs/getting-started.md), with the foot free to move.

// Each example uses part of the shared code.
#[allow(dead_code)]
pub(crate) mod shared;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use nalgebra::Vector4;
use rmd_rt::connect::{self, Target};
use rmd_rt::rt::StatsSummary;
use rmd_rt::sim::SimConfig;
use rmd_rt::traj::TrajectoryError;
use rmd_rt::{
    Commands, Controller, Feedback, Flow, LoopReport, RobotConfig, RtLoop, RunLimit, TickContext,
};
use shared::cli::CommonArgs;
use shared::impedance::{self, ErrorStats, Gains, JointState};
use shared::leg::{self, JOINT_NAMES, JOINTS, LegModel};
use shared::runner::{self, Monitor, Recorder, Sample};
use shared::step_cycle::{Phase, StepCycle, StepParams};
use shared::{say, say_raw};

/// One 4-motor leg stepping under Cartesian impedance control, on simulated motors or a real bus.
#[derive(Parser, Debug, Clone)]
#[command(name = "leg4")]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) common: CommonArgs,
    /// How long to run, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub(crate) duration: f64,
    /// Where to write the telemetry (CSV).
    #[arg(long, value_name = "FILE", default_value = "target/leg4.csv")]
    pub(crate) csv: PathBuf,
    /// Leave out the gravity compensation (to see what it does).
    #[arg(long)]
    pub(crate) no_gravity_compensation: bool,
    /// Foot stiffness along x, y and z, N/m.
    #[arg(long, value_name = "N_PER_M", default_value_t = Gains::new().stiffness[0])]
    pub(crate) stiffness: f64,
    /// Foot damping along x, y and z, N*s/m.
    #[arg(long, value_name = "NS_PER_M", default_value_t = Gains::new().damping[0])]
    pub(crate) damping: f64,
}

/// The pose the leg is in when the motors are switched on (degrees): folded, foot 38 cm below
/// the hip. Each joint's power-up window (40 degrees with a 1:9 gearbox) is centred on it.
pub(crate) const POWER_UP_DEG: [f64; JOINTS] = [0.0, -30.0, 60.0, -30.0];

/// Height of the foot below the hip in the middle of the step, m.
pub(crate) const STEP_DEPTH_M: f64 = 0.30;

/// The middle of the step: under the hip flexion axis, 30 cm down, foot vertical.
pub(crate) fn step_center(model: &LegModel) -> Vector4<f64> {
    Vector4::new(0.0, model.hip_offset_m, -STEP_DEPTH_M, 0.0)
}

/// The joint angles (degrees) in the middle of the step.
pub(crate) fn working_pose_deg(model: &LegModel) -> Result<[f64; JOINTS], String> {
    model
        .inverse(&step_center(model))
        .map(|q| leg::deg(&q))
        .ok_or_else(|| "the middle of the step is out of the leg's reach".to_string())
}

/// The robot description: one leg on `interface` at `rate_hz`.
pub(crate) fn robot(model: &LegModel, interface: &str, rate_hz: f64) -> RobotConfig {
    leg::leg_robot(model, interface, rate_hz, POWER_UP_DEG)
}

/// The simulated leg: powered up at [`POWER_UP_DEG`], loaded by the leg's weight.
pub(crate) fn sim(
    model: &LegModel,
    robot: &RobotConfig,
    seed: u64,
) -> Result<Vec<SimConfig>, String> {
    Ok(vec![leg::leg_sim(
        model,
        &robot.buses[0],
        POWER_UP_DEG,
        working_pose_deg(model)?,
        seed,
    )])
}

/// Checks a planned cycle against the joint limits (kept `margin_deg` inside them), sampling it
/// every millisecond; the error names the joint, the angle and the time.
pub(crate) fn check_cycle(
    model: &LegModel,
    cycle: &StepCycle,
    margin_deg: f64,
) -> Result<(), String> {
    let approach = cycle.approach_s();
    let steps = (cycle.period_s() * 1000.0).ceil() as usize;
    for k in 0..=steps {
        let t = approach + k as f64 / 1000.0;
        let target = cycle.at(t).position;
        let q = model.inverse(&target).ok_or_else(|| {
            format!("the step cycle leaves the leg's reach at {t:.3} s: {target:?}")
        })?;
        for (i, angle) in leg::deg(&q).into_iter().enumerate() {
            let limit = model.limits[i];
            if angle < limit.min_deg + margin_deg || angle > limit.max_deg - margin_deg {
                return Err(format!(
                    "the step cycle needs {} at {angle:.1} deg at {t:.3} s, outside {:.0}..{:.0} deg \
                     (limits with a {margin_deg} deg margin)",
                    JOINT_NAMES[i],
                    limit.min_deg + margin_deg,
                    limit.max_deg - margin_deg
                ));
            }
        }
    }
    Ok(())
}

/// Why the controller stopped the run by itself.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum Halt {
    /// A joint went beyond its limit.
    JointLimit {
        /// The joint.
        joint: usize,
        /// Its angle, degrees.
        deg: f64,
    },
    /// The approach to the cycle could not be planned (e.g. a joint started out of range).
    Approach(TrajectoryError),
}

impl std::fmt::Display for Halt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Halt::JointLimit { joint, deg } => write!(
                f,
                "{} at {deg:.1} deg is beyond its limit: stopped (check the homing: \
                 zero_offset_deg and the power-up pose)",
                JOINT_NAMES[*joint]
            ),
            Halt::Approach(e) => write!(f, "cannot plan the approach to the step cycle: {e}"),
        }
    }
}

/// One tick of the leg, for the live display and the CSV file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct LegSample {
    /// Seconds since the controller started.
    pub(crate) t: f64,
    /// Phase of the step.
    pub(crate) phase: Phase,
    /// Desired foot position (m, rad).
    pub(crate) target: Vector4<f64>,
    /// Measured foot position (m, rad).
    pub(crate) foot: Vector4<f64>,
    /// Joint angles, degrees.
    pub(crate) q_deg: [f64; JOINTS],
    /// Commanded joint torques (before the loop's current limit), N*m.
    pub(crate) torque_nm: [f64; JOINTS],
}

impl LegSample {
    /// Distance from the foot to its target, m.
    pub(crate) fn error_m(&self) -> f64 {
        (self.target - self.foot).fixed_rows::<3>(0).norm()
    }
}

impl Sample for LegSample {
    fn csv_header() -> &'static str {
        "time_s,phase,x_des_m,y_des_m,z_des_m,pitch_des_rad,x_m,y_m,z_m,pitch_rad,error_mm,\
         hip_aa_deg,hip_fe_deg,knee_deg,ankle_deg,hip_aa_nm,hip_fe_nm,knee_nm,ankle_nm"
    }

    fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        write!(out, "{:.4},{}", self.t, self.phase.name())?;
        runner::write_fields(out, self.target.as_slice(), 5)?;
        runner::write_fields(out, self.foot.as_slice(), 5)?;
        runner::write_fields(out, &[self.error_m() * 1000.0], 3)?;
        runner::write_fields(out, &self.q_deg, 3)?;
        runner::write_fields(out, &self.torque_nm, 3)
    }
}

/// The leg's controller: the step cycle, the impedance law, limits and statistics.
pub(crate) struct StepController {
    model: LegModel,
    gains: Gains,
    cycle: StepCycle,
    recorder: Recorder<LegSample>,
    t0: f64,
    /// Foot position error (m) over the step cycles (after the approach).
    pub(crate) tracking: ErrorStats,
    /// Foot position error (m) in the stance.
    pub(crate) stance_tracking: ErrorStats,
    /// Sum of the foot's height error (z - z_d, m) over the stance ticks (negative: sagging).
    pub(crate) stance_z_error_sum: f64,
    /// Completed step cycles.
    pub(crate) cycles: u64,
    /// Ticks in which some motor's feedback was not fresh.
    pub(crate) stale_ticks: u64,
    /// Why the controller stopped the run, if it did.
    pub(crate) halt: Option<Halt>,
}

impl StepController {
    /// A controller for `model` stepping through `cycle` (its approach is planned at start).
    pub(crate) fn new(
        model: LegModel,
        gains: Gains,
        cycle: StepCycle,
        recorder: Recorder<LegSample>,
    ) -> Self {
        Self {
            model,
            gains,
            cycle,
            recorder,
            t0: 0.0,
            tracking: ErrorStats::default(),
            stance_tracking: ErrorStats::default(),
            stance_z_error_sum: 0.0,
            cycles: 0,
            stale_ticks: 0,
            halt: None,
        }
    }

    /// Telemetry samples overwritten before they were read.
    pub(crate) fn dropped_samples(&self) -> u64 {
        self.recorder.dropped
    }

    /// Mean height error of the foot in the stance, m (negative: the foot sags below its path).
    pub(crate) fn stance_z_bias_m(&self) -> f64 {
        if self.stance_tracking.count == 0 {
            0.0
        } else {
            self.stance_z_error_sum / self.stance_tracking.count as f64
        }
    }
}

impl Controller for StepController {
    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        let joints = JointState::read(feedback, 0);
        if let Some(joint) = self.model.limit_violation(&joints.q) {
            self.halt = Some(Halt::JointLimit {
                joint,
                deg: joints.q[joint].to_degrees(),
            });
            return;
        }
        if let Err(e) = self.cycle.plan_approach(self.model.foot(&joints.q)) {
            self.halt = Some(Halt::Approach(e));
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
        let joints = JointState::read(feedback, 0);
        if !joints.fresh {
            self.stale_ticks += 1;
        }
        let target = self.cycle.at(t);
        let out = impedance::impedance(
            &self.model,
            &self.gains,
            &joints,
            &target.position,
            &target.velocity,
        );
        if let Some(joint) = out.beyond_limit {
            self.halt = Some(Halt::JointLimit {
                joint,
                deg: joints.q[joint].to_degrees(),
            });
            return Flow::Stop;
        }
        for i in 0..JOINTS {
            // Finite by construction; the loop clamps to the current limit.
            let _ = cmd.set_torque(i, out.torque[i]);
        }
        if target.phase != Phase::Approach {
            let error = out.position_error_m(&target.position);
            self.tracking.add(error);
            if target.phase == Phase::Stance {
                self.stance_tracking.add(error);
                self.stance_z_error_sum += out.foot.z - target.position.z;
            }
            self.cycles = target.cycle;
        }
        self.recorder.record(LegSample {
            t,
            phase: target.phase,
            target: target.position,
            foot: out.foot,
            q_deg: leg::deg(&joints.q),
            torque_nm: out.torque.into(),
        });
        Flow::Continue
    }
}

/// The leg's part of the status line: phase, foot error, largest foot error over the cycles.
#[derive(Debug, Default)]
pub(crate) struct LegStatus {
    max_error_m: f64,
}

impl runner::Status<LegSample> for LegStatus {
    fn observe(&mut self, s: &LegSample) {
        if s.phase != Phase::Approach {
            self.max_error_m = self.max_error_m.max(s.error_m());
        }
    }

    fn line(&self, s: &LegSample) -> String {
        if s.phase == Phase::Approach {
            return format!("approach foot error {:5.1} mm", s.error_m() * 1000.0);
        }
        format!(
            "{:<8} foot error {:5.1} mm (max {:4.1})",
            s.phase.name(),
            s.error_m() * 1000.0,
            self.max_error_m * 1000.0
        )
    }
}

/// What a run of the example produced.
#[derive(Debug)]
pub(crate) struct Summary {
    /// The loop's report.
    pub(crate) report: LoopReport,
    /// Foot error over the step cycles, m.
    pub(crate) tracking: ErrorStats,
    /// Foot error in the stance, m.
    pub(crate) stance_tracking: ErrorStats,
    /// Mean height error in the stance, m.
    pub(crate) stance_z_bias_m: f64,
    /// Completed cycles.
    pub(crate) cycles: u64,
    /// Whether gravity compensation was on.
    pub(crate) gravity_compensation: bool,
    /// Why the controller stopped by itself.
    pub(crate) halt: Option<Halt>,
    /// CSV rows written.
    pub(crate) csv_rows: u64,
    /// Telemetry samples lost.
    pub(crate) dropped_samples: u64,
}

impl Summary {
    /// Whether the run ended as planned.
    pub(crate) fn ok(&self) -> bool {
        self.report.normal_stop && self.halt.is_none()
    }
}

/// Builds everything from the options and runs the leg. Errors are setup problems (bad options,
/// an interface that does not open, ...), with a message saying what to do.
pub(crate) fn run(args: &Args) -> Result<Summary, String> {
    let common = &args.common;
    let target = common.target().map_err(|e| e.to_string())?;
    let model = LegModel::new();
    let interface = match &target {
        Target::SocketCan(names) => names[0].clone(),
        Target::Simulator(_) => "sim".to_string(),
    };
    let mut robot = robot(&model, &interface, common.rate_hz);
    common.apply(&mut robot);
    robot.validate().map_err(|e| e.to_string())?;

    let params = StepParams::new(step_center(&model));
    let cycle = StepCycle::plan(params).map_err(|e| format!("cannot plan the step cycle: {e}"))?;
    check_cycle(&model, &cycle, 5.0)?;
    let mut gains = Gains::new();
    gains.gravity_compensation = !args.no_gravity_compensation;
    for axis in 0..3 {
        gains.stiffness[axis] = args.stiffness;
        gains.damping[axis] = args.damping;
    }

    if !common.quiet {
        say!(
            "leg4: 4-motor leg on {target}, {} Hz, step {:.0} cm x {:.0} cm every {:.2} s \
             (stance {:.2} s at {:.2} m/s), gravity compensation {}",
            robot.loop_config.rate_hz,
            params.length_m * 100.0,
            params.height_m * 100.0,
            cycle.period_s(),
            cycle.stance_s(),
            params.ground_speed(),
            if gains.gravity_compensation {
                "on"
            } else {
                "off"
            },
        );
    }
    if !common.confirm_motion(&target, "the leg will step for the given duration") {
        return Err("not started".to_string());
    }
    let limit = RunLimit::Duration(std::time::Duration::from_secs_f64(args.duration.max(0.0)));
    let (recorder, samples) = runner::recorder(runner::capacity_for(limit, common.rate_hz));
    let controller = StepController::new(model.clone(), gains, cycle, recorder);
    let connection = connect::open(&target, &robot, sim(&model, &robot, common.seed)?)
        .map_err(|e| e.to_string())?;
    let rt = RtLoop::new(robot, connection.clock, connection.buses, controller)
        .map_err(|e| e.to_string())?;

    let mut status = LegStatus::default();
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
    let k = &finished.outcome.controller;
    if let Some(e) = &finished.csv_error {
        eprintln!("warning: writing {} failed: {e}", args.csv.display());
    }
    Ok(Summary {
        tracking: k.tracking,
        stance_tracking: k.stance_tracking,
        stance_z_bias_m: k.stance_z_bias_m(),
        cycles: k.cycles,
        gravity_compensation: gains.gravity_compensation,
        halt: k.halt,
        dropped_samples: k.dropped_samples(),
        csv_rows: finished.csv_rows,
        report: finished.outcome.report,
    })
}

/// Prints the loop report and the leg's results.
fn print_summary(summary: &Summary, csv: &std::path::Path) {
    say!();
    say_raw!("{}", summary.report);
    say!();
    print_results(summary, &summary.report.stats, csv);
}

fn print_results(summary: &Summary, stats: &StatsSummary, csv: &std::path::Path) {
    say!("leg4 results");
    say!(
        "  foot tracking  rms {:.2} mm   max {:.2} mm over {} step cycle(s) (stance: rms {:.2} mm, max {:.2} mm)",
        summary.tracking.rms() * 1000.0,
        summary.tracking.max * 1000.0,
        summary.cycles,
        summary.stance_tracking.rms() * 1000.0,
        summary.stance_tracking.max * 1000.0,
    );
    say!(
        "  foot height    {:+.2} mm on average in the stance (gravity compensation {})",
        summary.stance_z_bias_m * 1000.0,
        if summary.gravity_compensation {
            "on"
        } else {
            "off: the foot sags under the leg's weight"
        }
    );
    let clamped: u64 = stats.motors.iter().map(|m| m.clamped_commands).sum();
    say!("  current limit  {clamped} command(s) clamped by the loop");
    if let Some(halt) = &summary.halt {
        say!("  STOPPED        {halt}");
    }
    say!(
        "  telemetry      {} rows in {}{}",
        summary.csv_rows,
        csv.display(),
        if summary.dropped_samples > 0 {
            format!(
                " ({} samples lost: the writer fell behind)",
                summary.dropped_samples
            )
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
            eprintln!("leg4: {e}");
            ExitCode::from(2)
        }
    }
}
