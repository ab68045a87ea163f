//! `rmd monitor`: every motor's temperature, voltage, current, speed and angle (status 1, status
//! 2 and the multi-turn angle, read at `--rate`), until Ctrl-C, `q` or `--count`: on a terminal
//! a live view with a plot per motor of the chosen signal above the table ([`view`], drawn with
//! ratatui); elsewhere the table, one per reading; with `--json` one object per reading.
//! Each motor is read in its own protocol (a mixed bus is fine); a MyActuator V3 motor's speed
//! and angle are its output shaft's.
//! `--sim --demo` moves the simulated motors gently ([`demo`]) so there is something to watch.

mod demo;
mod view;

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use ratatui::crossterm::event::{self, Event, KeyEventKind};
use rmd_bus::{Clock, MonotonicClock, Timestamp};
use rmd_protocol::{Reply, Request};
use serde_json::{Value, json};
use view::{Action, History, Sample, Screen, View};

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
    after_help = "On a terminal: a plot per motor of one signal (keys a angle, s speed, c current, t temperature, Tab next; arrows or 1-9 select a motor; q quits) above the table. Elsewhere (a pipe, a file): the table once per reading. With --robot FILE: the robot's joints (--ids: joint names), labelled by name, the angle column in joint degrees; JSON objects carry `name`, `bus` and `joint`."
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
    /// Drive the simulated motors (--sim) through a gentle motion (each a slow sine in position
    /// mode), so that there is something to watch.
    #[arg(long, requires = "sim")]
    demo: bool,
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
    let terminal = !args.json && std::io::stdout().is_terminal();
    let mut readings = Readings {
        period: timing::period(args.rate),
        clock: MonotonicClock,
        start: MonotonicClock.now(),
        done: 0,
        demo: args.demo.then(Vec::new),
    };
    let shown = if terminal && std::io::stdin().is_terminal() {
        live_view(args, &mut motors, &mut readings)
    } else {
        print_readings(args, &mut motors, &mut readings, terminal)
    };
    // Whatever happened, the motors are left as they were and the recording (--log) flushed.
    let finished = motors.finish();
    shown.and(finished)
}

/// One reading of every motor: each one's replies, or why it could not be read.
type Rows = Vec<(Motor, Result<Vec<Reply>, String>)>;

/// The schedule of the readings, and the demo's motion.
struct Readings {
    period: Duration,
    clock: MonotonicClock,
    start: Timestamp,
    done: u64,
    /// With `--demo`: each motor's angle at the start (motor degrees; `None` when it did not
    /// answer, and it is not moved), read before the first reading.
    demo: Option<Vec<Option<f64>>>,
}

impl Readings {
    /// When the next reading is due.
    fn next_at(&self) -> Timestamp {
        self.start + self.period * u32::try_from(self.done).unwrap_or(u32::MAX)
    }

    /// Whether `--count` readings are done.
    fn finished(&self, count: Option<u64>) -> bool {
        count.is_some_and(|n| self.done >= n)
    }

    /// Reads every motor now (after the demo's commands, if on); returns the time and rows.
    fn read(&mut self, motors: &mut Motors) -> Result<(f64, Rows), CliError> {
        let time_s = (self.clock.now() - self.start).as_secs_f64();
        if let Some(centres) = &mut self.demo {
            let all = motors.motors().to_vec();
            if centres.is_empty() {
                for motor in &all {
                    centres.push(start_angle(motors, motor)?);
                }
            }
            for (index, (motor, centre)) in all.iter().zip(centres.iter()).enumerate() {
                let Some(centre) = centre else { continue };
                let command = demo::command(*centre, index, time_s).map_err(CliError::Failed)?;
                // A motor that does not answer says so in its row of the reading.
                if let Err(error) = motors.request(motor, &command)
                    && error.is_bus_failure()
                {
                    return Err(error.into());
                }
            }
        }
        let mut rows = Vec::with_capacity(motors.motors().len());
        for motor in motors.motors().to_vec() {
            let reading = read(motors, &motor)?;
            rows.push((motor, reading));
        }
        self.done += 1;
        Ok((time_s, rows))
    }
}

/// The readings as text: the table (redrawn in place on a terminal) or JSON lines.
fn print_readings(
    args: &MonitorArgs,
    motors: &mut Motors,
    readings: &mut Readings,
    redraw: bool,
) -> Result<(), CliError> {
    let mut drawn_lines = 0;
    while !readings.finished(args.count) && !interrupt::requested() {
        if !interrupt::sleep_until(&readings.clock, readings.next_at()) {
            break;
        }
        let (time_s, rows) = readings.read(motors)?;
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
        // Nobody reads any more (or the output failed): stop.
        shown?;
    }
    Ok(())
}

/// How long the live view waits for a key at most before looking at the clock again.
const KEY_POLL: Duration = Duration::from_millis(50);

/// The live view: plots and the table, redrawn at every reading and every key, until `q`,
/// Ctrl-C or `--count`; then the last table is printed as text.
fn live_view(
    args: &MonitorArgs,
    motors: &mut Motors,
    readings: &mut Readings,
) -> Result<(), CliError> {
    // Raw mode and the alternate screen; a panic restores the terminal too (ratatui's hook).
    let mut terminal = ratatui::try_init().map_err(|e| {
        // Whatever part of the set-up succeeded is undone.
        ratatui::restore();
        CliError::Failed(format!("cannot set up the terminal: {e}"))
    })?;
    let labels: Vec<String> = motors.motors().iter().map(Motor::label).collect();
    let mut histories = vec![History::default(); labels.len()];
    let mut view = View::new(labels.len());
    let mut last: Option<(f64, Rows)> = None;
    let bus = match motors.motors().first().cloned() {
        Some(first) => motors.connection(&first).setup().name(),
        None => String::new(),
    };
    let result = (|| -> Result<(), CliError> {
        let mut dirty = true;
        loop {
            if dirty {
                let table_lines: Vec<String> = last
                    .as_ref()
                    .map(|(t, rows)| {
                        table(*t, rows, "")
                            .lines()
                            .skip(1)
                            .map(str::to_owned)
                            .collect()
                    })
                    .unwrap_or_default();
                let time = last.as_ref().map_or(0.0, |(t, _)| *t);
                let screen = Screen {
                    title: format!(
                        "rmd monitor: {bus}  t {time:.2} s  {} reading(s){}",
                        readings.done,
                        if readings.demo.is_some() {
                            "  (demo motion)"
                        } else {
                            ""
                        }
                    ),
                    motors: labels.iter().cloned().zip(histories.iter()).collect(),
                    table: table_lines,
                };
                terminal
                    .draw(|frame| view::draw(frame, &view, &screen))
                    .map_err(|e| CliError::Failed(format!("drawing: {e}")))?;
                dirty = false;
            }
            if readings.finished(args.count) || interrupt::requested() {
                return Ok(());
            }
            // The keys are looked at before every reading, even when the readings fall behind
            // their schedule (slow replies, a high --rate): `q` always works.
            let due = readings.next_at();
            let wait = due
                .checked_duration_since(readings.clock.now())
                .unwrap_or(Duration::ZERO)
                .min(KEY_POLL);
            let keys = |e: std::io::Error| CliError::Failed(format!("reading the keys: {e}"));
            if event::poll(wait).map_err(keys)? {
                match event::read().map_err(keys)? {
                    Event::Key(key) if key.kind == KeyEventKind::Press => {
                        if view.key(key) == Action::Quit {
                            return Ok(());
                        }
                        dirty = true;
                    }
                    Event::Resize(..) => dirty = true,
                    _ => {}
                }
            }
            if readings.clock.now() < due {
                continue;
            }
            let (time_s, rows) = readings.read(motors)?;
            for (history, (motor, row)) in histories.iter_mut().zip(&rows) {
                if let Some(values) = row.as_ref().ok().and_then(|r| values(motor, r)) {
                    history.push(Sample { time_s, values });
                }
            }
            last = Some((time_s, rows));
            dirty = true;
        }
    })();
    ratatui::restore();
    if let Some((time_s, rows)) = &last {
        out!("{}", table(*time_s, rows, ""))?;
    }
    result
}

/// A motor's angle (joint degrees with a robot, as in the table), speed, current and
/// temperature from one reading; `None` when a reply is missing.
fn values(motor: &Motor, replies: &[Reply]) -> Option<[f64; 4]> {
    let (mut status2, mut angle) = (None, None);
    for reply in replies {
        match reply {
            Reply::ReadStatus2(s) => status2 = Some(*s),
            Reply::ReadMultiTurnAngle { motor_angle } => {
                angle = Some(match &motor.joint {
                    Some(joint) => joint.map.joint_angle_deg(motor_angle.degrees()),
                    None => motor_angle.degrees(),
                });
            }
            _ => {}
        }
    }
    let (s2, angle) = (status2?, angle?);
    Some([
        angle,
        s2.speed.dps(),
        s2.iq.amps(),
        s2.temperature.celsius(),
    ])
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
            // A motor whose family cannot be read as the command stands answered too: its
            // reading says why.
            Ok(_) => found.push(motor.id),
            Err(error) if error.is_refusal() => found.push(motor.id),
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

/// A motor's multi-turn angle before the demo moves it, motor degrees; `None` when it does not
/// answer (the demo leaves it alone).
fn start_angle(motors: &mut Motors, motor: &Motor) -> Result<Option<f64>, CliError> {
    match motors.request(motor, &Request::ReadMultiTurnAngle) {
        Ok(Reply::ReadMultiTurnAngle { motor_angle }) => Ok(Some(motor_angle.degrees())),
        Err(error) if error.is_bus_failure() => Err(error.into()),
        _ => Ok(None),
    }
}

/// One reading of one motor, or why it failed (the monitor goes on).
fn read(motors: &mut Motors, motor: &Motor) -> Result<Result<Vec<Reply>, String>, CliError> {
    let mut replies = Vec::with_capacity(READS.len());
    for request in &READS {
        match motors.request(motor, request) {
            Ok(reply) => replies.push(reply),
            // The bus is gone, or the motor cannot be read as the command stands (an LK-TECH
            // motor without --lk-series): no later reading would do better.
            Err(error) if error.is_bus_failure() || error.is_refusal() => {
                return Err(error.into());
            }
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
            // In the motor's family's layout and scales (`live::exchange`).
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
        format!("{:.1}", s1.volts()),
        format!("{:.2}", s2.iq.amps()),
        s2.speed.dps().to_string(),
        format!("{angle:.2}"),
        readings::status1_errors_text(&s1),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{
        CurrentScale, EncoderValue, MotorAngle, ScaledCurrent, Speed, Status1, Status2,
        StatusPosition, Temperature, V161Status1,
    };

    #[test]
    fn rows_line_up_under_the_header_whatever_their_state() {
        let id = |n| crate::live::motors::Motor {
            id: rmd_protocol::MotorId::new(n).unwrap(),
            bus: 0,
            width: rmd_protocol::EncoderWidth::DEFAULT,
            joint: None,
        };
        let status2 = Status2 {
            temperature: Temperature::default(),
            iq: ScaledCurrent::saturating(0, CurrentScale::V161_IQ),
            speed: Speed::default(),
            position: StatusPosition::Encoder(EncoderValue::default()),
        };
        let answered = vec![
            Reply::ReadStatus1(Status1::V161(V161Status1::default())),
            Reply::ReadStatus2(status2),
            Reply::ReadMultiTurnAngle {
                motor_angle: MotorAngle::new(-1_234_567).unwrap(),
            },
        ];
        let rows = [
            (id(2), Ok(answered)),
            (id(9), Err("motor 9 did not answer".to_owned())),
            (
                id(12),
                Ok(vec![Reply::ReadStatus1(Status1::V161(
                    V161Status1::default(),
                ))]),
            ),
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
