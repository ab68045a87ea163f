//! # trajectory_follow: joint-space multi-axis trajectories through a list of waypoints
//!
//! The 4-motor leg of the `leg4` example (examples/robots/leg4.toml), moved in joint space: from
//! where it is, through each waypoint (four joint angles), pausing at each. Every move is a
//! time-optimal, jerk-limited trajectory of the four joints from the online generator
//! (`rmd_rt::traj::OnlineGenerator`), synchronized so that all joints start and arrive together;
//! a joint-space PD law with gravity compensation follows it (`rmd_demos::trajectory_follow`):
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
//! The run ends after the last waypoint (or gives up after `--duration`, 30 s by default). At
//! the end it prints, for each waypoint, how far each joint was from it after the pause.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use rmd_demos::leg::LegModel;
use rmd_demos::trajectory_follow::{self, FollowStatus, Follower};
use rmd_rt::rig::args::{LoopArgs, OutputArgs, RobotArgs};
use rmd_rt::rig::program::{Launch, Program};

/// The robot (the leg of `leg4`), unless `--robot FILE` replaces it.
const ROBOT: &str = include_str!("robots/leg4.toml");

/// When to give up unless `--duration` says otherwise.
const DURATION: Duration = Duration::from_secs(30);

/// Moves the 4-motor leg through joint-space waypoints, on simulated motors or a real bus.
#[derive(Parser, Debug)]
#[command(name = "trajectory_follow")]
struct Args {
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    run: LoopArgs,
    #[command(flatten)]
    output: OutputArgs,
    /// A waypoint: four joint angles in degrees (hip_aa,hip_fe,knee,ankle). Repeat for a tour;
    /// without any, a built-in tour of four waypoints.
    #[arg(
        long = "waypoint",
        value_name = "DEG,DEG,DEG,DEG",
        allow_hyphen_values = true
    )]
    waypoints: Vec<String>,
    /// Pause at each waypoint (seconds, or 400ms, 1s, ...).
    #[arg(long, value_name = "SECONDS", default_value = "0.4", value_parser = pause)]
    pause: Duration,
}

/// `--pause`: 0 up to an hour.
fn pause(text: &str) -> Result<Duration, String> {
    use rmd_rt::rig::args::duration::{Bounds, parse};
    parse(text, Bounds::up_to(Duration::from_secs(3600)))
}

fn main() -> ExitCode {
    let args = Args::parse();
    Program::new(
        "trajectory_follow",
        ROBOT,
        &args.robot,
        &args.run,
        &args.output,
    )
    .duration(DURATION)
    .csv("target/trajectory_follow.csv")
    .time_line()
    .gap_before_results()
    .main(
        |site| {
            // Waypoints are checked against the joint limits before anything moves.
            let model = LegModel::new();
            let waypoints = trajectory_follow::parse_waypoints(&model, &args.waypoints)?;
            let pause_s = args.pause.as_secs_f64();
            let follower = Follower::new(site.robot, model, waypoints, pause_s)?;
            let tour = follower.waypoints().len();
            Ok(Launch {
                banner: format!(
                    "trajectory_follow: 4-motor leg on {}, {} Hz, {tour} waypoint(s), \
                         {pause_s:.1} s pause at each",
                    site.placement,
                    site.robot.settings().period.hz(),
                ),
                motion: "the leg will move through the waypoints".into(),
                sims: trajectory_follow::sims(site.robot, args.robot.seed)?,
                controller: follower,
                status: FollowStatus::new(tour),
            })
        },
        |finished, _, _| finished.outcome.controller.results(),
    )
}
