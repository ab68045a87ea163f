//! `rmd bench`: the benchmarks users choose a real-time framework by.
//!
//! - `rmd bench loop`: the real-time loop with a PD controller on simulated motors, and its report;
//! - `rmd bench jitter`: the loop's timer alone, measured as cyclictest measures the kernel's;
//! - `rmd bench rate`: per bus count, the highest rate with at most 0.1% of ticks missed and
//!   the highest with none, against the wire limit of the frames sent, and what the loop adds
//!   per exchange;
//! - `rmd bench telemetry`: the loop's work with every telemetry sink on against all off.
//!
//! In real time each simulated bus runs on its own thread (`rmd_sim::threaded`), as real motors
//! do: the loop thread is measured alone.
//!
//! See docs/benchmarks.md for the figures and how they were produced.

mod flags;
mod histogram;
mod jitter;
mod loop_bench;
mod pd;
mod rate;
mod robot;
mod telemetry_cost;
mod wire_limit;

use std::process::ExitCode;

use clap::{Args, Subcommand};

use crate::output::console::{self, WriteError};
use crate::output::report;

/// Arguments of `rmd bench`.
#[derive(Args, Debug)]
pub(crate) struct BenchArgs {
    #[command(subcommand)]
    command: BenchCommand,
}

#[derive(Subcommand, Debug)]
enum BenchCommand {
    /// Run the real-time loop with a PD position controller on simulated motors and print its
    /// report (latency percentiles, deadline misses, missing replies).
    Loop(loop_bench::LoopBenchArgs),
    /// Measure the loop timer's wake latency alone (no bus, no controller), like cyclictest.
    Jitter(jitter::JitterArgs),
    /// Find, per bus count, the highest rate with at most 0.1% of ticks missed by the loop (not
    /// those a late simulator thread caused) and the highest with none, against the wire limit
    /// of the frames sent; and what the loop adds per exchange.
    Rate(rate::RateArgs),
    /// Compare the loop's work per tick with every telemetry sink on (MCAP, CSV, live server)
    /// and all off, in alternating rounds: the p99 ratio.
    Telemetry(telemetry_cost::TelemetryCostArgs),
}

/// Runs `rmd bench`.
pub(crate) fn run(args: BenchArgs) -> ExitCode {
    match args.command {
        BenchCommand::Loop(a) => loop_bench::run(a),
        BenchCommand::Jitter(a) => jitter::run(a),
        BenchCommand::Rate(a) => rate::run(a),
        BenchCommand::Telemetry(a) => telemetry_cost::run(a),
    }
}

/// Writes a result to stdout. A closed pipe (`rmd bench ... | head`) is no failure: the result
/// is simply not read. Any other write error is (`Err` holds the exit code).
fn emit(text: &str) -> Result<(), ExitCode> {
    match console::write_all(text.as_bytes()) {
        Ok(()) | Err(WriteError::Closed) => Ok(()),
        Err(error) => Err(report::failure(error)),
    }
}

/// The simulated firmware of a benchmark's `--sim-firmware` (LK-TECH: the MG series).
fn sim_family(family: rmd_protocol::ProtocolFamily) -> rmd_sim::FirmwareFamily {
    match family {
        rmd_protocol::ProtocolFamily::LkV23x => {
            rmd_sim::FirmwareFamily::LkV23x(rmd_protocol::LkSeries::Mg)
        }
        rmd_protocol::ProtocolFamily::MyActuatorV3 => rmd_sim::FirmwareFamily::MyActuatorV3,
        _ => rmd_sim::FirmwareFamily::V161,
    }
}
