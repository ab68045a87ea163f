//! `rmd`: the command-line tool of rmd-rt.
//!
//! `main` only parses the command line and dispatches; each subcommand group lives in its own
//! module (`encode`, `decode`, ...) with its clap `Args` and a `run` function returning the exit
//! code. To add a subcommand: a module, a variant in [`Command`], a line in `main`.

mod bench;
mod decode;
mod encode;
mod json;
mod pairing;
mod parse;
mod report;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Tools for GYEMS / MyActuator RMD servo motors on CAN.
#[derive(Parser, Debug)]
#[command(name = "rmd", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Encode one command as a CAN frame, printed as candump's compact `ID#DATA`.
    Encode(encode::EncodeArgs),
    /// Decode frames (candump compact, -L log or default text) into JSON lines.
    Decode(decode::DecodeArgs),
    /// Benchmarks: the loop on simulated motors, timer jitter, the bus-limited rate.
    Bench(bench::BenchArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(err) => return report::clap_error(err),
    };
    match cli.command {
        Command::Encode(args) => encode::run(args),
        Command::Decode(args) => decode::run(args),
        Command::Bench(args) => bench::run(args),
    }
}
