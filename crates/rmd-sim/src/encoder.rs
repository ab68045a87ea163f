//! The motor-side encoder as the firmware sees it: quantised to its width, with the mounting
//! offset, and how its counts map to the u16 wire fields.
//!
//! Encoders of up to 16 bits report their counts as they are. Wider ones (17, 18 bits) cannot
//! fit the u16 fields; as the protocol crate assumes (see `rmd_protocol::encoder`), the motor
//! reports the position scaled into 16 bits (counts shifted right by `bits - 16`), while the
//! firmware itself keeps the full resolution for its angles and loops.

use core::f64::consts::TAU;

use rmd_protocol::{EncoderValue, EncoderWidth};

/// A quantising encoder.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Encoder {
    /// Counts per turn at full resolution, 2^bits.
    counts: i64,
    /// Right shift from full resolution to the wire (bits - 16, or 0).
    shift: u32,
    /// Raw reading at rotor angle 0, in turns.
    mount_offset_turns: f64,
}

impl Encoder {
    pub(crate) fn new(width: EncoderWidth, mount_offset_turns: f64) -> Self {
        let bits = u32::from(width.bits());
        Self {
            counts: 1 << bits,
            shift: bits.saturating_sub(16),
            mount_offset_turns,
        }
    }

    /// Counts per turn at full resolution.
    pub(crate) fn counts(&self) -> i64 {
        self.counts
    }

    /// The unbounded count of the rotor at `motor_angle_rad` (floor of the exact position).
    pub(crate) fn absolute_count(&self, motor_angle_rad: f64) -> i64 {
        ((motor_angle_rad / TAU + self.mount_offset_turns) * self.counts as f64).floor() as i64
    }

    /// The raw reading (0..counts) of an absolute count.
    pub(crate) fn raw(&self, absolute: i64) -> i64 {
        absolute.rem_euclid(self.counts)
    }

    /// A full-resolution count as the u16 wire field carries it.
    pub(crate) fn wire_value(&self, count: i64) -> EncoderValue {
        EncoderValue::from_raw((count.rem_euclid(self.counts) >> self.shift) as u16)
    }

    /// A wire value as a full-resolution count.
    pub(crate) fn count_of(&self, value: EncoderValue) -> i64 {
        i64::from(value.raw()) << self.shift
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantises_wraps_and_scales() {
        let e14 = Encoder::new(EncoderWidth::DEFAULT, 0.25);
        assert_eq!(e14.counts(), 16_384);
        // Rotor at 0: a quarter turn of mounting offset = 4096 counts.
        assert_eq!(e14.absolute_count(0.0), 4_096);
        // Just below one count more.
        let count = TAU / 16_384.0;
        assert_eq!(e14.absolute_count(0.999 * count), 4_096);
        assert_eq!(e14.absolute_count(1.001 * count), 4_097);
        // Three quarters of a turn further: wraps to 0.
        let abs = e14.absolute_count(0.75 * TAU + 0.5 * count);
        assert_eq!(abs, 16_384);
        assert_eq!(e14.raw(abs), 0);
        assert_eq!(e14.raw(-1), 16_383);
        assert_eq!(e14.wire_value(16_383).raw(), 16_383);

        let e18 = Encoder::new(EncoderWidth::new(18).unwrap(), 0.0);
        assert_eq!(e18.counts(), 262_144);
        assert_eq!(e18.wire_value(262_143).raw(), 65_535);
        assert_eq!(e18.count_of(EncoderValue::from_raw(1)), 4);
    }
}
