//! `rmd`: the command-line tool of rmd-rt.
//!
//! `main` only parses the command line and dispatches. The layers, each a folder:
//! - [`cmd`]: one module per subcommand (its clap `Args` and `run`);
//! - [`live`]: talking to motors on a live bus (connect, exchange, Ctrl-C, safe stop, confirm);
//! - [`args`]: argument types and value parsers shared by the commands;
//! - [`output`]: errors and exit codes, JSON, readings.

mod args;
mod cmd;
mod live;
mod output;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches};

/// Tools for GYEMS / MyActuator RMD servo motors on CAN.
///
/// Commands that talk to motors take `--iface IFACE` (a SocketCAN interface such as can0) or
/// `--sim` (simulated motors in this process). Commands that move a motor turn it off when
/// they end and on Ctrl-C.
#[derive(clap::Parser, Debug)]
#[command(name = "rmd", version, propagate_version = true)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: cmd::CliCommand,
}

/// `rmd`'s command line as clap builds it: [`Cli`] with an example in every command's help.
pub(crate) fn command() -> clap::Command {
    cmd::examples::attach(Cli::command())
}

fn main() -> ExitCode {
    match command()
        .try_get_matches()
        .and_then(|matches| Cli::from_arg_matches(&matches).map_err(|e| e.format(&mut command())))
    {
        Ok(cli) => cli.command.run(),
        Err(err) => output::report::clap_error(err),
    }
}
