//! What every example's `main` uses besides `rmd-rig`: a status-line part for the motors and a
//! value parser for its own flags.

use core::fmt;

use rmd_loop::telemetry::TelemetrySample;

/// The largest torque current and temperature of any motor so far (a part of the examples'
/// status lines): `|iq| <= 2.3 A  25 degC`.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct MotorExtremes {
    /// Largest torque current magnitude, A.
    pub max_abs_current_amps: f64,
    /// Highest temperature, degrees Celsius.
    pub max_temperature_celsius: f64,
}

impl MotorExtremes {
    /// Takes one tick into account.
    pub fn observe(&mut self, sample: &TelemetrySample) {
        for j in sample.joints() {
            let motor = &j.feedback.motor;
            self.max_abs_current_amps = self.max_abs_current_amps.max(motor.current_amps.abs());
            self.max_temperature_celsius =
                self.max_temperature_celsius.max(motor.temperature_celsius);
        }
    }
}

impl fmt::Display for MotorExtremes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "|iq| <= {:.1} A  {:.0} degC",
            self.max_abs_current_amps, self.max_temperature_celsius
        )
    }
}

/// Parses a finite number (a clap value parser for the examples' own flags): `inf`, `NaN` and
/// anything not a number are errors that say so.
///
/// ```
/// use rmd_demos::support::parse_finite;
/// assert_eq!(parse_finite("-20"), Ok(-20.0));
/// assert!(parse_finite("inf").is_err());
/// assert!(parse_finite("NaN").is_err());
/// assert!(parse_finite("ten").is_err());
/// ```
pub fn parse_finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("`{text}` is not a finite number")),
        Err(e) => Err(format!("`{text}` is not a number ({e})")),
    }
}
