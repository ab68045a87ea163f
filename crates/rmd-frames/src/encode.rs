//! The values of `rmd encode` whose range depends on more than their own type: the torque
//! current (on the protocol dialect's scale: v1.61, LK-TECH's series, MyActuator V3's 0.01 A)
//! and the encoder offset (on the encoder's width).
//! Their messages name the `rmd encode` flags (`--iq-control`, `--amps`, `--encoder-offset`,
//! `--encoder-bits`); the Python package's keyword arguments have the same names in snake case.
//!
//! ```
//! use rmd_protocol::{Dialect, EncoderWidth, LkSeries};
//! use rmd_frames::encode::{encoder_offset, torque_current};
//!
//! assert_eq!(torque_current(Dialect::V161, None, Some(1.6))?.raw(), 100);
//! let error = torque_current(Dialect::LkV23x(LkSeries::Mf), None, Some(20.0)).unwrap_err();
//! assert!(error.starts_with("--amps 20: lk-v2.3x (MF) takes -16.5..=16.5 A"), "{error}");
//! // MyActuator V3: 0.01 A per step, 1 A is 100.
//! let v3 = Dialect::MyActuatorV3(Default::default());
//! assert_eq!(torque_current(v3, None, Some(1.0))?.raw(), 100);
//! assert!(encoder_offset(4096, EncoderWidth::new(12)?).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use rmd_protocol::{Dialect, EncoderValue, EncoderWidth, ProtocolError, ScaledCurrent};

/// The torque current of `--iq-control` (`raw`, in the dialect's steps) or `--amps`, in
/// `dialect`'s `iqControl` scale; `raw` wins when both are given. The error is `rmd encode`'s
/// message.
pub fn torque_current(
    dialect: Dialect,
    raw: Option<i64>,
    amps: Option<f64>,
) -> Result<ScaledCurrent, String> {
    let scale = dialect.iq_control_scale();
    match (raw, amps) {
        (Some(raw), _) => ScaledCurrent::new(raw, scale)
            .map_err(|e| format!("--iq-control: {e} in {dialect} ({scale})")),
        (None, Some(amps)) => ScaledCurrent::from_amps(amps, scale).map_err(|e| match e {
            ProtocolError::ValueOutOfRange { .. } => format!(
                "--amps {amps}: {dialect} takes {}..={} A; {e}",
                scale.amps(scale.min_raw()),
                scale.amps(scale.max_raw())
            ),
            other => format!("--amps: {other}"),
        }),
        (None, None) => Err("missing --iq-control or --amps".to_owned()),
    }
}

/// The encoder offset of `--encoder-offset` for an encoder of `width` (`--encoder-bits`). The
/// error is `rmd encode`'s message.
pub fn encoder_offset(raw: i64, width: EncoderWidth) -> Result<EncoderValue, String> {
    EncoderValue::new(raw, width).map_err(|e| {
        format!(
            "--encoder-offset: {e} for a {}-bit encoder (see --encoder-bits)",
            width.bits()
        )
    })
}
