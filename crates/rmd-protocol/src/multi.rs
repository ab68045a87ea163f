//! The 0x280 multi-motor torque frame of v1.61 and LK-TECH V2.3x.

use crate::bytes::{i16_at, put_i16};
use crate::current::ScaledCurrent;
use crate::error::ProtocolError;
use crate::frame::CanFrame;
use crate::ids::{MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId};
use crate::scale::CurrentScale;

/// The multi-motor torque command (CAN ID 0x280) of v1.61 and LK-TECH: one `iqControl` for
/// each of motors 1..=4 in DATA\[0..=7\] (little-endian i16 each, no command byte), each in its
/// motor's scale (a bus may mix v1.61 and LK-TECH motors).
///
/// Each motor 1..=4 present answers on its own ID (0x141..=0x144, in ascending ID order) with
/// a [`Reply::Torque`](crate::Reply::Torque) (0xA1 layout): decode those as replies to
/// [`Command::Torque`](crate::Command::Torque). Only ids 1..=4 can be driven by one 0x280
/// frame: a robot with more motors needs one bus per group of four.
///
/// Sources: gyems-can-v1.61, "multi motor torque closed loop control"; for LK-TECH, whose
/// V2.35 document's multi-motor section was not available as text, drivers of LK motors:
/// github.com/Jason0-0/logging_car_pro_plus `Core/Bsp/RMD_L_Motor/RMD_protocol.h` (0x280,
/// replies 0xA1 on 0x141..=0x144, "-2048~2048 -> -33A~33A") and MG4005 / MG6012 drivers that
/// fill DATA\[2k..=2k+1\] with motor k+1's `iqControl`, low byte first. MyActuator V3 has no
/// such frame: there 0x280 is one command for every motor, and
/// [`Dialect::encode_multi_torque`](crate::Dialect::encode_multi_torque) refuses it.
///
/// ```
/// use rmd_protocol::{CurrentScale, Dialect, IqControl, MultiTorque};
/// let iq = |raw| IqControl::new(raw).unwrap().into();
/// let cmd = MultiTorque::new([iq(100), iq(-100), iq(0), iq(2000)]);
/// assert_eq!(Dialect::V161.encode_multi_torque(&cmd)?.to_string(), "280#64009CFF0000D007");
/// let mf = MultiTorque::from_amps([16.5, -16.5, 0.0, 8.25], CurrentScale::LK_MF_IQ_CONTROL)?;
/// assert_eq!(mf.encode().to_string(), "280#000800F800000004");
/// # Ok::<(), rmd_protocol::ProtocolError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MultiTorque {
    /// `iqControl_1` ..= `iqControl_4`: index 0 drives motor 1, index 3 motor 4.
    pub iq_control: [ScaledCurrent; MULTI_TORQUE_MOTORS],
}

impl MultiTorque {
    /// The command driving motors 1..=4 with `iq_control[0..=3]`.
    pub const fn new(iq_control: [ScaledCurrent; MULTI_TORQUE_MOTORS]) -> Self {
        Self { iq_control }
    }

    /// The command for four currents in amperes with the scale `scale` (checked: see
    /// [`ScaledCurrent::from_amps`]).
    pub fn from_amps(
        amps: [f64; MULTI_TORQUE_MOTORS],
        scale: CurrentScale,
    ) -> Result<Self, ProtocolError> {
        let mut out = [ScaledCurrent::saturating(0, scale); MULTI_TORQUE_MOTORS];
        for (slot, a) in out.iter_mut().zip(amps) {
            *slot = ScaledCurrent::from_amps(a, scale)?;
        }
        Ok(Self::new(out))
    }

    /// The current command for `motor`, or `None` if it is not one of motors 1..=4.
    pub const fn iq_control_for(&self, motor: MotorId) -> Option<ScaledCurrent> {
        match motor.multi_torque_slot() {
            Some(slot) => Some(self.iq_control[slot]),
            None => None,
        }
    }

    /// The 8 data bytes.
    #[inline]
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        put_i16::<0>(&mut d, self.iq_control[0].raw());
        put_i16::<2>(&mut d, self.iq_control[1].raw());
        put_i16::<4>(&mut d, self.iq_control[2].raw());
        put_i16::<6>(&mut d, self.iq_control[3].raw());
        d
    }

    /// The frame: CAN ID 0x280, DLC 8, each slot in its own scale. For a bus of one family,
    /// [`Dialect::encode_multi_torque`](crate::Dialect::encode_multi_torque) also checks that
    /// every slot uses that family's scale; a bus mixing v1.61 and LK-TECH motors (the loop's)
    /// scales each slot for its motor and encodes here.
    #[inline]
    pub const fn encode(&self) -> CanFrame {
        CanFrame::rmd(MULTI_TORQUE_CAN_ID, self.to_data())
    }

    /// Decodes the 8 data bytes with `scale`; every value must be in the scale's range.
    pub(crate) fn from_data(d: &[u8; 8], scale: CurrentScale) -> Result<Self, ProtocolError> {
        let at = |v: i16| ScaledCurrent::new(i64::from(v), scale);
        Ok(Self::new([
            at(i16_at::<0>(d))?,
            at(i16_at::<2>(d))?,
            at(i16_at::<4>(d))?,
            at(i16_at::<6>(d))?,
        ]))
    }
}
