//! # trajectory_follow: joint-space multi-axis trajectories through a list of waypoints
//!
//! The 4-motor leg of the `leg4` example, moved in joint space: from where it is, through each
//! waypoint (four joint angles), pausing at each. Every move is a time-optimal, jerk-limited
//! trajectory of the four joints from the online generator (`rmd_rt::traj::OnlineGenerator`),
//! synchronized so that all joints start and arrive together; a joint-space PD law with gravity
//! compensation follows it:
//!
//! ```text
//! torque = Kp (q_d - q) + Kd (q_d' - q') + gravity compensation
//! ```
//!
//! ```sh
//! cargo run --release --example trajectory_follow
//! cargo run --release --example trajectory_follow -- --virtual-time \
//!     --waypoint=0,-50,100,-50 --waypoint=10,-20,40,-20 --waypoint=0,-30,60,-30
//! cargo run --release --example trajectory_follow -- --iface can0
//! ```
//!
//! At the end it prints, for each waypoint, how far each joint was from it after the pause.

// Each example uses part of the shared code.
#[allow(dead_code)]
pub(crate) mod shared;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use nalgebra::Vector4;
use rmd_rt::connect::{self, Target};
use rmd_rt::sim::SimConfig;
use rmd_rt::traj::{Input, OnlineGenerator, OnlineStatus, TrajectoryError};
use rmd_rt::{
    Commands, Controller, Feedback, Flow, LoopReport, RobotConfig, RtLoop, RunLimit, TickContext,
};
use shared::cli::CommonArgs;
use shared::impedance::JointState;
use shared::leg::{self, JOINT_NAMES, JOINTS, LegModel};
use shared::runner::{self, Monitor, Recorder, Sample};
use shared::{say, say_raw};

/// The leg's pose when the motors are switched on (as in `leg4`), degrees.
pub(crate) const POWER_UP_DEG: [f64; JOINTS] = [0.0, -30.0, 60.0, -30.0];

/// The default tour: fold, stretch out to the side, fold the other way, back to rest (degrees:
/// hip_aa, hip_fe, knee, ankle).
pub(crate) const WAYPOINTS_DEG: [[f64; JOINTS]; 4] = [
    [0.0, -55.0, 110.0, -55.0],
    [12.0, -15.0, 30.0, -15.0],
    [-12.0, -70.0, 130.0, -40.0],
    [0.0, -30.0, 60.0, -30.0],
];

/// Moves the 4-motor leg through joint-space waypoints, on simulated motors or a real bus.
#[derive(Parser, Debug, Clone)]
#[command(name = "trajectory_follow")]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) common: CommonArgs,
    /// A waypoint: four joint angles in degrees (hip_aa,hip_fe,knee,ankle). Repeat for a tour;
    /// without any, a built-in tour of four waypoints.
    #[arg(
        long = "waypoint",
        value_name = "DEG,DEG,DEG,DEG",
        allow_hyphen_values = true
    )]
    pub(crate) waypoints: Vec<String>,
    /// Pause at each waypoint, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.4)]
    pub(crate) pause: f64,
    /// Give up after this long, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub(crate) timeout: f64,
    /// Where to write the telemetry (CSV).
    #[arg(
        long,
        value_name = "FILE",
        default_value = "target/trajectory_follow.csv"
    )]
    pub(crate) csv: PathBuf,
}

/// Parses `--waypoint` values and checks them against the joint limits.
pub(crate) fn parse_waypoints(
    model: &LegModel,
    args: &[String],
) -> Result<Vec<[f64; JOINTS]>, String> {
    if args.is_empty() {
        return Ok(WAYPOINTS_DEG.to_vec());
    }
    args.iter()
        .enumerate()
        .map(|(n, text)| {
            let values: Vec<f64> = text
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("waypoint {} ({text:?}): {e}", n + 1))?;
            let deg: [f64; JOINTS] = values.try_into().map_err(|v: Vec<f64>| {
                format!(
                    "waypoint {} ({text:?}) has {} angles, needs {JOINTS}",
                    n + 1,
                    v.len()
                )
            })?;
            for (i, angle) in deg.iter().enumerate() {
                let limit = model.limits[i];
                if !limit.contains(*angle) {
                    return Err(format!(
                        "waypoint {}: {} at {angle} deg is outside its limits {}..{} deg",
                        n + 1,
                        JOINT_NAMES[i],
                        limit.min_deg,
                        limit.max_deg
                    ));
                }
            }
            Ok(deg)
        })
        .collect()
}

/// Joint-space gains: stiffness (N*m/rad) and damping (N*m*s/rad) per joint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct JointGains {
    /// Stiffness.
    pub(crate) kp: Vector4<f64>,
    /// Damping.
    pub(crate) kd: Vector4<f64>,
}

impl JointGains {
    /// 120 / 120 / 80 / 40 N*m/rad and 3 / 3 / 2 / 0.6 N*m*s/rad.
    pub(crate) fn new() -> Self {
        Self {
            kp: Vector4::new(120.0, 120.0, 80.0, 40.0),
            kd: Vector4::new(3.0, 3.0, 2.0, 0.6),
        }
    }
}

/// How close the leg came to one waypoint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Reached {
    /// The waypoint (index).
    pub(crate) waypoint: usize,
    /// When the move to it started, s.
    pub(crate) started_s: f64,
    /// How long the planned move took, s.
    pub(crate) move_s: f64,
    /// Each joint's angle minus the waypoint's after the pause, degrees.
    pub(crate) error_deg: [f64; JOINTS],
}

impl Reached {
    /// The largest joint error, degrees.
    pub(crate) fn max_error_deg(&self) -> f64 {
        self.error_deg.iter().fold(0.0f64, |m, e| m.max(e.abs()))
    }
}

/// What the follower is doing.
#[derive(Copy, Clone, Debug, PartialEq)]
enum Stage {
    /// Moving to waypoint `i` (started at `since`).
    Moving { i: usize, since: f64 },
    /// Pausing at waypoint `i` until `until`.
    Pausing {
        i: usize,
        until: f64,
        since: f64,
        move_s: f64,
    },
}

/// One tick, for the live display and the CSV file.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct FollowSample {
    /// Seconds since the start.
    pub(crate) t: f64,
    /// The waypoint being approached (index).
    pub(crate) waypoint: usize,
    /// Desired joint angles, degrees.
    pub(crate) q_des_deg: [f64; JOINTS],
    /// Joint angles, degrees.
    pub(crate) q_deg: [f64; JOINTS],
    /// Commanded torques, N*m.
    pub(crate) torque_nm: [f64; JOINTS],
}

impl Sample for FollowSample {
    fn csv_header() -> &'static str {
        "time_s,waypoint,hip_aa_des_deg,hip_fe_des_deg,knee_des_deg,ankle_des_deg,\
         hip_aa_deg,hip_fe_deg,knee_deg,ankle_deg,hip_aa_nm,hip_fe_nm,knee_nm,ankle_nm"
    }

    fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        write!(out, "{:.4},{}", self.t, self.waypoint + 1)?;
        runner::write_fields(out, &self.q_des_deg, 3)?;
        runner::write_fields(out, &self.q_deg, 3)?;
        runner::write_fields(out, &self.torque_nm, 3)
    }
}

/// The joint-space trajectory follower.
pub(crate) struct Follower {
    model: LegModel,
    gains: JointGains,
    waypoints: Vec<[f64; JOINTS]>,
    pause_s: f64,
    input: Input<JOINTS>,
    generator: OnlineGenerator<JOINTS>,
    stage: Stage,
    t0: f64,
    recorder: Recorder<FollowSample>,
    /// One entry per waypoint reached (capacity reserved up front: pushing never allocates).
    pub(crate) reached: Vec<Reached>,
    /// A planning error, if one stopped the run.
    pub(crate) error: Option<TrajectoryError>,
}

impl Follower {
    /// A follower through `waypoints` (degrees) pausing `pause_s` at each, for a loop of
    /// `period_s`.
    pub(crate) fn new(
        model: LegModel,
        waypoints: Vec<[f64; JOINTS]>,
        pause_s: f64,
        period_s: f64,
        recorder: Recorder<FollowSample>,
    ) -> Result<Self, TrajectoryError> {
        Ok(Self {
            model,
            gains: JointGains::new(),
            reached: Vec::with_capacity(waypoints.len()),
            waypoints,
            pause_s,
            // deg/s, deg/s², deg/s³ per joint.
            input: Input::with_limits([90.0; JOINTS], [400.0; JOINTS], [4000.0; JOINTS]),
            generator: OnlineGenerator::new(period_s)?,
            stage: Stage::Moving { i: 0, since: 0.0 },
            t0: 0.0,
            recorder,
            error: None,
        })
    }

    /// Telemetry samples overwritten before they were read.
    pub(crate) fn dropped_samples(&self) -> u64 {
        self.recorder.dropped
    }
}

impl Controller for Follower {
    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        let joints = JointState::read(feedback, 0);
        self.input.current_position = leg::deg(&joints.q);
        if let Some(first) = self.waypoints.first() {
            self.input.target_position = *first;
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        if self.waypoints.is_empty() || self.error.is_some() {
            return Flow::Stop;
        }
        let t = ctx.time_s() - self.t0;
        let joints = JointState::read(feedback, 0);
        // The desired state of this tick: the generator's next state while moving, the waypoint
        // (at rest) while pausing.
        match self.stage {
            Stage::Moving { i, since } => match self.generator.step(&mut self.input) {
                Ok(OnlineStatus::Working) => {}
                Ok(OnlineStatus::Finished) => {
                    self.stage = Stage::Pausing {
                        i,
                        until: t + self.pause_s,
                        since,
                        move_s: self.generator.trajectory().duration(),
                    };
                }
                Err(e) => {
                    self.error = Some(e);
                    return Flow::Stop;
                }
            },
            Stage::Pausing {
                i,
                until,
                since,
                move_s,
            } if t >= until => {
                let q = leg::deg(&joints.q);
                let wp = self.waypoints[i];
                if self.reached.len() < self.reached.capacity() {
                    self.reached.push(Reached {
                        waypoint: i,
                        started_s: since,
                        move_s,
                        error_deg: [0, 1, 2, 3].map(|j| q[j] - wp[j]),
                    });
                }
                if i + 1 == self.waypoints.len() {
                    return Flow::Stop;
                }
                self.input.target_position = self.waypoints[i + 1];
                self.stage = Stage::Moving { i: i + 1, since: t };
            }
            Stage::Pausing { .. } => {}
        }
        let q_des = leg::rad(self.input.current_position);
        let qd_des = leg::rad(self.input.current_velocity);
        let torque = self.gains.kp.component_mul(&(q_des - joints.q))
            + self.gains.kd.component_mul(&(qd_des - joints.qd))
            - self.model.gravity_torques(&joints.q);
        for i in 0..JOINTS {
            let _ = cmd.set_torque(i, torque[i]);
        }
        let waypoint = match self.stage {
            Stage::Moving { i, .. } | Stage::Pausing { i, .. } => i,
        };
        self.recorder.record(FollowSample {
            t,
            waypoint,
            q_des_deg: self.input.current_position,
            q_deg: leg::deg(&joints.q),
            torque_nm: torque.into(),
        });
        Flow::Continue
    }
}

/// The robot description (the leg of `leg4`).
pub(crate) fn robot(model: &LegModel, interface: &str, rate_hz: f64) -> RobotConfig {
    leg::leg_robot(model, interface, rate_hz, POWER_UP_DEG)
}

/// The simulated leg, loaded by its weight fitted at the power-up pose.
pub(crate) fn sim(model: &LegModel, robot: &RobotConfig, seed: u64) -> Vec<SimConfig> {
    vec![leg::leg_sim(
        model,
        &robot.buses[0],
        POWER_UP_DEG,
        POWER_UP_DEG,
        seed,
    )]
}

/// The follower's part of the status line: the waypoint and the following error.
#[derive(Debug)]
pub(crate) struct FollowStatus {
    waypoints: usize,
}

impl runner::Status<FollowSample> for FollowStatus {
    fn observe(&mut self, _: &FollowSample) {}

    fn line(&self, s: &FollowSample) -> String {
        let error = (0..JOINTS).fold(0.0f64, |m, j| m.max((s.q_des_deg[j] - s.q_deg[j]).abs()));
        format!(
            "waypoint {}/{}  following error {error:4.2} deg",
            s.waypoint + 1,
            self.waypoints
        )
    }
}

/// What a run of the example produced.
#[derive(Debug)]
pub(crate) struct Summary {
    /// The loop's report.
    pub(crate) report: LoopReport,
    /// The waypoints.
    pub(crate) waypoints: Vec<[f64; JOINTS]>,
    /// How close the leg came to each.
    pub(crate) reached: Vec<Reached>,
    /// A planning error, if one stopped the run.
    pub(crate) error: Option<TrajectoryError>,
    /// CSV rows written.
    pub(crate) csv_rows: u64,
    /// Telemetry samples lost.
    pub(crate) dropped_samples: u64,
}

impl Summary {
    /// Whether every waypoint was visited and the run ended normally.
    pub(crate) fn ok(&self) -> bool {
        self.report.normal_stop
            && self.error.is_none()
            && self.reached.len() == self.waypoints.len()
    }
}

/// Builds everything from the options and runs the tour.
pub(crate) fn run(args: &Args) -> Result<Summary, String> {
    let common = &args.common;
    let target = common.target().map_err(|e| e.to_string())?;
    let model = LegModel::new();
    let waypoints = parse_waypoints(&model, &args.waypoints)?;
    let interface = match &target {
        Target::SocketCan(names) => names[0].clone(),
        Target::Simulator(_) => "sim".to_string(),
    };
    let mut robot = robot(&model, &interface, common.rate_hz);
    common.apply(&mut robot);
    robot.validate().map_err(|e| e.to_string())?;
    if !common.quiet {
        say!(
            "trajectory_follow: 4-motor leg on {target}, {} Hz, {} waypoint(s), {:.1} s pause at each",
            robot.loop_config.rate_hz,
            waypoints.len(),
            args.pause
        );
    }
    if !common.confirm_motion(&target, "the leg will move through the waypoints") {
        return Err("not started".to_string());
    }
    let limit = RunLimit::Duration(std::time::Duration::from_secs_f64(args.timeout.max(0.0)));
    let (recorder, samples) = runner::recorder(runner::capacity_for(limit, common.rate_hz));
    let period = 1.0 / robot.loop_config.rate_hz;
    let controller = Follower::new(
        model.clone(),
        waypoints.clone(),
        args.pause,
        period,
        recorder,
    )
    .map_err(|e| e.to_string())?;
    let connection = connect::open(&target, &robot, sim(&model, &robot, common.seed))
        .map_err(|e| e.to_string())?;
    let rt = RtLoop::new(robot, connection.clock, connection.buses, controller)
        .map_err(|e| e.to_string())?;
    let mut status = FollowStatus {
        waypoints: waypoints.len(),
    };
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
        waypoints,
        reached: k.reached.clone(),
        error: k.error,
        dropped_samples: k.dropped_samples(),
        csv_rows: finished.csv_rows,
        report: finished.outcome.report,
    })
}

fn print_summary(s: &Summary, csv: &std::path::Path) {
    say!();
    say_raw!("{}", s.report);
    say!();
    say!("trajectory_follow results (joint error after the pause, degrees)");
    say!(
        "  {:<9}{:>8}{:>8}{:>9}{:>9}{:>9}{:>9}{:>9}",
        "waypoint",
        "start s",
        "move s",
        "hip_aa",
        "hip_fe",
        "knee",
        "ankle",
        "max"
    );
    for r in &s.reached {
        say!(
            "  {:<9}{:>8.2}{:>8.2}{:>9.3}{:>9.3}{:>9.3}{:>9.3}{:>9.3}",
            r.waypoint + 1,
            r.started_s,
            r.move_s,
            r.error_deg[0],
            r.error_deg[1],
            r.error_deg[2],
            r.error_deg[3],
            r.max_error_deg()
        );
    }
    if s.reached.len() < s.waypoints.len() {
        say!(
            "  only {} of {} waypoints reached",
            s.reached.len(),
            s.waypoints.len()
        );
    }
    if let Some(e) = &s.error {
        say!("  STOPPED: trajectory planning failed: {e}");
    }
    say!(
        "  telemetry: {} rows in {}{}",
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
            eprintln!("trajectory_follow: {e}");
            ExitCode::from(2)
        }
    }
}
