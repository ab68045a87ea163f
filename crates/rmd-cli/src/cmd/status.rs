//! `rmd status IDS`: everything a motor reports: status 1, 2 and 3, the encoder, the multi-turn
//! and single-turn angles.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{EncoderWidth, MotorId, Reply, Request};

use crate::args::bus::BusArgs;
use crate::args::ids::{self, IdList};
use crate::live::connect::{Connection, DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::output::console::WriteError;
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{errln, out, outln};

/// Arguments of `rmd status`.
#[derive(Args, Debug)]
pub(crate) struct StatusArgs {
    /// Motor id(s): 1, 1-4, 1,3.
    #[arg(value_name = "IDS", value_parser = ids::parse)]
    ids: IdList,
    /// Print one JSON object per motor (one per line).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// The reads behind a status, in order.
pub(crate) const READS: [Request; 6] = [
    Request::ReadStatus1,
    Request::ReadStatus2,
    Request::ReadStatus3,
    Request::ReadEncoder,
    Request::ReadMultiTurnAngle,
    Request::ReadSingleTurnAngle,
];

/// Runs `rmd status`.
pub(crate) fn run(args: StatusArgs) -> ExitCode {
    report::exit(status(&args))
}

fn status(args: &StatusArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(&args.bus, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let mut failed = Vec::new();
    for &motor in args.ids.ids() {
        match read_all(&mut bus, motor) {
            Ok(replies) => {
                if args.json {
                    outln!("{}", readings::object(motor, &replies, bus.width()))?;
                } else {
                    print_human(motor, &replies, bus.width())?;
                }
            }
            Err(error) => {
                if error.is_bus_failure() {
                    return Err(error.into());
                }
                if args.json {
                    outln!("{}", readings::error_object(motor, &error.to_string()))?;
                }
                errln!("error: {error}");
                failed.push(motor);
            }
        }
    }
    bus.finish()?;
    if failed.is_empty() {
        Ok(())
    } else {
        let ids: Vec<String> = failed.iter().map(ToString::to_string).collect();
        Err(CliError::Failed(format!(
            "could not read motor(s) {} (see above)",
            ids.join(", ")
        )))
    }
}

/// The replies to [`READS`].
fn read_all(
    bus: &mut Connection,
    motor: MotorId,
) -> Result<Vec<Reply>, crate::live::exchange::ExchangeError> {
    READS
        .iter()
        .map(|request| bus.request(motor, request))
        .collect()
}

fn print_human(motor: MotorId, replies: &[Reply], width: EncoderWidth) -> Result<(), WriteError> {
    let mut table = TextTable::without_header(&[Align::Left, Align::Left])
        .indent(2)
        .gap(1);
    for (label, value) in rows(replies, width) {
        table.row([label.to_owned(), value]);
    }
    out!("motor {motor}\n{}", table.render())
}

/// The readings in words: `(label, value)` per line, in the order of [`READS`].
fn rows(replies: &[Reply], width: EncoderWidth) -> Vec<(&'static str, String)> {
    let mut rows = Vec::new();
    for reply in replies {
        match reply {
            Reply::ReadStatus1(s) => {
                rows.push(("temperature", format!("{} °C", s.temperature.celsius())));
                rows.push(("voltage", format!("{:.1} V", s.voltage.volts())));
                rows.push(("errors", readings::errors_text(s.error_state)));
            }
            Reply::ReadStatus2(s) => {
                rows.push(("torque current", format!("{:.2} A", s.iq.amps())));
                rows.push(("speed", format!("{} dps", s.speed.dps())));
            }
            Reply::ReadStatus3(s) => rows.push((
                "phase currents",
                format!(
                    "A {:.2}  B {:.2}  C {:.2} A",
                    s.i_a.amps(),
                    s.i_b.amps(),
                    s.i_c.amps()
                ),
            )),
            Reply::ReadEncoder {
                encoder,
                encoder_raw,
                encoder_offset,
            } => rows.push((
                "encoder",
                format!(
                    "{} ({:.2}°)   raw {}   offset {}   ({}-bit)",
                    encoder.raw(),
                    encoder.degrees(width),
                    encoder_raw.raw(),
                    encoder_offset.raw(),
                    width.bits()
                ),
            )),
            Reply::ReadMultiTurnAngle { motor_angle } => {
                rows.push(("multi-turn angle", format!("{:.2}°", motor_angle.degrees())))
            }
            Reply::ReadSingleTurnAngle { circle_angle } => {
                rows.push(("single-turn", format!("{:.2}°", circle_angle.degrees())))
            }
            _ => {}
        }
    }
    rows
}
