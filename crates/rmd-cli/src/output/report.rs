//! How the CLI reports errors: one line on stderr, nothing on stdout, a non-zero exit code.

use std::process::ExitCode;

use rmd_protocol::{MotorId, Reply};

use crate::output::console::WriteError;
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
/// condensed into one line on stderr: clap's message without its usage block, with clap's
/// suggestions for a mistyped name (`did you mean 'status'?`) and its tips that can work as
/// printed.
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
            errln!("{}", usage_line(&err));
            ExitCode::from(USAGE)
        }
    }
}

/// A clap usage error as one line: its message, then what clap suggests.
fn usage_line(err: &clap::Error) -> String {
    let mut line = one_line(&err.render().to_string());
    let names = suggested_names(err);
    if !names.is_empty() {
        line.push_str(&format!("; did you mean {}?", either(&names)));
    }
    for tip in tips(err) {
        line.push_str(&format!("; {tip}"));
    }
    line
}

/// The names clap found close to a mistyped subcommand, flag or value (its `suggestions`
/// feature, by Jaro distance), quoted.
fn suggested_names(err: &clap::Error) -> Vec<String> {
    use clap::error::{ContextKind, ContextValue};
    [
        ContextKind::SuggestedSubcommand,
        ContextKind::SuggestedArg,
        ContextKind::SuggestedValue,
    ]
    .into_iter()
    .flat_map(|kind| match err.get(kind) {
        Some(ContextValue::String(name)) => vec![name.clone()],
        Some(ContextValue::Strings(names)) => names.clone(),
        _ => Vec::new(),
    })
    .map(|name| format!("'{name}'"))
    .collect()
}

/// clap's other tips (`'pid get' exists`, `remove the '--' before it`), without "to pass
/// '--amp' as a value, use '-- --amp'": no `rmd` command takes a value that starts with `--`
/// as a positional argument, so that tip cannot work.
fn tips(err: &clap::Error) -> Vec<String> {
    use clap::error::{ContextKind, ContextValue};
    match err.get(ContextKind::Suggested) {
        Some(ContextValue::StyledStrs(tips)) => tips
            .iter()
            .map(ToString::to_string)
            .filter(|tip| !tip.contains(" as a value, use "))
            .collect(),
        _ => Vec::new(),
    }
}

/// `'a'`, `'a' or 'b'`, `'a', 'b' or 'c'`.
fn either(names: &[String]) -> String {
    match names {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

/// clap's multi-line message as one line: the lines before `Usage:`, without tips (see
/// [`usage_line`]) and the "For more information" hint, joined.
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

impl From<WriteError> for CliError {
    fn from(error: WriteError) -> Self {
        match error {
            WriteError::Closed => CliError::OutputClosed,
            WriteError::Failed(_) => CliError::Failed(error.to_string()),
        }
    }
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

    /// The one line `rmd ARGS` prints for its usage error.
    fn usage_error_of(args: &[&str]) -> String {
        use clap::Parser;
        let err = crate::Cli::try_parse_from(std::iter::once("rmd").chain(args.iter().copied()))
            .expect_err("a usage error");
        usage_line(&err)
    }

    #[test]
    fn suggestions_for_mistyped_names_are_kept() {
        assert_eq!(
            usage_error_of(&["staus"]),
            "error: unrecognized subcommand 'staus'; did you mean 'status'?"
        );
        assert_eq!(
            usage_error_of(&["torque", "1", "--sim", "--amp", "1"]),
            "error: unexpected argument '--amp' found; did you mean '--amps'?"
        );
        assert_eq!(
            usage_error_of(&["bench", "rat"]),
            "error: unrecognized subcommand 'rat'; did you mean 'rate'?"
        );
        // A flag of a subcommand given before it: clap's tip says where it belongs.
        assert_eq!(
            usage_error_of(&["--sim", "status"]),
            "error: unexpected argument '--sim' found; 'status --sim' exists"
        );
    }

    #[test]
    fn a_tip_that_cannot_work_is_left_out() {
        // clap would add "to pass '--amp' as a value, use '-- --amp'": `rmd status 1 --sim --
        // --amp` only fails differently (`--amp` is no motor id).
        assert_eq!(
            usage_error_of(&["status", "1", "--sim", "--amp"]),
            "error: unexpected argument '--amp' found"
        );
    }

    #[test]
    fn either_joins_names() {
        let names = |n: &[&str]| n.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(either(&names(&["'a'"])), "'a'");
        assert_eq!(either(&names(&["'a'", "'b'"])), "'a' or 'b'");
        assert_eq!(either(&names(&["'a'", "'b'", "'c'"])), "'a', 'b' or 'c'");
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
