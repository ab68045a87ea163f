//! `rmd status IDS`: everything a motor reports: status 1, 2 and 3, the encoder, the multi-turn
//! and single-turn angles.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{EncoderWidth, Reply, Request, Status1};

use crate::args::bus::BusArgs;
use crate::live::connect::{DEFAULT_RETRIES, DEFAULT_TIMEOUT};
use crate::live::motors::{Motor, Motors};
use crate::output::console::WriteError;
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{errln, out, outln};

/// Arguments of `rmd status`.
#[derive(Args, Debug)]
#[command(
    after_help = "With --robot FILE: the joints by name (all of them without JOINTS), each on its bus, with its joint angle, velocity and torque in joint units; JSON objects then also carry `name` (the joint), `bus` (the bus's name) and `joint` {angle_deg, velocity_dps, torque_nm}."
)]
pub(crate) struct StatusArgs {
    /// Motor id(s): 1, 1-4, 1,3; with --robot, joint names (none: every joint).
    #[arg(value_name = "IDS|JOINTS")]
    targets: Vec<String>,
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
    let mut motors = Motors::open(&args.bus, &args.targets, DEFAULT_TIMEOUT, DEFAULT_RETRIES)?;
    let mut failed = Vec::new();
    for motor in motors.motors().to_vec() {
        match read_all(&mut motors, &motor) {
            Ok(replies) => {
                if args.json {
                    outln!("{}", json_object(&motor, &replies))?;
                } else {
                    print_human(&motor, &replies)?;
                }
            }
            Err(error) => {
                if error.is_bus_failure() {
                    return Err(error.into());
                }
                if args.json {
                    let mut value = readings::error_object(motor.id, &error.to_string());
                    name_it(&mut value, &motor);
                    outln!("{value}")?;
                }
                errln!("error: {error}");
                failed.push(motor.label());
            }
        }
    }
    motors.finish()?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "could not read {} (see above)",
            failed.join(", ")
        )))
    }
}

/// One motor's JSON object: its readings, and with a robot its joint's name, bus and joint units.
fn json_object(motor: &Motor, replies: &[Reply]) -> serde_json::Value {
    let mut value = readings::object(motor.id, replies, motor.width);
    name_it(&mut value, motor);
    if let (Some(joint), serde_json::Value::Object(map)) = (&motor.joint, &mut value) {
        map.insert("joint".into(), readings::joint_object(&joint.map, replies));
    }
    value
}

/// Adds `name` and `bus` to a motor's object, with a robot.
fn name_it(value: &mut serde_json::Value, motor: &Motor) {
    if let (Some(joint), serde_json::Value::Object(map)) = (&motor.joint, value) {
        map.insert("name".into(), joint.name.clone().into());
        map.insert("bus".into(), joint.bus_name.clone().into());
    }
}

/// The replies to [`READS`].
fn read_all(
    motors: &mut Motors,
    motor: &Motor,
) -> Result<Vec<Reply>, crate::live::exchange::ExchangeError> {
    READS
        .iter()
        .map(|request| motors.request(motor, request))
        .collect()
}

fn print_human(motor: &Motor, replies: &[Reply]) -> Result<(), WriteError> {
    let mut table = TextTable::without_header(&[Align::Left, Align::Left])
        .indent(2)
        .gap(1);
    if let Some(joint) = &motor.joint {
        let units = readings::joint_object(&joint.map, replies);
        let show = |key: &str, unit: &str| {
            units
                .get(key)
                .and_then(serde_json::Value::as_f64)
                .map_or("-".to_owned(), |v| format!("{v:.2} {unit}"))
        };
        table.row(["joint angle".to_owned(), show("angle_deg", "°")]);
        table.row(["joint velocity".to_owned(), show("velocity_dps", "°/s")]);
        table.row(["joint torque".to_owned(), show("torque_nm", "N·m")]);
    }
    for (label, value) in rows(replies, motor.width) {
        table.row([label.to_owned(), value]);
    }
    out!("{}\n{}", motor.title(), table.render())
}

/// The readings in words: `(label, value)` per line, in the order of [`READS`].
fn rows(replies: &[Reply], width: EncoderWidth) -> Vec<(&'static str, String)> {
    let mut rows = Vec::new();
    for reply in replies {
        match reply {
            // The replies come in v1.61's shape (see `live::exchange`).
            Reply::ReadStatus1(Status1::V161(s)) => {
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
