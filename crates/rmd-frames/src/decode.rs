//! One frame of a candump line to its JSON object, read as a request (host to motor) or as a
//! reply (motor to host): what `rmd decode` prints for a line once its role is decided.
//!
//! A reply with a field out of range (an `iq` beyond ±2048, an encoder value beyond the encoder
//! width) still gives every other field: the bad one is left out and named under `errors`
//! ([`Decoded::field_errors`]). Errors of the whole frame (identifier, DLC, unknown command
//! byte, a reply to another command) give no object, only the message.

use rmd_bus::candump::CandumpLine;
use rmd_protocol::{
    Command, DecodedRequest, Dialect, EncoderWidth, ProtocolError, V3_MOTION_REPLY_BASE_ID,
};
use serde_json::Value;

use crate::json::FrameJson;
use crate::partial;

/// A decoded frame: its object, and the fields that could not be read (each also under
/// `errors` in the object).
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// The JSON object (see [`crate::json`] for its keys).
    pub value: Value,
    /// One message per field left out, in the order of `errors`.
    pub field_errors: Vec<String>,
}

fn header(line: &CandumpLine, direction: &str, command: &str, width: EncoderWidth) -> FrameJson {
    FrameJson::new(
        line.timestamp,
        line.interface.as_deref(),
        line.frame.id(),
        direction,
        command,
        width,
    )
}

fn finish(json: FrameJson) -> Decoded {
    let field_errors = json.errors().iter().map(|e| e.message.clone()).collect();
    Decoded {
        value: json.into_value(),
        field_errors,
    }
}

/// The `command` of a MyActuator V3 motion-mode frame.
const MOTION: &str = "motion";

/// Reads `line`'s frame as a request in `dialect`; encoder values are checked against `width`.
/// The error is the one line `rmd decode` prints for it.
pub fn request(
    line: &CandumpLine,
    width: EncoderWidth,
    dialect: Dialect,
) -> Result<Decoded, String> {
    let request = dialect
        .decode_request(&line.frame)
        .map_err(|e| e.to_string())?;
    let command = match &request {
        DecodedRequest::Multi(_) => "multi-torque",
        DecodedRequest::Single { request, .. } | DecodedRequest::Broadcast(request) => {
            request
                .check_encoder_width(width)
                .map_err(|e| encoder_hint(e, width))?;
            request.command().name()
        }
        DecodedRequest::Mit { .. } => MOTION,
    };
    Ok(finish(
        header(line, "request", command, width).decoded_request(&request),
    ))
}

/// Reads `line`'s frame as a reply in `dialect`, to the pending request `pending` if known (a
/// reply to another command is then an error); encoder values are checked against `width`.
/// The error is the one line `rmd decode` prints for it.
pub fn reply(
    line: &CandumpLine,
    pending: Option<Command>,
    width: EncoderWidth,
    dialect: Dialect,
) -> Result<Decoded, String> {
    let frame = &line.frame;
    if matches!(dialect, Dialect::MyActuatorV3(_))
        && (V3_MOTION_REPLY_BASE_ID + 1..=V3_MOTION_REPLY_BASE_ID + 32).contains(&frame.id())
    {
        let (_, feedback) = dialect.decode_mit_reply(frame).map_err(|e| e.to_string())?;
        return Ok(finish(
            header(line, "reply", MOTION, width).mit_feedback(&feedback),
        ));
    }
    let decoded = match pending {
        Some(command) => dialect.decode_reply_to(frame, command),
        None => dialect.decode_reply(frame),
    };
    let json = match decoded {
        Ok((_, reply)) => header(line, "reply", reply.command().name(), width)
            .checking_encoder_width()
            .reply(&reply),
        // Identifier, DLC, command byte and pairing passed: one field is out of range.
        Err(error @ ProtocolError::ValueOutOfRange { .. }) => {
            let command = frame
                .data()
                .first()
                .and_then(|&code| Command::from_code(code))
                .ok_or_else(|| error.to_string())?;
            let json = header(line, "reply", command.name(), width).checking_encoder_width();
            partial::partial_reply(json, dialect, command, frame)
                .ok_or_else(|| error.to_string())?
        }
        Err(error) => return Err(error.to_string()),
    };
    Ok(finish(json))
}

fn encoder_hint(err: ProtocolError, width: EncoderWidth) -> String {
    format!(
        "{err} for a {}-bit encoder (see --encoder-bits)",
        width.bits()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::candump::parse_line;

    #[test]
    fn a_reply_with_one_field_out_of_range_keeps_the_others() {
        let line = parse_line("141#9C1E0009F6FF0010").unwrap();
        let decoded = reply(&line, None, EncoderWidth::DEFAULT, Dialect::V161).unwrap();
        assert_eq!(decoded.value["speed_dps"], -10.0);
        assert_eq!(
            decoded.field_errors,
            ["iq 2304 is out of range -2048..=2048"]
        );
    }

    #[test]
    fn whole_frame_errors_give_no_object() {
        let line = parse_line("141#9C1E00").unwrap();
        assert!(reply(&line, None, EncoderWidth::DEFAULT, Dialect::V161).is_err());
        let line = parse_line("141#EE00000000000000").unwrap();
        assert!(request(&line, EncoderWidth::DEFAULT, Dialect::V161).is_err());
        // A status 2 reply to a pending status 1 request.
        let line = parse_line("141#9C1E000000000000").unwrap();
        assert!(
            reply(
                &line,
                Some(Command::ReadStatus1),
                EncoderWidth::DEFAULT,
                Dialect::V161
            )
            .is_err()
        );
    }

    #[test]
    fn an_encoder_offset_request_beyond_the_width_names_the_flag() {
        let line = parse_line("141#910000000000FFFF").unwrap();
        let error = request(&line, EncoderWidth::DEFAULT, Dialect::V161).unwrap_err();
        assert!(
            error.ends_with("for a 14-bit encoder (see --encoder-bits)"),
            "{error}"
        );
    }
}
