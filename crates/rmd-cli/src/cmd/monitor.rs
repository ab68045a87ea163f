//! `rmd monitor`: a live table of every motor's temperature, voltage, current, speed and angle
//! (status 1, status 2 and the multi-turn angle, read at `--rate`), until Ctrl-C or `--count`.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_bus::{Clock, MonotonicClock};
use rmd_protocol::{Reply, Request};
use serde_json::{Value, json};

use crate::args::bus::BusArgs;
use crate::args::timing;
use crate::live::connect::DEFAULT_TIMEOUT;
use crate::live::interrupt;
use crate::live::motors::{Motor, Motors};
use crate::output::progress::{self, Progress};
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{out, outln};

/// Arguments of `rmd monitor`.
#[derive(Args, Debug)]
#[command(
    after_help = "With --robot FILE: the robot's joints (--ids: joint names), labelled by name, the angle column in joint degrees; JSON objects carry `name`, `bus` and `joint`."
)]
pub(crate) struct MonitorArgs {
    /// Motors to watch [default: the ones that answer a scan of 1..=32; with --robot, every
    /// joint]; with --robot, joint names.
    #[arg(long, value_name = "IDS|JOINTS")]
    ids: Option<String>,
    /// Readings per second.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = timing::rate_hz, default_value = "10", allow_hyphen_values = true)]
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
    let scan_all = args.ids.is_none() && args.bus.robot.is_none();
    let targets: Vec<String> = match (&args.ids, scan_all) {
        (Some(ids), _) => vec![ids.clone()],
        (None, true) => vec!["all".to_owned()],
        (None, false) => Vec::new(),
    };
    let mut motors = Motors::open(&args.bus, &targets, DEFAULT_TIMEOUT, 0)?;
    interrupt::install()?;
    if scan_all {
        scan(
            &mut motors,
            args.bus.timeout_ms.is_none(),
            progress::shown(args.json),
        )?;
    }
    let period = timing::period(args.rate);
    let redraw = !args.json && std::io::stdout().is_terminal();
    let clock = MonotonicClock;
    let start = clock.now();
    let mut drawn_lines = 0;
    let mut readings_done = 0u64;
    while args.count.is_none_or(|n| readings_done < n) && !interrupt::requested() {
        let at = start + period * u32::try_from(readings_done).unwrap_or(u32::MAX);
        if !interrupt::sleep_until(&clock, at) {
            break;
        }
        let time_s = (clock.now() - start).as_secs_f64();
        let mut rows = Vec::with_capacity(motors.motors().len());
        for motor in motors.motors().to_vec() {
            let reading = read(&mut motors, &motor)?;
            rows.push((motor, reading));
        }
        let shown = if args.json {
            let list: Vec<Value> = rows
                .iter()
                .map(|(motor, row)| json_row(motor, row))
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
            motors.finish()?;
            return Err(error.into());
        }
        readings_done += 1;
    }
    motors.finish()?;
    Ok(())
}

/// One motor's JSON object in a reading: its readings (with a robot: its joint's name, bus and
/// joint units), or why it could not be read.
fn json_row(motor: &Motor, row: &Result<Vec<Reply>, String>) -> Value {
    let mut value = match row {
        Ok(replies) => readings::object(motor.id, replies, motor.width),
        Err(error) => readings::error_object(motor.id, error),
    };
    if let (Some(joint), Value::Object(map)) = (&motor.joint, &mut value) {
        map.insert("name".into(), joint.name.clone().into());
        map.insert("bus".into(), joint.bus_name.clone().into());
        if let Ok(replies) = row {
            map.insert("joint".into(), readings::joint_object(&joint.map, replies));
        }
    }
    value
}

/// Keeps the motors that answer a status-1 read (the scan of ids 1..=32).
fn scan(motors: &mut Motors, quick: bool, show: bool) -> Result<(), CliError> {
    let all = motors.motors().to_vec();
    let progress = Progress::counter(all.len() as u64, "ids", show);
    progress.set_prefix("looking for motors ");
    let mut found = Vec::new();
    for (done, motor) in all.iter().enumerate() {
        progress.set_position(done as u64);
        let connection = motors.connection(motor);
        let timeout = connection.policy().timeout;
        if quick {
            connection.set_timeout(SCAN_TIMEOUT);
        }
        let answer = connection.request(motor.id, &Request::ReadStatus1);
        connection.set_timeout(timeout);
        match answer {
            Ok(_) => found.push(motor.id),
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(_) => {}
        }
    }
    if found.is_empty() {
        let name = all
            .first()
            .map_or_else(String::new, |m| motors.connection(m).setup().name());
        return Err(CliError::Failed(format!(
            "no motor answered on {name}: check power, wiring and bit rate, or name the motors \
             with --ids"
        )));
    }
    motors.retain(|m| found.contains(&m.id));
    Ok(())
}

/// One reading of one motor, or why it failed (the monitor goes on).
fn read(motors: &mut Motors, motor: &Motor) -> Result<Result<Vec<Reply>, String>, CliError> {
    let mut replies = Vec::with_capacity(READS.len());
    for request in &READS {
        match motors.request(motor, request) {
            Ok(reply) => replies.push(reply),
            Err(error) if error.is_bus_failure() => return Err(error.into()),
            Err(error) => return Ok(Err(error.to_string())),
        }
    }
    Ok(Ok(replies))
}

/// The table of one reading; every line ends with `clear` (on a terminal: "clear to end of
/// line", so a redraw over a longer previous line leaves nothing behind).
fn table(time_s: f64, rows: &[(Motor, Result<Vec<Reply>, String>)], clear: &str) -> String {
    let joints = rows.iter().any(|(m, _)| m.joint.is_some());
    let mut table = TextTable::new(&[
        (if joints { "joint" } else { "id" }, Align::Right),
        ("temp °C", Align::Right),
        ("volts", Align::Right),
        ("iq A", Align::Right),
        ("speed dps", Align::Right),
        (if joints { "joint °" } else { "angle °" }, Align::Right),
        ("errors", Align::Left),
    ])
    // The widths of typical values: the table keeps its layout as they change.
    .min_widths(&[3, 7, 5, 6, 9, 10]);
    for (motor, row) in rows {
        table.row(cells(motor, row));
    }
    let mut text = format!("t {time_s:8.2} s{clear}\n");
    for line in table.render().lines() {
        text.push_str(line);
        text.push_str(clear);
        text.push('\n');
    }
    text
}

/// The cells of one motor's row; a motor that did not answer says so in the last column.
fn cells(motor: &Motor, row: &Result<Vec<Reply>, String>) -> Vec<String> {
    let id = match &motor.joint {
        Some(joint) => joint.name.clone(),
        None => motor.id.get().to_string(),
    };
    let missing = |why: &str| {
        let mut cells = vec![id.clone()];
        cells.extend(std::iter::repeat_n("-".to_owned(), 5));
        cells.push(why.to_owned());
        cells
    };
    let Ok(replies) = row else {
        return missing("no reply");
    };
    let (mut status1, mut status2, mut angle) = (None, None, None);
    for reply in replies {
        match reply {
            Reply::ReadStatus1(s) => status1 = Some(*s),
            Reply::ReadStatus2(s) => status2 = Some(*s),
            Reply::ReadMultiTurnAngle { motor_angle } => {
                angle = Some(match &motor.joint {
                    Some(joint) => joint.map.joint_angle_deg(motor_angle.degrees()),
                    None => motor_angle.degrees(),
                })
            }
            _ => {}
        }
    }
    let (Some(s1), Some(s2), Some(angle)) = (status1, status2, angle) else {
        return missing("incomplete reply");
    };
    vec![
        id,
        s2.temperature.celsius().to_string(),
        format!("{:.1}", s1.voltage.volts()),
        format!("{:.2}", s2.iq.amps()),
        s2.speed.dps().to_string(),
        format!("{angle:.2}"),
        readings::errors_text(s1.error_state),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{MotorAngle, Status1, Status2};

    #[test]
    fn rows_line_up_under_the_header_whatever_their_state() {
        let id = |n| crate::live::motors::Motor {
            id: rmd_protocol::MotorId::new(n).unwrap(),
            bus: 0,
            width: rmd_protocol::EncoderWidth::DEFAULT,
            joint: None,
        };
        let answered = vec![
            Reply::ReadStatus1(Status1::default()),
            Reply::ReadStatus2(Status2::default()),
            Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::new(-1_234_567).unwrap(),
            },
        ];
        let rows = [
            (id(2), Ok(answered)),
            (id(9), Err("motor 9 did not answer".to_owned())),
            (id(12), Ok(vec![Reply::ReadStatus1(Status1::default())])),
        ];
        let text = table(1.5, &rows, "");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "t     1.50 s");
        let header = lines[1];
        let errors_at = header.find("errors").unwrap();
        let angle_end = header.find("angle °").unwrap() + "angle °".len();
        let state = |line: &str| {
            line.chars()
                .skip(header[..errors_at].chars().count())
                .collect::<String>()
        };
        assert_eq!(state(lines[2]), "none");
        assert_eq!(state(lines[3]), "no reply");
        assert_eq!(state(lines[4]), "incomplete reply");
        // Numbers end where their titles end (counted in characters: `°` is one).
        let angle_col = header[..angle_end].chars().count();
        let prefix = |line: &str| line.chars().take(angle_col).collect::<String>();
        assert!(prefix(lines[2]).ends_with("-12345.67"), "{text}");
        assert!(prefix(lines[3]).ends_with(" -"), "{text}");
        assert!(
            lines[2].trim_start().starts_with("2 ") && lines[4].trim_start().starts_with("12 ")
        );
    }
}
