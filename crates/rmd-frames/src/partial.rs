//! Field-by-field decoding of a reply whose strict decoding failed on one field's range, so that
//! every other field is still shown (`rmd decode` names the bad one under `errors`).
//!
//! rmd-protocol's decoders are strict on purpose: an `iq` of 3000 means a corrupt frame or other
//! firmware, not a value to hand to a controller. A log decoder wants the rest of such a frame
//! (temperature, speed, encoder) all the same. Only two reply layouts have fields with a range
//! narrower than their wire type, and only they are read here, with the layouts rmd-protocol
//! documents:
//!
//! - status 2 (0x9C and the control replies 0xA1..=0xA6), every dialect: DATA\[1\] temperature,
//!   DATA\[2..=3\] `iq` (±2048 in v1.61's and LK-TECH's scales), DATA\[4..=5\] speed,
//!   DATA\[6..=7\] the encoder (V3: the output angle) (`rmd_protocol::Status2`);
//! - the u16 single-turn angle (0x94) of v1.61 and V4.3 firmware: DATA\[6..=7\] `circleAngle`,
//!   0..=35999 (`rmd_protocol::CircleAngle`).
//!
//! The identifier, the DLC, the command byte and the pairing with the pending request are
//! checked by the strict decoder before any field, so a frame reaching this module has passed
//! them.

use rmd_protocol::{
    CanFrame, CircleAngle, Command, Dialect, EncoderValue, OutputAngle, ScaledCurrent, Speed,
    StatusPosition, Temperature, V3Revision,
};

use crate::json::{FieldError, FrameJson};

/// Adds the fields of `frame`, a reply to `command` in `dialect` whose strict decoding failed
/// with a value out of range, to `json`; `None` if the frame has no layout with such fields (the
/// strict decoder's error then stands for the whole frame).
pub fn partial_reply(
    json: FrameJson,
    dialect: Dialect,
    command: Command,
    frame: &CanFrame,
) -> Option<FrameJson> {
    let d = frame.data8()?;
    let mut json = json;
    match command {
        Command::ReadStatus2
        | Command::Torque
        | Command::Speed
        | Command::Position1
        | Command::Position2
        | Command::Position3
        | Command::Position4 => {
            let temperature = Temperature::new(i64::from(d[1] as i8)).ok()?;
            let iq = ScaledCurrent::new(i64::from(i16_at(d, 2)), dialect.iq_scale());
            let speed = Speed::new(i64::from(i16_at(d, 4))).ok()?;
            let position = match dialect {
                Dialect::MyActuatorV3(_) => {
                    StatusPosition::OutputDegrees(OutputAngle::new(i64::from(i16_at(d, 6))).ok()?)
                }
                Dialect::V161 | Dialect::LkV23x(_) => {
                    StatusPosition::Encoder(EncoderValue::from_raw(u16_at(d, 6)))
                }
            };
            json.partial_status2(temperature, iq.map_err(field), speed, position);
        }
        Command::ReadSingleTurnAngle
            if match dialect {
                Dialect::V161 => true,
                Dialect::MyActuatorV3(f) => f.revision() == V3Revision::V4_3,
                Dialect::LkV23x(_) => false,
            } =>
        {
            json.circle_angle(CircleAngle::new(i64::from(u16_at(d, 6))).map_err(field));
        }
        _ => return None,
    }
    Some(json)
}

/// The field a range error names.
fn field(error: rmd_protocol::ProtocolError) -> FieldError {
    FieldError::from_protocol(error).unwrap_or_else(|other| FieldError {
        key: "frame".to_owned(),
        raw: 0,
        message: other.to_string(),
    })
}

fn i16_at(d: &[u8; 8], at: usize) -> i16 {
    i16::from_le_bytes([d[at], d[at + 1]])
}

fn u16_at(d: &[u8; 8], at: usize) -> u16 {
    u16::from_le_bytes([d[at], d[at + 1]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{EncoderWidth, LkSeries};
    use serde_json::json;

    fn header() -> FrameJson {
        FrameJson::new(None, None, 0x141, "reply", "x", EncoderWidth::DEFAULT)
            .checking_encoder_width()
    }

    #[test]
    fn status2_keeps_every_field_but_iq() {
        // iq = 0x0900 = 2304, beyond ±2048; 30 °C, -10 dps, encoder 0x1000.
        let frame = CanFrame::new(0x141, &[0x9C, 30, 0x00, 0x09, 0xF6, 0xFF, 0x00, 0x10]).unwrap();
        assert!(Dialect::V161.decode_reply(&frame).is_err());
        let json = partial_reply(header(), Dialect::V161, Command::ReadStatus2, &frame).unwrap();
        assert_eq!(json.errors().len(), 1);
        let v = json.into_value();
        assert_eq!(v["temperature_celsius"], 30.0);
        assert_eq!(v["speed_dps"], -10.0);
        assert_eq!(v["encoder"], 0x1000);
        assert!(v.get("iq").is_none() && v.get("iq_amps").is_none());
        assert_eq!(
            v["errors"],
            json!([{"field": "iq", "raw": 2304, "error": "iq 2304 is out of range -2048..=2048"}])
        );
    }

    #[test]
    fn an_encoder_beyond_the_width_is_a_second_error() {
        let frame = CanFrame::new(0x141, &[0xA1, 30, 0x00, 0x90, 0, 0, 0xFF, 0xFF]).unwrap();
        let json = partial_reply(
            header(),
            Dialect::LkV23x(LkSeries::Mf),
            Command::Torque,
            &frame,
        )
        .unwrap();
        let keys: Vec<&str> = json.errors().iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["iq", "encoder"]);
        assert_eq!(
            json.errors()[1].message,
            "encoder 65535 is out of range 0..=16383 for a 14-bit encoder (see --encoder-bits)"
        );
    }

    #[test]
    fn a_single_turn_angle_beyond_one_turn() {
        let frame = CanFrame::new(0x141, &[0x94, 0, 0, 0, 0, 0, 0xA0, 0x8C]).unwrap();
        let json = partial_reply(
            header(),
            Dialect::V161,
            Command::ReadSingleTurnAngle,
            &frame,
        )
        .unwrap();
        assert_eq!(
            json.errors()[0].message,
            "circle_angle 36000 is out of range 0..=35999"
        );
        // LK's u32 angle has no narrower range: nothing to do field by field.
        assert!(
            partial_reply(
                header(),
                Dialect::LkV23x(LkSeries::Mg),
                Command::ReadSingleTurnAngle,
                &frame
            )
            .is_none()
        );
        assert!(partial_reply(header(), Dialect::V161, Command::ReadStatus1, &frame).is_none());
    }
}
