//! Arguments shared by several functions: the protocol dialect and the encoder width, checked
//! into rmd-protocol's types, and numbers and durations, refused unless finite and in range;
//! every message names the Python argument.

use std::time::Duration;

use pyo3::PyResult;
use rmd_protocol::{Dialect, EncoderWidth, LkSeries, ProtocolFamily, V3Firmware};

use crate::errors::ArgumentError;

/// The dialect of `protocol` (`"v1.61"`, `"lk-v2.3x"` or `"myactuator-v3"`) and `lk_series`
/// (`"mf"` / `"mg"`, required with `"lk-v2.3x"` only). A MyActuator V3 dialect's firmware date
/// is unknown: its motion-mode ranges are not used here.
pub(crate) fn dialect(protocol: &str, lk_series: Option<&str>) -> Result<Dialect, String> {
    let family = match protocol.trim().parse::<ProtocolFamily>() {
        Ok(
            family @ (ProtocolFamily::V161 | ProtocolFamily::LkV23x | ProtocolFamily::MyActuatorV3),
        ) => family,
        _ => {
            return Err(format!(
                "unknown protocol `{protocol}`: expected v1.61, lk-v2.3x or myactuator-v3"
            ));
        }
    };
    let series = match lk_series {
        None => None,
        Some(text) => Some(
            text.trim()
                .to_ascii_lowercase()
                .parse::<LkSeries>()
                .map_err(|_| format!("unknown LK-TECH motor series `{text}`: expected mf or mg"))?,
        ),
    };
    match (family, series) {
        (ProtocolFamily::LkV23x, Some(series)) => Ok(Dialect::LkV23x(series)),
        (ProtocolFamily::LkV23x, None) => Err(
            "protocol=\"lk-v2.3x\" needs the motors' series, lk_series=\"mf\" or \"mg\": the \
             current scale depends on it (MF ±16.5 A, MG ±33 A over ±2048)"
                .to_owned(),
        ),
        (_, Some(series)) => Err(format!(
            "lk_series=\"{}\" applies to LK-TECH motors: add protocol=\"lk-v2.3x\"",
            series.name()
        )),
        (ProtocolFamily::MyActuatorV3, None) => Ok(Dialect::MyActuatorV3(V3Firmware::default())),
        (_, None) => Ok(Dialect::V161),
    }
}

/// The encoder width of `encoder_bits` (12..=18).
pub(crate) fn encoder_width(bits: i64) -> Result<EncoderWidth, String> {
    let bits =
        u8::try_from(bits).map_err(|_| format!("encoder width {bits} bits: must be 12..=18"))?;
    EncoderWidth::new(bits).map_err(|e| e.to_string())
}

/// `value` if it is a finite number; else `ArgumentError` naming `name`.
pub(crate) fn finite(name: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ArgumentError::new_err(format!(
            "{name} = {value:?}: must be a finite number"
        )))
    }
}

/// A duration `value` in seconds, `0..=max_s`; else `ArgumentError` naming `name`.
pub(crate) fn seconds(name: &str, value: f64, max_s: f64) -> PyResult<Duration> {
    if !(value.is_finite() && (0.0..=max_s).contains(&value)) {
        return Err(ArgumentError::new_err(format!(
            "{name} = {value:?} s: must be a finite number of seconds, 0..={max_s}"
        )));
    }
    Ok(Duration::from_secs_f64(value))
}
