//! Known motor models as plain data, each value with its source.

use crate::dialect::{Dialect, LkSeries};
use crate::encoder::EncoderWidth;
use crate::family::ProtocolFamily;
use crate::mit_ranges::MotorMaxTorque;
use crate::names::NameError;
use crate::scale::CurrentScale;
use crate::v3::V3Firmware;

/// A value and where it comes from (document and version, or repository and path).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Sourced<T> {
    /// The value.
    pub value: T,
    /// Its source.
    pub source: &'static str,
}

impl<T> Sourced<T> {
    /// A value from `source`.
    pub const fn new(value: T, source: &'static str) -> Self {
        Self { value, source }
    }

    /// A value the caller set (its source reads "set by the caller").
    pub const fn caller(value: T) -> Self {
        Self {
            value,
            source: "set by the caller",
        }
    }
}

/// One motor model. Plain data: copy it out of [`MODELS`] and change what you need.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MotorModel {
    /// Stable name (lower case), as the robot description's `model = "..."` gives it.
    pub name: &'static str,
    /// What it is, in a few words.
    pub description: &'static str,
    /// The protocol family its firmware speaks.
    pub family: ProtocolFamily,
    /// The dialect rmd-rt speaks to it (for V3: without a firmware date, with the model's
    /// maximum torque when known).
    pub dialect: Dialect,
    /// Amperes per `iqControl` step (0xA1, 0x280) and its range.
    pub iq_control_scale: Sourced<CurrentScale>,
    /// Amperes per `iq` step in replies (0x9C, 0xA1..=0xA6) and its range.
    pub iq_scale: Sourced<CurrentScale>,
    /// Torque constant at the output shaft, N·m per ampere of torque current.
    pub torque_constant_nm_per_a: Option<Sourced<f64>>,
    /// Gear ratio (motor turns per output turn).
    pub gear_ratio: Option<Sourced<f64>>,
    /// Encoder resolution.
    pub encoder_bits: Option<Sourced<EncoderWidth>>,
    /// Rated (continuous) current, A.
    pub rated_current_a: Option<Sourced<f64>>,
    /// Maximum (peak) current, A.
    pub max_current_a: Option<Sourced<f64>>,
    /// Maximum torque at the output, N·m: for MyActuator V3, the motion-mode torque range of
    /// V4.4 firmware ([`MitRanges::v4_4`](crate::MitRanges::v4_4)).
    pub max_torque_nm: Option<Sourced<f64>>,
}

const fn bits(n: u8) -> EncoderWidth {
    match EncoderWidth::new(n) {
        Ok(w) => w,
        // Evaluated at compile time for the constants below: a wrong width fails the build.
        Err(_) => panic!("encoder width outside 12..=18"),
    }
}

const SPEC: &str = "gyems-can-v1.61 (32 A over 2000 for iqControl, 33 A over 2048 for iq)";
const V3_DOC: &str = "MyActuator Servo Motor Control Protocol (driver V3) V4.3 §2.15 / §2.19, \
                      V4.4 §2.14 / §2.18: 0.01 A/LSB";
const LK_MF: &str = "LK-TECH CAN protocol V2.35, 0xA1: MF -16.5A~16.5A over -2048~2048";
const LK_MG: &str = "LK-TECH CAN protocol V2.35, 0xA1: MG -33A~33A over -2048~2048";

const fn v161(
    name: &'static str,
    description: &'static str,
    kt: Sourced<f64>,
    ratio: Sourced<f64>,
    rated: Sourced<f64>,
) -> MotorModel {
    MotorModel {
        name,
        description,
        family: ProtocolFamily::V161,
        dialect: Dialect::V161,
        iq_control_scale: Sourced::new(CurrentScale::V161_IQ_CONTROL, SPEC),
        iq_scale: Sourced::new(CurrentScale::V161_IQ, SPEC),
        torque_constant_nm_per_a: Some(kt),
        gear_ratio: Some(ratio),
        // No public source gives the encoder width of the v1.61-era RMD-X motors.
        encoder_bits: None,
        rated_current_a: Some(rated),
        max_current_a: None,
        max_torque_nm: None,
    }
}

/// A MyActuator V3 model of the given maximum torque (if known).
const fn v3_dialect(max_torque_milli_nm: Option<u32>) -> Dialect {
    Dialect::MyActuatorV3(V3Firmware {
        date: None,
        max_torque: match max_torque_milli_nm {
            Some(m) => Some(MotorMaxTorque::from_milli_nm(m)),
            None => None,
        },
    })
}

/// A MyActuator V3 model of `[myactuator_rmd]`: gear ratio, rated current, and the output
/// torque constant converted from the manufacturer's motor-side figure (`None` where it is not
/// credible: said where the model is listed).
const fn v3(
    name: &'static str,
    description: &'static str,
    kt: Option<Sourced<f64>>,
    ratio: Sourced<f64>,
    rated: Sourced<f64>,
) -> MotorModel {
    MotorModel {
        name,
        description,
        family: ProtocolFamily::MyActuatorV3,
        dialect: v3_dialect(None),
        iq_control_scale: Sourced::new(CurrentScale::MYACTUATOR_V3_IQ_CONTROL, V3_DOC),
        iq_scale: Sourced::new(CurrentScale::MYACTUATOR_V3_IQ, V3_DOC),
        torque_constant_nm_per_a: kt,
        gear_ratio: Some(ratio),
        encoder_bits: None,
        rated_current_a: Some(rated),
        max_current_a: None,
        max_torque_nm: None,
    }
}

/// A MyActuator V3 model known only by `[axol]`'s series table: its maximum torque.
const fn v3_series(name: &'static str, description: &'static str, max: Sourced<f64>) -> MotorModel {
    MotorModel {
        name,
        description,
        family: ProtocolFamily::MyActuatorV3,
        dialect: v3_dialect(Some((max.value * 1000.0) as u32)),
        iq_control_scale: Sourced::new(CurrentScale::MYACTUATOR_V3_IQ_CONTROL, V3_DOC),
        iq_scale: Sourced::new(CurrentScale::MYACTUATOR_V3_IQ, V3_DOC),
        torque_constant_nm_per_a: None,
        gear_ratio: None,
        encoder_bits: None,
        rated_current_a: None,
        max_current_a: None,
        max_torque_nm: Some(max),
    }
}

/// Known motor models as plain data, each value with its source.
///
/// A [`MotorModel`] says which family a motor speaks, the scales of its current fields, and the
/// mechanical values a controller needs (gear ratio, torque constant at the output, encoder
/// width, rated and maximum current, the maximum torque V4.4 firmware scales its motion mode
/// by). Look one up by its stable name with [`find_model`]; every field is public, so a caller
/// overrides any value by assigning it (use [`Sourced::caller`] for the source). Values without
/// a public source are left out (`None`), not guessed; where a vendor figure is the motor's
/// (before the gearbox) the source says so and the value is converted to the output.
///
/// Sources used below:
///
/// - `[spec]`: gyems-can-v1.61 (the protocol document this crate implements): the scales of
///   `iqControl` (32 A / 2000) and `iq` (33 A / 2048).
/// - `[myactuator_rmd]`: github.com/2b-t/myactuator_rmd
///   `include/myactuator_rmd/actuator_constants.hpp` (transcriptions of MyActuator's product
///   pages, class per model; the "manufacturer" torque constants are its comments).
/// - `[myactuator_rmd]` also names MyActuator's own torque constants of the V3 motors ("manufacturer:
///   0.17" for the X6 V3, ...). They are the motor's, before the gearbox (github.com/2b-t/myactuator_rmd
///   issue 6: the V3 figures are motor-side; multiplied by the gear ratio they come within 10 % of
///   rated torque over rated current for the X6, X8-H and X10 V3): the table multiplies them by
///   the gear ratio.
/// - `[V3 doc]`: MyActuator "Servo Motor Control Protocol" V4.3 (applicable driver V3), §2.15 and
///   §2.19, and V4.4, §2.14 and §2.18: 0.01 A per LSB.
/// - `[axol]`: github.com/almond-bot/axol `almond_axol/motor/myactuator.py` (HEAD 3d3c09c),
///   `_MA_SERIES_MAX_TORQUE = {6: 60.0, 8: 129.0}`: the maximum torque, N·m, by the `X<n>` series
///   in the 0xB5 model string (its examples: "RMD-X6-P20", "RMD-X8-P20"), used as the V4.4
///   motion-mode torque range.
/// - `[LK V2.35]`: LK-TECH CAN protocol V2.35, torque closed-loop command (0xA1): MF ±16.5 A, MG
///   ±33 A over ±2048 (quoted in github.com/aj3944/step-pyjoco `embedded/src/commands.py`).
/// - `[librmcs]`: github.com/Alliance-Algorithm/librmcs `librmcs/device/lk_motor.hpp` (commit
///   b82f2eaf), `Type::MG4005E_I10`: `raw_angle_max_ = 65535`, `current_max = 33.0`,
///   `torque_constant = 0.06`, `reduction_ratio = 10.0`.
/// - `[smc-powers]`: SMC-Powers product page "MG8016 Duo Robot dog Motor with Gear box & CAN
///   Driver" (shop.smc-powers.com/MG8016-DUO-CAN.html), LK MG series table, column MG4005:
///   nominal current 1.6 A, torque constant 0.06 N·m/A, gear ratio 10:1.
/// - `[mf4005]`: github.com/uLipe/lkmotor_mf4005_driver `drivers/lkm_mf4005_motor_regs.h`
///   (16500 mA over 2048) and `dts/bindings/lkm-mf4005.yml` (`encoder-resolution-bits = <16>`).
/// - `[mf9025]`: github.com/offisaac/23_Balance_Second
///   `digital_chassis/USP/Drivers/MF9025_v2/MF9025_v2.cpp` (`RATIO_CURRENT_TO_A 16.5f / 2048.f`,
///   `RATIO_ENCODER_TO_ANGLE 360 / 65536.f`, `TORQUE_CONSTANT 0.32f` for the 16T winding).
///
/// ```
/// use rmd_protocol::{Dialect, LkSeries, ProtocolFamily, Sourced, find_model};
/// let mut mg = *find_model("mg4005e-i10").unwrap();
/// assert_eq!(mg.family, ProtocolFamily::LkV23x);
/// assert_eq!(mg.dialect, Dialect::LkV23x(LkSeries::Mg));
/// assert_eq!(mg.encoder_bits.unwrap().value.bits(), 16);
/// // Override a value: this robot's gearbox is 6:1.
/// mg.gear_ratio = Some(Sourced::caller(6.0));
/// assert_eq!(mg.gear_ratio.unwrap().source, "set by the caller");
/// assert!(find_model("rmd-x9").is_err());
/// ```
///
/// Every known model.
pub const MODELS: &[MotorModel] = &[
    v161(
        "rmd-x4-v2",
        "MyActuator RMD-X4 V2 (1:10), protocol v1.61",
        Sourced::new(
            0.625,
            "myactuator_rmd actuator_constants.hpp, X4V2 (manufacturer: 0.625)",
        ),
        Sourced::new(
            10.0,
            "myactuator_rmd actuator_constants.hpp, X4V2 reducer_ratio",
        ),
        Sourced::new(
            1.6,
            "myactuator_rmd actuator_constants.hpp, X4V2 rated_current",
        ),
    ),
    v161(
        "rmd-x6-v2",
        "MyActuator RMD-X6 V2 (1:6), protocol v1.61",
        Sourced::new(
            0.88,
            "myactuator_rmd actuator_constants.hpp, X6V2 (manufacturer: 0.88)",
        ),
        Sourced::new(
            6.0,
            "myactuator_rmd actuator_constants.hpp, X6V2 reducer_ratio",
        ),
        Sourced::new(
            4.0,
            "myactuator_rmd actuator_constants.hpp, X6V2 rated_current",
        ),
    ),
    v161(
        "rmd-x8-v2",
        "MyActuator RMD-X8 V2 (1:9), protocol v1.61",
        Sourced::new(
            2.09,
            "myactuator_rmd actuator_constants.hpp, X8V2 (manufacturer: 2.09)",
        ),
        Sourced::new(
            9.0,
            "myactuator_rmd actuator_constants.hpp, X8V2 reducer_ratio",
        ),
        Sourced::new(
            4.3,
            "myactuator_rmd actuator_constants.hpp, X8V2 rated_current",
        ),
    ),
    v161(
        "rmd-x8-pro-v2",
        "MyActuator RMD-X8 Pro V2 (1:9), protocol v1.61",
        Sourced::new(
            2.6,
            "myactuator_rmd actuator_constants.hpp, X8ProV2 (manufacturer: 2.6)",
        ),
        Sourced::new(
            9.0,
            "myactuator_rmd actuator_constants.hpp, X8ProV2 reducer_ratio",
        ),
        Sourced::new(
            5.0,
            "myactuator_rmd actuator_constants.hpp, X8ProV2 rated_current",
        ),
    ),
    v3(
        "rmd-x4-v3",
        "MyActuator RMD-X4 V3 (1:6), firmware V3",
        // The manufacturer's 0.35 N·m/A times 6 (2.1) is five times rated torque over rated
        // current (1.2 / 3 = 0.4): the two disagree, the value is left out.
        None,
        Sourced::new(
            6.0,
            "myactuator_rmd actuator_constants.hpp, X4V3 reducer_ratio",
        ),
        Sourced::new(
            3.0,
            "myactuator_rmd actuator_constants.hpp, X4V3 rated_current",
        ),
    ),
    v3(
        "rmd-x6-v3",
        "MyActuator RMD-X6 V3 (1:8), firmware V3",
        Some(Sourced::new(
            0.17 * 8.0,
            "0.17 N·m/A at the motor (myactuator_rmd actuator_constants.hpp, X6V3 \"manufacturer: \
             0.17\"; motor-side per myactuator_rmd issue 6) × gear ratio 8; rated torque over \
             rated current gives 1.25",
        )),
        Sourced::new(
            8.0,
            "myactuator_rmd actuator_constants.hpp, X6V3 reducer_ratio",
        ),
        Sourced::new(
            3.6,
            "myactuator_rmd actuator_constants.hpp, X6V3 rated_current",
        ),
    ),
    v3(
        "rmd-x8-h-v3",
        "MyActuator RMD-X8-H V3 (1:6.2), firmware V3",
        Some(Sourced::new(
            0.30 * 6.2,
            "0.30 N·m/A at the motor (myactuator_rmd actuator_constants.hpp, X8HV3 \"manufacturer: \
             0.30\"; motor-side per myactuator_rmd issue 6) × gear ratio 6.2; rated torque over \
             rated current gives 1.71",
        )),
        Sourced::new(
            6.2,
            "myactuator_rmd actuator_constants.hpp, X8HV3 reducer_ratio",
        ),
        Sourced::new(
            3.5,
            "myactuator_rmd actuator_constants.hpp, X8HV3 rated_current",
        ),
    ),
    v3(
        "rmd-x8-pro-h-v3",
        "MyActuator RMD-X8-Pro-H V3 (1:6.2), firmware V3",
        Some(Sourced::new(
            0.29 * 6.2,
            "0.29 N·m/A at the motor (myactuator_rmd actuator_constants.hpp, X8ProHV3 \
             \"manufacturer: 0.29\"; motor-side per myactuator_rmd issue 6) × gear ratio 6.2; \
             rated torque over rated current gives 2.13",
        )),
        Sourced::new(
            6.2,
            "myactuator_rmd actuator_constants.hpp, X8ProHV3 reducer_ratio",
        ),
        Sourced::new(
            3.75,
            "myactuator_rmd actuator_constants.hpp, X8ProHV3 rated_current",
        ),
    ),
    v3(
        "rmd-x10-v3",
        "MyActuator RMD-X10 V3 (1:7), firmware V3",
        Some(Sourced::new(
            0.32 * 7.0,
            "0.32 N·m/A at the motor (myactuator_rmd actuator_constants.hpp, X10V3 \"manufacturer: \
             0.32\"; motor-side per myactuator_rmd issue 6) × gear ratio 7; rated torque over \
             rated current gives 2.26",
        )),
        Sourced::new(
            7.0,
            "myactuator_rmd actuator_constants.hpp, X10V3 reducer_ratio",
        ),
        Sourced::new(
            5.3,
            "myactuator_rmd actuator_constants.hpp, X10V3 rated_current",
        ),
    ),
    v3_series(
        "rmd-x6-p20",
        "MyActuator RMD-X6-P20, firmware V3 (X6 series of axol's table)",
        Sourced::new(
            60.0,
            "axol myactuator.py _MA_SERIES_MAX_TORQUE[6] (the series of \"RMD-X6-P20\")",
        ),
    ),
    v3_series(
        "rmd-x8-p20",
        "MyActuator RMD-X8-P20, firmware V3 (X8 series of axol's table)",
        Sourced::new(
            129.0,
            "axol myactuator.py _MA_SERIES_MAX_TORQUE[8] (the series of \"RMD-X8-P20\")",
        ),
    ),
    MotorModel {
        name: "mg4005e-i10",
        description: "LK-TECH MG4005E-i10 (1:10), protocol V2.3x, MG series",
        family: ProtocolFamily::LkV23x,
        dialect: Dialect::LkV23x(LkSeries::Mg),
        iq_control_scale: Sourced::new(CurrentScale::LK_MG_IQ_CONTROL, LK_MG),
        iq_scale: Sourced::new(CurrentScale::LK_MG_IQ, LK_MG),
        torque_constant_nm_per_a: Some(Sourced::new(
            0.6,
            "0.06 N·m/A at the motor (smc-powers MG table, MG4005; librmcs lk_motor.hpp \
             torque_constant 0.06) × gear ratio 10",
        )),
        gear_ratio: Some(Sourced::new(
            10.0,
            "librmcs lk_motor.hpp MG4005E_I10 reduction_ratio; smc-powers MG table",
        )),
        encoder_bits: Some(Sourced::new(
            bits(16),
            "librmcs lk_motor.hpp MG4005E_I10 raw_angle_max_ = 65535",
        )),
        rated_current_a: Some(Sourced::new(
            1.6,
            "smc-powers MG table, MG4005 nominal current",
        )),
        max_current_a: None,
        max_torque_nm: None,
    },
    MotorModel {
        name: "mf4005",
        description: "LK-TECH MF4005 (direct drive), protocol V2.3x, MF series",
        family: ProtocolFamily::LkV23x,
        dialect: Dialect::LkV23x(LkSeries::Mf),
        iq_control_scale: Sourced::new(CurrentScale::LK_MF_IQ_CONTROL, LK_MF),
        iq_scale: Sourced::new(CurrentScale::LK_MF_IQ, LK_MF),
        torque_constant_nm_per_a: None,
        gear_ratio: None,
        encoder_bits: Some(Sourced::new(
            bits(16),
            "github.com/uLipe/lkmotor_mf4005_driver dts/bindings/lkm-mf4005.yml",
        )),
        rated_current_a: None,
        max_current_a: None,
        max_torque_nm: None,
    },
    MotorModel {
        name: "mf9025-v2",
        description: "LK-TECH MF9025 V2 (direct drive, 16T winding), protocol V2.3x, MF series",
        family: ProtocolFamily::LkV23x,
        dialect: Dialect::LkV23x(LkSeries::Mf),
        iq_control_scale: Sourced::new(CurrentScale::LK_MF_IQ_CONTROL, LK_MF),
        iq_scale: Sourced::new(CurrentScale::LK_MF_IQ, LK_MF),
        torque_constant_nm_per_a: Some(Sourced::new(
            0.32,
            "github.com/offisaac/23_Balance_Second MF9025_v2.cpp TORQUE_CONSTANT (16T)",
        )),
        gear_ratio: None,
        encoder_bits: Some(Sourced::new(
            bits(16),
            "github.com/offisaac/23_Balance_Second MF9025_v2.cpp RATIO_ENCODER_TO_ANGLE 360/65536",
        )),
        rated_current_a: None,
        max_current_a: None,
        max_torque_nm: None,
    },
];

/// The model named `name` (exactly as in [`MODELS`]), else [`NameError::Model`].
pub fn find_model(name: &str) -> Result<&'static MotorModel, NameError> {
    MODELS
        .iter()
        .find(|m| m.name == name)
        .ok_or(NameError::Model)
}

impl MotorModel {
    /// The output torque of a torque current, N·m, if the torque constant is known.
    pub fn torque_nm(&self, amps: f64) -> Option<f64> {
        self.torque_constant_nm_per_a.map(|k| k.value * amps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_lower_case_and_found() {
        for (i, m) in MODELS.iter().enumerate() {
            assert!(
                !m.name.bytes().any(|b| b.is_ascii_uppercase()),
                "{}",
                m.name
            );
            assert!(MODELS[i + 1..].iter().all(|o| o.name != m.name));
            assert_eq!(find_model(m.name), Ok(m));
        }
    }

    #[test]
    fn lk_models_carry_16_bit_encoders() {
        for name in ["mg4005e-i10", "mf4005", "mf9025-v2"] {
            let m = find_model(name).unwrap();
            assert_eq!(m.encoder_bits.unwrap().value.bits(), 16, "{name}");
            assert_eq!(m.family, ProtocolFamily::LkV23x, "{name}");
        }
        assert_eq!(
            find_model("mf4005")
                .unwrap()
                .iq_control_scale
                .value
                .max_amps(),
            16.5
        );
        assert_eq!(
            find_model("mg4005e-i10").unwrap().iq_scale.value.max_amps(),
            33.0
        );
        assert_eq!(
            find_model("rmd-x8-v2").unwrap().gear_ratio.unwrap().value,
            9.0
        );
        assert_eq!(find_model("RMD-X8-V2"), Err(NameError::Model));
    }

    #[test]
    fn scales_agree_with_the_dialect() {
        for m in MODELS {
            let d = m.dialect;
            assert_eq!(d.family(), m.family, "{}", m.name);
            assert_eq!(d.iq_control_scale(), m.iq_control_scale.value, "{}", m.name);
            assert_eq!(d.iq_scale(), m.iq_scale.value, "{}", m.name);
            for s in [m.iq_control_scale.source, m.iq_scale.source] {
                assert!(!s.is_empty());
            }
        }
    }

    #[test]
    fn v3_models_are_output_side_and_carry_their_max_torque() {
        let x6 = find_model("rmd-x6-v3").unwrap();
        let kt = x6.torque_constant_nm_per_a.unwrap();
        assert!((kt.value - 1.36).abs() < 1e-12 && kt.source.contains("at the motor"));
        assert_eq!(x6.dialect.v3_firmware().unwrap().max_torque, None);
        assert!(
            find_model("rmd-x4-v3")
                .unwrap()
                .torque_constant_nm_per_a
                .is_none()
        );
        let p20 = find_model("rmd-x8-p20").unwrap();
        let firmware = p20.dialect.v3_firmware().unwrap();
        assert_eq!(firmware.max_torque.unwrap().nm(), 129.0);
        assert_eq!(p20.max_torque_nm.unwrap().value, 129.0);
        // Every value of every model names its source.
        for m in MODELS {
            let sources = [
                m.torque_constant_nm_per_a.map(|s| s.source),
                m.gear_ratio.map(|s| s.source),
                m.encoder_bits.map(|s| s.source),
                m.rated_current_a.map(|s| s.source),
                m.max_current_a.map(|s| s.source),
                m.max_torque_nm.map(|s| s.source),
            ];
            assert!(
                sources.iter().flatten().all(|s| !s.is_empty()),
                "{}",
                m.name
            );
        }
    }
}
