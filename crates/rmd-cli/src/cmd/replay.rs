//! `rmd replay FILE`: play a candump -L log back with its original timing (or faster): printed
//! to stdout, or sent onto an interface (`--iface`) or to simulated motors (`--sim`), with what
//! comes back printed as it arrives.
//!
//! Which frames: `host` (the requests, told apart from replies as `rmd decode` does), `motors`
//! (the replies) or `all`. Sending motion commands onto a real interface asks first, and so does
//! sending frames that write a motor's ROM ([`rom`], MyActuator V3's 0x280 broadcasts
//! included) anywhere; motors that received motion commands, and MyActuator V3 motors that
//! answered one (a 0x280 frame moves every V3 motor), are turned off at the end and on Ctrl-C,
//! each with its own motor-off frame. Printing a log never asks. The frames are sent as
//! recorded: nothing is scaled.
//!
//! The log is streamed, never held: one line at a time, at most
//! [`MAX_LINE_BYTES`](rmd_bus::replay::MAX_LINE_BYTES) of it (a longer line is reported and
//! skipped unread). Sending onto a bus reads it twice: once to know what it moves and writes
//! (to ask, and to turn those motors off), once to play it. A pause between two frames longer
//! than `--max-gap` (default 10 s) is played as `--max-gap`, and said on stderr.

mod rom;

use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, ValueEnum};
use rmd_bus::candump::{FrameDirection, LogLine};
use rmd_bus::record::wall_clock_offset;
use rmd_bus::replay::{BadLine, Due, LogReader, LogRecord, Pace, ReplaySchedule};
use rmd_bus::{BusMessage, Clock, Timestamp};
use rmd_protocol::{DecodedRequest, Dialect, MotorId, Request};
use rmd_rig::args::duration::{self, Bounds};

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

/// The longest `--max-gap`.
const MAX_GAP: Duration = Duration::from_secs(86_400);

/// How many shortened pauses are said one by one (then only counted).
const GAPS_SAID: u64 = 5;

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
    /// Play a pause between two frames longer than this (after --speed) as this long, and say
    /// so on stderr (0 to a day: 500ms, 10s, 1h; a bare number is seconds).
    #[arg(long, value_name = "DURATION", default_value = "10s", value_parser = max_gap, allow_hyphen_values = true)]
    max_gap: Duration,
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

fn max_gap(text: &str) -> Result<Duration, String> {
    duration::parse(text, Bounds::up_to(MAX_GAP))
}

/// Runs `rmd replay`.
pub(crate) fn run(args: ReplayArgs) -> ExitCode {
    report::exit(replay(&args))
}

fn replay(args: &ReplayArgs) -> Result<(), CliError> {
    let target = args.bus.has_target();
    let selection = args
        .frames
        .unwrap_or(if target { Frames::Host } else { Frames::All });
    let pace = if args.fast {
        Pace::AsFastAsPossible
    } else {
        Pace::scaled(args.speed).map_err(|e| CliError::Usage(e.to_string()))?
    };
    let played = if target {
        play_onto_bus(args, selection, pace)
    } else {
        print_in_time(args, selection, pace)
    };
    match played {
        Ok(bad_lines) if bad_lines > 0 => Err(CliError::Failed(format!(
            "{bad_lines} line(s) of {} could not be used (see above)",
            args.file.display()
        ))),
        other => other.map(drop),
    }
}

/// One line of the log, for a replay of `selection`.
enum Entry {
    /// A record of the selection.
    Record(LogRecord),
    /// A record of another selection.
    Other,
    /// A line that is not a usable record.
    Bad(BadLine),
}

/// The log, streamed: each line as an [`Entry`].
struct Log<'a> {
    args: &'a ReplayArgs,
    lines: LogReader<BufReader<File>>,
    pairing: Pairing,
    selection: Frames,
}

impl<'a> Log<'a> {
    fn open(args: &'a ReplayArgs, selection: Frames) -> Result<Self, CliError> {
        let file = File::open(&args.file)
            .map_err(|e| format!("cannot read {}: {e}", args.file.display()))?;
        Ok(Self {
            args,
            lines: LogReader::new(BufReader::new(file)),
            pairing: Pairing::default(),
            selection,
        })
    }

    /// The next line; `None` at the end.
    fn next(&mut self) -> Result<Option<Entry>, CliError> {
        let Some(line) = self.lines.next() else {
            return Ok(None);
        };
        let record =
            match line.map_err(|e| format!("cannot read {}: {e}", self.args.file.display()))? {
                Ok(record) => record,
                Err(bad) => return Ok(Some(Entry::Bad(bad))),
            };
        let role = self
            .pairing
            .classify(record.frame.id(), record.frame.data(), record.direction);
        let chosen = match self.selection {
            Frames::All => true,
            Frames::Host => role == Role::Request,
            Frames::Motors => matches!(role, Role::Reply(_)),
        };
        Ok(Some(if chosen {
            Entry::Record(record)
        } else {
            Entry::Other
        }))
    }

    /// Says `bad` on stderr.
    fn warn(&self, bad: &BadLine) {
        errln!("warning: {}: {bad} (skipped)", self.args.file.display());
    }

    /// The error of a log with no frame of the selection.
    fn empty(&self) -> CliError {
        CliError::Failed(format!(
            "{} has no {} frames to replay (see --frames)",
            self.args.file.display(),
            format!("{:?}", self.selection).to_lowercase()
        ))
    }
}

/// The pauses a replay shortened: says the first few on stderr, counts the rest.
#[derive(Default)]
struct Gaps {
    shortened: u64,
}

impl Gaps {
    fn note(&mut self, due: Due, line: usize, cap: Duration) {
        let Some(gap) = due.shortened else {
            return;
        };
        self.shortened += 1;
        if self.shortened <= GAPS_SAID {
            errln!(
                "replay: line {line} comes {} after the frame before it: played {} later (--max-gap)",
                words(gap),
                words(cap)
            );
        }
    }

    fn finish(&self, cap: Duration) {
        if self.shortened > GAPS_SAID {
            errln!(
                "replay: {} pauses longer than {} were played as {} (--max-gap)",
                self.shortened,
                words(cap),
                words(cap)
            );
        }
    }
}

/// A pause in words: `10s`, `8years 3months`, as humantime writes it, to the millisecond.
fn words(d: Duration) -> String {
    let millis = Duration::from_millis(u64::try_from(d.as_millis()).unwrap_or(u64::MAX));
    humantime::format_duration(millis).to_string()
}

/// The motors `record`, a host frame, sets moving (0x280 moves motors 1..=4), added to `moved`.
fn note_moved(record: &LogRecord, moved: &mut Vec<MotorId>) {
    match Dialect::V161.decode_request(&record.frame) {
        Ok(DecodedRequest::Single { motor, request }) if moves(&request) => moved.push(motor),
        Ok(DecodedRequest::Multi(_)) => {
            moved.extend((1..=4).filter_map(|id| MotorId::new(id).ok()))
        }
        _ => {}
    }
    moved.sort();
    moved.dedup();
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

/// Prints the records as candump -L lines, each when it is due; returns the bad lines.
fn print_in_time(args: &ReplayArgs, selection: Frames, pace: Pace) -> Result<u64, CliError> {
    let clock = rmd_bus::MonotonicClock;
    interrupt::install()?;
    let mut log = Log::open(args, selection)?;
    let progress = Progress::spinner(progress::shown(false));
    progress.set_prefix("replay ");
    let mut schedule: Option<ReplaySchedule> = None;
    let (mut played, mut bad_lines) = (0u64, 0u64);
    let mut gaps = Gaps::default();
    while let Some(entry) = log.next()? {
        let record = match entry {
            Entry::Record(record) => record,
            Entry::Other => continue,
            Entry::Bad(bad) => {
                bad_lines += 1;
                progress.suspend(|| log.warn(&bad));
                continue;
            }
        };
        let due = schedule
            .get_or_insert_with(|| {
                ReplaySchedule::new(record.timestamp, clock.now(), pace).max_gap(args.max_gap)
            })
            .next(record.timestamp);
        progress.suspend(|| gaps.note(due, record.line, args.max_gap));
        if !interrupt::sleep_until(&clock, due.at) {
            return Err(CliError::Interrupted("replay".into()));
        }
        let mut line = LogLine::new(record.timestamp, &record.interface, record.frame);
        if let Some(direction) = record.direction {
            line = line.with_direction(direction);
        }
        // A closed stdout (e.g. `| head`) ends the replay quietly.
        progress.suspend(|| outln!("{line}"))?;
        played += 1;
        progress.set_message(format!("{played} frames"));
    }
    drop(progress);
    gaps.finish(args.max_gap);
    if played == 0 {
        return Err(log.empty());
    }
    Ok(bad_lines)
}

/// What a first reading of the log found, before anything is sent.
#[derive(Default)]
struct Scan {
    records: u64,
    bad_lines: u64,
    moved: Vec<MotorId>,
    rom: rom::RomWrites,
}

/// Reads the log once: the records of the selection, the motors they move, their ROM writes;
/// the bad lines said on stderr.
fn scan(args: &ReplayArgs, selection: Frames) -> Result<Scan, CliError> {
    let mut log = Log::open(args, selection)?;
    let mut scan = Scan::default();
    while let Some(entry) = log.next()? {
        match entry {
            Entry::Record(record) => {
                scan.records += 1;
                note_moved(&record, &mut scan.moved);
                scan.rom.note(&record);
            }
            Entry::Other => {}
            Entry::Bad(bad) => {
                scan.bad_lines += 1;
                log.warn(&bad);
            }
        }
    }
    if scan.records == 0 {
        return Err(log.empty());
    }
    Ok(scan)
}

/// Sends the records onto the bus, each when it is due, printing what is sent and received;
/// returns the bad lines.
fn play_onto_bus(args: &ReplayArgs, selection: Frames, pace: Pace) -> Result<u64, CliError> {
    let found = scan(args, selection)?;
    confirm_replay(args, &found)?;
    let mut log = Log::open(args, selection)?;
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    interrupt::install()?;
    let name = match bus.setup() {
        Setup::Interface(iface) => iface.clone(),
        Setup::Simulator(_) | Setup::Robot(_) => "sim".to_owned(),
    };
    let progress = Progress::counter(found.records, "frames sent", progress::shown(false));
    progress.set_prefix(format!("replay onto {name} "));
    let mut printer = Printer {
        offset: wall_clock_offset(),
        interface: name,
        received: 0,
        progress,
    };
    let start = bus.clock().now();
    let mut schedule: Option<ReplaySchedule> = None;
    let mut gaps = Gaps::default();
    let mut sent = 0u64;
    // The motors to turn off: what the first reading found, and whatever this one sends
    // (should the file have changed in between).
    let mut moved = found.moved.clone();
    let outcome = (|| {
        while let Some(entry) = log.next()? {
            let Entry::Record(record) = entry else {
                continue;
            };
            let due = schedule
                .get_or_insert_with(|| {
                    ReplaySchedule::new(record.timestamp, start, pace).max_gap(args.max_gap)
                })
                .next(record.timestamp);
            printer
                .progress
                .suspend(|| gaps.note(due, record.line, args.max_gap));
            listen_until(&mut bus, due.at, &mut printer, &mut moved)?;
            note_moved(&record, &mut moved);
            let patience = bus.policy().timeout;
            let clock = *bus.clock();
            exchange::send(bus.bus(), &clock, &record.frame, patience).map_err(|error| {
                CliError::Failed(format!(
                    "sending line {} of the log onto {}: {error}",
                    record.line,
                    bus.setup().name()
                ))
            })?;
            printer.print(bus.clock().now(), FrameDirection::Tx, record.frame)?;
            sent += 1;
            printer.progress.set_position(sent);
        }
        // What the last frames bring back.
        let tail = bus.clock().now() + bus.policy().timeout;
        listen_until(&mut bus, tail, &mut printer, &mut moved)
    })();
    let elapsed = bus.clock().now() - start;
    let Printer {
        received, progress, ..
    } = printer;
    drop(progress);
    gaps.finish(args.max_gap);
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
    recording::after(result, finished).map(|()| found.bad_lines)
}

/// Asks before a replay that writes motors' ROM (whatever the target, as `rmd zero` does) or
/// moves motors on a real interface; one question for both. Without a terminal and without
/// `--yes`, refuses, naming the ROM-writing frames.
fn confirm_replay(args: &ReplayArgs, found: &Scan) -> Result<(), CliError> {
    let moved = &found.moved;
    let target = args.bus.iface.clone().unwrap_or_else(|| {
        if args.bus.robot.is_some() {
            "the robot's buses".to_owned()
        } else {
            "the simulated motors".to_owned()
        }
    });
    let rom = &found.rom;
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
            rom.count(),
            rom.describe()
        ));
        warnings.push(format!(
            "{} holds {} frame(s) that write the motors' ROM ({}). Every ROM write wears the \
             motor's flash, and a zero written to ROM takes effect only after a power cycle.",
            args.file.display(),
            rom.count(),
            rom.describe()
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
        direction: FrameDirection,
        frame: rmd_bus::CanFrame,
    ) -> Result<(), WriteError> {
        let timestamp = Duration::from_nanos(at.as_nanos()) + self.offset;
        let line = LogLine::new(timestamp, &self.interface, frame).with_direction(direction);
        self.progress.suspend(|| outln!("{line}"))
    }
}

/// Notes the MyActuator V3 motor that sent `frame` if it is its answer to a motion command (on
/// `0x240 + id`): moving, whichever frame (single or 0x280) moved it.
fn note_v3_moving(frame: &rmd_bus::CanFrame, moved: &mut Vec<MotorId>) {
    let v3 = Dialect::MyActuatorV3(rmd_protocol::V3Firmware::default());
    if let Ok((motor, reply)) = v3.decode_reply(frame)
        && matches!(
            reply,
            rmd_protocol::Reply::Torque(_)
                | rmd_protocol::Reply::Speed(_)
                | rmd_protocol::Reply::Position2(_)
        )
        && !moved.contains(&motor)
    {
        moved.push(motor);
        moved.sort();
    }
}

/// Receives (and prints) until `deadline`, or until Ctrl-C; notes the MyActuator V3 motors
/// that answered a motion command in `moved`.
fn listen_until(
    bus: &mut Connection,
    deadline: Timestamp,
    printer: &mut Printer,
    moved: &mut Vec<MotorId>,
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
                    note_v3_moving(&frame, moved);
                    printer.received += 1;
                    printer.print(received.at, FrameDirection::Rx, frame)?;
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

    const LOG: &str = "\
(1.000000) can0 141#9C00000000000000
(1.000300) can0 141#9C19000000000000
(1.001000) can0 280#6400000000000000
(1.001200) can0 141#A119000000000000
(1.001300) can0 142#A119000000000000
(1.002000) can0 143#A400680100000000
";

    fn args(file: PathBuf) -> ReplayArgs {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            replay: ReplayArgs,
        }
        Cli::parse_from(["replay", file.to_str().unwrap()]).replay
    }

    #[test]
    fn host_and_motor_frames_are_told_apart_as_decode_does() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.log");
        std::fs::write(&path, LOG).unwrap();
        let args = args(path);
        let lines = |frames| -> Vec<usize> {
            let mut log = Log::open(&args, frames).unwrap();
            let mut lines = Vec::new();
            while let Some(entry) = log.next().unwrap() {
                if let Entry::Record(record) = entry {
                    lines.push(record.line);
                }
            }
            lines
        };
        assert_eq!(lines(Frames::Host), [1, 3, 6]);
        assert_eq!(lines(Frames::Motors), [2, 4, 5]);
        assert_eq!(lines(Frames::All), [1, 2, 3, 4, 5, 6]);
        let found = scan(&args, Frames::Host).unwrap();
        let moved: Vec<u8> = found.moved.iter().map(|m| m.get()).collect();
        // 0x280 moves 1..=4; the 0xA4 position command moves 3; the 0x9C read moves nothing.
        assert_eq!(moved, [1, 2, 3, 4]);
        assert_eq!((found.records, found.bad_lines), (3, 0));
    }
}
