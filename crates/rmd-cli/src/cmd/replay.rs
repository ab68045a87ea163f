//! `rmd replay FILE`: play a candump -L log back with its original timing (or faster): printed
//! to stdout, or sent onto an interface (`--iface`) or to simulated motors (`--sim`), with what
//! comes back printed as it arrives.
//!
//! Which frames: `host` (the requests, told apart from replies as `rmd decode` does), `motors`
//! (the replies) or `all`. Sending motion commands onto a real interface asks first, and so does
//! sending frames that write a motor's ROM ([`rom`]) anywhere; motors that received motion
//! commands are turned off at the end and on Ctrl-C. Printing a log never asks.

mod rom;

use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, ValueEnum};
use rmd_bus::candump::{Direction, LogLine};
use rmd_bus::record::wall_clock_offset;
use rmd_bus::replay::{LogRecord, Pace, ReplaySchedule, read_log};
use rmd_bus::{BusMessage, Clock, Timestamp};
use rmd_protocol::{DecodedRequest, Dialect, MotorId, Request};

use crate::args::bus::BusArgs;
use crate::args::timing;
use crate::cmd::decode::pairing::{Pairing, Role};
use crate::live::confirm;
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::exchange::{self, Setup};
use crate::live::interrupt;
use crate::live::recording;
use crate::live::safe_stop;
use crate::output::console::WriteError;
use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};
use crate::output::{errln, outln};

/// Which frames of the log to play.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum Frames {
    /// The host's frames (requests and 0x280), as `rmd decode` tells them apart.
    Host,
    /// The motors' frames (replies).
    Motors,
    /// Every frame.
    All,
}

/// Arguments of `rmd replay`.
#[derive(Args, Debug)]
pub(crate) struct ReplayArgs {
    /// The candump -L log.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Play this many times faster than recorded (0.5: half speed).
    #[arg(long, value_parser = timing::replay_speed, default_value = "1", allow_hyphen_values = true)]
    speed: f64,
    /// Play every frame at once, without the recorded pauses.
    #[arg(long, conflicts_with = "speed")]
    fast: bool,
    /// Which frames [default: host when sending to --iface/--sim, all when printing].
    #[arg(long, value_enum)]
    frames: Option<Frames>,
    /// Do not ask before sending motion commands onto a (non-virtual) interface, or frames that
    /// write motors' ROM (0x19, 0x32, ...) anywhere.
    #[arg(long)]
    yes: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// Runs `rmd replay`.
pub(crate) fn run(args: ReplayArgs) -> ExitCode {
    report::exit(replay(&args))
}

fn replay(args: &ReplayArgs) -> Result<(), CliError> {
    let file =
        File::open(&args.file).map_err(|e| format!("cannot read {}: {e}", args.file.display()))?;
    let parsed = read_log(BufReader::new(file))
        .map_err(|e| format!("cannot read {}: {e}", args.file.display()))?;
    for bad in &parsed.bad_lines {
        errln!("warning: {}: {bad} (skipped)", args.file.display());
    }
    let target = args.bus.has_target();
    let selection = args
        .frames
        .unwrap_or(if target { Frames::Host } else { Frames::All });
    let chosen = select(parsed.records, selection);
    if chosen.is_empty() {
        return Err(CliError::Failed(format!(
            "{} has no {} frames to replay (see --frames)",
            args.file.display(),
            format!("{selection:?}").to_lowercase()
        )));
    }
    let pace = if args.fast {
        Pace::AsFastAsPossible
    } else {
        Pace::scaled(args.speed).map_err(|e| CliError::Usage(e.to_string()))?
    };
    let result = if target {
        play_onto_bus(args, &chosen, pace)
    } else {
        print_in_time(&chosen, pace)
    };
    match result {
        Ok(()) if !parsed.bad_lines.is_empty() => Err(CliError::Failed(format!(
            "{} line(s) of {} could not be used (see above)",
            parsed.bad_lines.len(),
            args.file.display()
        ))),
        other => other,
    }
}

/// The records of `selection`, in file order.
fn select(records: Vec<LogRecord>, selection: Frames) -> Vec<LogRecord> {
    let mut pairing = Pairing::default();
    records
        .into_iter()
        .filter(|r| {
            let role = pairing.classify(r.frame.id(), r.frame.data(), r.direction);
            match selection {
                Frames::All => true,
                Frames::Host => role == Role::Request,
                Frames::Motors => matches!(role, Role::Reply(_)),
            }
        })
        .collect()
}

/// The motors the host frames among `records` set moving (0x280 moves motors 1..=4).
fn motors_moved(records: &[LogRecord]) -> Vec<MotorId> {
    let mut moved = Vec::new();
    for record in records {
        match Dialect::V161.decode_request(&record.frame) {
            Ok(DecodedRequest::Single { motor, request }) if moves(&request) => moved.push(motor),
            Ok(DecodedRequest::Multi(_)) => {
                moved.extend((1..=4).filter_map(|id| MotorId::new(id).ok()))
            }
            _ => {}
        }
    }
    moved.sort();
    moved.dedup();
    moved
}

fn moves(request: &Request) -> bool {
    matches!(
        request,
        Request::Torque { .. }
            | Request::Speed { .. }
            | Request::Position1 { .. }
            | Request::Position2 { .. }
            | Request::Position3 { .. }
            | Request::Position4 { .. }
            | Request::MotorRun
    )
}

/// Prints the records as candump -L lines, each when it is due.
fn print_in_time(records: &[LogRecord], pace: Pace) -> Result<(), CliError> {
    let clock = rmd_bus::MonotonicClock;
    interrupt::install()?;
    let schedule = ReplaySchedule::new(records[0].timestamp, clock.now(), pace);
    let progress = Progress::counter(records.len() as u64, "frames", progress::shown(false));
    progress.set_prefix("replay ");
    for (done, record) in records.iter().enumerate() {
        progress.set_position(done as u64);
        if !interrupt::sleep_until(&clock, schedule.due(record.timestamp)) {
            return Err(CliError::Interrupted("replay".into()));
        }
        let mut line = LogLine::new(record.timestamp, &record.interface, record.frame);
        if let Some(direction) = record.direction {
            line = line.with_direction(direction);
        }
        // A closed stdout (e.g. `| head`) ends the replay quietly.
        progress.suspend(|| outln!("{line}"))?;
    }
    Ok(())
}

/// Sends the records onto the bus, each when it is due, printing what is sent and received.
fn play_onto_bus(args: &ReplayArgs, records: &[LogRecord], pace: Pace) -> Result<(), CliError> {
    let moved = motors_moved(records);
    confirm_replay(args, records, &moved)?;
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    interrupt::install()?;
    let name = match bus.setup() {
        Setup::Interface(iface) => iface.clone(),
        Setup::Simulator(_) | Setup::Robot(_) => "sim".to_owned(),
    };
    let progress = Progress::counter(records.len() as u64, "frames sent", progress::shown(false));
    progress.set_prefix(format!("replay onto {name} "));
    let mut printer = Printer {
        offset: wall_clock_offset(),
        interface: name,
        received: 0,
        progress,
    };
    let start = bus.clock().now();
    let schedule = ReplaySchedule::new(records[0].timestamp, start, pace);
    let mut sent = 0u64;
    let outcome = (|| {
        let mut previous = start;
        for record in records {
            let due = schedule.due(record.timestamp).max(previous);
            previous = due;
            listen_until(&mut bus, due, &mut printer)?;
            let patience = bus.policy().timeout;
            let clock = *bus.clock();
            exchange::send(bus.bus(), &clock, &record.frame, patience).map_err(|error| {
                CliError::Failed(format!(
                    "sending line {} of the log onto {}: {error}",
                    record.line,
                    bus.setup().name()
                ))
            })?;
            printer.print(bus.clock().now(), Direction::Tx, record.frame)?;
            sent += 1;
            printer.progress.set_position(sent);
        }
        // What the last frames bring back.
        let tail = bus.clock().now() + bus.policy().timeout;
        listen_until(&mut bus, tail, &mut printer)
    })();
    let elapsed = bus.clock().now() - start;
    let Printer {
        received, progress, ..
    } = printer;
    drop(progress);
    let result = if moved.is_empty() {
        outcome
    } else {
        safe_stop::finish(&mut bus, &moved, outcome)
    };
    let target = bus.setup().name();
    let finished = bus.finish();
    errln!(
        "replayed {sent} frame(s) onto {target} in {:.3} s; {} frame(s) received",
        elapsed.as_secs_f64(),
        received
    );
    recording::after(result, finished)
}

/// Asks before a replay that writes motors' ROM (whatever the target, as `rmd zero` does) or
/// moves motors on a real interface; one question for both. Without a terminal and without
/// `--yes`, refuses, naming the ROM-writing frames.
fn confirm_replay(
    args: &ReplayArgs,
    records: &[LogRecord],
    moved: &[MotorId],
) -> Result<(), CliError> {
    let target = args.bus.iface.clone().unwrap_or_else(|| {
        if args.bus.robot.is_some() {
            "the robot's buses".to_owned()
        } else {
            "the simulated motors".to_owned()
        }
    });
    let rom = rom::rom_writes(records);
    let real_motion = !moved.is_empty()
        && args
            .bus
            .iface
            .as_ref()
            .is_some_and(|iface| !iface.starts_with("vcan"));
    let mut whats = Vec::new();
    let mut warnings = Vec::new();
    if !rom.is_empty() {
        whats.push(format!(
            "replaying {} frame(s) that write motor ROM onto {target} ({})",
            rom.len(),
            rom::describe(&rom)
        ));
        warnings.push(format!(
            "{} holds {} frame(s) that write the motors' ROM ({}). Every ROM write wears the \
             motor's flash, and a zero written to ROM takes effect only after a power cycle.",
            args.file.display(),
            rom.len(),
            rom::describe(&rom)
        ));
    }
    if real_motion {
        let ids: Vec<String> = moved.iter().map(ToString::to_string).collect();
        whats.push(format!("replaying motion commands onto {target}"));
        warnings.push(format!(
            "{} holds motion commands for motor(s) {}: replaying it onto {target} moves \
             them as recorded (they are turned off at the end and on Ctrl-C).",
            args.file.display(),
            ids.join(", ")
        ));
    }
    if whats.is_empty() {
        return Ok(());
    }
    confirm::confirm(&whats.join(", and "), &warnings.join("\n"), args.yes)?;
    Ok(())
}

/// Prints frames as candump -L lines with direction markers, on the wall clock.
struct Printer {
    offset: Duration,
    interface: String,
    received: u64,
    progress: Progress,
}

impl Printer {
    fn print(
        &mut self,
        at: Timestamp,
        direction: Direction,
        frame: rmd_bus::CanFrame,
    ) -> Result<(), WriteError> {
        let timestamp = Duration::from_nanos(at.as_nanos()) + self.offset;
        let line = LogLine::new(timestamp, &self.interface, frame).with_direction(direction);
        self.progress.suspend(|| outln!("{line}"))
    }
}

/// Receives (and prints) until `deadline`, or until Ctrl-C.
fn listen_until(
    bus: &mut Connection,
    deadline: Timestamp,
    printer: &mut Printer,
) -> Result<(), CliError> {
    const SLICE: Duration = Duration::from_millis(20);
    loop {
        if interrupt::requested() {
            return Err(CliError::Interrupted("replay".into()));
        }
        let now = bus.clock().now();
        if now >= deadline {
            return Ok(());
        }
        let until = deadline.min(now + SLICE);
        match bus.bus().recv_until(until) {
            Ok(Some(received)) => {
                if let BusMessage::Frame(frame) = received.message {
                    printer.received += 1;
                    printer.print(received.at, Direction::Rx, frame)?;
                }
            }
            Ok(None) => {}
            Err(error) => {
                return Err(CliError::Failed(format!(
                    "receiving on {}: {error}",
                    bus.setup().name()
                )));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::replay::read_log;

    const LOG: &str = "\
(1.000000) can0 141#9C00000000000000
(1.000300) can0 141#9C19000000000000
(1.001000) can0 280#6400000000000000
(1.001200) can0 141#A119000000000000
(1.001300) can0 142#A119000000000000
(1.002000) can0 143#A400680100000000
";

    #[test]
    fn host_and_motor_frames_are_told_apart_as_decode_does() {
        let records = read_log(LOG.as_bytes()).unwrap().records;
        let lines = |frames| -> Vec<usize> {
            select(records.clone(), frames)
                .iter()
                .map(|r| r.line)
                .collect()
        };
        assert_eq!(lines(Frames::Host), [1, 3, 6]);
        assert_eq!(lines(Frames::Motors), [2, 4, 5]);
        assert_eq!(lines(Frames::All), [1, 2, 3, 4, 5, 6]);
        let host = select(records, Frames::Host);
        let moved: Vec<u8> = motors_moved(&host).iter().map(|m| m.get()).collect();
        // 0x280 moves 1..=4; the 0xA4 position command moves 3; the 0x9C read moves nothing.
        assert_eq!(moved, [1, 2, 3, 4]);
    }
}
