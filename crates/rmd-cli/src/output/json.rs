//! The JSON object `rmd decode` prints for one frame.
//!
//! Keys, in order: `timestamp` (seconds, if the line had one), `interface` (if any), `id` (motor
//! id; absent for 0x280), `can_id` (`"0x141"`), `direction` (`request` / `reply`), `command`
//! (kebab-case name, `multi-torque` for 0x280), then every field under its snake_case spec name
//! with its RAW integer value, each physical value right after its raw field under
//! `<field>_<unit>` (`iq_amps`, `voltage_volts`, `temperature_celsius`, `speed_dps`, ...).

use std::time::Duration;

use rmd_protocol::{
    EncoderValue, EncoderWidth, MULTI_TORQUE_CAN_ID, MotorId, MultiTorque, PidParams, Reply,
    Request, SpinDirection, Status1, Status2,
};
use serde_json::{Map, Value, json};

/// The fields of a reply as `rmd decode` names them (raw values and physical values), without
/// the frame header (`id`, `can_id`, `direction`, `command`).
pub(crate) fn reply_fields(reply: &Reply, width: EncoderWidth) -> Map<String, Value> {
    const HEADER: [&str; 4] = ["id", "can_id", "direction", "command"];
    let object = FrameJson::new(None, None, 0x141, "reply", "", width)
        .reply(reply)
        .into_value();
    match object {
        Value::Object(map) => map
            .into_iter()
            .filter(|(key, _)| !HEADER.contains(&key.as_str()))
            .collect(),
        _ => Map::new(),
    }
}

/// Builder for one output object.
pub(crate) struct FrameJson {
    map: Map<String, Value>,
    width: EncoderWidth,
}

impl FrameJson {
    /// The common header of a frame's object.
    pub(crate) fn new(
        timestamp: Option<Duration>,
        interface: Option<&str>,
        can_id: u16,
        direction: &str,
        command: &str,
        width: EncoderWidth,
    ) -> Self {
        let mut map = Map::new();
        if let Some(t) = timestamp {
            map.insert("timestamp".into(), json!(t.as_secs_f64()));
        }
        if let Some(i) = interface {
            map.insert("interface".into(), json!(i));
        }
        if can_id != MULTI_TORQUE_CAN_ID
            && let Ok(motor) = MotorId::from_can_id(can_id)
        {
            map.insert("id".into(), json!(motor.get()));
        }
        map.insert("can_id".into(), json!(format!("0x{can_id:03X}")));
        map.insert("direction".into(), json!(direction));
        map.insert("command".into(), json!(command));
        Self { map, width }
    }

    /// The finished object.
    pub(crate) fn into_value(self) -> Value {
        Value::Object(self.map)
    }

    fn put(&mut self, key: &str, value: Value) {
        self.map.insert(key.to_string(), value);
    }

    fn pid(&mut self, p: &PidParams) {
        self.put("angle_pid_kp", json!(p.angle_pid_kp));
        self.put("angle_pid_ki", json!(p.angle_pid_ki));
        self.put("speed_pid_kp", json!(p.speed_pid_kp));
        self.put("speed_pid_ki", json!(p.speed_pid_ki));
        self.put("iq_pid_kp", json!(p.iq_pid_kp));
        self.put("iq_pid_ki", json!(p.iq_pid_ki));
    }

    fn encoder(&mut self, key: &str, v: EncoderValue) {
        self.put(key, json!(v.raw()));
        self.put(&format!("{key}_degrees"), json!(v.degrees(self.width)));
    }

    fn spin(&mut self, d: SpinDirection) {
        self.put("spin_direction", json!(d.raw()));
        let name = match d {
            SpinDirection::Clockwise => "cw",
            SpinDirection::CounterClockwise => "ccw",
        };
        self.put("spin_direction_name", json!(name));
    }

    fn status1(&mut self, s: &Status1) {
        self.put("temperature", json!(s.temperature.raw()));
        self.put("temperature_celsius", json!(s.temperature.celsius()));
        self.put("voltage", json!(s.voltage.raw()));
        self.put("voltage_volts", json!(s.voltage.volts()));
        self.put("error_state", json!(s.error_state.raw()));
        self.put("low_voltage", json!(s.error_state.low_voltage()));
        self.put("over_temperature", json!(s.error_state.over_temperature()));
    }

    fn status2(&mut self, s: &Status2) {
        self.put("temperature", json!(s.temperature.raw()));
        self.put("temperature_celsius", json!(s.temperature.celsius()));
        self.put("iq", json!(s.iq.raw()));
        self.put("iq_amps", json!(s.iq.amps()));
        self.put("speed", json!(s.speed.raw()));
        self.put("speed_dps", json!(s.speed.dps()));
        self.encoder("encoder", s.encoder);
    }

    /// Adds the fields of a single-motor request.
    pub(crate) fn request(mut self, request: &Request) -> Self {
        match request {
            Request::WritePidRam(p) | Request::WritePidRom(p) => self.pid(p),
            Request::WriteAccelRam { accel } => {
                self.put("accel", json!(accel.raw()));
                self.put("accel_dps_per_s", json!(accel.dps_per_s()));
            }
            Request::WriteEncoderOffset { encoder_offset } => {
                self.encoder("encoder_offset", *encoder_offset)
            }
            Request::Torque { iq_control } => {
                self.put("iq_control", json!(iq_control.raw()));
                self.put("iq_control_amps", json!(iq_control.amps()));
            }
            Request::Speed { speed_control } => {
                self.put("speed_control", json!(speed_control.raw()));
                self.put("speed_control_dps", json!(speed_control.dps()));
            }
            Request::Position1 { angle_control } => {
                self.put("angle_control", json!(angle_control.raw()));
                self.put("angle_control_degrees", json!(angle_control.degrees()));
            }
            Request::Position2 {
                max_speed,
                angle_control,
            } => {
                self.put("max_speed", json!(max_speed.raw()));
                self.put("max_speed_dps", json!(max_speed.dps()));
                self.put("angle_control", json!(angle_control.raw()));
                self.put("angle_control_degrees", json!(angle_control.degrees()));
            }
            Request::Position3 {
                spin_direction,
                angle_control,
            } => {
                self.spin(*spin_direction);
                self.put("angle_control", json!(angle_control.raw()));
                self.put("angle_control_degrees", json!(angle_control.degrees()));
            }
            Request::Position4 {
                spin_direction,
                max_speed,
                angle_control,
            } => {
                self.spin(*spin_direction);
                self.put("max_speed", json!(max_speed.raw()));
                self.put("max_speed_dps", json!(max_speed.dps()));
                self.put("angle_control", json!(angle_control.raw()));
                self.put("angle_control_degrees", json!(angle_control.degrees()));
            }
            // The remaining requests carry no fields.
            _ => {}
        }
        self
    }

    /// Adds the fields of the 0x280 frame.
    pub(crate) fn multi(mut self, m: &MultiTorque) -> Self {
        let raw: Vec<i16> = m.iq_control.iter().map(|v| v.raw()).collect();
        let amps: Vec<f64> = m.iq_control.iter().map(|v| v.amps()).collect();
        self.put("iq_control", json!(raw));
        self.put("iq_control_amps", json!(amps));
        self
    }

    /// Adds the fields of a reply.
    pub(crate) fn reply(mut self, reply: &Reply) -> Self {
        match reply {
            Reply::ReadPid(p) | Reply::WritePidRam(p) | Reply::WritePidRom(p) => self.pid(p),
            Reply::ReadAccel { accel } | Reply::WriteAccelRam { accel } => {
                self.put("accel", json!(accel.raw()));
                self.put("accel_dps_per_s", json!(accel.dps_per_s()));
            }
            Reply::ReadEncoder {
                encoder,
                encoder_raw,
                encoder_offset,
            } => {
                self.encoder("encoder", *encoder);
                self.encoder("encoder_raw", *encoder_raw);
                self.encoder("encoder_offset", *encoder_offset);
            }
            Reply::WriteEncoderOffset { encoder_offset }
            | Reply::WriteZeroRom { encoder_offset } => {
                self.encoder("encoder_offset", *encoder_offset)
            }
            Reply::ReadMultiTurnAngle { motor_angle } => {
                self.put("motor_angle", json!(motor_angle.raw()));
                self.put("motor_angle_degrees", json!(motor_angle.degrees()));
            }
            Reply::ReadSingleTurnAngle { circle_angle } => {
                self.put("circle_angle", json!(circle_angle.raw()));
                self.put("circle_angle_degrees", json!(circle_angle.degrees()));
            }
            Reply::ReadStatus1(s) | Reply::ClearError(s) => self.status1(s),
            Reply::ReadStatus3(s) => {
                for (key, current) in [("i_a", s.i_a), ("i_b", s.i_b), ("i_c", s.i_c)] {
                    self.put(key, json!(current.raw()));
                    self.put(&format!("{key}_amps"), json!(current.amps()));
                }
            }
            Reply::MotorOff | Reply::MotorStop | Reply::MotorRun => {}
            Reply::ReadStatus2(s)
            | Reply::Torque(s)
            | Reply::Speed(s)
            | Reply::Position1(s)
            | Reply::Position2(s)
            | Reply::Position3(s)
            | Reply::Position4(s) => self.status2(s),
        }
        self
    }
}
