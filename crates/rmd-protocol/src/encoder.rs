//! Encoder values and the per-motor encoder width they are checked against.

use crate::error::ProtocolError;
use crate::field::Field;
use crate::round::round_half_away;

/// Encoder values and the per-motor encoder width they are checked against.
///
/// The spec describes a 14-bit encoder (values 0..=16383), but its last note says motors ship
/// with 12- to 18-bit encoders. The width is therefore a per-motor setting, [`EncoderWidth`]
/// (default 14), and encoder values are checked against it where the width is known: when a
/// value is constructed for a request ([`EncoderValue::new`]), and by the simulator or loop on
/// decoded frames ([`Request::check_encoder_width`](crate::Request::check_encoder_width),
/// [`Reply::check_encoder_width`](crate::Reply::check_encoder_width)). Decoding alone cannot
/// know the motor's width, so it accepts every value the u16 field can carry.
///
/// Encoders wider than 16 bits: the wire fields (`encoder`, `encoderRaw`, `encoderOffset`) are
/// uint16_t, so they cannot carry 17 or 18 bits. The document gives no layout for those motors;
/// rmd-rt assumes the motor reports the position scaled into the 16-bit field (one turn = 65536
/// counts). For such widths every u16 value is valid and [`EncoderValue::degrees`] uses 65536
/// counts per turn. Check this against your motor before relying on encoder angles above 16 bits.
///
/// The resolution of a motor's encoder in bits, 12..=18 (default 14, the spec's).
///
/// ```
/// use rmd_protocol::EncoderWidth;
/// let w = EncoderWidth::new(14).unwrap();
/// assert_eq!(w.max_value(), 16_383);
/// assert_eq!(EncoderWidth::new(18).unwrap().max_value(), u16::MAX); // see above
/// assert!(EncoderWidth::new(11).is_err());
/// assert_eq!(EncoderWidth::default(), w);
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EncoderWidth(u8);

impl EncoderWidth {
    /// Narrowest supported encoder.
    pub const MIN_BITS: u8 = 12;
    /// Widest supported encoder.
    pub const MAX_BITS: u8 = 18;
    /// The spec's 14-bit encoder.
    pub const DEFAULT: Self = Self(14);

    /// A width of `bits` bits; [`ProtocolError::ValueOutOfRange`] outside 12..=18.
    pub const fn new(bits: u8) -> Result<Self, ProtocolError> {
        if bits >= Self::MIN_BITS && bits <= Self::MAX_BITS {
            Ok(Self(bits))
        } else {
            Err(ProtocolError::ValueOutOfRange {
                field: Field::EncoderWidth,
                value: bits as i64,
                min: Self::MIN_BITS as i64,
                max: Self::MAX_BITS as i64,
            })
        }
    }

    /// The width in bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Counts per turn as the u16 wire field carries them: 2^bits, at most 65536.
    pub const fn counts_per_turn(self) -> u32 {
        if self.0 >= 16 { 1 << 16 } else { 1 << self.0 }
    }

    /// The largest valid encoder value: 2^bits - 1, at most 65535.
    pub const fn max_value(self) -> u16 {
        (self.counts_per_turn() - 1) as u16
    }
}

impl Default for EncoderWidth {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// An encoder value as carried by the u16 fields `encoder`, `encoderRaw` and `encoderOffset`.
///
/// ```
/// use rmd_protocol::{EncoderValue, EncoderWidth};
/// let w14 = EncoderWidth::default();
/// assert_eq!(EncoderValue::new(16_383, w14).unwrap().raw(), 16_383);
/// assert!(EncoderValue::new(16_384, w14).is_err());
/// assert_eq!(EncoderValue::from_raw(8_192).degrees(w14), 180.0);
/// assert!(EncoderValue::from_raw(20_000).check(w14).is_err());
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EncoderValue(u16);

impl EncoderValue {
    /// A value for an encoder of width `width`; [`ProtocolError::ValueOutOfRange`] outside
    /// `0..=width.max_value()`.
    pub const fn new(raw: i64, width: EncoderWidth) -> Result<Self, ProtocolError> {
        let max = width.max_value() as i64;
        if raw < 0 || raw > max {
            Err(ProtocolError::ValueOutOfRange {
                field: Field::EncoderValue,
                value: raw,
                min: 0,
                max,
            })
        } else {
            Ok(Self(raw as u16))
        }
    }

    /// The value as read off the wire, not checked against any width (decoding cannot know the
    /// motor's width; see [`EncoderWidth`]).
    pub const fn from_raw(raw: u16) -> Self {
        Self(raw)
    }

    /// The raw wire integer.
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// `self` if it fits an encoder of width `width`, else [`ProtocolError::ValueOutOfRange`].
    pub const fn check(self, width: EncoderWidth) -> Result<Self, ProtocolError> {
        Self::new(self.0 as i64, width)
    }

    /// The position in degrees within one turn for an encoder of width `width`
    /// (`raw * 360 / counts_per_turn`).
    pub fn degrees(self, width: EncoderWidth) -> f64 {
        self.0 as f64 * 360.0 / width.counts_per_turn() as f64
    }

    /// A value from degrees within one turn for an encoder of width `width`, rounded to the
    /// nearest count. Errors: [`ProtocolError::NotFinite`], [`ProtocolError::ValueOutOfRange`]
    /// (360° itself is out of range: it is count `counts_per_turn`, i.e. 0 of the next turn).
    pub fn from_degrees(degrees: f64, width: EncoderWidth) -> Result<Self, ProtocolError> {
        if !degrees.is_finite() {
            return Err(ProtocolError::NotFinite {
                field: Field::EncoderValue,
            });
        }
        Self::new(
            round_half_away(degrees * width.counts_per_turn() as f64 / 360.0),
            width,
        )
    }
}
