//! A frame addressed to one motor, as that motor's firmware family reads it.

use rmd_protocol::v3::V3Request;
use rmd_protocol::{
    CanFrame, Command, DecodedRequest, Dialect, DialectRequest, Request, ScaledCurrent,
    decode_request, decode_request_with,
};

use crate::family::FirmwareFamily;
use crate::fault::FrameKind;

/// A request to one motor.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum MotorRequest {
    /// A v1.61 request on `0x140 + id`.
    V161(Request),
    /// An LK-TECH request on `0x140 + id`.
    Lk(DialectRequest),
    /// A MyActuator V3 request (on `0x140 + id`, or a 0x280 broadcast).
    V3(V3Request),
    /// This motor's slot of a 0x280 torque frame, in its family's `iqControl` scale.
    SlotTorque(ScaledCurrent),
}

impl MotorRequest {
    /// How a motor of `family` reads `frame` sent to its own `0x140 + id`; `None`: not a request
    /// it knows (the firmware ignores it).
    pub(crate) fn single(family: FirmwareFamily, frame: &CanFrame) -> Option<Self> {
        match family {
            FirmwareFamily::V161 => match decode_request(frame).ok()? {
                DecodedRequest::Single { request, .. } => Some(Self::V161(request)),
                DecodedRequest::Multi(_) => None,
            },
            FirmwareFamily::LkV23x(series) => {
                match decode_request_with(Dialect::LkV23x(series), frame).ok()? {
                    r @ (DialectRequest::Torque { .. }
                    | DialectRequest::Common(DecodedRequest::Single { .. })) => Some(Self::Lk(r)),
                    _ => None,
                }
            }
            FirmwareFamily::MyActuatorV3 => {
                frame.data8().and_then(V3Request::from_data).map(Self::V3)
            }
        }
    }

    /// The frame kind fault rules see.
    pub(crate) fn kind(&self) -> FrameKind {
        match self {
            Self::V161(r) => FrameKind::Single(r.command()),
            Self::Lk(DialectRequest::Torque { .. }) => FrameKind::Single(Command::Torque),
            Self::Lk(DialectRequest::Common(DecodedRequest::Single { request, .. })) => {
                FrameKind::Single(request.command())
            }
            Self::Lk(_) | Self::SlotTorque(_) => FrameKind::Multi,
            Self::V3(r) => {
                Command::from_code(r.command().code()).map_or(FrameKind::Other, FrameKind::Single)
            }
        }
    }

    /// The command byte (DATA\[0\]) of the request, or 0xA1 for a 0x280 torque slot.
    pub(crate) fn command_byte(&self) -> u8 {
        match self {
            Self::V161(r) => r.command().code(),
            Self::Lk(DialectRequest::Common(DecodedRequest::Single { request, .. })) => {
                request.command().code()
            }
            Self::Lk(_) | Self::SlotTorque(_) => Command::Torque.code(),
            Self::V3(r) => r.command().code(),
        }
    }

    /// Whether it is a motion command (0xA1..=0xA6, a 0x280 torque slot, V3 0xA1).
    pub(crate) fn is_motion(&self) -> bool {
        match self {
            Self::SlotTorque(_) | Self::V3(V3Request::Torque { .. }) => true,
            Self::V3(_) => false,
            _ => (0xA1..=0xA6).contains(&self.command_byte()),
        }
    }

    /// Whether it is 0x88 (motor run).
    pub(crate) fn is_run(&self) -> bool {
        matches!(self, Self::V161(_) | Self::Lk(_))
            && self.command_byte() == Command::MotorRun.code()
    }
}
