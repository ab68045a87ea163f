//! `rmd off|stop|run IDS` (or `--robot FILE [JOINTS]`): motor off (0x80), stop (0x81), run
//! (0x88).
//!
//! Off needs no protocol (the same frame in every family) and locks a MyActuator V3 motor's
//! brake after it ([`crate::live::connect::Connection::motor_off`]); stop and run are sent in the motor's protocol,
//! learned first: V3's stop holds the position, and V3 has no run.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{ProtocolFamily, Reply, Request};

use crate::args::bus::BusArgs;
use crate::live::connect::{DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::motors::Motors;
use crate::output::report::{self, CliError};
use crate::output::{errln, outln};

/// Arguments of `rmd off`, `rmd stop` and `rmd run`.
#[derive(Args, Debug)]
#[command(
    after_help = "With --robot FILE: the joints by name (all of them without JOINTS), each on the bus the description names (--iface moves buses, --sim simulates them)."
)]
pub(crate) struct PowerArgs {
    /// Motor id(s): 1, 1-4, 1,3, all; with --robot, joint names (none: every joint).
    #[arg(value_name = "IDS|JOINTS")]
    targets: Vec<String>,
    #[command(flatten)]
    bus: BusArgs,
}

/// Which of the three.
#[derive(Copy, Clone, Debug)]
pub(crate) enum Action {
    /// 0x80: output off, mode forgotten.
    Off,
    /// 0x81: output off, mode kept (`run` resumes it).
    Stop,
    /// 0x88: resume after a stop.
    Run,
}

impl Action {
    fn request(self) -> Request {
        match self {
            Action::Off => Request::MotorOff,
            Action::Stop => Request::MotorStop,
            Action::Run => Request::MotorRun,
        }
    }

    /// What the motor does now, in its family's meaning of the command.
    fn done(self, family: ProtocolFamily) -> &'static str {
        match (self, family) {
            (Action::Off, _) => "off",
            (Action::Stop, ProtocolFamily::MyActuatorV3) => {
                "stopped, holding its position (`rmd off` releases it)"
            }
            (Action::Stop, _) => "stopped (run resumes it)",
            (Action::Run, _) => "running",
        }
    }
}

/// Runs `rmd off`, `rmd stop` or `rmd run`.
pub(crate) fn run(action: Action, args: PowerArgs) -> ExitCode {
    report::exit(apply(action, &args))
}

fn apply(action: Action, args: &PowerArgs) -> Result<(), CliError> {
    let mut motors = Motors::open(&args.bus, &args.targets, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let request = action.request();
    let mut failed = Vec::new();
    for motor in motors.motors().to_vec() {
        if let Action::Off = action {
            match motors.connection(&motor).motor_off(motor.id) {
                Ok(off) if off.brake_locked => outln!("{}: off, brake locked", motor.title())?,
                Ok(_) => outln!("{}: off", motor.title())?,
                Err(problem) => {
                    errln!("error: {problem}");
                    failed.push(motor.label());
                }
            }
            continue;
        }
        match motors.request(&motor, &request) {
            Ok(reply) if reply == expected(action) => {
                let family = motors
                    .connection(&motor)
                    .family(motor.id)
                    .map_or(ProtocolFamily::Unknown, |f| f.family());
                outln!("{}: {}", motor.title(), action.done(family))?;
            }
            Ok(reply) => {
                errln!(
                    "error: {} answered {} with {}: try again",
                    motor.label(),
                    request.command(),
                    reply.command()
                );
                failed.push(motor.label());
            }
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(error) => {
                errln!("error: {error}");
                failed.push(motor.label());
            }
        }
    }
    motors.finish()?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "{} did not confirm (see above)",
            failed.join(", ")
        )))
    }
}

fn expected(action: Action) -> Reply {
    match action {
        Action::Off => Reply::MotorOff,
        Action::Stop => Reply::MotorStop,
        Action::Run => Reply::MotorRun,
    }
}
