//! Validated raw wire values with their physical-unit conversions.
//!
//! Every field of the protocol that has a range or a unit is a newtype around its raw wire
//! integer. The raw value is what travels on the wire; construction checks the range the spec
//! gives, so a value of these types is always valid. Physical values are plain `f64` behind
//! unit-suffixed names (`amps()`, `from_amps(..)`, ...). Each type has:
//!
//! - `new(raw: i64) -> Result<Self, ProtocolError>`: checked; the error names the field, the value
//!   and the allowed range;
//! - `saturating(raw)`: clamps into the range (what a controller usually wants);
//! - `raw()`: the wire integer;
//! - `<unit>()`, `from_<unit>(f64) -> Result`, `from_<unit>_saturating(f64)`: physical values,
//!   rounded half away from zero to the nearest raw step. `from_<unit>` rejects NaN and
//!   infinities; `from_<unit>_saturating` maps NaN to zero and infinities to the range ends.

use crate::error::ProtocolError;
use crate::field::Field;
use crate::round::round_half_away;

macro_rules! wire_value {
    (
        $(#[$meta:meta])*
        $name:ident($wire:ty), field $field:expr, range $min:expr, $max:expr,
        unit $unit:ident / $from_unit:ident / $from_unit_sat:ident ($unit_text:literal),
        scale $num:literal / $den:literal
    ) => {
        $(#[$meta])*
        #[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name($wire);

        impl $name {
            #[doc = concat!("The smallest valid value (raw ", stringify!($min), ").")]
            pub const MIN: Self = Self($min);
            #[doc = concat!("The largest valid value (raw ", stringify!($max), ").")]
            pub const MAX: Self = Self($max);
            /// The field this type is reported as in errors.
            pub const FIELD: Field = $field;

            #[doc = concat!(
                "A value from its raw wire integer; [`ProtocolError::ValueOutOfRange`] outside ",
                stringify!($min), "..=", stringify!($max), "."
            )]
            pub const fn new(raw: i64) -> Result<Self, ProtocolError> {
                if raw < $min as i64 || raw > $max as i64 {
                    Err(ProtocolError::ValueOutOfRange {
                        field: $field,
                        value: raw,
                        min: $min as i64,
                        max: $max as i64,
                    })
                } else {
                    Ok(Self(raw as $wire))
                }
            }

            /// A value from a raw integer, clamped into the valid range.
            pub fn saturating(raw: impl Into<i64>) -> Self {
                let raw: i64 = raw.into();
                Self(raw.clamp($min as i64, $max as i64) as $wire)
            }

            /// The raw wire integer.
            pub const fn raw(self) -> $wire {
                self.0
            }

            #[doc = concat!("The physical value in ", $unit_text, ".")]
            pub fn $unit(self) -> f64 {
                self.0 as f64 * ($num as f64) / ($den as f64)
            }

            #[doc = concat!(
                "A value from ", $unit_text, ", rounded half away from zero to the nearest raw ",
                "step. Errors: [`ProtocolError::NotFinite`] for NaN or infinity, ",
                "[`ProtocolError::ValueOutOfRange`] (with the rounded raw value) outside the range."
            )]
            pub fn $from_unit(value: f64) -> Result<Self, ProtocolError> {
                if !value.is_finite() {
                    return Err(ProtocolError::NotFinite { field: $field });
                }
                Self::new($crate::round::round_half_away(value * ($den as f64) / ($num as f64)))
            }

            #[doc = concat!(
                "A value from ", $unit_text, ", rounded to the nearest raw step and clamped into ",
                "the range; NaN gives zero."
            )]
            pub fn $from_unit_sat(value: f64) -> Self {
                // round_half_away maps NaN to 0 and saturates infinities.
                Self::saturating($crate::round::round_half_away(value * ($den as f64) / ($num as f64)))
            }
        }
    };
}

pub(crate) use wire_value;

wire_value! {
    /// `iqControl` of the torque commands 0xA1 and 0x280: i16 in -2000..=2000, mapping to
    /// -32..=32 A (32/2000 = 0.016 A/LSB).
    ///
    /// This is NOT the scale of [`Iq`], the torque current in replies (33/2048 A/LSB): the spec
    /// uses two different scales on purpose.
    ///
    /// ```
    /// use rmd_protocol::IqControl;
    /// let iq = IqControl::new(100).unwrap();
    /// assert_eq!(iq.amps(), 1.6);
    /// assert_eq!(IqControl::from_amps(1.6), Ok(iq));
    /// assert!(IqControl::from_amps(32.5).is_err());
    /// assert_eq!(IqControl::from_amps_saturating(40.0), IqControl::MAX);
    /// assert_eq!(IqControl::saturating(-5000), IqControl::MIN);
    /// ```
    IqControl(i16), field Field::IqControl, range -2000, 2000,
    unit amps / from_amps / from_amps_saturating ("amperes"), scale 32 / 2000
}

wire_value! {
    /// `speedControl` of the speed command 0xA2: i32, 0.01 dps/LSB.
    ///
    /// Not the scale of [`Speed`] in replies (1 dps/LSB).
    ///
    /// ```
    /// use rmd_protocol::SpeedControl;
    /// assert_eq!(SpeedControl::from_dps(360.0).unwrap().raw(), 36_000);
    /// assert_eq!(SpeedControl::new(-150).unwrap().dps(), -1.5);
    /// ```
    SpeedControl(i32), field Field::SpeedControl, range i32::MIN, i32::MAX,
    unit dps / from_dps / from_dps_saturating ("degrees per second"), scale 1 / 100
}

wire_value! {
    /// Multi-turn `angleControl` of the position commands 0xA3 and 0xA4: i32, 0.01 deg/LSB
    /// (36000 = one turn). The wire field is DATA\[4..=7\]: the spec's "Data" column for 0xA3/0xA4
    /// says DATA\[3..6\], a slip (its "Data field" column and the reading notes say DATA\[4..=7\]).
    ///
    /// ```
    /// use rmd_protocol::AngleControl;
    /// assert_eq!(AngleControl::from_degrees(-720.0).unwrap().raw(), -72_000);
    /// ```
    AngleControl(i32), field Field::AngleControl, range i32::MIN, i32::MAX,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

wire_value! {
    /// Single-turn `angleControl` of the position commands 0xA5 and 0xA6: u16 in 0..=35999,
    /// 0.01 deg/LSB (0..=359.99°).
    ///
    /// ```
    /// use rmd_protocol::SingleTurnAngle;
    /// assert_eq!(SingleTurnAngle::from_degrees(90.0).unwrap().raw(), 9_000);
    /// assert!(SingleTurnAngle::new(36_000).is_err());
    /// assert_eq!(SingleTurnAngle::from_degrees_wrapping(-90.0).raw(), 27_000);
    /// ```
    SingleTurnAngle(u16), field Field::SingleTurnAngleControl, range 0, 35_999,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

impl SingleTurnAngle {
    /// A value from degrees, rounded to 0.01° and wrapped into one turn (e.g. -90° is 270°,
    /// 360° is 0°); NaN and infinities give 0.
    pub fn from_degrees_wrapping(degrees: f64) -> Self {
        if !degrees.is_finite() {
            return Self(0);
        }
        Self(round_half_away(degrees * 100.0).rem_euclid(36_000) as u16)
    }
}

wire_value! {
    /// `maxSpeed` of the position commands 0xA4 and 0xA6: u16, 1 dps/LSB. The wire field is
    /// DATA\[2..=3\]: the spec's "Data" column for 0xA4 says DATA\[3..4\], a slip.
    ///
    /// ```
    /// use rmd_protocol::MaxSpeed;
    /// assert_eq!(MaxSpeed::from_dps(500.0).unwrap().raw(), 500);
    /// assert!(MaxSpeed::new(-1).is_err());
    /// ```
    MaxSpeed(u16), field Field::MaxSpeed, range 0, u16::MAX,
    unit dps / from_dps / from_dps_saturating ("degrees per second"), scale 1 / 1
}

wire_value! {
    /// `Accel` of 0x33 (reply) and 0x34 (request): i32, 1 dps/s per LSB, in DATA\[4..=7\]
    /// (DATA\[1..=3\] are 0). The spec's descriptions of DATA\[2..7\] for these two commands
    /// ("Position/Speed/Torque loop P/I parameter") are copy-paste slips.
    ///
    /// ```
    /// use rmd_protocol::Accel;
    /// assert_eq!(Accel::from_dps_per_s(1000.0).unwrap().dps_per_s(), 1000.0);
    /// ```
    Accel(i32), field Field::Accel, range i32::MIN, i32::MAX,
    unit dps_per_s / from_dps_per_s / from_dps_per_s_saturating ("degrees per second squared"),
    scale 1 / 1
}

wire_value! {
    /// `iq`, the torque current in replies (0x9C, 0xA1..=0xA6): i16 in -2048..=2048, mapping to
    /// -33..=33 A (33/2048 A/LSB).
    ///
    /// Not the scale of [`IqControl`] (32/2000 A/LSB): the spec uses two scales on purpose.
    ///
    /// ```
    /// use rmd_protocol::Iq;
    /// assert_eq!(Iq::new(2048).unwrap().amps(), 33.0);
    /// assert_eq!(Iq::new(-1024).unwrap().amps(), -16.5);
    /// assert!(Iq::new(2049).is_err());
    /// ```
    Iq(i16), field Field::Iq, range -2048, 2048,
    unit amps / from_amps / from_amps_saturating ("amperes"), scale 33 / 2048
}

wire_value! {
    /// `speed`, the motor speed in replies: i16, 1 dps/LSB.
    ///
    /// Not the scale of [`SpeedControl`] (0.01 dps/LSB).
    ///
    /// ```
    /// use rmd_protocol::Speed;
    /// assert_eq!(Speed::new(-300).unwrap().dps(), -300.0);
    /// ```
    Speed(i16), field Field::Speed, range i16::MIN, i16::MAX,
    unit dps / from_dps / from_dps_saturating ("degrees per second"), scale 1 / 1
}

wire_value! {
    /// `temperature`: 1 °C/LSB. The spec writes it as `*(uint8_t*)&temperature`, but it is an
    /// int8_t: the sign matters (-128..=127 °C).
    ///
    /// ```
    /// use rmd_protocol::Temperature;
    /// assert_eq!(Temperature::new(-5).unwrap().celsius(), -5.0);
    /// ```
    Temperature(i8), field Field::Temperature, range i8::MIN, i8::MAX,
    unit celsius / from_celsius / from_celsius_saturating ("degrees Celsius"), scale 1 / 1
}

wire_value! {
    /// `voltage` (0x9A / 0x9B replies): u16, 0.1 V/LSB.
    ///
    /// ```
    /// use rmd_protocol::Voltage;
    /// assert_eq!(Voltage::new(240).unwrap().volts(), 24.0);
    /// assert_eq!(Voltage::from_volts(48.2).unwrap().raw(), 482);
    /// ```
    Voltage(u16), field Field::Voltage, range 0, u16::MAX,
    unit volts / from_volts / from_volts_saturating ("volts"), scale 1 / 10
}

wire_value! {
    /// A phase current (`iA`, `iB`, `iC` of the 0x9D reply): i16, 1 A per 64 LSB.
    ///
    /// ```
    /// use rmd_protocol::PhaseCurrent;
    /// assert_eq!(PhaseCurrent::new(-96).unwrap().amps(), -1.5);
    /// ```
    PhaseCurrent(i16), field Field::PhaseCurrent, range i16::MIN, i16::MAX,
    unit amps / from_amps / from_amps_saturating ("amperes"), scale 1 / 64
}

wire_value! {
    /// `motorAngle` of the 0x92 reply: the multi-turn angle, 0.01 deg/LSB, positive clockwise.
    ///
    /// The spec calls it "int64_t" but sends only 7 bytes (DATA\[1..=7\]): it is a 56-bit
    /// two's-complement value, sign-extended on decoding, so the range is -2^55..=2^55-1.
    /// Conversions to and from degrees round-trip exactly for |raw| < 2^45 (about 10^9 turns);
    /// beyond that `f64` has fewer than 0.01° of resolution.
    ///
    /// ```
    /// use rmd_protocol::MotorAngle;
    /// assert_eq!(MotorAngle::new(-36_000).unwrap().degrees(), -360.0);
    /// assert!(MotorAngle::new(1 << 55).is_err());
    /// ```
    MotorAngle(i64), field Field::MotorAngle, range -(1i64 << 55), (1i64 << 55) - 1,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

wire_value! {
    /// `circleAngle` of the 0x94 reply: u16, 0.01 deg/LSB, counted clockwise from the encoder
    /// zero and back to zero after a full turn, so 0..=35999.
    ///
    /// ```
    /// use rmd_protocol::CircleAngle;
    /// assert_eq!(CircleAngle::new(18_000).unwrap().degrees(), 180.0);
    /// assert!(CircleAngle::new(36_000).is_err());
    /// ```
    CircleAngle(u16), field Field::CircleAngle, range 0, 35_999,
    unit degrees / from_degrees / from_degrees_saturating ("degrees"), scale 1 / 100
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn current_scales_differ_on_purpose() {
        assert_eq!(IqControl::new(2000).unwrap().amps(), 32.0);
        assert_eq!(IqControl::new(-2000).unwrap().amps(), -32.0);
        assert_eq!(Iq::new(2048).unwrap().amps(), 33.0);
        assert_eq!(IqControl::from_amps(1.0).unwrap().raw(), 63); // 62.5 rounds away from zero
        assert_eq!(IqControl::from_amps(-1.0).unwrap().raw(), -63);
        assert_eq!(Iq::from_amps(1.0).unwrap().raw(), 62); // 62.06
        assert_eq!(PhaseCurrent::from_amps(1.0).unwrap().raw(), 64);
    }

    #[test]
    fn physical_constructors_reject_non_finite_and_out_of_range() {
        assert_eq!(
            IqControl::from_amps(f64::NAN),
            Err(ProtocolError::NotFinite {
                field: Field::IqControl
            })
        );
        assert_eq!(
            IqControl::from_amps(32.01),
            Err(ProtocolError::ValueOutOfRange {
                field: Field::IqControl,
                value: 2001,
                min: -2000,
                max: 2000
            })
        );
        assert_eq!(IqControl::from_amps_saturating(f64::NAN).raw(), 0);
        assert_eq!(
            IqControl::from_amps_saturating(f64::INFINITY),
            IqControl::MAX
        );
        assert_eq!(
            IqControl::from_amps_saturating(f64::NEG_INFINITY),
            IqControl::MIN
        );
        assert_eq!(SpeedControl::from_dps_saturating(1e300), SpeedControl::MAX);
        assert!(Temperature::new(128).is_err());
        assert!(Voltage::from_volts(-0.1).is_err());
    }

    #[test]
    fn single_turn_wrapping() {
        assert_eq!(SingleTurnAngle::from_degrees_wrapping(360.0).raw(), 0);
        assert_eq!(SingleTurnAngle::from_degrees_wrapping(359.99).raw(), 35_999);
        assert_eq!(SingleTurnAngle::from_degrees_wrapping(-0.01).raw(), 35_999);
        assert_eq!(SingleTurnAngle::from_degrees_wrapping(725.0).raw(), 500);
        assert_eq!(SingleTurnAngle::from_degrees_wrapping(f64::NAN).raw(), 0);
    }
}
