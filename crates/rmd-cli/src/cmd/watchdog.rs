//! `rmd watchdog ID TIME|off` (or `--robot FILE`): a MyActuator V3 motor's
//! communication-interruption protection (0xB3; V4.3 §2.31, V4.4 §2.32): when no frame reaches
//! the motor for TIME, "the drive cuts off the output and locks the brake", so a motor whose host
//! died stops by itself. The time is kept in ROM: this asks first (or `--yes`), and refuses while
//! the motor moves ("avoid writing this parameter right when the motor has just started or is in
//! motion"). With `--robot FILE`, each motor's `watchdog_ms` from the description is written,
//! after one question for all of them; the loop's report then counts those motors protected
//! (the firmware cannot report the time back). v1.61 and LK-TECH motors have no such protection:
//! refused, naming what to use instead.

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_loop::robot::Robot;
use rmd_protocol::{Command, MotorId, Reply, Request, WatchdogTimeout};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::confirm;
use crate::live::connect::{DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::motors::{Motor, Motors};
use crate::output::outln;
use crate::output::report::{self, CliError};

/// Arguments of `rmd watchdog`.
#[derive(Args, Debug)]
#[command(
    after_help = "With --robot FILE (and no ID or TIME): every motor whose description sets `watchdog_ms` gets that time, each on the bus the description names (--iface moves buses, --sim simulates them); one question for all of them."
)]
pub(crate) struct WatchdogArgs {
    /// Motor id, 1..=32 (not with --robot).
    #[arg(value_parser = parse::motor_id, required_unless_present = "robot")]
    id: Option<MotorId>,
    /// The protection time (e.g. 100ms, 0.5s; a bare number is seconds; whole milliseconds),
    /// or `off`. Longer than the longest pause between two commands: 5 ms proved too short
    /// on real motors.
    #[arg(value_name = "TIME|off", value_parser = protection_time, required_unless_present = "robot")]
    time: Option<WatchdogTimeout>,
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
    match (&args.bus.robot, args.id, args.time) {
        (Some(path), None, None) => from_robot(args, path),
        (None, Some(id), Some(timeout)) => {
            let ids = [id.get().to_string()];
            let motors = Motors::open(&args.bus, &ids, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
            let motor = motors.motors()[0].clone();
            write(motors, &[(motor, timeout)], args.yes)
        }
        (Some(path), _, _) => Err(CliError::Usage(format!(
            "--robot {}: the times come from the description's `watchdog_ms`; give no ID or \
             TIME",
            path.display()
        ))),
        (None, _, _) => Err(CliError::Usage(
            "give a motor id and a time (e.g. `rmd watchdog 1 100ms`), or --robot FILE".to_owned(),
        )),
    }
}

/// Writes the watchdog of every motor of the description that sets `watchdog_ms`.
fn from_robot(args: &WatchdogArgs, path: &Path) -> Result<(), CliError> {
    let robot = Robot::from_file(path).map_err(|e| CliError::Usage(e.to_string()))?;
    let motors = Motors::open(&args.bus, &[], DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let wanted = |motor: &Motor| {
        let joint = motor.joint.as_ref()?;
        robot
            .joints()
            .iter()
            .find(|spec| spec.name == joint.name)?
            .watchdog
    };
    let mut plan = Vec::new();
    for motor in motors.motors() {
        match wanted(motor) {
            Some(timeout) => plan.push((motor.clone(), timeout)),
            None => outln!(
                "{}: no `watchdog_ms` in {}: left as it is",
                motor.title(),
                path.display()
            )?,
        }
    }
    if plan.is_empty() {
        return Err(CliError::Usage(format!(
            "{}: no motor sets `watchdog_ms` (MyActuator V3 motors only; e.g. `watchdog_ms = 50`)",
            path.display()
        )));
    }
    write(motors, &plan, args.yes)
}

/// `timeout` in words.
fn described(timeout: WatchdogTimeout) -> String {
    if timeout.is_off() {
        "the communication watchdog off".to_owned()
    } else {
        format!("a communication watchdog of {} ms", timeout.millis())
    }
}

/// Writes each motor's watchdog, after checking every motor speaks V3 and stands still, and
/// after one question for all of them.
fn write(mut motors: Motors, plan: &[(Motor, WatchdogTimeout)], yes: bool) -> Result<(), CliError> {
    // Each motor's protocol first: v1.61 and LK-TECH are refused before anything is asked.
    for (motor, _) in plan {
        motors.dialect(motor, Command::SetWatchdog)?;
    }
    for (motor, _) in plan {
        let moving = match motors.request(motor, &Request::ReadStatus2)?.status2() {
            Some(status) if status.speed.dps() != 0.0 => Some(status.speed.dps()),
            _ => None,
        };
        if let Some(dps) = moving {
            return Err(CliError::Failed(format!(
                "{} is moving ({dps} dps at the output): the manual asks not to write the \
                 protection time while the motor is in motion; stop it (`rmd off {}`) and try \
                 again. Nothing was written",
                motor.label(),
                motor.id
            )));
        }
    }
    let (what, details) = match plan {
        [(motor, timeout)] => (
            format!(
                "writing {} to the ROM of {}",
                described(*timeout),
                motor.label()
            ),
            format!(
                "This writes {} to {}'s ROM (0xB3): it is kept across power cycles, and every \
                 ROM write wears the motor's flash.{}",
                described(*timeout),
                motor.label(),
                consequence(motor, *timeout)
            ),
        ),
        many => (
            format!(
                "writing communication watchdogs to the ROM of {} motors",
                many.len()
            ),
            format!(
                "This writes to each motor's ROM (0xB3), kept across power cycles (every ROM \
                 write wears the motor's flash): {}. A motor with a watchdog turns its output \
                 off and locks its brake whenever no frame reaches it for that long, and ignores \
                 the first command after that.",
                many.iter()
                    .map(|(m, t)| format!("{}: {}", m.title(), described(*t)))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        ),
    };
    confirm::confirm(&what, &details, yes)?;
    for (motor, timeout) in plan {
        let reply = motors.request(motor, &Request::SetWatchdog { timeout: *timeout })?;
        check_echo(motor, *timeout, reply)?;
    }
    motors.finish()
}

/// What the motor does from now on, for the question.
fn consequence(motor: &Motor, timeout: WatchdogTimeout) -> String {
    if timeout.is_off() {
        String::new()
    } else {
        format!(
            " From now on, whenever no frame reaches {} for {} ms, it turns its output off and \
             locks its brake, and ignores the first command after that.",
            motor.label(),
            timeout.millis()
        )
    }
}

/// Checks the motor echoed the time written, and says so.
fn check_echo(motor: &Motor, timeout: WatchdogTimeout, reply: Reply) -> Result<(), CliError> {
    let id = motor.id;
    match reply {
        Reply::SetWatchdog { timeout: echoed } if echoed == timeout => {
            if timeout.is_off() {
                outln!(
                    "{}: communication watchdog off (written to ROM)",
                    motor.title()
                )?;
            } else {
                outln!(
                    "{}: communication watchdog {} ms written to ROM: with no frame for that \
                     long, the motor turns its output off and locks its brake (`rmd watchdog \
                     {id} off` disables it)",
                    motor.title(),
                    timeout.millis()
                )?;
            }
            Ok(())
        }
        Reply::SetWatchdog { timeout: echoed } => Err(CliError::Failed(format!(
            "{} echoed a protection time of {} ms instead of {}: write it again",
            motor.label(),
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
