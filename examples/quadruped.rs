//! # quadruped: four legs on four buses stand up from a crouch and hold the pose
//!
//! Sixteen RMD motors: four legs of four motors (examples/robots/quadruped.toml: one CAN bus per
//! leg, joints `fl_hip_aa` .. `hr_ankle`), all driven by one loop that sends four 0x280 frames
//! per tick (one per bus, the buses exchange in parallel) and collects the sixteen replies.
//!
//! The robot powers up lying on its belly with its legs folded (the crouch, hips 15 cm above the
//! feet). The controller plans one trajectory of all sixteen foot coordinates (x, y, z, pitch of
//! each foot), synchronized so that every foot arrives at the same time, from where the feet are
//! to the standing pose (hips 28 cm above the feet), follows it with a Cartesian impedance law
//! per leg (see the `leg4` example) and then holds the pose. Model and controller:
//! `rmd_demos::quadruped`.
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

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use rmd_demos::quadruped::{self, CROUCH_HEIGHT_M, STAND_HEIGHT_M, StandController, StandStatus};
use rmd_demos::support::parse_finite;
use rmd_rt::rig::args::{LoopArgs, OutputArgs, RobotArgs};
use rmd_rt::rig::program::{Launch, Program};

/// The robot, unless `--robot FILE` replaces it.
const ROBOT: &str = include_str!("robots/quadruped.toml");

/// How long to run unless `--duration` says otherwise (standing up takes about 1.2 s, then the
/// robot holds the pose).
const DURATION: Duration = Duration::from_secs(6);

/// Four legs on four buses, standing up from a crouch and holding the pose.
#[derive(Parser, Debug)]
#[command(name = "quadruped")]
struct Args {
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    run: LoopArgs,
    #[command(flatten)]
    output: OutputArgs,
    /// Standing height: hips above the feet, m.
    #[arg(long, value_name = "M", default_value_t = STAND_HEIGHT_M, value_parser = parse_finite)]
    height: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    Program::new("quadruped", ROBOT, &args.robot, &args.run, &args.output)
        .duration(DURATION)
        .csv("target/quadruped.csv")
        .time_line()
        .gap_before_results()
        .main(
            |site| {
                let robot = site.robot;
                // A height the legs cannot reach is refused here, before anything moves.
                let controller = StandController::new(robot, args.height)?;
                Ok(Launch {
                    banner: format!(
                        "quadruped: {} motors on {} buses ({}), {} Hz: {} 0x280 frames per \
                         tick; standing up from {CROUCH_HEIGHT_M:.2} m to {:.2} m, then holding",
                        robot.joint_count(),
                        robot.buses().len(),
                        site.placement,
                        robot.settings().period.hz(),
                        robot.buses().len(),
                        args.height
                    ),
                    motion: "the robot will stand up from its crouch and hold the pose".into(),
                    sims: quadruped::sims(robot, args.robot.seed)?,
                    controller,
                    status: StandStatus::default(),
                })
            },
            |finished, _, _| {
                let outcome = &finished.outcome;
                outcome.controller.results(&outcome.report)
            },
        )
}
