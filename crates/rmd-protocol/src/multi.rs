//! The 0x280 multi-motor torque frame.

use crate::frame::CanFrame;
use crate::ids::{MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId};
use crate::values::IqControl;
use crate::wire::{i16_at, put_i16};

/// The multi-motor torque command (CAN ID 0x280): one `iqControl` for each of motors 1..=4 in
/// DATA\[0..=7\] (little-endian i16 each, no command byte).
///
/// Each motor 1..=4 present answers on its own ID (0x141..=0x144, in ascending ID order) with a
/// [`Reply::Torque`](crate::Reply::Torque) (0xA1 layout); decode those with
/// [`decode_reply_to`](crate::decode_reply_to)`(frame, Command::Torque)`. Only ids 1..=4 can be
/// driven by one 0x280 frame: a robot with more motors needs one bus per group of four.
///
/// ```
/// use rmd_protocol::{IqControl, MultiTorque};
/// let iq = |raw| IqControl::new(raw).unwrap();
/// let cmd = MultiTorque::new([iq(100), iq(-100), iq(0), iq(2000)]);
/// assert_eq!(cmd.encode().to_string(), "280#64009CFF0000D007");
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct MultiTorque {
    /// `iqControl_1` ..= `iqControl_4`: index 0 drives motor 1, index 3 motor 4.
    pub iq_control: [IqControl; MULTI_TORQUE_MOTORS],
}

impl MultiTorque {
    /// The command driving motors 1..=4 with `iq_control[0..=3]`.
    pub const fn new(iq_control: [IqControl; MULTI_TORQUE_MOTORS]) -> Self {
        Self { iq_control }
    }

    /// The current command for `motor`, or `None` if it is not one of motors 1..=4.
    pub const fn iq_control_for(&self, motor: MotorId) -> Option<IqControl> {
        match motor.multi_torque_slot() {
            Some(slot) => Some(self.iq_control[slot]),
            None => None,
        }
    }

    /// The 8 data bytes.
    pub const fn to_data(&self) -> [u8; 8] {
        let mut d = [0u8; 8];
        put_i16::<0>(&mut d, self.iq_control[0].raw());
        put_i16::<2>(&mut d, self.iq_control[1].raw());
        put_i16::<4>(&mut d, self.iq_control[2].raw());
        put_i16::<6>(&mut d, self.iq_control[3].raw());
        d
    }

    /// The frame: CAN ID 0x280, DLC 8.
    pub const fn encode(&self) -> CanFrame {
        CanFrame::rmd(MULTI_TORQUE_CAN_ID, self.to_data())
    }

    /// Decodes the 8 data bytes; every value must be in -2000..=2000.
    pub(crate) fn from_data(d: &[u8; 8]) -> Result<Self, crate::ProtocolError> {
        Ok(Self::new([
            IqControl::new(i16_at::<0>(d).into())?,
            IqControl::new(i16_at::<2>(d).into())?,
            IqControl::new(i16_at::<4>(d).into())?,
            IqControl::new(i16_at::<6>(d).into())?,
        ]))
    }
}
