//! clap value parsers for the protocol's typed values: a raw integer (or a physical value) in,
//! a validated value or the protocol's one-line error out.

use rmd_protocol::{
    AngleControl, EncoderWidth, IqControl, MotorId, ProtocolError, SingleTurnAngle, SpeedControl,
};

fn int(text: &str) -> Result<i64, String> {
    text.trim()
        .parse::<i64>()
        .map_err(|_| format!("`{text}` is not an integer"))
}

fn float(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| format!("`{text}` is not a number"))
}

fn msg(err: ProtocolError) -> String {
    err.to_string()
}

/// `--id`: a motor id 1..=32.
pub(crate) fn motor_id(text: &str) -> Result<MotorId, String> {
    let id = int(text)?;
    let id = u8::try_from(id).map_err(|_| format!("invalid motor id {id}: must be 1..=32"))?;
    MotorId::new(id).map_err(msg)
}

/// `--encoder-bits`: 12..=18.
pub(crate) fn encoder_width(text: &str) -> Result<EncoderWidth, String> {
    let bits = int(text)?;
    let bits =
        u8::try_from(bits).map_err(|_| format!("encoder width {bits} bits: must be 12..=18"))?;
    EncoderWidth::new(bits).map_err(msg)
}

/// A raw integer checked by `new`.
macro_rules! raw_parser {
    ($fn_name:ident, $ty:ty) => {
        #[doc = concat!("A raw `", stringify!($ty), "`.")]
        pub(crate) fn $fn_name(text: &str) -> Result<$ty, String> {
            <$ty>::new(int(text)?).map_err(msg)
        }
    };
}

/// A physical value converted by `from_<unit>`.
macro_rules! physical_parser {
    ($fn_name:ident, $ty:ty, $from:ident) => {
        #[doc = concat!("A physical value for `", stringify!($ty), "`.")]
        pub(crate) fn $fn_name(text: &str) -> Result<$ty, String> {
            <$ty>::$from(float(text)?).map_err(msg)
        }
    };
}

raw_parser!(iq_control, IqControl);
raw_parser!(speed_control, SpeedControl);
raw_parser!(angle_control, AngleControl);
raw_parser!(single_turn_angle, SingleTurnAngle);
raw_parser!(max_speed, rmd_protocol::MaxSpeed);
raw_parser!(accel, rmd_protocol::Accel);
physical_parser!(iq_amps, IqControl, from_amps);
physical_parser!(speed_dps, SpeedControl, from_dps);
physical_parser!(angle_deg, AngleControl, from_degrees);
physical_parser!(single_turn_deg, SingleTurnAngle, from_degrees);

/// `A,B,C,D` of values parsed by `one`.
fn four<T: Copy + Default>(
    text: &str,
    one: fn(&str) -> Result<T, String>,
) -> Result<[T; 4], String> {
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != 4 {
        return Err(format!(
            "expected 4 comma-separated values (motors 1..=4), got {}",
            parts.len()
        ));
    }
    let mut out = [T::default(); 4];
    for (slot, part) in out.iter_mut().zip(parts) {
        *slot = one(part)?;
    }
    Ok(out)
}

/// `--iq-control A,B,C,D` of multi-torque.
pub(crate) fn iq_control4(text: &str) -> Result<[IqControl; 4], String> {
    four(text, iq_control)
}

/// `--amps A,B,C,D` of multi-torque.
pub(crate) fn iq_amps4(text: &str) -> Result<[IqControl; 4], String> {
    four(text, iq_amps)
}
