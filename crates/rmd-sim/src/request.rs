//! A frame addressed to one motor, as that motor's firmware reads it.

use rmd_protocol::{
    CanFrame, Command, DecodedRequest, Dialect, MitCommand, ProtocolError, Request, ScaledCurrent,
};

use crate::fault::RequestKind;

/// A request to one motor.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum MotorRequest {
    /// A request on `0x140 + id`, or (MyActuator V3) a 0x280 frame, decoded in the motor's
    /// dialect.
    Single(Request),
    /// This motor's slot of a v1.61 / LK-TECH 0x280 torque frame, in its family's scale.
    SlotTorque(ScaledCurrent),
    /// A MyActuator V3 motion-mode command on `0x400 + id`.
    Mit(MitCommand),
    /// A frame on `0x140 + id` with a command byte the motor's firmware does not know (what a
    /// V3 motor answers with its previous reply, when that trap is set).
    Unknown {
        /// DATA\[0\].
        code: u8,
    },
}

impl MotorRequest {
    /// How a motor speaking `dialect` reads `frame` sent to its own `0x140 + id` (or, for V3,
    /// its `0x400 + id`); `None`: not a request it can take (bad DLC, a value out of range: the
    /// firmware ignores it).
    pub(crate) fn single(dialect: Dialect, frame: &CanFrame) -> Option<Self> {
        match dialect.decode_request(frame) {
            Ok(DecodedRequest::Single { request, .. }) => Some(Self::Single(request)),
            Ok(DecodedRequest::Mit { command, .. }) => Some(Self::Mit(command)),
            Ok(DecodedRequest::Multi(_) | DecodedRequest::Broadcast(_)) => None,
            Err(ProtocolError::UnknownCommand { code, .. }) => Some(Self::Unknown { code }),
            Err(_) => None,
        }
    }

    /// The frame kind fault rules see.
    pub(crate) fn kind(&self) -> RequestKind {
        match self {
            Self::Single(r) => RequestKind::Single(r.command()),
            Self::SlotTorque(_) => RequestKind::Multi,
            Self::Mit(_) | Self::Unknown { .. } => RequestKind::Other,
        }
    }

    /// The command byte (DATA\[0\]) of the request; 0xA1 for a 0x280 torque slot, none for a
    /// motion-mode command.
    pub(crate) fn command_byte(&self) -> Option<u8> {
        match self {
            Self::Single(r) => Some(r.command().code()),
            Self::SlotTorque(_) => Some(Command::Torque.code()),
            Self::Mit(_) => None,
            Self::Unknown { code } => Some(*code),
        }
    }

    /// Whether it is a motion command (0xA1..=0xA6, a 0x280 torque slot, a motion-mode command).
    pub(crate) fn is_motion(&self) -> bool {
        match self {
            Self::Single(r) => (0xA1..=0xA6).contains(&r.command().code()),
            Self::SlotTorque(_) | Self::Mit(_) => true,
            Self::Unknown { .. } => false,
        }
    }

    /// Whether it is 0x88 (motor run).
    pub(crate) fn is_run(&self) -> bool {
        matches!(self, Self::Single(Request::MotorRun))
    }
}
