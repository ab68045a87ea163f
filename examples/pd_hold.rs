//! # pd_hold: the smallest useful controller
//!
//! Turns one motor's joint (id 1, an RMD-X8-class motor with a 1:9 gearbox swinging a 1 kg arm
//! 0.2 m long) a given angle from where it is and holds it there, with a PD law on the joint
//! angle. The whole controller is `PdHold` and its `impl Controller` below.
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

use std::io::Write;
use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use rmd_rt::connect::{self, Target};
use rmd_rt::rt::config::MAX_MOTORS;
use rmd_rt::sim::{GravityLink, SimConfig};
use rmd_rt::{
    BusConfig, Commands, Controller, Feedback, Flow, MotorConfig, RobotConfig, RtLoop, RunLimit,
    TickContext,
};

/// Holds every joint `move_deg` away from where it was at the start:
/// current = kp * angle error - kd * velocity.
pub(crate) struct PdHold {
    /// How far to turn each joint from its start angle, degrees.
    pub(crate) move_deg: f64,
    /// Amperes per degree of error.
    pub(crate) kp: f64,
    /// Amperes per degree per second of velocity.
    pub(crate) kd: f64,
    /// Each joint's target angle, set in the first tick.
    pub(crate) targets: [f64; MAX_MOTORS],
}

impl Controller for PdHold {
    fn start(&mut self, _: &TickContext, feedback: &Feedback<'_>) {
        for (target, joint) in self.targets.iter_mut().zip(feedback.iter()) {
            *target = joint.joint_angle_deg + self.move_deg;
        }
    }

    fn update(&mut self, _: &TickContext, feedback: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        for (i, joint) in feedback.iter().enumerate() {
            let amps = self.kp * (self.targets[i] - joint.joint_angle_deg)
                - self.kd * joint.joint_velocity_dps;
            let _ = cmd.set_current(i, amps); // joint sign; the loop clamps it to 3 A
        }
        Flow::Continue
    }
}

/// Turns motor 1 by an angle and holds it there with a PD law (simulated motor, or a real one
/// with --iface).
#[derive(Parser, Debug, Clone)]
#[command(name = "pd_hold")]
pub(crate) struct Args {
    /// CAN interface of the motor's bus (e.g. can0); without it the motor is simulated.
    #[arg(long, value_name = "IFACE")]
    pub(crate) iface: Option<String>,
    /// Simulate in virtual time (as fast as the CPU allows).
    #[arg(long)]
    pub(crate) virtual_time: bool,
    /// How far to turn the joint from where it is, degrees (at the output).
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 30.0,
        allow_negative_numbers = true
    )]
    pub(crate) move_deg: f64,
    /// How long to hold, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 3.0)]
    pub(crate) duration: f64,
}

/// One motor on one bus: 1:9 gearbox, 2.09 N*m/A at the output, at most 3 A.
pub(crate) fn robot(interface: &str) -> RobotConfig {
    let motor = MotorConfig::new(1)
        .gear_ratio(9.0)
        .torque_constant(2.09)
        .current_limit(3.0)
        .zero_offset_deg(20.0); // power-up window -20..20 deg: see docs/getting-started.md
    RobotConfig::new(1000.0).with_bus(BusConfig::new(interface).with_motor(motor))
}

/// The simulated motor: at power-up (joint 0) the arm points 30 degrees below horizontal;
/// hanging straight down is joint -60 degrees, horizontal is joint 30 (the default move).
pub(crate) fn sim(robot: &RobotConfig) -> Vec<SimConfig> {
    let mut sims = connect::sim_configs(robot, 1);
    sims[0].motors[0].load.gravity = Some(GravityLink {
        mass_kg: 1.0,
        length_m: 0.2,
        angle_offset_deg: 60.0,
    });
    sims
}

/// The controller with its gains: 0.8 A per degree (1.7 N*m/deg at the output), 0.03 A per deg/s.
pub(crate) fn controller(move_deg: f64) -> PdHold {
    PdHold {
        move_deg,
        kp: 0.8,
        kd: 0.03,
        targets: [0.0; MAX_MOTORS],
    }
}

fn main() -> ExitCode {
    match run(&Args::parse()) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE, // a fault, an emergency stop: the report says which
        Err(e) => {
            eprintln!("pd_hold: {e}");
            ExitCode::from(2)
        }
    }
}

/// Connects, runs the hold and prints the report; returns whether the run ended normally.
fn run(args: &Args) -> Result<bool, Box<dyn std::error::Error>> {
    let target = Target::from_args(args.iface.as_slice(), args.virtual_time)?;
    let robot = robot(args.iface.as_deref().unwrap_or("sim"));
    let connection = connect::open(&target, &robot, sim(&robot))?;
    let controller = controller(args.move_deg);
    let rt = RtLoop::new(robot, connection.clock, connection.buses, controller)?;
    // Ctrl-C stops the loop, which sends zero torque and motor-off before it returns.
    connect::stop_on_ctrl_c(rt.stopper())?;
    let telemetry = rt.telemetry();
    // Output errors (a closed pipe) are ignored: they must not interrupt a run.
    let mut out = std::io::stdout();
    let _ = writeln!(
        out,
        "turning motor 1 by {} deg and holding it for {} s ({target})",
        args.move_deg, args.duration
    );
    let limit = RunLimit::Duration(Duration::from_secs_f64(args.duration.max(0.0)));
    let outcome = rt.run(limit);
    let _ = write!(out, "{}", outcome.report);
    if let Some(last) = telemetry.latest() {
        let joint = last.joints()[0];
        let _ = writeln!(
            out,
            "final angle {:.2} deg (target {:.2} deg), velocity {:.2} deg/s, current {:.2} A",
            joint.joint_angle_deg,
            outcome.controller.targets[0],
            joint.joint_velocity_dps,
            joint.iq_amps
        );
    }
    Ok(outcome.report.normal_stop)
}
