//! `encode` and `decode`: the frames, keys and messages of `rmd encode` and `rmd decode`.
//!
//! A command is named as on the `rmd encode` command line (`"read-status-2"`, `"torque"`, ...)
//! and its fields are that command's flags in snake case (`iq_control=100` for
//! `--iq-control 100`, `deg=90.0` for `--deg 90`). The values are checked by the same
//! rmd-protocol types and `rmd-frames` functions, so out-of-range values fail with the same
//! messages. A frame is decoded by `rmd-frames`, which `rmd decode` prints.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use rmd_bus::candump;
use rmd_frames::encode::{encoder_offset, torque_current};
use rmd_protocol::{
    Accel, AngleControl, CanFrame, Dialect, EncoderWidth, MaxSpeed, MaxTorquePercent, MotorId,
    MultiTorque, PidParams, Request, ScaledCurrent, SingleTurnAngle, SpeedControl, SpinDirection,
};

use crate::args;
use crate::errors::{ProtocolError, guard};
use crate::fields::Fields;

/// Every command `encode` (and `Bus.request`) knows, as `rmd encode` names it.
pub(crate) const COMMANDS: [&str; 24] = [
    "read-pid",
    "write-pid-ram",
    "write-pid-rom",
    "read-accel",
    "write-accel-ram",
    "read-encoder",
    "write-encoder-offset",
    "write-zero-rom",
    "read-multi-turn-angle",
    "read-single-turn-angle",
    "read-status-1",
    "clear-error",
    "read-status-2",
    "read-status-3",
    "motor-off",
    "motor-stop",
    "motor-run",
    "torque",
    "speed",
    "position-1",
    "position-2",
    "position-3",
    "position-4",
    "multi-torque",
];

/// The commands that write the motor's ROM (flash): `Bus.request` sends them only when
/// confirmed.
const ROM_WRITES: [&str; 2] = ["write-pid-rom", "write-zero-rom"];

/// Whether `command` writes the motor's ROM (flash) under `dialect`: the PID and zero writes
/// always; the encoder offset (0x91) on LK-TECH firmware, which keeps it in ROM as the motor's
/// zero (v1.61 does not say it persists), as `rmd replay` counts it.
pub(crate) fn writes_rom(command: &str, dialect: Dialect) -> bool {
    ROM_WRITES.contains(&command)
        || (command == "write-encoder-offset" && matches!(dialect, Dialect::LkV23x(_)))
}

/// The command named `name`, as a `'static` name.
pub(crate) fn command_name(name: &str) -> Result<&'static str, String> {
    COMMANDS
        .iter()
        .find(|c| **c == name)
        .copied()
        .ok_or_else(|| {
            format!(
                "unknown command `{name}`: expected one of {}",
                COMMANDS.join(", ")
            )
        })
}

fn motor(command: &str, id: Option<i64>) -> Result<MotorId, String> {
    let id = id.ok_or_else(|| format!("{command} needs id=<1..=32>"))?;
    let id = u8::try_from(id).map_err(|_| format!("invalid motor id {id}: must be 1..=32"))?;
    MotorId::new(id).map_err(|e| e.to_string())
}

fn pid(fields: &mut Fields<'_>) -> Result<PidParams, String> {
    let mut gain = |key: &'static str| -> Result<u8, String> {
        let value = fields.required_int(key)?;
        u8::try_from(value).map_err(|_| format!("{key} {value} is out of range 0..=255"))
    };
    Ok(PidParams {
        angle_pid_kp: gain("angle_pid_kp")?,
        angle_pid_ki: gain("angle_pid_ki")?,
        speed_pid_kp: gain("speed_pid_kp")?,
        speed_pid_ki: gain("speed_pid_ki")?,
        iq_pid_kp: gain("iq_pid_kp")?,
        iq_pid_ki: gain("iq_pid_ki")?,
    })
}

fn spin(fields: &mut Fields<'_>) -> Result<SpinDirection, String> {
    match fields.text("spin_direction")?.as_deref() {
        Some("cw") => Ok(SpinDirection::Clockwise),
        Some("ccw") => Ok(SpinDirection::CounterClockwise),
        Some(other) => Err(format!(
            "invalid value '{other}' for spin_direction: expected cw or ccw"
        )),
        None => Err("missing spin_direction (\"cw\" or \"ccw\")".to_owned()),
    }
}

fn max_speed(fields: &mut Fields<'_>) -> Result<MaxSpeed, String> {
    MaxSpeed::new(fields.required_int("max_speed")?).map_err(|e| e.to_string())
}

fn multi_turn_angle(fields: &mut Fields<'_>) -> Result<AngleControl, String> {
    let raw = fields.int("angle_control")?;
    let deg = fields.number("deg")?;
    fields.one_of(("angle_control", &raw), ("deg", &deg))?;
    // `one_of` made sure that one is given.
    match raw {
        Some(raw) => AngleControl::new(raw),
        None => AngleControl::from_degrees(deg.unwrap_or(f64::NAN)),
    }
    .map_err(|e| e.to_string())
}

fn single_turn_angle(fields: &mut Fields<'_>) -> Result<SingleTurnAngle, String> {
    let raw = fields.int("angle_control")?;
    let deg = fields.number("deg")?;
    fields.one_of(("angle_control", &raw), ("deg", &deg))?;
    match raw {
        Some(raw) => SingleTurnAngle::new(raw),
        None => SingleTurnAngle::from_degrees(deg.unwrap_or(f64::NAN)),
    }
    .map_err(|e| e.to_string())
}

/// Builds the frame of `command` for motor `id` with `fields`, in `dialect`.
pub(crate) fn build_frame(
    command: &'static str,
    id: Option<i64>,
    fields: Option<&Bound<'_, PyDict>>,
    dialect: Dialect,
) -> Result<CanFrame, String> {
    let mut f = Fields::new(command, fields).map_err(|e| e.to_string())?;
    if command == "multi-torque" {
        if id.is_some() {
            return Err(
                "multi-torque commands motors 1..=4 in one frame (CAN ID 0x280): give no id"
                    .to_owned(),
            );
        }
        let raw = f.four_ints("iq_control")?;
        let amps = f.four_numbers("amps")?;
        f.one_of(("iq_control", &raw), ("amps", &amps))?;
        f.finish()?;
        let mut iq = [ScaledCurrent::saturating(0, dialect.iq_control_scale()); 4];
        for (k, slot) in iq.iter_mut().enumerate() {
            *slot = torque_current(dialect, raw.map(|v| v[k]), amps.map(|v| v[k]))?;
        }
        return dialect
            .encode_multi_torque(&MultiTorque::new(iq))
            .map_err(|e| e.to_string());
    }
    let motor = motor(command, id)?;
    let request = match command {
        "read-pid" => Request::ReadPid,
        "write-pid-ram" => Request::WritePidRam(pid(&mut f)?),
        "write-pid-rom" => Request::WritePidRom(pid(&mut f)?),
        "read-accel" => Request::ReadAccel,
        "write-accel-ram" => Request::WriteAccelRam {
            accel: Accel::new(f.required_int("accel")?).map_err(|e| e.to_string())?,
        },
        "read-encoder" => Request::ReadEncoder,
        "write-encoder-offset" => {
            let raw = f.required_int("encoder_offset")?;
            let width = match f.int("encoder_bits")? {
                Some(bits) => args::encoder_width(bits)?,
                None => EncoderWidth::DEFAULT,
            };
            Request::WriteEncoderOffset {
                encoder_offset: encoder_offset(raw, width)?,
            }
        }
        "write-zero-rom" => Request::WriteZeroRom,
        "read-multi-turn-angle" => Request::ReadMultiTurnAngle,
        "read-single-turn-angle" => Request::ReadSingleTurnAngle,
        "read-status-1" => Request::ReadStatus1,
        "clear-error" => Request::ClearError,
        "read-status-2" => Request::ReadStatus2,
        "read-status-3" => Request::ReadStatus3,
        "motor-off" => Request::MotorOff,
        "motor-stop" => Request::MotorStop,
        "motor-run" => Request::MotorRun,
        "torque" => {
            let raw = f.int("iq_control")?;
            let amps = f.number("amps")?;
            f.one_of(("iq_control", &raw), ("amps", &amps))?;
            Request::Torque {
                iq_control: torque_current(dialect, raw, amps)?,
            }
        }
        "speed" => {
            let raw = f.int("speed_control")?;
            let dps = f.number("dps")?;
            f.one_of(("speed_control", &raw), ("dps", &dps))?;
            let speed_control = match raw {
                Some(raw) => SpeedControl::new(raw),
                None => SpeedControl::from_dps(dps.unwrap_or(f64::NAN)),
            }
            .map_err(|e| e.to_string())?;
            Request::Speed {
                speed_control,
                max_torque: MaxTorquePercent::NONE,
            }
        }
        "position-1" => Request::Position1 {
            angle_control: multi_turn_angle(&mut f)?,
        },
        "position-2" => Request::Position2 {
            max_speed: max_speed(&mut f)?,
            angle_control: multi_turn_angle(&mut f)?,
        },
        "position-3" => Request::Position3 {
            spin_direction: spin(&mut f)?,
            angle_control: single_turn_angle(&mut f)?,
        },
        "position-4" => Request::Position4 {
            spin_direction: spin(&mut f)?,
            max_speed: max_speed(&mut f)?,
            angle_control: single_turn_angle(&mut f)?,
        },
        other => return Err(format!("unknown command `{other}`")),
    };
    f.finish()?;
    dialect.encode(motor, &request).map_err(|e| e.to_string())
}

/// One command as a frame in candump's compact form (`141#A100000064000000`), exactly as
/// `rmd encode` prints it.
///
/// `command` is the `rmd encode` subcommand (`"torque"`, `"position-4"`, ...); `id` the motor,
/// 1..=32 (none for `"multi-torque"`); `fields` that command's flags in snake case, raw
/// integers (`iq_control`, `speed_control`, `angle_control`, `max_speed`, `accel`,
/// `encoder_offset`, the six PID gains) or physical values (`amps`, `dps`, `deg`), and
/// `spin_direction="cw"|"ccw"`, `encoder_bits`. Raises `ProtocolError` with `rmd encode`'s
/// message for a value out of range.
#[pyfunction]
#[pyo3(signature = (command, id=None, protocol="v1.61", lk_series=None, **fields))]
pub(crate) fn encode(
    command: &str,
    id: Option<i64>,
    protocol: &str,
    lk_series: Option<&str>,
    fields: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    guard(|| {
        let built = args::dialect(protocol, lk_series)
            .and_then(|dialect| build_frame(command_name(command)?, id, fields, dialect));
        built
            .map(|frame| frame.to_string())
            .map_err(ProtocolError::new_err)
    })
}

/// One candump line (any of candump's formats) read as `direction` (`"request"`, `"reply"`, or
/// `"auto"`: a line on its own is a request, as `rmd decode` reads it), to the object
/// `rmd decode` prints for it, as a dict. A field out of range is left out and named under
/// `"errors"`; a frame that cannot be read raises `ProtocolError` with `rmd decode`'s message.
#[pyfunction]
#[pyo3(signature = (line, direction="auto", protocol="v1.61", lk_series=None, encoder_bits=14))]
pub(crate) fn decode<'py>(
    py: Python<'py>,
    line: &str,
    direction: &str,
    protocol: &str,
    lk_series: Option<&str>,
    encoder_bits: i64,
) -> PyResult<Bound<'py, PyAny>> {
    guard(|| {
        let decoded = (|| {
            let dialect = args::dialect(protocol, lk_series)?;
            let width = args::encoder_width(encoder_bits)?;
            let line = candump::parse_line(line).map_err(|e| e.to_string())?;
            match direction {
                "auto" | "request" => rmd_frames::decode::request(&line, width, dialect),
                "reply" => rmd_frames::decode::reply(&line, None, width, dialect),
                other => Err(format!(
                    "unknown direction `{other}`: expected auto, request or reply"
                )),
            }
        })()
        .map_err(ProtocolError::new_err)?;
        Ok(pythonize::pythonize(py, &decoded.value)?)
    })
}
