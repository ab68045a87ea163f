//! `rmd monitor`: a live table of every motor's temperature, voltage, current, speed and angle
//! (status 1, status 2 and the multi-turn angle, read at `--rate`), until Ctrl-C or `--count`.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_bus::Clock;
use rmd_protocol::{MotorId, Reply, Request};
use serde_json::{Value, json};

use crate::args::bus::BusArgs;
use crate::args::ids::{self, IdList};
use crate::args::parse;
use crate::live::connect::{Connection, DEFAULT_TIMEOUT};
use crate::live::interrupt;
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::{out, outln};

/// Arguments of `rmd monitor`.
#[derive(Args, Debug)]
pub(crate) struct MonitorArgs {
    /// Motors to watch [default: the ones that answer a scan of 1..=32].
    #[arg(long, value_name = "IDS", value_parser = ids::parse)]
    ids: Option<IdList>,
    /// Readings per second.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = parse::positive, default_value = "10")]
    rate: f64,
    /// Stop after this many readings [default: until Ctrl-C].
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Print one JSON object per reading (`{"time_s":..,"motors":[..]}`), one per line.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// Reply timeout while looking for motors (absent ids cost the whole timeout).
const SCAN_TIMEOUT: Duration = Duration::from_millis(20);

/// What one reading of one motor asks.
const READS: [Request; 3] = [
    Request::ReadStatus1,
    Request::ReadStatus2,
    Request::ReadMultiTurnAngle,
];

/// Runs `rmd monitor`.
pub(crate) fn run(args: MonitorArgs) -> ExitCode {
    report::exit(monitor(&args))
}

fn monitor(args: &MonitorArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, 0)?;
    interrupt::install()?;
    let motors = match &args.ids {
        Some(ids) => ids.ids().to_vec(),
        None => {
            let timeout = bus.policy().timeout;
            if args.bus.timeout_ms.is_none() {
                bus.set_timeout(SCAN_TIMEOUT);
            }
            let found = scan(&mut bus)?;
            bus.set_timeout(timeout);
            found
        }
    };
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let redraw = !args.json && std::io::stdout().is_terminal();
    let start = bus.clock().now();
    let mut drawn_lines = 0;
    let mut readings_done = 0u64;
    while args.count.is_none_or(|n| readings_done < n) && !interrupt::requested() {
        let at = start + period * u32::try_from(readings_done).unwrap_or(u32::MAX);
        if !interrupt::sleep_until(bus.clock(), at) {
            break;
        }
        let time_s = (bus.clock().now() - start).as_secs_f64();
        let mut rows = Vec::with_capacity(motors.len());
        for &motor in &motors {
            rows.push((motor, read(&mut bus, motor)?));
        }
        let shown = if args.json {
            let list: Vec<Value> = rows
                .iter()
                .map(|(motor, row)| match row {
                    Ok(replies) => readings::object(*motor, replies, bus.width()),
                    Err(error) => readings::error_object(*motor, error),
                })
                .collect();
            outln!("{}", json!({"time_s": time_s, "motors": list}))
        } else {
            let mut text = String::new();
            if redraw && drawn_lines > 0 {
                // Back to the top of the previous table.
                text += &format!("\x1b[{drawn_lines}A");
            }
            let table = table(time_s, &rows, if redraw { "\x1b[K" } else { "" });
            drawn_lines = table.lines().count();
            text += &table;
            if !redraw {
                text.push('\n');
            }
            out!("{text}")
        };
        if let Err(error) = shown {
            // Nobody reads any more (or the output failed): stop, keeping the recording.
            bus.finish()?;
            return Err(error.into());
        }
        readings_done += 1;
    }
    bus.finish()?;
    Ok(())
}

/// The motors that answer a status-1 read, ids 1..=32.
fn scan(bus: &mut Connection) -> Result<Vec<MotorId>, CliError> {
    let mut found = Vec::new();
    for &motor in IdList::all().ids() {
        match bus.request(motor, &Request::ReadStatus1) {
            Ok(_) => found.push(motor),
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(_) => {}
        }
    }
    if found.is_empty() {
        return Err(CliError::Failed(format!(
            "no motor answered on {}: check power, wiring and bit rate, or name the motors \
             with --ids",
            bus.setup().name()
        )));
    }
    Ok(found)
}

/// One reading of one motor, or why it failed (the monitor goes on).
fn read(bus: &mut Connection, motor: MotorId) -> Result<Result<Vec<Reply>, String>, CliError> {
    let mut replies = Vec::with_capacity(READS.len());
    for request in &READS {
        match bus.request(motor, request) {
            Ok(reply) => replies.push(reply),
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(error) => return Ok(Err(error.to_string())),
        }
    }
    Ok(Ok(replies))
}

/// The table of one reading; every line ends with `clear` (on a terminal: "clear to end of
/// line", so a redraw over a longer previous line leaves nothing behind).
fn table(time_s: f64, rows: &[(MotorId, Result<Vec<Reply>, String>)], clear: &str) -> String {
    let mut text = format!(
        "t {time_s:8.2} s{clear}\n{:>3} {:>7} {:>7} {:>8} {:>9} {:>11}  errors{clear}\n",
        "id", "temp °C", "volts", "iq A", "speed dps", "angle °"
    );
    for (motor, row) in rows {
        let line = match row {
            Err(_) => format!("{:>3}  no reply", motor.get()),
            Ok(replies) => {
                let mut cells = (None, None, None);
                for reply in replies {
                    match reply {
                        Reply::ReadStatus1(s) => cells.0 = Some(*s),
                        Reply::ReadStatus2(s) => cells.1 = Some(*s),
                        Reply::ReadMultiTurnAngle { motor_angle } => {
                            cells.2 = Some(motor_angle.degrees())
                        }
                        _ => {}
                    }
                }
                match cells {
                    (Some(s1), Some(s2), Some(angle)) => format!(
                        "{:>3} {:>7} {:>7.1} {:>8.2} {:>9} {:>11.2}  {}",
                        motor.get(),
                        s2.temperature.celsius(),
                        s1.voltage.volts(),
                        s2.iq.amps(),
                        s2.speed.dps(),
                        angle,
                        readings::errors_text(s1.error_state)
                    ),
                    _ => format!("{:>3}  incomplete reply", motor.get()),
                }
            }
        };
        text.push_str(&line);
        text.push_str(clear);
        text.push('\n');
    }
    text
}
