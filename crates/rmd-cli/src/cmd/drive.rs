//! `rmd torque ID` and `rmd speed ID`: drive a motor in torque or speed mode for a duration,
//! then turn it off. The command is sent again at `--rate` (each reply is shown live), and
//! Ctrl-C turns the motor off at once.

use std::process::ExitCode;
use std::time::Duration;

use clap::{ArgGroup, Args};
use rmd_bus::Clock;
use rmd_protocol::{IqControl, MotorId, Request, SpeedControl, Status2};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::args::timing;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::interrupt;
use crate::live::recording;
use crate::live::safe_stop;
use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};
use crate::output::{errln, outln};
use rmd_rig::args::duration;

/// How long and how often (shared by torque and speed).
#[derive(Args, Debug)]
struct Timing {
    /// How long to drive the motor before turning it off (e.g. 2s, 500ms; a bare number is
    /// seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", value_parser = duration::any, default_value = "1s", allow_hyphen_values = true)]
    duration: Duration,
    /// How often the command is sent again (and the motor's reply shown), Hz.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = timing::rate_hz, default_value = "50", allow_hyphen_values = true)]
    rate: f64,
}

/// Arguments of `rmd torque`.
#[derive(Args, Debug)]
#[command(group(ArgGroup::new("current").required(true).args(["amps", "iq_control"])))]
pub(crate) struct TorqueArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// Torque current in amperes, -32..=32.
    #[arg(long, value_parser = parse::iq_amps, allow_hyphen_values = true)]
    amps: Option<IqControl>,
    /// Torque current as raw iqControl, -2000..=2000.
    #[arg(long, value_parser = parse::iq_control, allow_hyphen_values = true)]
    iq_control: Option<IqControl>,
    /// Turn the motor off early if its speed exceeds this, dps (motor side): an unloaded motor
    /// in torque mode speeds up until its back-EMF limits it.
    #[arg(long, value_name = "DPS", value_parser = parse::positive)]
    max_speed: Option<f64>,
    #[command(flatten)]
    timing: Timing,
    #[command(flatten)]
    bus: BusArgs,
}

/// Arguments of `rmd speed`.
#[derive(Args, Debug)]
#[command(group(ArgGroup::new("target").required(true).args(["dps", "speed_control"])))]
pub(crate) struct SpeedArgs {
    /// Motor id, 1..=32.
    #[arg(value_parser = parse::motor_id)]
    id: MotorId,
    /// Speed in degrees per second (motor side).
    #[arg(long, value_parser = parse::speed_dps, allow_hyphen_values = true)]
    dps: Option<SpeedControl>,
    /// Speed as raw speedControl, 0.01 dps per LSB.
    #[arg(long, value_parser = parse::speed_control, allow_hyphen_values = true)]
    speed_control: Option<SpeedControl>,
    #[command(flatten)]
    timing: Timing,
    #[command(flatten)]
    bus: BusArgs,
}

/// Runs `rmd torque`.
pub(crate) fn run_torque(args: TorqueArgs) -> ExitCode {
    let Some(iq_control) = args.amps.or(args.iq_control) else {
        return report::usage_error("give --amps or --iq-control");
    };
    let what = format!("torque {:.3} A", iq_control.amps());
    report::exit(drive(
        &args.bus,
        args.id,
        Request::Torque { iq_control },
        &what,
        &args.timing,
        args.max_speed,
    ))
}

/// Runs `rmd speed`.
pub(crate) fn run_speed(args: SpeedArgs) -> ExitCode {
    let Some(speed_control) = args.dps.or(args.speed_control) else {
        return report::usage_error("give --dps or --speed-control");
    };
    let what = format!("speed {:.2} dps", speed_control.dps());
    report::exit(drive(
        &args.bus,
        args.id,
        Request::Speed { speed_control },
        &what,
        &args.timing,
        None,
    ))
}

fn drive(
    bus_args: &BusArgs,
    id: MotorId,
    request: Request,
    what: &str,
    timing: &Timing,
    max_speed: Option<f64>,
) -> Result<(), CliError> {
    let mut bus = Connection::open(bus_args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    interrupt::install_driving()?;
    let period = timing::period(timing.rate);
    let start = bus.clock().now();
    let end = start + timing.duration;
    let mut sent: u32 = 0;
    let mut last: Option<Status2> = None;
    errln!(
        "motor {id}: {what} for {:.2} s (Ctrl-C stops it)",
        timing.duration.as_secs_f64()
    );
    let progress = Progress::timer(timing.duration, progress::shown(false));
    progress.set_prefix(format!("motor {id} "));
    let outcome = loop {
        if interrupt::requested() {
            break Err(CliError::Interrupted(format!("{what} on motor {id}")));
        }
        match bus.request(id, &request) {
            Ok(reply) => last = reply.status2().or(last),
            Err(error) => break Err(error.into()),
        }
        sent += 1;
        let elapsed = bus.clock().now() - start;
        if let Some(status) = last {
            progress.set_elapsed(elapsed);
            progress.set_message(reading(&status));
            if let Some(limit) = max_speed
                && status.speed.dps().abs() > limit
            {
                break Err(CliError::Failed(format!(
                    "motor {id} reached {} dps, above --max-speed {limit}",
                    status.speed.dps()
                )));
            }
        }
        let wake = (start + period * sent).min(end);
        if !interrupt::sleep_until(bus.clock(), wake) {
            break Err(CliError::Interrupted(format!("{what} on motor {id}")));
        }
        if wake >= end {
            break Ok(());
        }
    };
    drop(progress);
    let elapsed = bus.clock().now() - start;
    let result = safe_stop::finish(&mut bus, &[id], outcome);
    // The motor is off: the log (a stalled reader is waited for a bounded time) comes after.
    let finished = bus.finish();
    if result.is_err() {
        return recording::after(result, finished);
    }
    outln!(
        "motor {id}: {what} for {:.2} s ({sent} commands), then turned off{}",
        elapsed.as_secs_f64(),
        last.map_or(String::new(), |s| format!("; last reply: {}", reading(&s)))
    )?;
    finished
}

/// One status-2 reply in words.
pub(crate) fn reading(status: &Status2) -> String {
    format!(
        "iq {:6.2} A  speed {:6} dps  {} °C",
        status.iq.amps(),
        status.speed.dps(),
        status.temperature.celsius()
    )
}
