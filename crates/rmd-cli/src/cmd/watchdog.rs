//! `rmd watchdog ID TIME|off`: a MyActuator V3 motor's communication-interruption protection
//! (0xB3; V4.3 §2.31, V4.4 §2.32): when no frame reaches the motor for TIME, "the drive cuts
//! off the output and locks the brake", so a motor whose host died stops by itself. The time is
//! kept in ROM: this asks first (or `--yes`), and refuses while the motor moves ("avoid writing
//! this parameter right when the motor has just started or is in motion"). v1.61 and LK-TECH
//! motors have no such protection: refused, naming what to use instead.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_protocol::{Command, MotorId, Reply, Request, WatchdogTimeout};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::confirm;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::outln;
use crate::output::report::{self, CliError};

/// Arguments of `rmd watchdog`.
#[derive(Args, Debug)]
pub(crate) struct WatchdogArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// The protection time (e.g. 100ms, 0.5s; a bare number is seconds; whole milliseconds),
    /// or `off`. Longer than the longest pause between two commands: 5 ms proved too short
    /// on real motors.
    #[arg(value_name = "TIME|off", value_parser = protection_time)]
    time: WatchdogTimeout,
    /// Do not ask first (the time is written to the motor's ROM).
    #[arg(long)]
    yes: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// `TIME|off`: a duration in whole milliseconds that fits 0xB3's u32, or `off` (0).
fn protection_time(text: &str) -> Result<WatchdogTimeout, String> {
    if text.trim().eq_ignore_ascii_case("off") {
        return Ok(WatchdogTimeout::OFF);
    }
    let time = rmd_rig::args::duration::any(text)?;
    let millis = time.as_millis();
    if Duration::from_millis(u64::try_from(millis).unwrap_or(u64::MAX)) != time {
        return Err(format!(
            "`{text}`: the motor counts whole milliseconds (e.g. 100ms)"
        ));
    }
    u32::try_from(millis)
        .map(WatchdogTimeout::from_millis)
        .map_err(|_| format!("`{text}`: at most {} ms (about 49 days)", u32::MAX))
}

/// Runs `rmd watchdog`.
pub(crate) fn run(args: WatchdogArgs) -> ExitCode {
    report::exit(watchdog(&args))
}

fn watchdog(args: &WatchdogArgs) -> Result<(), CliError> {
    let id = args.id;
    let timeout = args.time;
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    // The motor's protocol first: v1.61 and LK-TECH are refused before anything is asked.
    bus.dialect(id, Command::SetWatchdog)?;
    let moving = match bus.request(id, &Request::ReadStatus2)?.status2() {
        Some(status) if status.speed.dps() != 0.0 => Some(status.speed.dps()),
        _ => None,
    };
    if let Some(dps) = moving {
        return Err(CliError::Failed(format!(
            "motor {id} is moving ({dps} dps at the output): the manual asks not to write the \
             protection time while the motor is in motion; stop it (`rmd off {id}`) and try \
             again. Nothing was written"
        )));
    }
    let what = if timeout.is_off() {
        "turning the communication watchdog off".to_owned()
    } else {
        format!("a communication watchdog of {} ms", timeout.millis())
    };
    confirm::confirm(
        &format!("writing {what} to the ROM of motor {id}"),
        &format!(
            "This writes {what} to motor {id}'s ROM (0xB3): it is kept across power cycles, and \
             every ROM write wears the motor's flash.{}",
            if timeout.is_off() {
                String::new()
            } else {
                format!(
                    " From now on, whenever no frame reaches motor {id} for {} ms, it turns its \
                     output off and locks its brake, and ignores the first command after that.",
                    timeout.millis()
                )
            }
        ),
        args.yes,
    )?;
    let reply = bus.request(id, &Request::SetWatchdog { timeout })?;
    bus.finish()?;
    match reply {
        Reply::SetWatchdog { timeout: echoed } if echoed == timeout => {
            if timeout.is_off() {
                outln!("motor {id}: communication watchdog off (written to ROM)")?;
            } else {
                outln!(
                    "motor {id}: communication watchdog {} ms written to ROM: with no frame for \
                     that long, the motor turns its output off and locks its brake (`rmd watchdog \
                     {id} off` disables it)",
                    timeout.millis()
                )?;
            }
            Ok(())
        }
        Reply::SetWatchdog { timeout: echoed } => Err(CliError::Failed(format!(
            "motor {id} echoed a protection time of {} ms instead of {}: write it again",
            echoed.millis(),
            timeout.millis()
        ))),
        other => Err(CliError::unexpected_reply(id, &other)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_whole_milliseconds_or_off() {
        assert_eq!(
            protection_time("100ms"),
            Ok(WatchdogTimeout::from_millis(100))
        );
        assert_eq!(
            protection_time("0.5"),
            Ok(WatchdogTimeout::from_millis(500))
        );
        assert_eq!(protection_time("off"), Ok(WatchdogTimeout::OFF));
        assert_eq!(protection_time("0"), Ok(WatchdogTimeout::OFF));
        assert!(
            protection_time("1.5ms")
                .unwrap_err()
                .contains("whole milliseconds")
        );
        assert!(protection_time("50days").unwrap_err().contains("at most"));
        assert!(protection_time("-1").is_err());
    }
}
