//! `rmd scan`: which motor ids answer on the bus (a status-1 read each), with their status 1.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_protocol::{Reply, Request};
use serde_json::Value;

use crate::args::bus::BusArgs;
use crate::args::ids::{self, IdList};
use crate::live::connect::Connection;
use crate::output::progress::{self, Progress};
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{errln, out, outln};

/// Arguments of `rmd scan`.
#[derive(Args, Debug)]
pub(crate) struct ScanArgs {
    /// Ids to try.
    #[arg(long, value_name = "IDS", value_parser = ids::parse, default_value = "1-32")]
    ids: IdList,
    /// Print one JSON array of the motors that answered (their status 1).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// A scan waits this long per id by default (absent ids cost the whole timeout).
const SCAN_TIMEOUT: Duration = Duration::from_millis(20);

/// Runs `rmd scan`.
pub(crate) fn run(args: ScanArgs) -> ExitCode {
    report::exit(scan(&args))
}

fn scan(args: &ScanArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(&args.bus, SCAN_TIMEOUT, 0)?;
    let mut found = Vec::new();
    let mut problems = Vec::new();
    let progress = Progress::counter(
        args.ids.ids().len() as u64,
        "ids",
        progress::shown(args.json),
    );
    progress.set_prefix("scan ");
    for (done, &motor) in args.ids.ids().iter().enumerate() {
        progress.set_position(done as u64);
        progress.set_message(format!("found {}", found.len()));
        match bus.request(motor, &Request::ReadStatus1) {
            Ok(Reply::ReadStatus1(status)) => found.push((motor, status)),
            Ok(other) => problems.push(format!("motor {motor}: unexpected {}", other.command())),
            Err(error) if error.is_no_reply() => {}
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            // It answered, badly: it is there, and the user must hear about it.
            Err(error) => problems.push(error.to_string()),
        }
    }
    drop(progress);
    let setup = bus.setup().clone();
    bus.finish()?;
    for problem in &problems {
        errln!("warning: {problem}");
    }
    if args.json {
        let list: Vec<Value> = found
            .iter()
            .map(|(motor, status)| {
                readings::object(
                    *motor,
                    &[Reply::ReadStatus1(*status)],
                    args.bus.encoder_bits,
                )
            })
            .collect();
        outln!("{}", Value::Array(list))?;
    } else if !found.is_empty() {
        let mut table = TextTable::new(&[
            ("id", Align::Right),
            ("temperature", Align::Right),
            ("voltage", Align::Right),
            ("errors", Align::Left),
        ]);
        for (motor, status) in &found {
            table.row([
                motor.get().to_string(),
                format!("{} °C", status.temperature.celsius()),
                format!("{:.1} V", status.voltage.volts()),
                readings::errors_text(status.error_state),
            ]);
        }
        out!("{}", table.render())?;
    }
    let ids: Vec<String> = found.iter().map(|(m, _)| m.to_string()).collect();
    if found.is_empty() && problems.is_empty() {
        return Err(CliError::Failed(format!(
            "no motor answered on {} (ids {}): check that the motors are powered and wired, \
             and that the interface runs at their bit rate (1 Mbit/s by default); raise \
             --timeout-ms if the adapter is slow",
            setup.name(),
            args.ids
        )));
    }
    errln!(
        "{} motor{} answered on {}{}",
        found.len(),
        if found.len() == 1 { "" } else { "s" },
        setup.name(),
        if ids.is_empty() {
            String::new()
        } else {
            format!(": {}", ids.join(", "))
        }
    );
    Ok(())
}
