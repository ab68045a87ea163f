//! # pd_hold: the smallest useful controller
//!
//! Turns every joint of the robot (examples/robots/pd_hold.toml: one RMD-X8-class motor with a
//! 1:9 gearbox, joint `arm`, swinging a 1 kg arm 0.2 m long in the simulator) a given angle from
//! where it is and holds it there, with a PD law on the joint angle. The whole controller is
//! `rmd_demos::pd_hold::PdHold` (crates/rmd-demos/src/pd_hold.rs): its `start` takes each joint's
//! angle plus the move as the target, and its `update` sets each joint's current to
//! `kp * (target - angle) - kd * velocity`, all in joint units (degrees, degrees per second).
//!
//! ```sh
//! cargo run --example pd_hold                                # simulated motor, 3 s
//! cargo run --example pd_hold -- --virtual-time --move-deg -20
//! cargo run --example pd_hold -- --iface can0 --move-deg 10  # motor 1 on can0
//! ```
//!
//! A PD law has no integral term: against gravity the arm settles short of the target by the
//! gravity torque over the stiffness, at most 1.96 N*m / 1.67 N*m per degree = 1.2 degrees here
//! (the gearbox's friction takes part of it).

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use rmd_demos::pd_hold::{self, HoldStatus, PdHold};
use rmd_demos::support::parse_finite;
use rmd_rt::rig::args::{LoopArgs, OutputArgs, RobotArgs};
use rmd_rt::rig::program::{Launch, Program};

/// The robot, unless `--robot FILE` replaces it.
const ROBOT: &str = include_str!("robots/pd_hold.toml");

/// How long to hold unless `--duration` says otherwise.
const DURATION: Duration = Duration::from_secs(3);

/// Turns every joint by an angle and holds it there with a PD law (simulated motor, or a real
/// one with --iface).
#[derive(Parser, Debug)]
#[command(name = "pd_hold")]
struct Args {
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    run: LoopArgs,
    #[command(flatten)]
    output: OutputArgs,
    /// How far to turn each joint from where it is, degrees (at the output).
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 30.0,
        allow_negative_numbers = true,
        value_parser = parse_finite
    )]
    move_deg: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    Program::new("pd_hold", ROBOT, &args.robot, &args.run, &args.output)
        .duration(DURATION)
        .main(
            |site| {
                Ok(Launch {
                    banner: format!(
                        "pd_hold: turning every joint by {} deg and holding it for {:.1} s ({})",
                        args.move_deg,
                        site.duration.unwrap_or(DURATION).as_secs_f64(),
                        site.placement
                    ),
                    motion: "every joint will turn and hold".into(),
                    sims: pd_hold::sims(site.robot, args.robot.seed),
                    controller: PdHold::new(site.robot, args.move_deg),
                    status: HoldStatus::default(),
                })
            },
            |finished, status, robot| status.results(robot, &finished.outcome.controller),
        )
}
