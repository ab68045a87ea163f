//! Leaving motors safe when a command that moves them ends, fails or is interrupted: each is
//! turned off (0x80, the loop's safe state: no torque, no command), confirmed by its echo, one
//! frame per motor on `0x140 + id` in every family (never a 0x280 frame, which is torque to
//! v1.61 and LK-TECH motors and a command to every motor on a MyActuator V3 bus); then a V3
//! motor has its brake locked (0x78) ([`Connection::motor_off`]).

use rmd_protocol::MotorId;

use crate::live::connect::Connection;
use crate::output::report::CliError;

/// Turns `motors` off. The error lists every motor that did not confirm, and what to do.
pub(crate) fn turn_off(bus: &mut Connection, motors: &[MotorId]) -> Result<(), String> {
    let mut problems = Vec::new();
    for &motor in motors {
        if let Err(problem) = bus.motor_off(motor) {
            problems.push(problem);
        }
    }
    // Sent (confirmed or not): a third Ctrl-C may now exit.
    rmd_rig::signals::motors_off_sent();
    if problems.is_empty() {
        return Ok(());
    }
    let ids: Vec<String> = motors.iter().map(ToString::to_string).collect();
    Err(match bus.later(&format!("off {}", ids.join(","))) {
        Some(off) => format!(
            "{}. THE MOTOR MAY STILL BE MOVING: turn it off with `{off}`, or cut its power",
            problems.join("; ")
        ),
        // In-process simulated motors: they end with this command.
        None => format!(
            "{} (simulated motors: they stop when this command ends)",
            problems.join("; ")
        ),
    })
}

/// Ends a motion command: turns `motors` off, whatever `outcome` was, and merges what
/// happened into one result. `done` describes a normal end (e.g. "after 2.00 s").
pub(crate) fn finish(
    bus: &mut Connection,
    motors: &[MotorId],
    outcome: Result<(), CliError>,
) -> Result<(), CliError> {
    let stopped = turn_off(bus, motors);
    let ids: Vec<String> = motors.iter().map(ToString::to_string).collect();
    let off = format!("motor {} turned off", ids.join(", "));
    match (outcome, stopped) {
        (Ok(()), Ok(())) => Ok(()),
        (Ok(()), Err(problem)) => Err(CliError::Failed(problem)),
        (Err(CliError::Interrupted(what)), Ok(())) => {
            Err(CliError::Interrupted(format!("{what}; {off}")))
        }
        (Err(CliError::Interrupted(what)), Err(problem)) => Err(CliError::Failed(format!(
            "interrupted {what}, and {problem}"
        ))),
        // Nobody reads the output any more: quiet if the motors are off, loud if not.
        (Err(CliError::OutputClosed), Ok(())) => Err(CliError::OutputClosed),
        (Err(CliError::OutputClosed), Err(problem)) => Err(CliError::Failed(problem)),
        (Err(CliError::Failed(error) | CliError::Usage(error)), Ok(())) => {
            Err(CliError::Failed(format!("{error} ({off})")))
        }
        (Err(CliError::Failed(error) | CliError::Usage(error)), Err(problem)) => {
            Err(CliError::Failed(format!("{error}; then {problem}")))
        }
    }
}
