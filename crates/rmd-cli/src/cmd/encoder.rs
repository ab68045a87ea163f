//! `rmd encoder get|offset ID`: read the encoder (0x90); write the encoder offset (0x91).

use std::process::ExitCode;

use clap::{ArgGroup, Args, Subcommand};
use rmd_protocol::{EncoderValue, MotorId, ProtocolFamily, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::confirm;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::outln;
use crate::output::readings;
use crate::output::report::{self, CliError};

/// Arguments of `rmd encoder`.
#[derive(Args, Debug)]
pub(crate) struct EncoderArgs {
    #[command(subcommand)]
    command: EncoderCommand,
}

#[derive(Subcommand, Debug)]
enum EncoderCommand {
    /// Read the encoder position, raw position and offset (0x90).
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
    /// Write the encoder offset (0x91): encoder = raw - offset. `--here` makes the present
    /// position zero. For a zero kept across power cycles, see `rmd zero`. LK-TECH firmware
    /// keeps the offset in ROM: to an LK-TECH motor this asks first (or `--yes`).
    Offset(OffsetArgs),
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("value").required(true).args(["offset", "here"])))]
struct OffsetArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// The offset, 0..=2^bits-1 (see --encoder-bits).
    #[arg(value_name = "OFFSET", allow_hyphen_values = true)]
    offset: Option<i64>,
    /// Use the present raw position as the offset (the motor reads 0 here).
    #[arg(long)]
    here: bool,
    /// Do not ask first (LK-TECH firmware writes the offset to ROM).
    #[arg(long)]
    yes: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// Runs `rmd encoder`.
pub(crate) fn run(args: EncoderArgs) -> ExitCode {
    report::exit(match args.command {
        EncoderCommand::Get { id, json, bus } => get(id, json, &bus),
        EncoderCommand::Offset(offset) => set_offset(&offset),
    })
}

fn get(id: MotorId, json: bool, args: &BusArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let reply = bus.request(id, &Request::ReadEncoder)?;
    let Reply::ReadEncoder {
        encoder,
        encoder_raw,
        encoder_offset,
    } = reply
    else {
        return Err(CliError::unexpected_reply(id, &reply));
    };
    let width = bus.width();
    bus.finish()?;
    if json {
        outln!("{}", readings::object(id, &[reply], width))?;
    } else {
        outln!(
            "motor {id}: encoder {} ({:.2}°), raw {}, offset {} ({}-bit)",
            encoder.raw(),
            encoder.degrees(width),
            encoder_raw.raw(),
            encoder_offset.raw(),
            width.bits()
        )?;
    }
    Ok(())
}

fn set_offset(args: &OffsetArgs) -> Result<(), CliError> {
    let id = args.id;
    let width = args.bus.encoder_bits;
    // Check the value before touching the bus.
    let given = match args.offset {
        Some(raw) => Some(EncoderValue::new(raw, width).map_err(|e| {
            CliError::Usage(format!(
                "encoder offset for motor {id}: {e} for a {}-bit encoder (see --encoder-bits)",
                width.bits()
            ))
        })?),
        None => None,
    };
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    // The motor's family first: LK-TECH firmware keeps the offset in ROM.
    let command = rmd_protocol::Command::WriteEncoderOffset;
    if bus.dialect(id, command)?.family() == ProtocolFamily::LkV23x {
        confirm::confirm(
            &format!("writing the encoder offset of motor {id} to ROM"),
            &format!(
                "LK-TECH firmware keeps the encoder offset (0x91) in ROM as motor {id}'s zero. \
                 Every ROM write wears the motor's flash."
            ),
            args.yes,
        )?;
    }
    let offset = match given {
        Some(offset) => offset,
        None => match bus.request(id, &Request::ReadEncoder)? {
            Reply::ReadEncoder { encoder_raw, .. } => encoder_raw,
            other => return Err(CliError::unexpected_reply(id, &other)),
        },
    };
    let reply = bus.request(
        id,
        &Request::WriteEncoderOffset {
            encoder_offset: offset,
        },
    )?;
    let read_back = bus
        .later(&format!("encoder get {id}"))
        .map_or_else(String::new, |get| format!(": read it back with `{get}`"));
    bus.finish()?;
    match reply {
        Reply::WriteEncoderOffset { encoder_offset } if encoder_offset == offset => {
            outln!("motor {id}: encoder offset {} written", offset.raw())?;
            Ok(())
        }
        Reply::WriteEncoderOffset { encoder_offset } => Err(CliError::Failed(format!(
            "motor {id} reports offset {} instead of {}{read_back}",
            encoder_offset.raw(),
            offset.raw()
        ))),
        other => Err(CliError::unexpected_reply(id, &other)),
    }
}
