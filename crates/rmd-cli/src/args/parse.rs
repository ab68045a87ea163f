//! clap value parsers for the protocol's typed values: a raw integer (or a physical value) in,
//! a validated value or the protocol's one-line error out.

use rmd_protocol::{
    AngleControl, EncoderWidth, FirmwareDate, LkSeries, MotorId, ProtocolError, ProtocolFamily,
    SingleTurnAngle, SpeedControl,
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

raw_parser!(speed_control, SpeedControl);
raw_parser!(angle_control, AngleControl);
raw_parser!(single_turn_angle, SingleTurnAngle);
raw_parser!(max_speed, rmd_protocol::MaxSpeed);
raw_parser!(accel, rmd_protocol::Accel);
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

/// A raw integer, checked later against a range that depends on other options (`--protocol`).
pub(crate) fn raw_int(text: &str) -> Result<i64, String> {
    int(text)
}

/// A number, checked later (NaN and infinities too) against a range that depends on other
/// options (`--protocol`).
pub(crate) fn number(text: &str) -> Result<f64, String> {
    float(text)
}

/// `A,B,C,D` raw integers (motors 1..=4), checked later.
pub(crate) fn raw_int4(text: &str) -> Result<[i64; 4], String> {
    four(text, raw_int)
}

/// `A,B,C,D` numbers (motors 1..=4), checked later.
pub(crate) fn number4(text: &str) -> Result<[f64; 4], String> {
    four(text, number)
}

/// `--protocol`: a protocol rmd-rt speaks, `v1.61`, `lk-v2.3x` or `myactuator-v3`.
pub(crate) fn protocol(text: &str) -> Result<ProtocolFamily, String> {
    match text.trim().parse::<ProtocolFamily>() {
        Ok(ProtocolFamily::Unknown) | Err(_) => Err(format!(
            "unknown protocol `{text}`: expected v1.61, lk-v2.3x or myactuator-v3"
        )),
        Ok(family) => Ok(family),
    }
}

/// `--firmware-date`: a MyActuator V3 firmware version date as 0xB2 reports it (`YYYYMMDD` or
/// `YYYYMMDDNN`, e.g. 2025070202).
pub(crate) fn firmware_date(text: &str) -> Result<FirmwareDate, String> {
    let digits = text.trim();
    match digits.parse::<u32>() {
        Ok(raw) if (8..=10).contains(&digits.len()) => Ok(FirmwareDate::from_raw(raw)),
        _ => Err(format!(
            "`{text}` is not a firmware date: expected YYYYMMDD or YYYYMMDDNN as 0xB2 reports \
             it (e.g. 2025070202)"
        )),
    }
}

/// `--lk-series`: `mf` or `mg`.
pub(crate) fn lk_series(text: &str) -> Result<LkSeries, String> {
    text.trim()
        .to_ascii_lowercase()
        .parse::<LkSeries>()
        .map_err(|_| format!("unknown LK-TECH motor series `{text}`: expected mf or mg"))
}

/// `--exchange`: `multi-torque`, `per-motor` or `motion` (MyActuator V3's motion mode).
pub(crate) fn exchange(text: &str) -> Result<rmd_loop::robot::ExchangeKind, String> {
    match text.trim() {
        "multi-torque" => Ok(rmd_loop::robot::ExchangeKind::MultiTorque),
        "per-motor" => Ok(rmd_loop::robot::ExchangeKind::PerMotor),
        "motion" => Ok(rmd_loop::robot::ExchangeKind::Motion),
        other => Err(format!(
            "`{other}` is no exchange: multi-torque, per-motor or motion"
        )),
    }
}

/// `--sim-firmware`: a firmware family the simulator emulates, `v1.61`, `lk-v2.3x` or
/// `myactuator-v3`.
pub(crate) fn sim_firmware(text: &str) -> Result<ProtocolFamily, String> {
    match text.trim().parse::<ProtocolFamily>() {
        Ok(ProtocolFamily::Unknown) | Err(_) => Err(format!(
            "unknown firmware `{text}`: expected v1.61, lk-v2.3x or myactuator-v3"
        )),
        Ok(family) => Ok(family),
    }
}

/// A probability, 0..=1.
pub(crate) fn probability(text: &str) -> Result<f64, String> {
    let p = float(text)?;
    if (0.0..=1.0).contains(&p) {
        Ok(p)
    } else {
        Err(format!("probability {p} must be within 0..=1"))
    }
}

/// A finite number above zero.
pub(crate) fn positive(text: &str) -> Result<f64, String> {
    let v = float(text)?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} must be a finite number above 0"))
    }
}

/// A finite number.
pub(crate) fn finite(text: &str) -> Result<f64, String> {
    let v = float(text)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} must be a finite number"))
    }
}

/// `MASS_KG,LENGTH_M[,OFFSET_DEG]`: a link under gravity on a motor's output.
pub(crate) fn gravity_link(text: &str) -> Result<rmd_sim::GravityLink, String> {
    let parts: Vec<&str> = text.split(',').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(format!(
            "`{text}`: expected MASS_KG,LENGTH_M[,OFFSET_DEG], e.g. 1.5,0.25 or 1.5,0.25,90"
        ));
    }
    let link = rmd_sim::GravityLink {
        mass_kg: float(parts[0])?,
        length_m: float(parts[1])?,
        angle_offset_deg: parts.get(2).map_or(Ok(0.0), |p| float(p))?,
    };
    link.validate().map_err(|e| e.to_string())?;
    Ok(link)
}

/// `PROBABILITY,MILLISECONDS`: replies sent late.
pub(crate) fn late_fault(text: &str) -> Result<(f64, std::time::Duration), String> {
    let Some((p, ms)) = text.split_once(',') else {
        return Err(format!(
            "`{text}`: expected PROBABILITY,MILLISECONDS, e.g. 0.1,5"
        ));
    };
    let p = probability(p)?;
    let ms = float(ms)?;
    if !(ms.is_finite() && (0.0..=60_000.0).contains(&ms)) {
        return Err(format!("late reply delay {ms} ms must be within 0..=60000"));
    }
    Ok((p, std::time::Duration::from_secs_f64(ms / 1e3)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn fault_and_load_options() {
        assert_eq!(probability("0.25"), Ok(0.25));
        assert!(probability("1.5").is_err());
        assert_eq!(late_fault("0.5,3"), Ok((0.5, Duration::from_millis(3))));
        assert!(late_fault("0.5").is_err());
        let link = gravity_link("1.5,0.25,90").unwrap();
        assert_eq!(
            (link.mass_kg, link.length_m, link.angle_offset_deg),
            (1.5, 0.25, 90.0)
        );
        assert_eq!(gravity_link("2,0.1").unwrap().angle_offset_deg, 0.0);
        assert!(gravity_link("-1,0.1").is_err());
        assert!(gravity_link("1").is_err());
        assert!(positive("0").is_err() && positive("inf").is_err());
    }

    #[test]
    fn protocol_names() {
        assert_eq!(protocol("v1.61"), Ok(ProtocolFamily::V161));
        assert_eq!(protocol("lk-v2.3x"), Ok(ProtocolFamily::LkV23x));
        assert_eq!(protocol("myactuator-v3"), Ok(ProtocolFamily::MyActuatorV3));
        assert!(
            protocol("unknown")
                .unwrap_err()
                .contains("expected v1.61, lk-v2.3x or myactuator-v3")
        );
        assert_eq!(
            firmware_date("2025070202").map(|d| d.raw()),
            Ok(2_025_070_202)
        );
        assert!(firmware_date("2025").is_err() && firmware_date("x").is_err());
        assert_eq!(lk_series("MF"), Ok(LkSeries::Mf));
        assert!(lk_series("ms").is_err());
        assert_eq!(
            sim_firmware("myactuator-v3"),
            Ok(ProtocolFamily::MyActuatorV3)
        );
        assert!(sim_firmware("unknown").is_err());
        assert_eq!(raw_int4("1,-2,3,4"), Ok([1, -2, 3, 4]));
        assert!(number4("1,2").is_err());
    }
}
