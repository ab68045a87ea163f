//! `rmd accel get|set ID`: the acceleration limit (0x33 / 0x34, RAM).

use std::process::ExitCode;

use clap::{Args, Subcommand};
use rmd_protocol::{Accel, MotorId, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::outln;
use crate::output::readings;
use crate::output::report::{self, CliError};

/// Arguments of `rmd accel`.
#[derive(Args, Debug)]
pub(crate) struct AccelArgs {
    #[command(subcommand)]
    command: AccelCommand,
}

#[derive(Subcommand, Debug)]
enum AccelCommand {
    /// Read the acceleration limit in use (0x33), dps/s (motor side).
    Get {
        /// Motor id, 1..=32.
        #[arg(value_parser = parse::motor_id)]
        id: MotorId,
        /// Print a JSON object.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        bus: BusArgs,
    },
    /// Set the acceleration limit in RAM (0x34; lost at power off).
    Set {
        /// Motor id, 1..=32.
        #[arg(value_parser = parse::motor_id)]
        id: MotorId,
        /// Acceleration limit in dps/s (motor side), an integer.
        #[arg(value_name = "DPS_PER_S", value_parser = parse::accel, allow_hyphen_values = true)]
        accel: Accel,
        #[command(flatten)]
        bus: BusArgs,
    },
}

/// Runs `rmd accel`.
pub(crate) fn run(args: AccelArgs) -> ExitCode {
    report::exit(match args.command {
        AccelCommand::Get { id, json, bus } => get(id, json, &bus),
        AccelCommand::Set { id, accel, bus } => set(id, accel, &bus),
    })
}

fn get(id: MotorId, json: bool, args: &BusArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let reply = bus.request(id, &Request::ReadAccel)?;
    let Reply::ReadAccel { accel } = reply else {
        return Err(CliError::unexpected_reply(id, &reply));
    };
    if json {
        outln!("{}", readings::object(id, &[reply], bus.width()))?;
    } else {
        outln!("motor {id}: acceleration {} dps/s", accel.dps_per_s())?;
    }
    bus.finish()?;
    Ok(())
}

fn set(id: MotorId, accel: Accel, args: &BusArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let reply = bus.request(id, &Request::WriteAccelRam { accel })?;
    let read_back = bus
        .later(&format!("accel get {id}"))
        .map_or_else(String::new, |get| format!(": read it back with `{get}`"));
    bus.finish()?;
    match reply {
        Reply::WriteAccelRam { accel: echoed } if echoed == accel => {
            outln!(
                "motor {id}: acceleration {} dps/s written to RAM (lost at power off)",
                accel.dps_per_s()
            )?;
            Ok(())
        }
        Reply::WriteAccelRam { accel: echoed } => Err(CliError::Failed(format!(
            "motor {id} echoed {} dps/s instead of {}{read_back}",
            echoed.dps_per_s(),
            accel.dps_per_s()
        ))),
        other => Err(CliError::unexpected_reply(id, &other)),
    }
}
