//! `rmd zero ID`: write the present position to ROM as the motor's zero (0x19). Asks first;
//! takes effect after a power cycle.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{Command, MotorId, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::confirm;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::outln;
use crate::output::report::{self, CliError};

/// Arguments of `rmd zero`.
#[derive(Args, Debug)]
pub(crate) struct ZeroArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// Do not ask first.
    #[arg(long)]
    yes: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// Runs `rmd zero`.
pub(crate) fn run(args: ZeroArgs) -> ExitCode {
    report::exit(zero(&args))
}

fn zero(args: &ZeroArgs) -> Result<(), CliError> {
    let id = args.id;
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    // The motor's protocol first: one without 0x19 is refused before anything is asked.
    bus.dialect(id, Command::WriteZeroRom)?;
    confirm::confirm(
        &format!("writing the zero of motor {id} to ROM"),
        &format!(
            "This writes motor {id}'s present position to its ROM as the zero (0x19). Every ROM \
             write wears the motor's flash, and the new zero takes effect only after the motor \
             is power-cycled."
        ),
        args.yes,
    )?;
    let reply = bus.request(id, &Request::WriteZeroRom)?;
    let check = bus
        .later(&format!("encoder get {id}"))
        .map_or_else(String::new, |get| {
            format!("; check with `{get}` after a power cycle")
        });
    bus.finish()?;
    match reply {
        Reply::WriteZeroRom { encoder_offset } => {
            outln!(
                "motor {id}: zero offset {} written to ROM; power-cycle the motor for it to take \
                 effect",
                encoder_offset.raw()
            )?;
            Ok(())
        }
        other => Err(CliError::Failed(format!(
            "motor {id} answered with an unexpected {} reply: the zero may not be \
             written{check}",
            other.command()
        ))),
    }
}
