//! `rmd decode [--as request|reply|auto] [FILE]`: frames in, one JSON object per frame out.
//!
//! Reads FILE (or stdin, also with `-`) line by line in any of candump's text formats (see
//! [`rmd_bus::candump`]). Each valid frame prints one JSON object on stdout, in input order (see
//! [`crate::output::json`]); each bad line prints `line N: <what is wrong>` on stderr and the run goes
//! on; the exit status is 1 if any line failed. Blank lines are skipped.

pub(crate) mod pairing;

use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use rmd_bus::candump::{self, CandumpLine};
use rmd_protocol::{DecodedRequest, EncoderWidth, decode_reply, decode_reply_to, decode_request};
use serde_json::Value;

use crate::args::parse;
use crate::output::console::WriteError;
use crate::output::errln;
use crate::output::json::FrameJson;
use crate::output::report;
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
    snake_case spec name with its raw value and physical values under `<field>_<unit>` names. \
    Bad lines are reported on stderr as `line N: ...`; the exit status is 1 if any line failed."
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
}

/// Decodes one parsed line into its JSON object.
fn decode_line(
    line: &CandumpLine,
    mode: Mode,
    pairing: &mut Pairing,
    width: EncoderWidth,
) -> Result<Value, String> {
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
    let value = match role {
        Role::Request => match decode_request(frame).map_err(|e| e.to_string())? {
            DecodedRequest::Single { request, .. } => {
                request
                    .check_encoder_width(width)
                    .map_err(|e| encoder_hint(e, width))?;
                header("request", request.command().name()).request(&request)
            }
            DecodedRequest::Multi(m) => header("request", "multi-torque").multi(&m),
        },
        Role::Reply(pending) => {
            let (_, reply) = match pending {
                Some(command) => decode_reply_to(frame, command),
                None => decode_reply(frame),
            }
            .map_err(|e| e.to_string())?;
            reply
                .check_encoder_width(width)
                .map_err(|e| encoder_hint(e, width))?;
            header("reply", reply.command().name()).reply(&reply)
        }
    };
    Ok(value.into_value())
}

fn encoder_hint(err: rmd_protocol::ProtocolError, width: EncoderWidth) -> String {
    format!(
        "{err} for a {}-bit encoder (see --encoder-bits)",
        width.bits()
    )
}

/// Runs `rmd decode`.
pub(crate) fn run(args: DecodeArgs) -> ExitCode {
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
    for (index, line) in input.split(b'\n').enumerate() {
        let number = index + 1;
        let bytes = match line {
            Ok(bytes) => bytes,
            Err(e) => {
                let _ = out.flush();
                return report::failure(format!("line {number}: read error: {e}"));
            }
        };
        let Ok(text) = std::str::from_utf8(&bytes) else {
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
            .and_then(|parsed| decode_line(&parsed, args.mode, &mut pairing, args.encoder_bits));
        match result {
            Ok(value) => {
                if let Err(error) = writeln!(out, "{value}") {
                    return written_until(WriteError::from_io(error), failed);
                }
            }
            Err(message) => {
                failed = true;
                // Keep stdout and stderr in input order when both go to a terminal.
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
