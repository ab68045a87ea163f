//! Current values that carry the scale they assume: a raw value can never be read with another
//! family's scale.
//!
//! ```
//! use rmd_protocol::{CurrentScale, ScaledCurrent};
//! let mf = ScaledCurrent::from_amps(8.25, CurrentScale::LK_MF_IQ_CONTROL)?;
//! assert_eq!(mf.raw(), 1024);
//! let mg = ScaledCurrent::new(1024, CurrentScale::LK_MG_IQ_CONTROL)?;
//! assert_eq!(mg.amps(), 16.5);
//! # Ok::<(), rmd_protocol::ProtocolError>(())
//! ```

use crate::error::ProtocolError;
use crate::scale::CurrentScale;
use crate::values::{Iq, IqControl};

/// A current on the wire: the raw integer and the [`CurrentScale`] it is read with.
///
/// ```
/// use rmd_protocol::{CurrentScale, IqControl, ScaledCurrent};
/// let v161: ScaledCurrent = IqControl::new(100)?.into();
/// assert_eq!(v161.scale(), CurrentScale::V161_IQ_CONTROL);
/// assert_eq!(v161.amps(), 1.6);
/// assert!(ScaledCurrent::new(2049, CurrentScale::LK_MG_IQ).is_err());
/// assert_eq!(ScaledCurrent::from_amps_saturating(50.0, CurrentScale::LK_MF_IQ_CONTROL).raw(), 2048);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct ScaledCurrent {
    raw: i16,
    scale: CurrentScale,
}

impl ScaledCurrent {
    /// A value from its raw integer; [`ProtocolError::ValueOutOfRange`] (naming the scale's
    /// field) outside the scale's range.
    pub const fn new(raw: i64, scale: CurrentScale) -> Result<Self, ProtocolError> {
        if raw < scale.min_raw() as i64 || raw > scale.max_raw() as i64 {
            Err(ProtocolError::ValueOutOfRange {
                field: scale.field_of(),
                value: raw,
                min: scale.min_raw() as i64,
                max: scale.max_raw() as i64,
            })
        } else {
            Ok(Self {
                raw: raw as i16,
                scale,
            })
        }
    }

    /// A value from a raw integer, clamped into the scale's range.
    #[inline]
    pub fn saturating(raw: i64, scale: CurrentScale) -> Self {
        Self {
            raw: raw.clamp(i64::from(scale.min_raw()), i64::from(scale.max_raw())) as i16,
            scale,
        }
    }

    /// A value from amperes, rounded half away from zero to the nearest raw step. Errors:
    /// [`ProtocolError::NotFinite`], [`ProtocolError::ValueOutOfRange`] (with the rounded raw
    /// value) outside the range.
    pub fn from_amps(amps: f64, scale: CurrentScale) -> Result<Self, ProtocolError> {
        if !amps.is_finite() {
            return Err(ProtocolError::NotFinite {
                field: scale.field_of(),
            });
        }
        Self::new(scale.raw_of(amps), scale)
    }

    /// A value from amperes, rounded and clamped into the range; NaN gives zero.
    pub fn from_amps_saturating(amps: f64, scale: CurrentScale) -> Self {
        Self::saturating(scale.raw_of(amps), scale)
    }

    /// The raw wire integer.
    pub const fn raw(self) -> i16 {
        self.raw
    }

    /// The scale this value is read with.
    pub const fn scale(self) -> CurrentScale {
        self.scale
    }

    /// The current in amperes, with this value's own scale.
    pub fn amps(self) -> f64 {
        self.scale.amps(self.raw)
    }

    /// The same raw value checked against `expected`:
    /// [`ProtocolError::ScaleMismatch`] unless this value uses exactly that scale.
    pub const fn expect_scale(self, expected: CurrentScale) -> Result<Self, ProtocolError> {
        if self.scale.same_as(expected) {
            Ok(self)
        } else {
            Err(ProtocolError::ScaleMismatch {
                field: expected.field_of(),
                expected,
                got: self.scale,
            })
        }
    }
}

impl From<IqControl> for ScaledCurrent {
    fn from(v: IqControl) -> Self {
        Self {
            raw: v.raw(),
            scale: CurrentScale::V161_IQ_CONTROL,
        }
    }
}

impl From<Iq> for ScaledCurrent {
    fn from(v: Iq) -> Self {
        Self {
            raw: v.raw(),
            scale: CurrentScale::V161_IQ,
        }
    }
}

impl TryFrom<ScaledCurrent> for IqControl {
    type Error = ProtocolError;
    /// The v1.61 `iqControl` of a value with scale [`CurrentScale::V161_IQ_CONTROL`];
    /// [`ProtocolError::ScaleMismatch`] for any other scale.
    fn try_from(v: ScaledCurrent) -> Result<Self, ProtocolError> {
        let v = v.expect_scale(CurrentScale::V161_IQ_CONTROL)?;
        IqControl::new(i64::from(v.raw))
    }
}

impl TryFrom<ScaledCurrent> for Iq {
    type Error = ProtocolError;
    /// The v1.61 `iq` of a value with scale [`CurrentScale::V161_IQ`];
    /// [`ProtocolError::ScaleMismatch`] for any other scale.
    fn try_from(v: ScaledCurrent) -> Result<Self, ProtocolError> {
        let v = v.expect_scale(CurrentScale::V161_IQ)?;
        Iq::new(i64::from(v.raw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;

    #[test]
    fn conversions_round_and_check() {
        let s = CurrentScale::LK_MF_IQ_CONTROL;
        assert_eq!(ScaledCurrent::from_amps(16.5, s).unwrap().raw(), 2048);
        assert_eq!(
            ScaledCurrent::from_amps(16.51, s),
            Err(ProtocolError::ValueOutOfRange {
                field: Field::IqControl,
                value: 2049,
                min: -2048,
                max: 2048
            })
        );
        assert_eq!(
            ScaledCurrent::from_amps(f64::NAN, s),
            Err(ProtocolError::NotFinite {
                field: Field::IqControl
            })
        );
        assert_eq!(ScaledCurrent::from_amps_saturating(f64::NAN, s).raw(), 0);
        assert_eq!(ScaledCurrent::from_amps_saturating(-1e9, s).raw(), -2048);
        let v3 = ScaledCurrent::from_amps(1.0, CurrentScale::MYACTUATOR_V3_IQ_CONTROL).unwrap();
        assert_eq!(v3.raw(), 100);
        assert!(IqControl::try_from(v3).is_err());
        let v161 = ScaledCurrent::new(100, CurrentScale::V161_IQ_CONTROL).unwrap();
        assert_eq!(IqControl::try_from(v161), IqControl::new(100));
    }
}
