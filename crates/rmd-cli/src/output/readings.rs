//! What the read commands print: one JSON object per motor (the reply fields under the names
//! `rmd decode` uses), or short human-readable text.

use rmd_protocol::{EncoderWidth, ErrorState, MotorId, Reply, Status1, V3ErrorState};
use serde_json::{Map, Value, json};

use crate::output::json::reply_fields;

/// `{"id": N, <fields of every reply>}`; a field present in several replies (temperature) keeps
/// the last value.
pub(crate) fn object(motor: MotorId, replies: &[Reply], width: EncoderWidth) -> Value {
    let mut map = Map::new();
    map.insert("id".into(), json!(motor.get()));
    for reply in replies {
        map.extend(reply_fields(reply, width));
    }
    Value::Object(map)
}

/// A joint's readings in joint units, from a motor's replies (multi-turn angle, status 2): `{"angle_deg",
/// "velocity_dps", "torque_nm"}`, each present when a reply carried it (torque: with the torque
/// constant).
pub(crate) fn joint_object(map: &rmd_loop::mapping::JointMap, replies: &[Reply]) -> Value {
    let mut joint = Map::new();
    for reply in replies {
        match reply {
            Reply::ReadMultiTurnAngle { motor_angle } => {
                joint.insert(
                    "angle_deg".into(),
                    json!(map.joint_angle_deg(motor_angle.degrees())),
                );
            }
            Reply::ReadStatus2(s) | Reply::Torque(s) => {
                joint.insert(
                    "velocity_dps".into(),
                    json!(map.joint_velocity_dps(s.speed.dps())),
                );
                if let Some(nm) = map.joint_torque_nm(s.iq.amps()) {
                    joint.insert("torque_nm".into(), json!(nm));
                }
            }
            _ => {}
        }
    }
    Value::Object(joint)
}

/// `{"id": N, "error": "..."}` for a motor that could not be read.
pub(crate) fn error_object(motor: MotorId, error: &str) -> Value {
    json!({"id": motor.get(), "error": error})
}

/// The error flags of a status 1, in its family's meaning, in words.
pub(crate) fn status1_errors_text(status: &Status1) -> String {
    match status {
        Status1::V161(s) => errors_text(s.error_state),
        Status1::Lk(s) => errors_text(s.error_state),
        Status1::V3(s) => v3_errors_text(s.error_state),
    }
}

/// A MyActuator V3 error code in words: `none`, `stall, low voltage`, ... (the names of
/// `rmd decode`'s `error_names`), and `code 0x....` for bits without a name.
pub(crate) fn v3_errors_text(state: V3ErrorState) -> String {
    if state.is_clear() {
        return "none".to_owned();
    }
    let mut parts: Vec<String> = crate::output::json::v3_error_names(state)
        .into_iter()
        .map(|name| name.replace('_', " "))
        .collect();
    if state.unknown_bits() != 0 {
        parts.push(format!("code 0x{:04X}", state.unknown_bits()));
    }
    parts.join(", ")
}

/// The protection flags in words: `none`, `low voltage`, `over temperature`, and unknown bits.
pub(crate) fn errors_text(state: ErrorState) -> String {
    let mut parts = Vec::new();
    if state.low_voltage() {
        parts.push("low voltage".to_owned());
    }
    if state.over_temperature() {
        parts.push("over temperature".to_owned());
    }
    if state.unknown_bits() != 0 {
        parts.push(format!("unknown bits 0x{:02X}", state.unknown_bits()));
    }
    if parts.is_empty() {
        "none".to_owned()
    } else {
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{Status1, Temperature, V161Status1, Voltage};

    #[test]
    fn objects_merge_reply_fields_under_decode_names() {
        let status = Status1::V161(V161Status1 {
            temperature: Temperature::new(30).unwrap(),
            voltage: Voltage::new(480).unwrap(),
            error_state: ErrorState::LOW_VOLTAGE,
        });
        let value = object(
            MotorId::new(2).unwrap(),
            &[Reply::ReadStatus1(status)],
            EncoderWidth::DEFAULT,
        );
        assert_eq!(value["id"], 2);
        assert_eq!(value["voltage_volts"], 48.0);
        assert_eq!(value["low_voltage"], true);
        assert!(value.get("command").is_none() && value.get("can_id").is_none());
    }

    #[test]
    fn v3_error_codes_in_words() {
        assert_eq!(v3_errors_text(V3ErrorState::from_raw(0)), "none");
        assert_eq!(
            v3_errors_text(V3ErrorState::from_raw(0x0004 | 0x1000 | 0x0100 | 0x0001)),
            "low voltage, over speed, motor over temperature, code 0x0001"
        );
    }

    #[test]
    fn flags_in_words() {
        assert_eq!(errors_text(ErrorState::NONE), "none");
        assert_eq!(
            errors_text(ErrorState::from_raw(0b1000_1001)),
            "low voltage, over temperature, unknown bits 0x80"
        );
    }
}
