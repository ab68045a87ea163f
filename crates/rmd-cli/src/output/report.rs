//! How the CLI reports errors: one line on stderr, nothing on stdout, a non-zero exit code.

use std::process::ExitCode;

use rmd_protocol::{MotorId, Reply};

use crate::output::errln;

/// Exit code for a usage error (bad or missing argument), as clap uses.
pub(crate) const USAGE: u8 = 2;
/// Exit code when the command ran but something failed (a bad input line, an I/O error).
pub(crate) const FAILURE: u8 = 1;
/// Exit code after Ctrl-C or SIGTERM (128 + SIGINT, as shells report it).
pub(crate) const INTERRUPTED: u8 = 130;

/// How a command failed.
#[derive(Debug)]
pub(crate) enum CliError {
    /// The command line asks for something impossible (exit 2).
    Usage(String),
    /// The command ran and failed (exit 1).
    Failed(String),
    /// Ctrl-C or SIGTERM ended the command; the message says what was done about it (exit 130).
    Interrupted(String),
    /// The reader of stdout went away (`| head`): the command stopped writing and ends quietly
    /// (exit 0).
    OutputClosed,
}

impl CliError {
    /// `motor` answered a request with a reply to another command.
    pub(crate) fn unexpected_reply(motor: MotorId, reply: &Reply) -> Self {
        CliError::Failed(format!(
            "motor {motor} answered with an unexpected {} reply; try again",
            reply.command()
        ))
    }
}

impl From<String> for CliError {
    fn from(message: String) -> Self {
        CliError::Failed(message)
    }
}

/// The exit code of a command's result, after printing its error on stderr.
pub(crate) fn exit(result: Result<(), CliError>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Usage(message)) => usage_error(message),
        Err(CliError::Failed(message)) => failure(message),
        Err(CliError::Interrupted(message)) => {
            errln!("interrupted: {message}");
            ExitCode::from(INTERRUPTED)
        }
        Err(CliError::OutputClosed) => ExitCode::SUCCESS,
    }
}

/// Prints `error: <message>` on stderr and returns the usage-error exit code.
pub(crate) fn usage_error(message: impl std::fmt::Display) -> ExitCode {
    errln!("error: {message}");
    ExitCode::from(USAGE)
}

/// Prints `error: <message>` on stderr and returns the failure exit code.
pub(crate) fn failure(message: impl std::fmt::Display) -> ExitCode {
    errln!("error: {message}");
    ExitCode::from(FAILURE)
}

/// Reports a clap error: help and version go to stdout as usual (exit 0); a usage error is
/// condensed into one line on stderr (clap's message without its usage block and tips).
pub(crate) fn clap_error(err: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match err.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = err.print();
            ExitCode::SUCCESS
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = err.print();
            ExitCode::from(USAGE)
        }
        _ => {
            errln!("{}", one_line(&err.render().to_string()));
            ExitCode::from(USAGE)
        }
    }
}

/// clap's multi-line message as one line: the lines before `Usage:`, without tips and the
/// "For more information" hint, joined.
fn one_line(message: &str) -> String {
    message
        .lines()
        .take_while(|l| !l.starts_with("Usage:"))
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("tip:") && !l.starts_with("For more information")
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unexpected_reply_names_the_motor_and_the_command() {
        let motor = MotorId::new(3).unwrap();
        let CliError::Failed(message) = CliError::unexpected_reply(motor, &Reply::MotorOff) else {
            panic!("an unexpected reply is a failure, not a usage error");
        };
        assert!(
            message.starts_with("motor 3 answered with an unexpected"),
            "{message}"
        );
        assert!(
            message.contains(&Reply::MotorOff.command().to_string()),
            "{message}"
        );
    }

    #[test]
    fn condenses_clap_messages() {
        let msg = "error: the following required arguments were not provided:\n  --id <ID>\n\n\
                   Usage: rmd encode torque --id <ID>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            one_line(msg),
            "error: the following required arguments were not provided: --id <ID>"
        );
        let msg = "error: unexpected argument '--foo' found\n\n  tip: to pass '--foo' as a value, \
                   use '-- --foo'\n\nUsage: rmd encode\n";
        assert_eq!(one_line(msg), "error: unexpected argument '--foo' found");
        let msg = "error: invalid value '33' for '--id <ID>': invalid motor id 33\n\n\
                   For more information, try '--help'.\n";
        assert_eq!(
            one_line(msg),
            "error: invalid value '33' for '--id <ID>': invalid motor id 33"
        );
    }
}
