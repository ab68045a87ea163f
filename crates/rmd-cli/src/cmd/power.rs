//! `rmd off|stop|run IDS`: motor off (0x80), stop (0x81), run (0x88).
//!
//! Off needs no protocol (the same frame in every family) and locks a MyActuator V3 motor's
//! brake after it ([`Connection::motor_off`]); stop and run are sent in the motor's protocol,
//! learned first: V3's stop holds the position, and V3 has no run.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{ProtocolFamily, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::ids::{self, IdList};
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::report::{self, CliError};
use crate::output::{errln, outln};

/// Arguments of `rmd off`, `rmd stop` and `rmd run`.
#[derive(Args, Debug)]
pub(crate) struct PowerArgs {
    /// Motor id(s): 1, 1-4, 1,3, all.
    #[arg(value_name = "IDS", value_parser = ids::parse)]
    ids: IdList,
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
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let request = action.request();
    let mut failed = Vec::new();
    for &motor in args.ids.ids() {
        if let Action::Off = action {
            match bus.motor_off(motor) {
                Ok(off) if off.brake_locked => outln!("motor {motor}: off, brake locked")?,
                Ok(_) => outln!("motor {motor}: off")?,
                Err(problem) => {
                    errln!("error: {problem}");
                    failed.push(motor.to_string());
                }
            }
            continue;
        }
        match bus.request(motor, &request) {
            Ok(reply) if reply == expected(action) => {
                let family = bus
                    .family(motor)
                    .map_or(ProtocolFamily::Unknown, |f| f.family());
                outln!("motor {motor}: {}", action.done(family))?;
            }
            Ok(reply) => {
                errln!(
                    "error: motor {motor} answered {} with {}: try again",
                    request.command(),
                    reply.command()
                );
                failed.push(motor.to_string());
            }
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(error) => {
                errln!("error: {error}");
                failed.push(motor.to_string());
            }
        }
    }
    bus.finish()?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "motor(s) {} did not confirm (see above)",
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
