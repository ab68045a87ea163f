//! `rmd traj check FILE`: runs every case of a trajectory test-vector file (the schema of the
//! reference vectors, ruckig's answers) against rmd-rt's trajectory generator and prints
//! per-category counts, the cases where we are verified better than the reference, every
//! failure, and as the last line `N passed, M failed`. Exit status: 0 if every case passed, 1 if
//! any failed, 2 if the file cannot be read or is not in the schema.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Subcommand};

use crate::output::outln;
use crate::output::progress::{self, Progress};
use crate::output::report;

/// `rmd traj ...`.
#[derive(Args, Debug)]
pub(crate) struct TrajArgs {
    #[command(subcommand)]
    command: TrajCommand,
}

#[derive(Subcommand, Debug)]
enum TrajCommand {
    /// Check the trajectory generator against a vectors file (JSON, schema version 1).
    Check {
        /// The vectors file.
        file: PathBuf,
    },
}

pub(crate) fn run(args: TrajArgs) -> ExitCode {
    match args.command {
        TrajCommand::Check { file } => check(&file),
    }
}

fn check(file: &std::path::Path) -> ExitCode {
    let json = match std::fs::read_to_string(file) {
        Ok(json) => json,
        Err(e) => return report::usage_error(format!("cannot read {}: {e}", file.display())),
    };
    let progress = Progress::spinner(progress::shown(false));
    progress.set_message(format!("checking {}", file.display()));
    let checked = rmd_traj_vectors::check_vectors(&json);
    drop(progress);
    match checked {
        Ok(outcome) => {
            if let Err(error) = outln!("{outcome}") {
                return report::exit(Err(error.into()));
            }
            if outcome.all_passed() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(report::FAILURE)
            }
        }
        Err(e) => report::usage_error(format!("{}: {e}", file.display())),
    }
}
