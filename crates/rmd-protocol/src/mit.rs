//! MyActuator V3's motion-mode (MIT) frames: the command on `0x400 + id` and the feedback on
//! `0x500 + id`.

use crate::error::ProtocolError;
use crate::field::Field;
use crate::mit_ranges::MitRanges;
use crate::round::round_half_away;

/// The largest 12-bit value.
const MAX12: u16 = 0x0FFF;

/// `x` (finite, within `min..=max`) packed into `bits` bits.
fn pack(x: f64, min: f64, max: f64, bits: u32, field: Field) -> Result<u16, ProtocolError> {
    if !x.is_finite() {
        return Err(ProtocolError::NotFinite { field });
    }
    // A value within a rounding error of a bound is the bound (the ranges are given in
    // milli-units; 1e-9 of the span is far below one step).
    let slack = (max - min) * 1e-9;
    if x < min - slack || x > max + slack {
        let milli = |v: f64| round_half_away(v * 1000.0);
        return Err(ProtocolError::OutOfRangeMilli {
            field,
            value_milli: milli(x),
            min_milli: milli(min),
            max_milli: milli(max),
        });
    }
    let top = ((1u32 << bits) - 1) as f64;
    let raw = round_half_away((x - min) * top / (max - min)).clamp(0, top as i64);
    Ok(raw as u16)
}

/// `raw` of `bits` bits unpacked onto `min..=max`.
fn unpack(raw: u16, min: f64, max: f64, bits: u32) -> f64 {
    let top = ((1u32 << bits) - 1) as f64;
    f64::from(raw) * (max - min) / top + min
}

/// Checks a raw 12-bit value.
const fn raw12(raw: u16, field: Field) -> Result<u16, ProtocolError> {
    if raw > MAX12 {
        Err(ProtocolError::ValueOutOfRange {
            field,
            value: raw as i64,
            min: 0,
            max: MAX12 as i64,
        })
    } else {
        Ok(raw)
    }
}

/// MyActuator V3's motion-mode (MIT) frames: the command on `0x400 + id` and the feedback on
/// `0x500 + id`, five (three) fields packed big-endian into 16 and 12 bits.
///
/// Sources: MyActuator "Servo Motor Control Protocol" V4.3 §5 and V4.4 §4 ("Motion Mode Control
/// Command_CAN (0x400 + ID)"): §5.2 / §4.2 the command's bits, §5.3 / §4.3 the reply's, §5.4 /
/// §4.4 the worked example `401#E66682E052333B55` (p_des 10 rad, v_des 1.021 rad/s, kp 10.012,
/// kd 1 (V4.3) or 10 (V4.4), t_ff 10.004 N·m (V4.3)) and its reply `501#01E66682EB550000`. The
/// ranges are [`MitRanges`]'s. The control law (V4.4 §4.1):
/// `IqRef = [kp (p_des - p) + kd (v_des - v) + t_ff] / KT_OUT`, every quantity at the output
/// shaft (said of the RS485 variant, V4.4 §6.1; the CAN section does not say).
///
/// Each field maps its range linearly onto its bits: `raw = (x - min) (2^bits - 1) / (max -
/// min)`, rounded half away from zero to the nearest step (the manual's example values round to
/// its bytes; truncation, as some drivers do, gives `0xE665` for its 10 rad).
///
/// A motion-mode command (`0x400 + id`): the raw packed fields and the ranges they were packed
/// with (a value packed for other ranges is refused by the encoder: see
/// [`ProtocolError::MitRangesMismatch`]).
///
/// ```
/// use rmd_protocol::{MitCommand, MitRanges};
/// // V4.3 §5.4: p_des 10 rad, v_des 1.021 rad/s, kp 10.012, kd 1, t_ff 10.004 N·m.
/// let c = MitCommand::from_si(MitRanges::V4_3, 10.0, 1.021, 10.012, 1.0, 10.004)?;
/// assert_eq!(c.raw(), [0xE666, 0x82E, 0x052, 0x333, 0xB55]);
/// assert!((c.position_rad() - 10.0).abs() < 1e-3);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MitCommand {
    ranges: MitRanges,
    p_des: u16,
    v_des: u16,
    kp: u16,
    kd: u16,
    t_ff: u16,
}

impl MitCommand {
    /// A command from physical values: `p_des` rad, `v_des` rad/s, `kp` N·m/rad, `kd`
    /// N·m/(rad/s), `t_ff` N·m, at the output shaft, packed with `ranges`. Errors:
    /// [`ProtocolError::NotFinite`], [`ProtocolError::OutOfRangeMilli`] outside the ranges.
    pub fn from_si(
        ranges: MitRanges,
        p_des: f64,
        v_des: f64,
        kp: f64,
        kd: f64,
        t_ff: f64,
    ) -> Result<Self, ProtocolError> {
        let p = ranges.position_rad();
        let v = ranges.velocity_rad_s();
        let t = ranges.torque_nm();
        Ok(Self {
            ranges,
            p_des: pack(p_des, -p, p, 16, Field::MitPosition)?,
            v_des: pack(v_des, -v, v, 12, Field::MitVelocity)?,
            kp: pack(kp, 0.0, ranges.kp(), 12, Field::MitKp)?,
            kd: pack(kd, 0.0, ranges.kd(), 12, Field::MitKd)?,
            t_ff: pack(t_ff, -t, t, 12, Field::MitTorque)?,
        })
    }

    /// A command from its raw fields `[p_des, v_des, kp, kd, t_ff]` (16, 12, 12, 12, 12 bits)
    /// read with `ranges`; [`ProtocolError::ValueOutOfRange`] for a 12-bit field above 4095.
    pub const fn from_raw(ranges: MitRanges, raw: [u16; 5]) -> Result<Self, ProtocolError> {
        Ok(Self {
            ranges,
            p_des: raw[0],
            v_des: match raw12(raw[1], Field::MitVelocity) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
            kp: match raw12(raw[2], Field::MitKp) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
            kd: match raw12(raw[3], Field::MitKd) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
            t_ff: match raw12(raw[4], Field::MitTorque) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
        })
    }

    /// The ranges the fields are packed with.
    pub const fn ranges(&self) -> MitRanges {
        self.ranges
    }

    /// The raw fields `[p_des, v_des, kp, kd, t_ff]`.
    pub const fn raw(&self) -> [u16; 5] {
        [self.p_des, self.v_des, self.kp, self.kd, self.t_ff]
    }

    /// `p_des`, rad.
    pub fn position_rad(&self) -> f64 {
        let p = self.ranges.position_rad();
        unpack(self.p_des, -p, p, 16)
    }

    /// `v_des`, rad/s.
    pub fn velocity_rad_s(&self) -> f64 {
        let v = self.ranges.velocity_rad_s();
        unpack(self.v_des, -v, v, 12)
    }

    /// `kp`, N·m per rad.
    pub fn kp(&self) -> f64 {
        unpack(self.kp, 0.0, self.ranges.kp(), 12)
    }

    /// `kd`, N·m per rad/s.
    pub fn kd(&self) -> f64 {
        unpack(self.kd, 0.0, self.ranges.kd(), 12)
    }

    /// `t_ff`, N·m.
    pub fn torque_nm(&self) -> f64 {
        let t = self.ranges.torque_nm();
        unpack(self.t_ff, -t, t, 12)
    }

    /// The 8 data bytes (V4.3 §5.2, V4.4 §4.2).
    pub(crate) const fn to_data(self) -> [u8; 8] {
        [
            (self.p_des >> 8) as u8,
            self.p_des as u8,
            (self.v_des >> 4) as u8,
            (((self.v_des & 0xF) << 4) | (self.kp >> 8)) as u8,
            self.kp as u8,
            (self.kd >> 4) as u8,
            (((self.kd & 0xF) << 4) | (self.t_ff >> 8)) as u8,
            self.t_ff as u8,
        ]
    }

    /// The command in 8 data bytes, read with `ranges`.
    pub(crate) const fn from_data(ranges: MitRanges, d: &[u8; 8]) -> Self {
        Self {
            ranges,
            p_des: u16::from_be_bytes([d[0], d[1]]),
            v_des: ((d[2] as u16) << 4) | (d[3] as u16 >> 4),
            kp: (((d[3] & 0xF) as u16) << 8) | d[4] as u16,
            kd: ((d[5] as u16) << 4) | (d[6] as u16 >> 4),
            t_ff: (((d[6] & 0xF) as u16) << 8) | d[7] as u16,
        }
    }
}

/// A motion-mode reply (`0x500 + id`): position, velocity and torque, with the command's ranges
/// (V4.3 §5.3, V4.4 §4.3: "the reply frame carries only CANID, actual position, actual
/// velocity, and actual torque").
///
/// ```
/// use rmd_protocol::{MitFeedback, MitRanges};
/// let f = MitFeedback::from_raw(MitRanges::V4_3, [0xE666, 0x82E, 0xB55])?;
/// assert!((f.torque_nm() - 10.004).abs() < 1e-3);
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MitFeedback {
    ranges: MitRanges,
    p: u16,
    v: u16,
    t: u16,
}

impl MitFeedback {
    /// Feedback from physical values (rad, rad/s, N·m at the output), packed with `ranges`;
    /// values beyond the ranges are clamped to them (a motor reports what it can); NaN is
    /// [`ProtocolError::NotFinite`].
    pub fn from_si_saturating(
        ranges: MitRanges,
        p: f64,
        v: f64,
        t: f64,
    ) -> Result<Self, ProtocolError> {
        let (pm, vm, tm) = (
            ranges.position_rad(),
            ranges.velocity_rad_s(),
            ranges.torque_nm(),
        );
        Ok(Self {
            ranges,
            p: pack(p.clamp(-pm, pm), -pm, pm, 16, Field::MitPosition)?,
            v: pack(v.clamp(-vm, vm), -vm, vm, 12, Field::MitVelocity)?,
            t: pack(t.clamp(-tm, tm), -tm, tm, 12, Field::MitTorque)?,
        })
    }

    /// Feedback from its raw fields `[p, v, t]` (16, 12, 12 bits) read with `ranges`;
    /// [`ProtocolError::ValueOutOfRange`] for a 12-bit field above 4095.
    pub const fn from_raw(ranges: MitRanges, raw: [u16; 3]) -> Result<Self, ProtocolError> {
        Ok(Self {
            ranges,
            p: raw[0],
            v: match raw12(raw[1], Field::MitVelocity) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
            t: match raw12(raw[2], Field::MitTorque) {
                Ok(v) => v,
                Err(e) => return Err(e),
            },
        })
    }

    /// The ranges the fields are read with.
    pub const fn ranges(&self) -> MitRanges {
        self.ranges
    }

    /// The raw fields `[p, v, t]`.
    pub const fn raw(&self) -> [u16; 3] {
        [self.p, self.v, self.t]
    }

    /// Position, rad.
    pub fn position_rad(&self) -> f64 {
        let p = self.ranges.position_rad();
        unpack(self.p, -p, p, 16)
    }

    /// Velocity, rad/s.
    pub fn velocity_rad_s(&self) -> f64 {
        let v = self.ranges.velocity_rad_s();
        unpack(self.v, -v, v, 12)
    }

    /// Torque, N·m.
    pub fn torque_nm(&self) -> f64 {
        let t = self.ranges.torque_nm();
        unpack(self.t, -t, t, 12)
    }

    /// The 8 data bytes of motor `id`'s reply (DATA\[0\] = the motor id, DATA\[6..=7\] 0).
    pub(crate) const fn to_data(self, id: u8) -> [u8; 8] {
        [
            id,
            (self.p >> 8) as u8,
            self.p as u8,
            (self.v >> 4) as u8,
            (((self.v & 0xF) << 4) | (self.t >> 8)) as u8,
            self.t as u8,
            0,
            0,
        ]
    }

    /// The feedback in 8 data bytes (DATA\[0\] already checked), read with `ranges`.
    pub(crate) const fn from_data(ranges: MitRanges, d: &[u8; 8]) -> Self {
        Self {
            ranges,
            p: u16::from_be_bytes([d[1], d[2]]),
            v: ((d[3] as u16) << 4) | (d[4] as u16 >> 4),
            t: (((d[4] & 0xF) as u16) << 8) | d[5] as u16,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_is_the_manuals() {
        let c = MitCommand::from_si(MitRanges::V4_3, 10.0, 1.021, 10.012, 1.0, 10.004).unwrap();
        assert_eq!(
            c.to_data(),
            [0xE6, 0x66, 0x82, 0xE0, 0x52, 0x33, 0x3B, 0x55]
        );
        assert_eq!(MitCommand::from_data(MitRanges::V4_3, &c.to_data()), c);
        let f = MitFeedback::from_raw(MitRanges::V4_3, [0xE666, 0x82E, 0xB55]).unwrap();
        assert_eq!(f.to_data(1), [0x01, 0xE6, 0x66, 0x82, 0xEB, 0x55, 0, 0]);
        assert_eq!(MitFeedback::from_data(MitRanges::V4_3, &f.to_data(1)), f);
    }

    #[test]
    fn bounds_and_errors() {
        let r = MitRanges::V4_3;
        let lo = MitCommand::from_si(r, -12.5, -45.0, 0.0, 0.0, -24.0).unwrap();
        assert_eq!(lo.raw(), [0, 0, 0, 0, 0]);
        let hi = MitCommand::from_si(r, 12.5, 45.0, 500.0, 5.0, 24.0).unwrap();
        assert_eq!(hi.raw(), [0xFFFF, 0xFFF, 0xFFF, 0xFFF, 0xFFF]);
        assert_eq!(
            MitCommand::from_si(r, 12.6, 0.0, 0.0, 0.0, 0.0),
            Err(ProtocolError::OutOfRangeMilli {
                field: Field::MitPosition,
                value_milli: 12_600,
                min_milli: -12_500,
                max_milli: 12_500
            })
        );
        assert!(MitCommand::from_si(r, f64::NAN, 0.0, 0.0, 0.0, 0.0).is_err());
        assert!(MitCommand::from_si(r, 0.0, 0.0, 0.0, 5.5, 0.0).is_err());
        assert!(MitCommand::from_raw(r, [0, 0x1000, 0, 0, 0]).is_err());
        let f = MitFeedback::from_si_saturating(r, 99.0, -99.0, 0.0).unwrap();
        assert_eq!(f.raw()[..2], [0xFFFF, 0]);
    }
}
