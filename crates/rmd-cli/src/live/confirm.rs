//! Asking before an irreversible or flash-wearing write (ROM writes, zero offset).
//!
//! `--yes` confirms in advance. Otherwise the question is asked on the terminal; without a
//! terminal on stdin (a script, a pipe) the command refuses, since nobody can answer.

use std::io::{self, BufRead, IsTerminal, Write};

use crate::output::report::CliError;

/// Why the write was not confirmed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum NotConfirmed {
    /// No terminal to ask on, and no `--yes`.
    #[error(
        "{what} needs confirmation and stdin is not a terminal: pass --yes to confirm from a \
         script"
    )]
    NoTerminal {
        /// What would have been done.
        what: String,
    },
    /// The user said no (or anything but yes).
    #[error("{what} cancelled: nothing was written")]
    Declined {
        /// What would have been done.
        what: String,
    },
}

/// Asks `question` (after printing `warning`) unless `yes`; `what` names the action in errors.
pub(crate) fn confirm(what: &str, warning: &str, yes: bool) -> Result<(), NotConfirmed> {
    if yes {
        return Ok(());
    }
    let stdin = io::stdin();
    if !stdin.is_terminal() {
        return Err(NotConfirmed::NoTerminal {
            what: what.to_owned(),
        });
    }
    let mut stderr = io::stderr();
    let _ = write!(stderr, "{warning}\nProceed? [y/N] ");
    let _ = stderr.flush();
    let mut answer = String::new();
    if stdin.lock().read_line(&mut answer).is_err() {
        return Err(NotConfirmed::Declined {
            what: what.to_owned(),
        });
    }
    if is_yes(&answer) {
        Ok(())
    } else {
        Err(NotConfirmed::Declined {
            what: what.to_owned(),
        })
    }
}

impl From<NotConfirmed> for CliError {
    fn from(error: NotConfirmed) -> Self {
        CliError::Failed(error.to_string())
    }
}

fn is_yes(answer: &str) -> bool {
    matches!(answer.trim().to_ascii_lowercase().as_str(), "y" | "yes")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_yes_confirms() {
        assert!(is_yes("y\n") && is_yes(" YES ") && is_yes("yes"));
        assert!(!is_yes("") && !is_yes("n") && !is_yes("yep") && !is_yes("no\n"));
        assert!(confirm("writing", "careful", true).is_ok());
    }
}
