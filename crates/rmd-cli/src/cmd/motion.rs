//! `rmd move ID --deg X`: a position command (modes 1..=4 of the protocol, 0xA3..=0xA6) with
//! angle limits checked before anything is sent; waits until the motor is there (Ctrl-C or a
//! timeout turns it off), then leaves it holding the position.
//!
//! The motor's protocol is learned before the command is sent (see [`Connection`]): a
//! MyActuator V3 motor has mode 2 only (0xA4, the output shaft's absolute angle, which its
//! replies and 0x92 report too), and its brake released first if status 1 shows it locked.

use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, ValueEnum};
use rmd_bus::Clock;
use rmd_protocol::{
    AngleControl, Conversion, Dialect, MaxSpeed, Reply, Request, SingleTurnAngle, SpinDirection,
};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::frames_mcap::FramesTelemetryArgs;
use crate::live::interrupt;
use crate::live::motors::{Motor, Motors};
use crate::live::safe_stop;
use crate::output::outln;
use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};
use rmd_rig::args::duration;

/// Direction of the single-turn modes 3 and 4.
#[derive(Copy, Clone, Debug, ValueEnum)]
enum Direction {
    /// Clockwise (spinDirection 0x00; angles grow).
    Cw,
    /// Counterclockwise (spinDirection 0x01).
    Ccw,
}

/// Arguments of `rmd move`.
#[derive(Args, Debug)]
#[command(
    after_help = "With --robot FILE, MOTOR is a joint name and every angle and speed is on the joint side (gear ratio, direction and zero offset of the description applied); the multi-turn modes 1 and 2 only."
)]
pub(crate) struct MoveArgs {
    /// Motor id, 1..=32; with --robot, a joint name.
    #[arg(value_name = "MOTOR")]
    target: String,
    /// Target angle, degrees (motor side, the output shaft on MyActuator V3; with --robot,
    /// joint side): multi-turn for modes 1 and 2, 0..<360 for modes 3 and 4.
    #[arg(long, value_parser = parse::finite, allow_hyphen_values = true)]
    deg: f64,
    /// Position mode: 1 (0xA3, multi-turn), 2 (0xA4, multi-turn with --max-speed), 3 (0xA5,
    /// single-turn with --direction), 4 (0xA6, single-turn with --direction and --max-speed).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=4))]
    mode: u8,
    /// Speed limit of modes 2 and 4, dps (motor side; with --robot, joint side) [default: 360
    /// dps at the motor]. Modes 1 and 3 use the motor's own max-speed setting.
    #[arg(long, value_name = "DPS", value_parser = parse::positive)]
    max_speed: Option<f64>,
    /// Turning direction of modes 3 and 4 [default: cw].
    #[arg(long, value_enum)]
    direction: Option<Direction>,
    /// Refuse targets below this angle, degrees.
    #[arg(long, value_name = "DEG", value_parser = parse::finite, allow_hyphen_values = true)]
    min_deg: Option<f64>,
    /// Refuse targets above this angle, degrees.
    #[arg(long, value_name = "DEG", value_parser = parse::finite, allow_hyphen_values = true)]
    max_deg: Option<f64>,
    /// How close counts as there, degrees.
    #[arg(long, value_name = "DEG", value_parser = parse::positive, default_value = "1")]
    tolerance: f64,
    /// Give up (and turn the motor off) if it is not there after this long (e.g. 10s, 1m; a
    /// bare number is seconds).
    #[arg(long = "wait-timeout", value_name = "DURATION", value_parser = duration::any, default_value = "10s", allow_hyphen_values = true)]
    wait_timeout: Duration,
    /// Return once the motor accepted the command, without waiting for it to arrive.
    #[arg(long)]
    no_wait: bool,
    #[command(flatten)]
    telemetry: FramesTelemetryArgs,
    #[command(flatten)]
    bus: BusArgs,
}

/// Default speed limit of modes 2 and 4.
const DEFAULT_MAX_SPEED_DPS: f64 = 360.0;
/// How often the angle is read while waiting.
const POLL: Duration = Duration::from_millis(50);

/// Runs `rmd move`.
pub(crate) fn run(args: MoveArgs) -> ExitCode {
    report::exit(run_move(&args))
}

fn run_move(args: &MoveArgs) -> Result<(), CliError> {
    if args.bus.robot.is_some() && args.mode >= 3 {
        return Err(CliError::Usage(
            "with --robot, the single-turn modes 3 and 4 have no joint meaning: use mode 1 or 2"
                .to_owned(),
        ));
    }
    // The limits are checked before anything is opened: a bad target sends nothing.
    if args.bus.robot.is_none() {
        parse::motor_id(&args.target).map_err(CliError::Usage)?;
    }
    check_limits(args).map_err(CliError::Usage)?;
    args.telemetry.check("move")?;
    let mut motors = Motors::open(
        &args.bus,
        std::slice::from_ref(&args.target),
        DEFAULT_TIMEOUT,
        DEFAULT_RETRIES,
    )?;
    let motor = motors.motors()[0].clone();
    let request = position_request(args, &motor).map_err(CliError::Usage)?;
    motors
        .connection(&motor)
        .record_mcap(args.telemetry.mcap.as_deref())?;
    // The motor's protocol before anything moves it: a mode it does not have is refused here.
    let moved = motors
        .dialect(&motor, request.command())
        .map_err(CliError::from)
        .and_then(|_| move_to(args, &mut motors, &motor, request));
    // Whatever happened, the recording (--log) is flushed and reported.
    let finished = motors.finish();
    moved.and(finished)
}

/// The target against `--min-deg` / `--max-deg` (both in the units of `--deg`).
fn check_limits(args: &MoveArgs) -> Result<(), String> {
    let (min, max) = (
        args.min_deg.unwrap_or(f64::NEG_INFINITY),
        args.max_deg.unwrap_or(f64::INFINITY),
    );
    if min > max {
        return Err(format!("--min-deg {min} is above --max-deg {max}"));
    }
    if !(min..=max).contains(&args.deg) {
        return Err(format!(
            "target {}° for {} is outside the limits {}..={} (--min-deg/--max-deg): \
             nothing was sent",
            args.deg,
            if args.bus.robot.is_some() {
                format!("joint {}", args.target)
            } else {
                format!("motor {}", args.target)
            },
            args.min_deg.map_or("-inf".into(), |v| v.to_string()),
            args.max_deg.map_or("+inf".into(), |v| v.to_string())
        ));
    }
    Ok(())
}

/// The position request the arguments describe for `motor` (with a joint: its target and speed
/// turned into the motor's).
fn position_request(args: &MoveArgs, motor: &Motor) -> Result<Request, String> {
    let id = motor.label();
    let (deg, speed_factor) = match &motor.joint {
        Some(joint) => (joint.map.motor_angle_deg(args.deg), joint.map.gear_ratio()),
        None => (args.deg, 1.0),
    };
    let single_turn = args.mode >= 3;
    let with_speed = args.mode == 2 || args.mode == 4;
    if args.max_speed.is_some() && !with_speed {
        return Err(format!(
            "mode {} uses the motor's own max-speed setting: --max-speed needs mode 2 or 4",
            args.mode
        ));
    }
    if args.direction.is_some() && !single_turn {
        return Err(format!(
            "--direction is for the single-turn modes 3 and 4 (mode {} is multi-turn)",
            args.mode
        ));
    }
    // Given: in the target's units (joint side with --robot). Default: 360 dps at the motor,
    // whatever the gearbox, as without --robot.
    let motor_dps = args
        .max_speed
        .map_or(DEFAULT_MAX_SPEED_DPS, |dps| dps * speed_factor);
    let max_speed = MaxSpeed::from_dps(motor_dps).map_err(|e| format!("--max-speed: {e}"))?;
    let spin_direction = match args.direction.unwrap_or(Direction::Cw) {
        Direction::Cw => SpinDirection::Clockwise,
        Direction::Ccw => SpinDirection::CounterClockwise,
    };
    let multi = || AngleControl::from_degrees(deg).map_err(|e| format!("--deg for {id}: {e}"));
    let single = || {
        SingleTurnAngle::from_degrees(deg).map_err(|e| {
            format!("--deg for {id}: {e} (modes 3 and 4 take a single-turn angle, 0..<360°)")
        })
    };
    Ok(match args.mode {
        1 => Request::Position1 {
            angle_control: multi()?,
        },
        2 => Request::Position2 {
            max_speed,
            angle_control: multi()?,
        },
        3 => Request::Position3 {
            spin_direction,
            angle_control: single()?,
        },
        _ => Request::Position4 {
            spin_direction,
            max_speed,
            angle_control: single()?,
        },
    })
}

fn move_to(
    args: &MoveArgs,
    motors: &mut Motors,
    motor: &Motor,
    request: Request,
) -> Result<(), CliError> {
    let (id, label) = (motor.id, motor.label());
    let bus = motors.connection(motor);
    if !args.no_wait {
        // Before the motor moves: from here Ctrl-C turns it off instead of killing us.
        interrupt::install_driving()?;
    }
    let sent = bus
        .release_brake_to_move(id)
        .and_then(|()| bus.request(id, &request));
    let reply = match sent {
        Ok(reply) => reply,
        // The brake may be released, or the command taken: leave the motor off.
        Err(error) => return safe_stop::finish(bus, &[id], Err(error.into())),
    };
    if reply.status2().is_none() {
        let check = bus
            .later(&format!("status {id}"))
            .map_or_else(String::new, |status| format!("; check with `{status}`"));
        return Err(CliError::Failed(format!(
            "{label} answered {} with {}: the command may not have been taken{check}",
            request.command(),
            reply.command()
        )));
    }
    if args.no_wait {
        outln!("{label}: moving to {}° (mode {})", args.deg, args.mode)?;
        return Ok(());
    }
    let single_turn = args.mode >= 3;
    let progress = Progress::spinner(progress::shown(false));
    progress.set_prefix(format!("{label} "));
    let start = bus.clock().now();
    let mut angle = None;
    let outcome = loop {
        if interrupt::requested() {
            break Err(CliError::Interrupted(format!("moving {label}")));
        }
        match read_angle(bus, motor, single_turn) {
            Ok(a) => angle = Some(a),
            Err(error) => break Err(error),
        }
        let elapsed = bus.clock().now() - start;
        let error = distance(angle.unwrap_or(f64::NAN), args.deg, single_turn);
        progress.set_message(format!(
            "at {:.2}°, moving to {}°",
            angle.unwrap_or(f64::NAN),
            args.deg
        ));
        if error <= args.tolerance {
            break Ok(elapsed);
        }
        if elapsed >= args.wait_timeout {
            break Err(CliError::Failed(format!(
                "{label} did not reach {}° within {:.1} s (it is at {:.2}°): check the \
                 load, --max-speed, and the motor's max-angle setting",
                args.deg,
                args.wait_timeout.as_secs_f64(),
                angle.unwrap_or(f64::NAN)
            )));
        }
        if !interrupt::sleep_until(bus.clock(), bus.clock().now() + POLL) {
            break Err(CliError::Interrupted(format!("moving {label}")));
        }
    };
    drop(progress);
    match outcome {
        Ok(elapsed) => {
            let release = match bus.later(&format!("off {id}")) {
                Some(off) => format!("holding the position (`{off}` releases it)"),
                // Simulated in this process: nothing is left to release.
                None => "holding the position (simulated motors end with this command: \
                         nothing is left to release)"
                    .to_owned(),
            };
            outln!(
                "{label}: at {:.2}° (target {}°) after {:.2} s; {release}",
                angle.unwrap_or(f64::NAN),
                args.deg,
                elapsed.as_secs_f64(),
            )?;
            Ok(())
        }
        Err(error) => safe_stop::finish(bus, &[id], Err(error)),
    }
}

/// The motor's angle: multi-turn (0x92) or single-turn (0x94), degrees; with a joint, the joint
/// angle.
fn read_angle(bus: &mut Connection, motor: &Motor, single_turn: bool) -> Result<f64, CliError> {
    let id = motor.id;
    let request = if single_turn {
        Request::ReadSingleTurnAngle
    } else {
        Request::ReadMultiTurnAngle
    };
    let reply = bus.request(id, &request)?;
    // LK-TECH counts its single-turn angle over the output's turn (up to 36000 × gear ratio):
    // the angle within one motor turn, as modes 3 and 4 take it, is its v1.61 form.
    let reply = match reply {
        Reply::LkSingleTurnAngle { .. } => bus
            .dialect(id, request.command())?
            .convert_reply(&reply, Dialect::V161, Conversion::Nearest)
            .map_err(|e| CliError::Failed(format!("motor {id}: {e}")))?,
        reply => reply,
    };
    match reply {
        Reply::ReadMultiTurnAngle { motor_angle } => Ok(match &motor.joint {
            Some(joint) => joint.map.joint_angle_deg(motor_angle.degrees()),
            None => motor_angle.degrees(),
        }),
        Reply::ReadSingleTurnAngle { circle_angle } => Ok(circle_angle.degrees()),
        other => Err(CliError::Failed(format!(
            "motor {id} answered with an unexpected {} reply",
            other.command()
        ))),
    }
}

/// How far `angle` is from `target`, degrees (around the circle for single-turn angles).
fn distance(angle: f64, target: f64, single_turn: bool) -> f64 {
    let d = (angle - target).abs();
    if single_turn { d.min(360.0 - d) } else { d }
}

#[cfg(test)]
mod tests {
    use super::distance;

    #[test]
    fn single_turn_distance_goes_around() {
        assert_eq!(distance(359.0, 1.0, true), 2.0);
        assert_eq!(distance(359.0, 1.0, false), 358.0);
        assert!(distance(f64::NAN, 1.0, false).is_nan());
    }
}
