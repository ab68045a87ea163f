//! `rmd status IDS`: everything a motor reports: status 1, 2 and 3, the encoder, the multi-turn
//! and single-turn angles, those its protocol has (learned first: see
//! [`Connection`](crate::live::connect::Connection)), each in its family's layout and scale. A
//! MyActuator V3 motor reports the output shaft's speed and angles, its driver's temperature
//! and brake, and its own error flags; it has no status 3 and no encoder read.

use std::process::ExitCode;

use clap::Args;
use rmd_protocol::{Command, Dialect, EncoderWidth, Reply, Request, Status1, StatusPosition};

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

/// The reads behind a status, in order (those the motor's protocol has).
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
            Ok((dialect, replies)) => {
                if args.json {
                    outln!("{}", json_object(&motor, dialect, &replies))?;
                } else {
                    print_human(&motor, dialect, &replies)?;
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

/// One motor's JSON object: its protocol (`firmware`, and a V3 motor's `firmware_date`), its
/// readings, and with a robot its joint's name, bus and joint units.
fn json_object(motor: &Motor, dialect: Dialect, replies: &[Reply]) -> serde_json::Value {
    let mut value = readings::object(motor.id, replies, motor.width);
    if let serde_json::Value::Object(map) = &mut value {
        map.insert("firmware".into(), dialect.name().into());
        if let Some(date) = dialect.v3_firmware().and_then(|f| f.date) {
            map.insert("firmware_date".into(), date.raw().into());
        }
    }
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

/// The motor's protocol, and its replies to the [`READS`] it has.
fn read_all(
    motors: &mut Motors,
    motor: &Motor,
) -> Result<(Dialect, Vec<Reply>), crate::live::exchange::ExchangeError> {
    let dialect = motors.dialect(motor, Command::ReadStatus1)?;
    let replies = READS
        .iter()
        .filter(|request| dialect.supports(request.command()))
        .map(|request| motors.request(motor, request))
        .collect::<Result<_, _>>()?;
    Ok((dialect, replies))
}

fn print_human(motor: &Motor, dialect: Dialect, replies: &[Reply]) -> Result<(), WriteError> {
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
    table.row(["protocol".to_owned(), dialect.to_string()]);
    for (label, value) in rows(replies, motor.width, dialect.reports_output_shaft()) {
        table.row([label.to_owned(), value]);
    }
    out!("{}\n{}", motor.title(), table.render())
}

/// The readings in words: `(label, value)` per line, in the order of [`READS`], each in its
/// family's meaning (`output`: the speed and multi-turn angle are the output shaft's, as
/// MyActuator V3 reports them).
fn rows(replies: &[Reply], width: EncoderWidth, output: bool) -> Vec<(&'static str, String)> {
    let mut rows = Vec::new();
    for reply in replies {
        match reply {
            Reply::ReadStatus1(s) => {
                rows.push(("temperature", format!("{} °C", s.temperature().celsius())));
                if let Status1::V3(v3) = s {
                    rows.push((
                        "driver temperature",
                        format!("{} °C", v3.mos_temperature.celsius()),
                    ));
                    let brake = if v3.brake.is_released() {
                        "released"
                    } else {
                        "locked"
                    };
                    rows.push(("brake", brake.to_owned()));
                }
                rows.push(("voltage", format!("{:.1} V", s.volts())));
                if let Status1::Lk(lk) = s {
                    rows.push(("bus current", format!("{:.2} A", lk.bus_current.amps())));
                }
                rows.push(("errors", readings::status1_errors_text(s)));
            }
            Reply::ReadStatus2(s) => {
                rows.push(("torque current", format!("{:.2} A", s.iq.amps())));
                match s.position {
                    StatusPosition::Encoder(_) => {
                        rows.push(("speed", format!("{} dps", s.speed.dps())));
                    }
                    StatusPosition::OutputDegrees(angle) => {
                        rows.push(("output speed", format!("{} dps", s.speed.dps())));
                        rows.push(("output angle", format!("{}°", angle.degrees())));
                    }
                }
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
            Reply::ReadMultiTurnAngle { motor_angle } => rows.push((
                if output {
                    "output multi-turn"
                } else {
                    "multi-turn angle"
                },
                format!("{:.2}°", motor_angle.degrees()),
            )),
            Reply::ReadSingleTurnAngle { circle_angle } => {
                rows.push(("single-turn", format!("{:.2}°", circle_angle.degrees())))
            }
            Reply::LkSingleTurnAngle { circle_angle } => {
                rows.push(("single-turn", format!("{:.2}°", circle_angle.degrees())))
            }
            Reply::V3SingleTurnAngle { circle_angle } => {
                rows.push(("single-turn", format!("{:.2}°", circle_angle.degrees())))
            }
            _ => {}
        }
    }
    rows
}
