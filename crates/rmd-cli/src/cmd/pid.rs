//! `rmd pid get|set ID`: read the PID gains; change some of them, in RAM (default) or ROM.

use std::process::ExitCode;

use clap::{Args, Subcommand};
use rmd_protocol::{Command, MotorId, PidParams, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::confirm;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::outln;
use crate::output::readings;
use crate::output::report::{self, CliError};

/// Arguments of `rmd pid`.
#[derive(Args, Debug)]
pub(crate) struct PidArgs {
    #[command(subcommand)]
    command: PidCommand,
}

#[derive(Subcommand, Debug)]
enum PidCommand {
    /// Read the PID gains in use (0x30).
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
    /// Change PID gains: the ones given are changed, the others kept (read first). Written
    /// to RAM (0x31, lost at power off) unless --rom.
    Set(SetArgs),
}

#[derive(Args, Debug)]
struct SetArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// Position loop Kp (anglePidKp), 0..=255.
    #[arg(long)]
    angle_pid_kp: Option<u8>,
    /// Position loop Ki (anglePidKi), 0..=255.
    #[arg(long)]
    angle_pid_ki: Option<u8>,
    /// Speed loop Kp (speedPidKp), 0..=255.
    #[arg(long)]
    speed_pid_kp: Option<u8>,
    /// Speed loop Ki (speedPidKi), 0..=255.
    #[arg(long)]
    speed_pid_ki: Option<u8>,
    /// Torque loop Kp (iqPidKp), 0..=255.
    #[arg(long)]
    iq_pid_kp: Option<u8>,
    /// Torque loop Ki (iqPidKi), 0..=255.
    #[arg(long)]
    iq_pid_ki: Option<u8>,
    /// Write to ROM (0x32): kept across power cycles, wears the flash; asks first.
    #[arg(long)]
    rom: bool,
    /// Do not ask before writing to ROM.
    #[arg(long)]
    yes: bool,
    #[command(flatten)]
    bus: BusArgs,
}

impl SetArgs {
    fn any(&self) -> bool {
        [
            self.angle_pid_kp,
            self.angle_pid_ki,
            self.speed_pid_kp,
            self.speed_pid_ki,
            self.iq_pid_kp,
            self.iq_pid_ki,
        ]
        .iter()
        .any(Option::is_some)
    }

    fn apply(&self, current: PidParams) -> PidParams {
        PidParams {
            angle_pid_kp: self.angle_pid_kp.unwrap_or(current.angle_pid_kp),
            angle_pid_ki: self.angle_pid_ki.unwrap_or(current.angle_pid_ki),
            speed_pid_kp: self.speed_pid_kp.unwrap_or(current.speed_pid_kp),
            speed_pid_ki: self.speed_pid_ki.unwrap_or(current.speed_pid_ki),
            iq_pid_kp: self.iq_pid_kp.unwrap_or(current.iq_pid_kp),
            iq_pid_ki: self.iq_pid_ki.unwrap_or(current.iq_pid_ki),
        }
    }
}

/// Runs `rmd pid`.
pub(crate) fn run(args: PidArgs) -> ExitCode {
    report::exit(match args.command {
        PidCommand::Get { id, json, bus } => get(id, json, &bus),
        PidCommand::Set(set_args) => set(&set_args),
    })
}

/// The gains in words.
pub(crate) fn gains_text(p: &PidParams) -> String {
    format!(
        "angle kp {} ki {}, speed kp {} ki {}, iq kp {} ki {}",
        p.angle_pid_kp, p.angle_pid_ki, p.speed_pid_kp, p.speed_pid_ki, p.iq_pid_kp, p.iq_pid_ki
    )
}

fn read(bus: &mut Connection, id: MotorId) -> Result<PidParams, CliError> {
    match bus.request(id, &Request::ReadPid)? {
        Reply::ReadPid(p) => Ok(p),
        other => Err(CliError::unexpected_reply(id, &other)),
    }
}

fn get(id: MotorId, json: bool, args: &BusArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let gains = read(&mut bus, id)?;
    if json {
        outln!(
            "{}",
            readings::object(id, &[Reply::ReadPid(gains)], bus.width())
        )?;
    } else {
        outln!("motor {id}: {}", gains_text(&gains))?;
    }
    bus.finish()?;
    Ok(())
}

fn set(args: &SetArgs) -> Result<(), CliError> {
    let id = args.id;
    if !args.any() {
        let current = crate::live::hint::afresh(&args.bus, &format!("pid get {id}"))
            .map_or_else(String::new, |get| {
                format!("; `{get}` shows the current ones")
            });
        return Err(CliError::Usage(format!(
            "give at least one gain to change (e.g. --speed-pid-kp 60){current}"
        )));
    }
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    // The motor's protocol first: one without these commands is refused before anything is
    // asked or written.
    let write = if args.rom {
        Command::WritePidRom
    } else {
        Command::WritePidRam
    };
    bus.dialect(id, Command::ReadPid)?;
    bus.dialect(id, write)?;
    if args.rom {
        confirm::confirm(
            &format!("writing PID gains to the ROM of motor {id}"),
            &format!(
                "This writes the PID gains to motor {id}'s ROM (0x32): they are kept across \
                 power cycles, and every ROM write wears the motor's flash."
            ),
            args.yes,
        )?;
    }
    let gains = args.apply(read(&mut bus, id)?);
    let (request, memory) = if args.rom {
        (
            Request::WritePidRom(gains),
            "ROM (kept across power cycles)",
        )
    } else {
        (
            Request::WritePidRam(gains),
            "RAM (lost at power off; --rom keeps them)",
        )
    };
    let echoed = match bus.request(id, &request)? {
        Reply::WritePidRam(p) | Reply::WritePidRom(p) => p,
        other => return Err(CliError::unexpected_reply(id, &other)),
    };
    let read_back = bus
        .later(&format!("pid get {id}"))
        .map_or_else(String::new, |get| {
            format!("read them back with `{get}` and ")
        });
    bus.finish()?;
    if echoed != gains {
        return Err(CliError::Failed(format!(
            "motor {id} echoed other gains than written ({} instead of {}): {read_back}try \
             again",
            gains_text(&echoed),
            gains_text(&gains)
        )));
    }
    outln!(
        "motor {id}: PID gains written to {memory}: {}",
        gains_text(&gains)
    )?;
    Ok(())
}
