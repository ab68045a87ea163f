//! `rmd decode [--as request|reply|auto] [--protocol P] [FILE]`: frames in, one JSON object per
//! frame out.
//!
//! Reads FILE (or stdin, also with `-`) line by line in any of candump's text formats (see
//! [`rmd_bus::candump`]), in bounded memory: a line longer than [`lines::MAX_LINE`] bytes is that
//! line's error. Each valid frame prints one JSON object on stdout, in input order (see
//! [`crate::output::json`]); each bad line prints `line N: <what is wrong>` on stderr and the run
//! goes on; the exit status is 1 if any line failed. Blank lines are skipped.
//!
//! A reply with a field out of range (an `iq` beyond ±2048, an encoder value beyond the encoder
//! width) still prints every other field: the bad one is left out, named under `errors` in the
//! JSON and on stderr as `line N: ...`, and the exit status is 1 ([`fields`]). Errors of the
//! whole frame (identifier, DLC, unknown command byte, a reply to another command) print no
//! object.

pub(crate) mod fields;
pub(crate) mod lines;
pub(crate) mod pairing;

use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use rmd_bus::candump::{self, CandumpLine};
use rmd_protocol::{
    Command, DecodedRequest, Dialect, DialectRequest, EncoderWidth, ProtocolError,
    decode_reply_to_with, decode_reply_with, decode_request_with,
};
use serde_json::Value;

use crate::args::bus::ProtocolArgs;
use crate::args::parse;
use crate::output::console::WriteError;
use crate::output::errln;
use crate::output::json::FrameJson;
use crate::output::report;
use lines::{Line, Lines};
use pairing::{Pairing, Role};

/// How to read each frame.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum Mode {
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
    line failed. Lines longer than 4096 bytes are errors. Pairing (--as auto): a frame repeating \
    the pending request of a read command is another request; TX/RX markers decide when the \
    log has TX frames."
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
    #[command(flatten)]
    protocol: ProtocolArgs,
}

/// A decoded line: its object, and the fields that could not be read (each also under
/// `errors` in the object).
struct Decoded {
    value: Value,
    field_errors: Vec<String>,
}

/// Decodes one parsed line into its JSON object.
fn decode_line(
    line: &CandumpLine,
    mode: Mode,
    pairing: &mut Pairing,
    width: EncoderWidth,
    dialect: Dialect,
) -> Result<Decoded, String> {
    let frame = &line.frame;
    let role = match mode {
        Mode::Request => Role::Request,
        Mode::Reply => Role::Reply(None),
        Mode::Auto => pairing.classify(frame.id(), frame.data(), line.direction),
    };
    let header = |direction: &str, command: &str| {
        FrameJson::new(
            line.timestamp,
            line.interface.as_deref(),
            frame.id(),
            direction,
            command,
            width,
        )
    };
    let json = match role {
        Role::Request => {
            let request = decode_request_with(dialect, frame).map_err(|e| e.to_string())?;
            let command = match &request {
                DialectRequest::Torque { .. } => Command::Torque.name(),
                DialectRequest::MultiTorque(_)
                | DialectRequest::Common(DecodedRequest::Multi(_)) => "multi-torque",
                DialectRequest::Common(DecodedRequest::Single { request, .. }) => {
                    request
                        .check_encoder_width(width)
                        .map_err(|e| encoder_hint(e, width))?;
                    request.command().name()
                }
            };
            header("request", command).dialect_request(&request)
        }
        Role::Reply(pending) => {
            let decoded = match pending {
                Some(command) => decode_reply_to_with(dialect, frame, command),
                None => decode_reply_with(dialect, frame),
            };
            match decoded {
                Ok((_, reply)) => header("reply", reply.command().name())
                    .checking_encoder_width()
                    .dialect_reply(&reply),
                // Identifier, DLC, command byte and pairing passed: one field is out of range.
                Err(error @ ProtocolError::ValueOutOfRange { .. }) => {
                    let command = frame
                        .data()
                        .first()
                        .and_then(|&code| Command::from_code(code))
                        .ok_or_else(|| error.to_string())?;
                    let json = header("reply", command.name()).checking_encoder_width();
                    fields::partial_reply(json, dialect, command, frame)
                        .ok_or_else(|| error.to_string())?
                }
                Err(error) => return Err(error.to_string()),
            }
        }
    };
    let field_errors = json.errors().iter().map(|e| e.message.clone()).collect();
    Ok(Decoded {
        value: json.into_value(),
        field_errors,
    })
}

fn encoder_hint(err: rmd_protocol::ProtocolError, width: EncoderWidth) -> String {
    format!(
        "{err} for a {}-bit encoder (see --encoder-bits)",
        width.bits()
    )
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
    let mut out = BufWriter::new(io::stdout().lock());
    let mut pairing = Pairing::default();
    let mut failed = false;
    let mut input = Lines::new(input, lines::MAX_LINE);
    let mut number = 0usize;
    loop {
        number += 1;
        let bytes = match input.next_line() {
            Ok(None) => break,
            Ok(Some(Line::Text(bytes))) => bytes,
            Ok(Some(Line::TooLong)) => {
                failed = true;
                let _ = out.flush();
                errln!(
                    "line {number}: longer than {} bytes, not a candump line (skipped to the \
                     next newline)",
                    lines::MAX_LINE
                );
                continue;
            }
            Err(e) => {
                let _ = out.flush();
                return report::failure(format!("line {number}: read error: {e}"));
            }
        };
        let Ok(text) = std::str::from_utf8(bytes) else {
            failed = true;
            let _ = out.flush();
            errln!("line {number}: not valid UTF-8 text");
            continue;
        };
        if text.trim().is_empty() {
            continue;
        }
        let result = candump::parse_line(text)
            .map_err(|e| e.to_string())
            .and_then(|parsed| {
                decode_line(&parsed, args.mode, &mut pairing, args.encoder_bits, dialect)
            });
        match result {
            Ok(decoded) => {
                if let Err(error) = writeln!(out, "{}", decoded.value) {
                    return written_until(WriteError::from_io(error), failed);
                }
                if !decoded.field_errors.is_empty() {
                    failed = true;
                    // Keep stdout and stderr in input order when both go to a terminal.
                    let _ = out.flush();
                    for message in &decoded.field_errors {
                        errln!("line {number}: {message}");
                    }
                }
            }
            Err(message) => {
                failed = true;
                let _ = out.flush();
                errln!("line {number}: {message}");
            }
        }
    }
    if let Err(error) = out.flush() {
        return written_until(WriteError::from_io(error), failed);
    }
    if failed {
        ExitCode::from(report::FAILURE)
    } else {
        ExitCode::SUCCESS
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
