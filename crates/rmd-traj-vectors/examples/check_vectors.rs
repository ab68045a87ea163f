//! Checks a vectors file (schema of `tests/data/SCHEMA.md`) against rmd-traj,
//! the same as `rmd traj check FILE`: `cargo run -p rmd-traj-vectors --example check_vectors --
//! FILE`. Exit status 1 if any case failed, 2 if the file cannot be read.

use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: check_vectors FILE");
        return ExitCode::from(2);
    };
    let json = match std::fs::read_to_string(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("cannot read {path}: {e}");
            return ExitCode::from(2);
        }
    };
    match rmd_traj_vectors::check_vectors(&json) {
        Ok(report) => {
            println!("{report}");
            if report.all_passed() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(2)
        }
    }
}
