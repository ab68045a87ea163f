//! `rmd torque ID` and `rmd speed ID`: drive a motor in torque or speed mode for a duration,
//! then turn it off. The command is sent again at `--rate` (each reply is shown live), and
//! Ctrl-C turns the motor off at once.

use std::process::ExitCode;
use std::time::Duration;

use clap::{ArgGroup, Args};
use rmd_bus::{Clock, Timestamp};
use rmd_protocol::{IqControl, MotorId, Request, SpeedControl, Status2};

use crate::args::bus::BusArgs;
use crate::args::parse;
use crate::args::timing;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::frames_mcap::FramesTelemetryArgs;
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
    /// A rate above what the motor answers is sent as fast as it answers (each command waits
    /// for the reply to the previous one); the drive still ends after `--duration`.
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
    telemetry: FramesTelemetryArgs,
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
    telemetry: FramesTelemetryArgs,
    #[command(flatten)]
    bus: BusArgs,
}

/// Runs `rmd torque`.
pub(crate) fn run_torque(args: TorqueArgs) -> ExitCode {
    let Some(iq_control) = args.amps.or(args.iq_control) else {
        return report::usage_error("give --amps or --iq-control");
    };
    let what = format!("torque {:.3} A", iq_control.amps());
    report::exit(args.telemetry.check("torque").and_then(|()| {
        drive(
            &args.bus,
            &args.telemetry,
            args.id,
            Request::Torque {
                iq_control: iq_control.into(),
            },
            &what,
            &args.timing,
            args.max_speed,
        )
    }))
}

/// Runs `rmd speed`.
pub(crate) fn run_speed(args: SpeedArgs) -> ExitCode {
    let Some(speed_control) = args.dps.or(args.speed_control) else {
        return report::usage_error("give --dps or --speed-control");
    };
    let what = format!("speed {:.2} dps", speed_control.dps());
    report::exit(args.telemetry.check("speed").and_then(|()| {
        drive(
            &args.bus,
            &args.telemetry,
            args.id,
            Request::Speed {
                speed_control,
                max_torque: rmd_protocol::MaxTorquePercent::NONE,
            },
            &what,
            &args.timing,
            None,
        )
    }))
}

fn drive(
    bus_args: &BusArgs,
    telemetry: &FramesTelemetryArgs,
    id: MotorId,
    request: Request,
    what: &str,
    timing: &Timing,
    max_speed: Option<f64>,
) -> Result<(), CliError> {
    let mut bus = Connection::open(bus_args, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    bus.record_mcap(telemetry.mcap.as_deref())?;
    interrupt::install_driving()?;
    let start = bus.clock().now();
    let mut schedule = Schedule::new(start, timing.duration, timing::period(timing.rate));
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
        sent = sent.saturating_add(1);
        let now = bus.clock().now();
        if let Some(status) = last {
            progress.set_elapsed(now - start);
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
        let Some(wake) = schedule.next(now) else {
            break Ok(());
        };
        if !interrupt::sleep_until(bus.clock(), wake) {
            break Err(CliError::Interrupted(format!("{what} on motor {id}")));
        }
        if schedule.is_over(bus.clock().now()) {
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
    let achieved = f64::from(sent) / elapsed.as_secs_f64().max(1e-9);
    outln!(
        "motor {id}: {what} for {:.2} s ({sent} commands{}), then turned off{}",
        elapsed.as_secs_f64(),
        shortfall(achieved, timing.rate),
        last.map_or(String::new(), |s| format!("; last reply: {}", reading(&s)))
    )?;
    finished
}

/// Words for a rate below the one asked for: each command waits for the motor's reply, so a
/// `--rate` above what the bus and motor answer is sent as fast as they answer.
fn shortfall(achieved: f64, asked: f64) -> String {
    if achieved < 0.9 * asked {
        let asked = if asked < 1e9 {
            format!("{asked}")
        } else {
            format!("{asked:e}")
        };
        format!(
            ", {achieved:.0} per second: --rate {asked} is more than the motor answers, so \
             each was sent as soon as the previous reply came"
        )
    } else {
        String::new()
    }
}

/// When to send the next command: every `period` from the start, never after the end, and
/// without bursts to catch up when an exchange took longer than a period. The drive ends when
/// the wall-clock duration is over, however many commands that took.
#[derive(Copy, Clone, Debug)]
struct Schedule {
    next: Timestamp,
    end: Timestamp,
    period: Duration,
}

impl Schedule {
    fn new(start: Timestamp, duration: Duration, period: Duration) -> Self {
        Self {
            next: start,
            end: start + duration,
            period,
        }
    }

    /// After a command sent by `now`: the instant to wait for before the next one (at most
    /// the end), or `None` once the duration is over.
    fn next(&mut self, now: Timestamp) -> Option<Timestamp> {
        if self.is_over(now) {
            return None;
        }
        self.next = (self.next + self.period).max(now);
        Some(self.next.min(self.end))
    }

    /// Whether the duration is over at `now`.
    fn is_over(&self, now: Timestamp) -> bool {
        now >= self.end
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::timing::period;

    fn at(ms: u64) -> Timestamp {
        Timestamp::ZERO + Duration::from_millis(ms)
    }

    /// Runs a schedule where every exchange takes `exchange`: how many commands are sent,
    /// and when the drive ends.
    fn run(duration_ms: u64, rate: f64, exchange: Duration) -> (u32, Timestamp) {
        let mut schedule = Schedule::new(at(0), Duration::from_millis(duration_ms), period(rate));
        let mut now = at(0);
        let mut sent = 0;
        loop {
            now += exchange;
            sent += 1;
            let Some(wake) = schedule.next(now) else {
                return (sent, now);
            };
            now = now.max(wake);
            if schedule.is_over(now) {
                return (sent, now);
            }
        }
    }

    #[test]
    fn the_duration_is_wall_clock_time_whatever_the_rate() {
        // 20 kHz asked, 500 us per exchange: 1 s is about 2000 commands, not 20 000 (10 s).
        let (sent, ended) = run(1000, 20_000.0, Duration::from_micros(500));
        assert_eq!(ended, at(1000));
        assert_eq!(sent, 2000);
        // A rate the exchanges keep up with: one command per period.
        let (sent, ended) = run(1000, 50.0, Duration::from_micros(500));
        assert_eq!(ended, at(1000));
        assert_eq!(sent, 50);
        // A slow exchange ends the drive once it returns past the end, not later.
        let (sent, ended) = run(100, 50.0, Duration::from_millis(150));
        assert_eq!((sent, ended), (1, at(150)));
    }

    #[test]
    fn no_bursts_after_a_slow_exchange_and_no_overflow_at_extreme_rates() {
        let mut schedule = Schedule::new(at(0), Duration::from_secs(10), period(10.0));
        // The first exchange took 350 ms (3.5 periods): the next waits a period from now.
        assert_eq!(schedule.next(at(350)), Some(at(350)));
        assert_eq!(schedule.next(at(351)), Some(at(450)));
        // A period beyond the duration: one command, then the wait until the end.
        let mut schedule = Schedule::new(at(0), Duration::from_secs(1), period(1e-9));
        assert_eq!(schedule.next(at(1)), Some(at(1000)));
        assert_eq!(schedule.next(at(1000)), None);
        // A period of zero (1e300 Hz): as fast as the exchanges go.
        let mut schedule = Schedule::new(at(0), Duration::from_secs(1), period(1e300));
        assert_eq!(schedule.next(at(5)), Some(at(5)));
    }

    #[test]
    fn a_shortfall_is_said_only_when_real() {
        assert_eq!(shortfall(49.0, 50.0), "");
        assert!(shortfall(2000.0, 20_000.0).contains("--rate 20000 is more than"));
        assert!(shortfall(2000.0, 1e300).contains("--rate 1e300 is more than"));
    }
}
