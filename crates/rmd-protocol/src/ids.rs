//! Motor ids and the CAN identifiers of the protocol.

use crate::error::{ExpectedIds, ProtocolError};

/// Base of the single-motor identifiers: motor `n` uses CAN ID `0x140 + n`.
pub const SINGLE_MOTOR_BASE_ID: u16 = 0x140;
/// CAN ID of motor 1, the lowest single-motor identifier.
pub const FIRST_MOTOR_CAN_ID: u16 = SINGLE_MOTOR_BASE_ID + MotorId::MIN as u16;
/// CAN ID of motor 32, the highest single-motor identifier.
pub const LAST_MOTOR_CAN_ID: u16 = SINGLE_MOTOR_BASE_ID + MotorId::MAX as u16;
/// CAN ID of the multi-motor torque command (four `iqControl` values for motors 1..=4).
pub const MULTI_TORQUE_CAN_ID: u16 = 0x280;
/// Number of motors one 0x280 frame drives (ids 1..=4).
pub const MULTI_TORQUE_MOTORS: usize = 4;
/// Base of MyActuator V3's reply identifiers: motor `n` replies on `0x240 + n` (V4.3 / V4.4
/// §1.1.2).
pub const V3_REPLY_BASE_ID: u16 = 0x240;
/// Base of MyActuator V3's motion-mode identifiers: `0x400 + n` (V4.3 §5, V4.4 §4).
pub const V3_MOTION_BASE_ID: u16 = 0x400;
/// Base of MyActuator V3's motion-mode reply identifiers: `0x500 + n` (V4.3 §5, V4.4 §4).
pub const V3_MOTION_REPLY_BASE_ID: u16 = 0x500;

/// The id of one motor on a bus, 1..=32 (spec: "0x140 + ID(1~32)").
///
/// Requests to the motor and its replies both use CAN ID `0x140 + id`.
///
/// ```
/// use rmd_protocol::MotorId;
/// let m = MotorId::new(3).unwrap();
/// assert_eq!(m.get(), 3);
/// assert_eq!(m.can_id(), 0x143);
/// assert_eq!(MotorId::from_can_id(0x143), Ok(m));
/// assert!(MotorId::new(0).is_err() && MotorId::new(33).is_err());
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MotorId(u8);

impl MotorId {
    /// Lowest motor id.
    pub const MIN: u8 = 1;
    /// Highest motor id.
    pub const MAX: u8 = 32;

    /// The motor with id `id`; [`ProtocolError::InvalidMotorId`] unless `1 <= id <= 32`.
    pub const fn new(id: u8) -> Result<Self, ProtocolError> {
        if id >= Self::MIN && id <= Self::MAX {
            Ok(Self(id))
        } else {
            Err(ProtocolError::InvalidMotorId { id })
        }
    }

    /// The id, 1..=32.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// The CAN ID of this motor's requests and replies, `0x140 + id`.
    pub const fn can_id(self) -> u16 {
        SINGLE_MOTOR_BASE_ID + self.0 as u16
    }

    /// The motor whose CAN ID is `can_id`; [`ProtocolError::UnexpectedCanId`] outside
    /// 0x141..=0x160.
    pub const fn from_can_id(can_id: u16) -> Result<Self, ProtocolError> {
        if can_id >= FIRST_MOTOR_CAN_ID && can_id <= LAST_MOTOR_CAN_ID {
            Ok(Self((can_id - SINGLE_MOTOR_BASE_ID) as u8))
        } else {
            Err(ProtocolError::UnexpectedCanId {
                can_id,
                expected: ExpectedIds::Motor,
            })
        }
    }

    /// This motor's slot in a 0x280 multi-motor torque frame (0..=3 for ids 1..=4), or `None`
    /// for ids 5..=32, which a 0x280 frame cannot drive.
    pub const fn multi_torque_slot(self) -> Option<usize> {
        if self.0 as usize <= MULTI_TORQUE_MOTORS {
            Some(self.0 as usize - 1)
        } else {
            None
        }
    }
}

/// The motor whose identifier is `can_id` on the identifiers `base + 1 ..= base + 32`; else
/// [`ProtocolError::UnexpectedCanId`] with `expected`.
pub(crate) const fn motor_on(
    can_id: u16,
    base: u16,
    expected: ExpectedIds,
) -> Result<MotorId, ProtocolError> {
    if can_id > base && can_id <= base + MotorId::MAX as u16 {
        Ok(MotorId((can_id - base) as u8))
    } else {
        Err(ProtocolError::UnexpectedCanId { can_id, expected })
    }
}

impl core::fmt::Display for MotorId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl TryFrom<u8> for MotorId {
    type Error = ProtocolError;
    fn try_from(id: u8) -> Result<Self, ProtocolError> {
        Self::new(id)
    }
}
