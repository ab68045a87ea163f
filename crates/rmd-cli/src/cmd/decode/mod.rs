//! `rmd decode [--as request|reply|auto] [--protocol P] [FILE]`: frames in, one JSON object per
//! frame out.
//!
//! With `--protocol myactuator-v3` the replies on `0x240 + id` (and the motion-mode frames on
//! `0x400 + id` / `0x500 + id`) are decoded in V3's layouts and units.
//!
//! Reads FILE (or stdin, also with `-`) line by line in any of candump's text formats (see
//! [`rmd_bus::candump`]), in bounded memory: a line longer than [`lines::MAX_LINE`] bytes is that
//! line's error. Each valid frame prints one JSON object on stdout, in input order (see
//! [`crate::output::json`]); each bad line prints `line N: <what is wrong>` on stderr and the run
//! goes on; the exit status is 1 if any line failed. Blank lines are skipped.
//!
//! With `--mcap OUT` the objects go into an MCAP file instead, one channel per motor and
//! direction ([`mcap`]); stdout stays empty and a summary goes to stderr.
//!
//! A reply with a field out of range (an `iq` beyond ±2048, an encoder value beyond the encoder
//! width) still prints every other field: the bad one is left out, named under `errors` in the
//! JSON and on stderr as `line N: ...`, and the exit status is 1 ([`rmd_frames::partial`]). Errors of the
//! whole frame (identifier, DLC, unknown command byte, a reply to another command) print no
//! object.

pub(crate) mod lines;
pub(crate) mod mcap;
pub(crate) mod pairing;

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, StdoutLock, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use rmd_bus::candump::{self, CandumpLine};
use rmd_frames::decode::Decoded;
use rmd_protocol::{Dialect, EncoderWidth};
use serde_json::Value;

use crate::args::bus::ProtocolArgs;
use crate::args::parse;
use crate::output::console::WriteError;
use crate::output::errln;
use crate::output::report;
use lines::{Line, Lines};
use mcap::McapFrames;
use pairing::{HELD_LINES, LookAhead, Role, Ticket, V3Pairing};

/// How to read each frame.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum Mode {
    /// Every frame is a request (host to motor).
    Request,
    /// Every frame is a reply (motor to host).
    Reply,
    /// Pair replies with the preceding request on the same ID; use candump's TX/RX marker when
    /// the log has one.
    Auto,
}

/// Arguments of `rmd decode`.
#[derive(Args, Debug)]
#[command(
    after_help = "Output: one JSON object per frame: `id` (motor id, absent for 0x280), \
    `can_id` (\"0x141\"), `direction` (request|reply), `command`, then each field under its \
    snake_case spec name with its raw value and physical values under `<field>_<unit>` names, \
    and `errors` ({field, raw, error} objects) for fields out of range, which are left out. Bad \
    lines and bad fields are reported on stderr as `line N: ...`; the exit status is 1 if any \
    line failed. Lines longer than 4096 bytes are errors. Pairing (--as auto): frames repeating \
    the pending request of a read command are more requests when its reply follows, else \
    all-zero replies; TX/RX markers decide when the log has TX frames (docs/cli.md). With \
    --protocol myactuator-v3 the identifier decides: requests on 0x140 + id, 0x280 and 0x400 + \
    id, replies on 0x240 + id (paired with the last request to their motor) and 0x500 + id."
)]
pub(crate) struct DecodeArgs {
    /// Read frames as requests, replies, or decide per frame.
    #[arg(long = "as", value_enum, default_value_t = Mode::Auto)]
    mode: Mode,
    /// Width of the motors' encoders in bits (12..=18): encoder values are checked against it
    /// and converted to degrees with it.
    #[arg(long, value_parser = parse::encoder_width, default_value = "14")]
    encoder_bits: EncoderWidth,
    /// Input file; stdin if absent or `-`.
    file: Option<PathBuf>,
    /// Write the decoded frames to this MCAP file (one channel per motor and direction, each
    /// message the JSON object printed otherwise) instead of printing them; open it in Foxglove
    /// or PlotJuggler.
    #[arg(long, value_name = "OUT")]
    mcap: Option<PathBuf>,
    #[command(flatten)]
    protocol: ProtocolArgs,
}

/// Decodes one parsed line, a frame of `role`, into its JSON object (`rmd-frames`, shared with
/// the Python package's `decode`).
fn decode_line(
    line: &CandumpLine,
    role: Role,
    width: EncoderWidth,
    dialect: Dialect,
) -> Result<Decoded, String> {
    match role {
        Role::Request => rmd_frames::decode::request(line, width, dialect),
        Role::Reply(pending) => rmd_frames::decode::reply(line, pending, width, dialect),
    }
}

/// A line waiting for its turn on the output (input order), its role perhaps still undecided
/// (a run of repeated queries, see [`pairing::LookAhead`]).
enum Held {
    /// A frame.
    Frame {
        number: usize,
        line: CandumpLine,
        role: Slot,
    },
    /// A line that is not a frame: its error message.
    Error { number: usize, message: String },
}

/// A frame's role: known, or to be taken from the look-ahead.
enum Slot {
    Known(Role),
    Pending(Ticket),
}

/// Where decoded frames go.
pub(crate) enum DecodeOutput<'a> {
    /// One JSON object per line on stdout.
    Json(BufWriter<StdoutLock<'a>>),
    /// An MCAP file.
    Mcap(McapFrames),
}

impl DecodeOutput<'_> {
    fn write(&mut self, line: &CandumpLine, value: &Value) -> Result<(), WriteError> {
        match self {
            DecodeOutput::Json(out) => writeln!(out, "{value}").map_err(WriteError::from_io),
            DecodeOutput::Mcap(mcap) => mcap
                .write(line, value)
                .map_err(|e| WriteError::Failed(io::Error::other(e))),
        }
    }

    fn flush(&mut self) -> Result<(), WriteError> {
        match self {
            DecodeOutput::Json(out) => out.flush().map_err(WriteError::from_io),
            DecodeOutput::Mcap(_) => Ok(()),
        }
    }
}

/// Prints decoded lines in input order as their roles are decided.
pub(crate) struct Printer<'a> {
    out: DecodeOutput<'a>,
    held: VecDeque<Held>,
    pairing: LookAhead,
    v3_pairing: V3Pairing,
    width: EncoderWidth,
    dialect: Dialect,
    failed: bool,
}

impl Printer<'_> {
    /// Queues a line that is not a frame.
    fn error(&mut self, number: usize, message: String) {
        self.held.push_back(Held::Error { number, message });
    }

    /// Queues a frame, classified as `mode` says.
    fn frame(&mut self, number: usize, line: CandumpLine, mode: Mode) {
        let role = match mode {
            Mode::Request => Slot::Known(Role::Request),
            Mode::Reply => Slot::Known(Role::Reply(None)),
            Mode::Auto if matches!(self.dialect, Dialect::MyActuatorV3(_)) => {
                Slot::Known(self.v3_pairing.classify(line.frame.id(), line.frame.data()))
            }
            Mode::Auto => Slot::Pending(self.pairing.push(
                line.frame.id(),
                line.frame.data(),
                line.direction,
            )),
        };
        self.held.push_back(Held::Frame { number, line, role });
    }

    /// Prints every line whose turn has come; a run held for [`HELD_LINES`] lines is decided
    /// without its follower. `end`: decide everything.
    fn print_ready(&mut self, end: bool) -> Result<(), WriteError> {
        if end {
            self.pairing.finish();
        } else if self.held.len() > HELD_LINES
            && let Some(Held::Frame {
                role: Slot::Pending(ticket),
                ..
            }) = self.held.front()
        {
            self.pairing.decide(*ticket);
        }
        loop {
            // The front line's role, if it is a frame whose role is decided.
            let role = match self.held.front() {
                None => return Ok(()),
                Some(Held::Frame {
                    role: Slot::Pending(ticket),
                    ..
                }) => match self.pairing.take(*ticket) {
                    Some(role) => Some(role),
                    None => return Ok(()),
                },
                Some(Held::Frame {
                    role: Slot::Known(role),
                    ..
                }) => Some(*role),
                Some(Held::Error { .. }) => None,
            };
            match (self.held.pop_front(), role) {
                (Some(Held::Error { number, message }), _) => self.fail(number, &message),
                (Some(Held::Frame { number, line, .. }), Some(role)) => {
                    match decode_line(&line, role, self.width, self.dialect) {
                        Ok(decoded) => {
                            self.out.write(&line, &decoded.value)?;
                            for message in &decoded.field_errors {
                                self.fail(number, message);
                            }
                        }
                        Err(message) => self.fail(number, &message),
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    /// Reports `line N: message` on stderr (stdout flushed first, to keep input order on a
    /// terminal) and marks the run failed.
    fn fail(&mut self, number: usize, message: &str) {
        self.failed = true;
        let _ = self.out.flush();
        errln!("line {number}: {message}");
    }
}

/// How reading and decoding a whole input ended.
pub(crate) enum Ended<'a> {
    /// Every line was read; `failed`: some line could not be decoded (reported on stderr).
    Done { out: DecodeOutput<'a>, failed: bool },
    /// Writing stopped on an error; `failed` as above.
    Write { error: WriteError, failed: bool },
    /// Reading failed at a line (what was decoded before is written).
    Read {
        out: DecodeOutput<'a>,
        message: String,
    },
}

/// Reads `input` line by line, decodes each frame as `mode` says, and writes the objects to
/// `out` in input order; bad lines are reported on stderr as `line N: ...`.
pub(crate) fn decode_all<'a>(
    input: Box<dyn BufRead + '_>,
    mode: Mode,
    width: EncoderWidth,
    dialect: Dialect,
    out: DecodeOutput<'a>,
) -> Ended<'a> {
    let mut printer = Printer {
        out,
        held: VecDeque::new(),
        pairing: LookAhead::default(),
        v3_pairing: V3Pairing::default(),
        width,
        dialect,
        failed: false,
    };
    let mut input = Lines::new(input, lines::MAX_LINE);
    let mut number = 0usize;
    loop {
        number += 1;
        match input.next_line() {
            Ok(None) => break,
            Ok(Some(Line::TooLong)) => printer.error(
                number,
                format!(
                    "longer than {} bytes, not a candump line (skipped to the next newline)",
                    lines::MAX_LINE
                ),
            ),
            Ok(Some(Line::Text(bytes))) => match std::str::from_utf8(bytes) {
                Err(_) => printer.error(number, "not valid UTF-8 text".to_owned()),
                Ok(text) if text.trim().is_empty() => continue,
                Ok(text) => match candump::parse_line(text) {
                    Ok(line) => printer.frame(number, line, mode),
                    Err(e) => printer.error(number, e.to_string()),
                },
            },
            Err(e) => {
                let failed = printer.failed;
                if let Err(error) = printer.print_ready(true).and_then(|()| printer.out.flush()) {
                    return Ended::Write { error, failed };
                }
                return Ended::Read {
                    out: printer.out,
                    message: format!("line {number}: read error: {e}"),
                };
            }
        }
        if let Err(error) = printer.print_ready(false) {
            return Ended::Write {
                error,
                failed: printer.failed,
            };
        }
    }
    if let Err(error) = printer.print_ready(true).and_then(|()| printer.out.flush()) {
        return Ended::Write {
            error,
            failed: printer.failed,
        };
    }
    Ended::Done {
        failed: printer.failed,
        out: printer.out,
    }
}

/// Runs `rmd decode`.
pub(crate) fn run(args: DecodeArgs) -> ExitCode {
    let dialect = match args.protocol.dialect() {
        Ok(dialect) => dialect,
        Err(message) => return report::usage_error(message),
    };
    let input: Box<dyn BufRead> = match &args.file {
        None => Box::new(BufReader::new(io::stdin().lock())),
        Some(path) if path.as_os_str() == "-" => Box::new(BufReader::new(io::stdin().lock())),
        Some(path) => match File::open(path) {
            Ok(f) => Box::new(BufReader::new(f)),
            Err(e) => return report::failure(format!("cannot read {}: {e}", path.display())),
        },
    };
    let out = match &args.mcap {
        None => DecodeOutput::Json(BufWriter::new(io::stdout().lock())),
        Some(path) => {
            let source = args
                .file
                .as_ref()
                .map_or_else(|| "-".to_owned(), |p| p.display().to_string());
            match McapFrames::create(
                path,
                &[
                    ("source", source),
                    ("protocol", dialect.name().to_owned()),
                    ("encoder_bits", args.encoder_bits.bits().to_string()),
                ],
            ) {
                Ok(mcap) => DecodeOutput::Mcap(mcap),
                Err(message) => return report::failure(message),
            }
        }
    };
    match decode_all(input, args.mode, args.encoder_bits, dialect, out) {
        Ended::Write { error, failed } => written_until(error, failed),
        Ended::Read { out, message } => {
            if let Err(e) = finish(out) {
                errln!("{e}");
            }
            report::failure(message)
        }
        Ended::Done { out, failed } => match finish(out) {
            Err(e) => report::failure(e),
            Ok(()) if failed => ExitCode::from(report::FAILURE),
            Ok(()) => ExitCode::SUCCESS,
        },
    }
}

/// Closes the output: an MCAP file gets its summary, and stderr says what it holds.
fn finish(out: DecodeOutput<'_>) -> Result<(), String> {
    match out {
        DecodeOutput::Json(_) => Ok(()),
        DecodeOutput::Mcap(mcap) => {
            let summary = mcap.finish()?;
            errln!("{summary}");
            Ok(())
        }
    }
}

/// The exit code when writing stopped on `error`: a closed stdout (e.g. piped into `head`) ends
/// quietly, with the status of the lines decoded so far; any other write error is a failure.
fn written_until(error: WriteError, failed: bool) -> ExitCode {
    match error {
        WriteError::Closed if failed => ExitCode::from(report::FAILURE),
        WriteError::Closed => ExitCode::SUCCESS,
        WriteError::Failed(_) => report::failure(error),
    }
}
