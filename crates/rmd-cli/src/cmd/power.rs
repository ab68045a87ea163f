//! `rmd off|stop|run IDS` (or `--robot FILE [JOINTS]`): motor off (0x80), stop (0x81), run
//! (0x88).

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{Reply, Request};

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

    fn done(self) -> &'static str {
        match self {
            Action::Off => "off",
            Action::Stop => "stopped (run resumes it)",
            Action::Run => "running",
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
        match motors.request(&motor, &request) {
            Ok(reply) if reply == expected(action) => {
                outln!("{}: {}", motor.title(), action.done())?;
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
