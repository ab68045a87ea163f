//! Current scales as data.

use core::fmt;

use crate::field::Field;
use crate::milli::Milli;
use crate::round::round_half_away;

/// Current scales as data, and current values that carry the scale they assume.
///
/// Protocol v1.61 has two fixed current scales (`IqControl`: 32/2000 A per
/// LSB; `Iq`: 33/2048 A per LSB). Other firmware families use other scales for the
/// same wire fields, and LK-TECH's depend on the motor series:
///
/// | scale | field | A per LSB | raw range | source |
/// |---|---|---|---|---|
/// | [`CurrentScale::V161_IQ_CONTROL`] | `iqControl` | 32/2000 | ±2000 | gyems-can-v1.61, 0xA1 / 0x280 |
/// | [`CurrentScale::V161_IQ`] | `iq` | 33/2048 | ±2048 | gyems-can-v1.61, 0x9C |
/// | [`CurrentScale::LK_MF_IQ_CONTROL`], [`CurrentScale::LK_MF_IQ`] | both | 16.5/2048 | ±2048 | LK-TECH CAN protocol V2.35, torque closed-loop command (0xA1): "MF ... -16.5A~16.5A" |
/// | [`CurrentScale::LK_MG_IQ_CONTROL`], [`CurrentScale::LK_MG_IQ`] | both | 33/2048 | ±2048 | same section: "MG ... -33A~33A" |
/// | [`CurrentScale::MYACTUATOR_V3_IQ_CONTROL`], [`CurrentScale::MYACTUATOR_V3_IQ`] | both | 0.01 | i16 | MyActuator Servo Motor Control Protocol V4.3 (driver V3), §2.19 (0xA1), §2.15 (0x9C) |
///
/// A `ScaledCurrent` is a raw wire value together with its [`CurrentScale`], so a value can
/// never be read with the wrong scale: `amps()` always uses the scale it was built with.
///
/// ```
/// use rmd_protocol::{CurrentScale, ScaledCurrent};
/// let mf = ScaledCurrent::from_amps(8.25, CurrentScale::LK_MF_IQ_CONTROL)?;
/// assert_eq!(mf.raw(), 1024);
/// let mg = ScaledCurrent::new(1024, CurrentScale::LK_MG_IQ_CONTROL)?;
/// assert_eq!(mg.amps(), 16.5);
/// // The same raw value means 16.38 A under v1.61's iqControl scale.
/// assert!((ScaledCurrent::new(1024, CurrentScale::V161_IQ_CONTROL)?.amps() - 16.384).abs() < 1e-12);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
///
/// How a current field's raw integer maps to amperes, and which raw values it allows:
/// `amps = raw * milliamps / per_raw / 1000`, `min_raw <= raw <= max_raw`.
///
/// The scale also names the protocol field it belongs to (`iq_control` for commands, `iq` for
/// replies), so that errors name the field and a command scale is never mistaken for a reply
/// scale even where the numbers agree.
#[derive(Copy, Clone, Debug)]
pub struct CurrentScale {
    field: Field,
    milliamps: u32,
    per_raw: u32,
    min_raw: i16,
    max_raw: i16,
    /// `milliamps / per_raw`, worked out once (it follows from the two: equality and hashing
    /// leave it out). Exact in binary for every scale here (`per_raw` a power of two, or
    /// dividing `milliamps`), so `amps` equals `raw * milliamps / per_raw / 1000` to the bit.
    milliamps_per_raw: f64,
}

/// Scales are equal when their field, numbers and range are.
impl PartialEq for CurrentScale {
    fn eq(&self, other: &Self) -> bool {
        self.same_as(*other)
    }
}

impl Eq for CurrentScale {}

impl core::hash::Hash for CurrentScale {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        (
            self.field,
            self.milliamps,
            self.per_raw,
            self.min_raw,
            self.max_raw,
        )
            .hash(state);
    }
}

impl CurrentScale {
    /// v1.61 `iqControl` (0xA1, 0x280): 32 A per 2000 LSB, -2000..=2000 (gyems-can-v1.61, torque
    /// closed-loop command).
    pub const V161_IQ_CONTROL: Self = Self::new(Field::IqControl, 32_000, 2000, -2000, 2000);
    /// v1.61 `iq` in replies: 33 A per 2048 LSB, -2048..=2048 (gyems-can-v1.61, 0x9C reply).
    pub const V161_IQ: Self = Self::new(Field::Iq, 33_000, 2048, -2048, 2048);
    /// LK-TECH MF series `iqControl`: 16.5 A per 2048 LSB, -2048..=2048. Source: LK-TECH "CAN
    /// protocol V2.35", torque closed-loop command 0xA1 ("iqControl ... range -2048~2048,
    /// corresponding MF motor actual torque current range is -16.5A~16.5A"), as quoted in
    /// github.com/aj3944/step-pyjoco `embedded/src/commands.py` and used with these numbers in
    /// github.com/uLipe/lkmotor_mf4005_driver `drivers/lkm_mf4005_motor_regs.h`
    /// (`MF4005_CURRENT_HARD_LIMIT_MILIAMPERES 16500`, `MF4005_CURRENT_SCALE_MULT 2048`).
    pub const LK_MF_IQ_CONTROL: Self = Self::new(Field::IqControl, 16_500, 2048, -2048, 2048);
    /// LK-TECH MF series `iq` in replies: the same 16.5 A per 2048 LSB (LK "CAN protocol V2.35",
    /// torque closed-loop command, reply: "iq ... range -2048~2048, corresponding MF motor actual
    /// torque current range is -16.5A~16.5A"; written 33/4096 A/LSB in
    /// github.com/han-xudong/pyLKMotor `pylkmotor/LKMotor.py`).
    pub const LK_MF_IQ: Self = Self::new(Field::Iq, 16_500, 2048, -2048, 2048);
    /// LK-TECH MG series `iqControl`: 33 A per 2048 LSB, -2048..=2048 (LK "CAN protocol V2.35",
    /// torque closed-loop command: "MG motor actual torque current range is -33A~33A"; also
    /// github.com/Alliance-Algorithm/librmcs `librmcs/device/lk_motor.hpp`, `current_max = 33.0`,
    /// `raw_current_max_ = 2048` for the MG types).
    pub const LK_MG_IQ_CONTROL: Self = Self::new(Field::IqControl, 33_000, 2048, -2048, 2048);
    /// LK-TECH MG series `iq` in replies: 33 A per 2048 LSB (same sources; 66/4096 A/LSB in
    /// pyLKMotor). The same numbers as [`V161_IQ`](Self::V161_IQ), so the two compare equal.
    pub const LK_MG_IQ: Self = Self::new(Field::Iq, 33_000, 2048, -2048, 2048);
    /// MyActuator V3 `iqControl`: 0.01 A per LSB, the whole i16 range (MyActuator "Servo Motor
    /// Control Protocol" V4.3, applicable driver V3, §2.19: "iqControl is int16_t, unit 0.01
    /// A/LSB"; github.com/2b-t/myactuator_rmd `src/protocol/requests.cpp`, `SetTorqueRequest`).
    pub const MYACTUATOR_V3_IQ_CONTROL: Self =
        Self::new(Field::IqControl, 10, 1, i16::MIN, i16::MAX);
    /// MyActuator V3 `iq` in replies: 0.01 A per LSB (same document §2.15; myactuator_rmd
    /// `include/myactuator_rmd/protocol/responses.hpp`, `FeedbackResponse::getStatus`).
    pub const MYACTUATOR_V3_IQ: Self = Self::new(Field::Iq, 10, 1, i16::MIN, i16::MAX);

    /// A scale of `milliamps / per_raw` mA per LSB over `min_raw..=max_raw`, for `field`.
    ///
    /// `per_raw` of 0 is taken as 1 (a scale must be finite).
    pub const fn new(
        field: Field,
        milliamps: u32,
        per_raw: u32,
        min_raw: i16,
        max_raw: i16,
    ) -> Self {
        let per_raw = if per_raw == 0 { 1 } else { per_raw };
        Self {
            field,
            milliamps,
            per_raw,
            min_raw,
            max_raw,
            milliamps_per_raw: milliamps as f64 / per_raw as f64,
        }
    }

    /// The field this scale belongs to.
    pub const fn field(self) -> Field {
        self.field
    }

    /// Amperes per raw step.
    pub fn amps_per_lsb(self) -> f64 {
        f64::from(self.milliamps) / f64::from(self.per_raw) / 1000.0
    }

    /// The smallest valid raw value.
    pub const fn min_raw(self) -> i16 {
        self.min_raw
    }

    /// The largest valid raw value.
    pub const fn max_raw(self) -> i16 {
        self.max_raw
    }

    /// The current at the largest raw value, A.
    pub fn max_amps(self) -> f64 {
        f64::from(self.max_raw) * self.amps_per_lsb()
    }

    /// The current a raw value means, A (not range-checked): `raw * (milliamps / per_raw) /
    /// 1000`, the same to the bit as `raw * milliamps / per_raw / 1000` wherever the quotient is
    /// exact in binary (every scale of the protocols).
    #[inline]
    pub fn amps(self, raw: i16) -> f64 {
        f64::from(raw) * self.milliamps_per_raw / 1000.0
    }

    /// The raw value nearest to `amps` (half away from zero), unclamped; NaN gives 0.
    pub(crate) fn raw_of(self, amps: f64) -> i64 {
        round_half_away(amps * 1000.0 * f64::from(self.per_raw) / f64::from(self.milliamps))
    }
}

/// Formats as e.g. `33 A per 2048 LSB (-2048..=2048)` or `0.01 A per LSB (-32768..=32767)`.
impl fmt::Display for CurrentScale {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", Milli(i64::from(self.milliamps)))?;
        if self.per_raw == 1 {
            write!(f, " A per LSB")?;
        } else {
            write!(f, " A per {} LSB", self.per_raw)?;
        }
        write!(f, " ({}..={})", self.min_raw, self.max_raw)
    }
}

impl CurrentScale {
    /// Whether `self` and `other` are the same scale of the same field (a `const` `==`).
    pub const fn same_as(self, other: Self) -> bool {
        self.field as u8 == other.field as u8
            && self.milliamps == other.milliamps
            && self.per_raw == other.per_raw
            && self.min_raw == other.min_raw
            && self.max_raw == other.max_raw
    }

    /// The field.
    pub(crate) const fn field_of(self) -> Field {
        self.field
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_per_family() {
        let full = |s: CurrentScale| s.max_amps();
        assert_eq!(full(CurrentScale::V161_IQ_CONTROL), 32.0);
        assert_eq!(full(CurrentScale::V161_IQ), 33.0);
        assert_eq!(full(CurrentScale::LK_MF_IQ_CONTROL), 16.5);
        assert_eq!(full(CurrentScale::LK_MF_IQ), 16.5);
        assert_eq!(full(CurrentScale::LK_MG_IQ_CONTROL), 33.0);
        assert_eq!(full(CurrentScale::LK_MG_IQ), 33.0);
        assert_eq!(CurrentScale::MYACTUATOR_V3_IQ_CONTROL.amps_per_lsb(), 0.01);
        assert_eq!(CurrentScale::MYACTUATOR_V3_IQ.amps(-100), -1.0);
        // Command and reply scales of one family are distinct values (they name their field).
        assert_ne!(CurrentScale::LK_MG_IQ_CONTROL, CurrentScale::LK_MG_IQ);
    }

    #[test]
    fn amps_are_raw_times_milliamps_over_per_raw_over_1000_to_the_bit() {
        for scale in [
            CurrentScale::V161_IQ_CONTROL,
            CurrentScale::V161_IQ,
            CurrentScale::LK_MF_IQ_CONTROL,
            CurrentScale::LK_MF_IQ,
            CurrentScale::LK_MG_IQ_CONTROL,
            CurrentScale::LK_MG_IQ,
            CurrentScale::MYACTUATOR_V3_IQ_CONTROL,
            CurrentScale::MYACTUATOR_V3_IQ,
        ] {
            for raw in scale.min_raw()..=scale.max_raw() {
                let exact =
                    f64::from(raw) * f64::from(scale.milliamps) / f64::from(scale.per_raw) / 1000.0;
                assert_eq!(scale.amps(raw).to_bits(), exact.to_bits(), "{scale} {raw}");
            }
        }
    }

    #[test]
    fn equal_numbers_are_equal_scales_with_equal_hashes() {
        extern crate std;
        use core::hash::BuildHasher;
        let state = std::hash::RandomState::new();
        let hash = |s: CurrentScale| state.hash_one(s);
        let built = CurrentScale::new(Field::Iq, 33_000, 2048, -2048, 2048);
        assert_eq!(built, CurrentScale::V161_IQ);
        assert_eq!(CurrentScale::LK_MG_IQ, CurrentScale::V161_IQ);
        assert_eq!(hash(built), hash(CurrentScale::V161_IQ));
        // A zero `per_raw` is taken as 1.
        assert_eq!(
            CurrentScale::new(Field::Iq, 10, 0, i16::MIN, i16::MAX),
            CurrentScale::MYACTUATOR_V3_IQ
        );
        assert_ne!(
            built,
            CurrentScale::new(Field::Iq, 33_000, 2048, -2047, 2048)
        );
    }

    #[test]
    fn display_names_amperes_per_lsbs() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            CurrentScale::V161_IQ.to_string(),
            "33 A per 2048 LSB (-2048..=2048)"
        );
        assert_eq!(
            CurrentScale::V161_IQ_CONTROL.to_string(),
            "32 A per 2000 LSB (-2000..=2000)"
        );
        assert_eq!(
            CurrentScale::LK_MF_IQ.to_string(),
            "16.5 A per 2048 LSB (-2048..=2048)"
        );
        assert_eq!(
            CurrentScale::MYACTUATOR_V3_IQ.to_string(),
            "0.01 A per LSB (-32768..=32767)"
        );
    }
}
