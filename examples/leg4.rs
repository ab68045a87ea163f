//! # leg4: one 4-motor leg stepping under Cartesian impedance control
//!
//! A leg of four RMD motors on one CAN bus (`hip_aa`, `hip_fe`, `knee`, `ankle`: ids 1..=4 in
//! examples/robots/leg4.toml), mounted on a stand with its foot in the air. The controller moves
//! the foot through a step cycle planned with the trajectory generator (a stance at constant
//! ground speed, a swing that lifts the foot 6 cm), with a Cartesian impedance law:
//!
//! ```text
//! torque = J^T (K (x_d - x) + D (v_d - v)) + gravity compensation
//! ```
//!
//! Joint limits are enforced (the planned cycle is checked against them; a spring acts near
//! each limit; a joint beyond its limit stops the run) and so are current limits (the loop
//! clamps every command to the description's `current_limit_amps`). The leg's model and
//! controller are in the `rmd-demos` crate (`rmd_demos::leg4`).
//!
//! ```sh
//! cargo run --release --example leg4                    # simulated leg, real time, 10 s
//! cargo run --release --example leg4 -- --virtual-time  # as fast as the CPU allows
//! cargo run --release --example leg4 -- --iface can0    # a real leg on can0 (see below)
//! cargo run --release --example leg4 -- --robot my-leg.toml --iface can0
//! ```
//!
//! It shows a status line, then prints the loop report and the tracking error, and writes every
//! tick (each joint's state and command; the foot target, foot position, error and step phase
//! as user signals) to `target/leg4.csv` (`--csv FILE` elsewhere).
//!
//! On a real leg: switch the motors on with the leg in its power-up pose (examples/robots/leg4.toml
//! says which, and how the zero offsets centre each joint's power-up window on it), with the
//! foot free to move.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use rmd_demos::leg::LegModel;
use rmd_demos::leg4::{self, LegStatus, StepController};
use rmd_demos::support::parse_finite;
use rmd_rt::rig::args::{LoopArgs, OutputArgs, RobotArgs};
use rmd_rt::rig::program::{Launch, Program};

/// The robot, unless `--robot FILE` replaces it.
const ROBOT: &str = include_str!("robots/leg4.toml");

/// How long the leg steps unless `--duration` says otherwise.
const DURATION: Duration = Duration::from_secs(10);

/// One 4-motor leg stepping under Cartesian impedance control, on simulated motors (or a real
/// bus with --iface).
#[derive(Parser, Debug)]
#[command(name = "leg4")]
struct Args {
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    run: LoopArgs,
    #[command(flatten)]
    output: OutputArgs,
    /// Leave out the gravity compensation (to see what it does).
    #[arg(long)]
    no_gravity_compensation: bool,
    /// Foot stiffness along x, y and z, N/m.
    #[arg(long, value_name = "N_PER_M", default_value_t = 3000.0, value_parser = parse_finite)]
    stiffness: f64,
    /// Foot damping along x, y and z, N*s/m.
    #[arg(long, value_name = "NS_PER_M", default_value_t = 60.0, value_parser = parse_finite)]
    damping: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    Program::new("leg4", ROBOT, &args.robot, &args.run, &args.output)
        .duration(DURATION)
        .csv("target/leg4.csv")
        .time_line()
        .gap_before_results()
        .main(
            |site| {
                // The controller finds its joints by name; the step is planned and checked
                // before anything moves.
                let model = LegModel::new();
                let gains =
                    leg4::gains(!args.no_gravity_compensation, args.stiffness, args.damping)?;
                let cycle = leg4::plan_cycle(&model)?;
                let controller = StepController::new(site.robot, model, gains, cycle)?;
                Ok(Launch {
                    banner: format!(
                        "leg4: 4-motor leg on {}, {} Hz, {}",
                        site.placement,
                        site.robot.settings().period.hz(),
                        controller.describe()
                    ),
                    motion: "the leg will step for the given duration".into(),
                    sims: leg4::sims(site.robot, args.robot.seed)?,
                    controller,
                    status: LegStatus::default(),
                })
            },
            |finished, _, _| {
                let outcome = &finished.outcome;
                outcome.controller.results(&outcome.report)
            },
        )
}
