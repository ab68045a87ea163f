//! Decoding frames into requests and replies. Never panics, on any input.

use crate::command::Command;
use crate::error::{ExpectedIds, ProtocolError};
use crate::frame::CanFrame;
use crate::ids::{MULTI_TORQUE_CAN_ID, MotorId};
use crate::multi::MultiTorque;
use crate::reply::Reply;
use crate::request::Request;

/// A decoded request: to one motor, or the multi-motor torque frame.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum DecodedRequest {
    /// A request on a single-motor ID (0x141..=0x160).
    Single {
        /// The motor addressed.
        motor: MotorId,
        /// The request.
        request: Request,
    },
    /// The 0x280 multi-motor torque frame.
    Multi(MultiTorque),
}

impl DecodedRequest {
    /// Encodes the request back into its frame.
    pub const fn encode(&self) -> CanFrame {
        match self {
            DecodedRequest::Single { motor, request } => request.encode(*motor),
            DecodedRequest::Multi(m) => m.encode(),
        }
    }
}

/// The 8 data bytes, or [`ProtocolError::WrongDlc`].
#[inline]
pub(crate) fn data8(frame: &CanFrame) -> Result<&[u8; 8], ProtocolError> {
    frame.data8().ok_or(ProtocolError::WrongDlc {
        can_id: frame.id(),
        dlc: frame.dlc(),
    })
}

/// The command in DATA\[0\], or [`ProtocolError::UnknownCommand`].
#[inline]
pub(crate) fn command_of(frame: &CanFrame, d: &[u8; 8]) -> Result<Command, ProtocolError> {
    Command::from_code(d[0]).ok_or(ProtocolError::UnknownCommand {
        can_id: frame.id(),
        code: d[0],
    })
}

/// Decodes a frame sent by the host: a single-motor request (0x141..=0x160) or the 0x280
/// multi-motor torque frame (used to read logs and by the simulator).
///
/// Checks, in order: the CAN ID ([`ProtocolError::UnexpectedCanId`]), DLC 8
/// ([`ProtocolError::WrongDlc`]), the command byte ([`ProtocolError::UnknownCommand`]) and the
/// field ranges ([`ProtocolError::ValueOutOfRange`]). Reserved bytes are ignored.
///
/// ```
/// use rmd_protocol::{decode_request, CanFrame, DecodedRequest, Request};
/// let frame = CanFrame::new(0x141, &[0xA1, 0, 0, 0, 0x64, 0, 0, 0]).unwrap();
/// let DecodedRequest::Single { motor, request } = decode_request(&frame).unwrap() else { panic!() };
/// assert_eq!(motor.get(), 1);
/// assert!(matches!(request, Request::Torque { iq_control } if iq_control.raw() == 100));
/// ```
#[inline]
pub fn decode_request(frame: &CanFrame) -> Result<DecodedRequest, ProtocolError> {
    if frame.id() == MULTI_TORQUE_CAN_ID {
        let d = data8(frame)?;
        return Ok(DecodedRequest::Multi(MultiTorque::from_data(d)?));
    }
    let motor = MotorId::from_can_id(frame.id()).map_err(|_| ProtocolError::UnexpectedCanId {
        can_id: frame.id(),
        expected: ExpectedIds::MotorOrMultiTorque,
    })?;
    let d = data8(frame)?;
    let command = command_of(frame, d)?;
    Ok(DecodedRequest::Single {
        motor,
        request: Request::from_data(command, d)?,
    })
}

/// Decodes a frame sent by a motor, whatever request it answers.
///
/// Checks, in order: the CAN ID (0x141..=0x160, else [`ProtocolError::UnexpectedCanId`]), DLC 8,
/// the command byte, the field ranges. Reserved bytes are ignored. A frame with DATA\[0\] = 0x9A
/// decodes as [`Reply::ReadStatus1`]; use [`decode_reply_to`] to read it as the answer to a
/// pending 0x9B.
#[inline]
pub fn decode_reply(frame: &CanFrame) -> Result<(MotorId, Reply), ProtocolError> {
    let motor = MotorId::from_can_id(frame.id())?;
    let d = data8(frame)?;
    let command = command_of(frame, d)?;
    Ok((motor, Reply::from_data(command, d)?))
}

/// Decodes a frame sent by a motor as the reply to the pending request `pending`
/// (for a 0x280 multi-motor frame, pass [`Command::Torque`]).
///
/// Like [`decode_reply`], and rejects a reply to another command with
/// [`ProtocolError::ReplyMismatch`] (checked before the field ranges). As the reading notes
/// require, DATA\[0\] = 0x9A is accepted as the reply to a pending 0x9B (the spec's table shows
/// 0x9A there) and decodes as [`Reply::ClearError`]. It does not check which motor answered:
/// compare the returned [`MotorId`] with the one you asked.
///
/// ```
/// use rmd_protocol::{decode_reply_to, CanFrame, Command, ProtocolError, Reply};
/// let status1 = CanFrame::new(0x141, &[0x9A, 30, 0, 0xF0, 0, 0, 0, 0]).unwrap();
/// let (_, reply) = decode_reply_to(&status1, Command::ClearError).unwrap();
/// assert!(matches!(reply, Reply::ClearError(s) if s.voltage.volts() == 24.0));
/// assert!(matches!(
///     decode_reply_to(&status1, Command::Torque),
///     Err(ProtocolError::ReplyMismatch { .. })
/// ));
/// ```
#[inline]
pub fn decode_reply_to(
    frame: &CanFrame,
    pending: Command,
) -> Result<(MotorId, Reply), ProtocolError> {
    let motor = MotorId::from_can_id(frame.id())?;
    let d = data8(frame)?;
    let got = command_of(frame, d)?;
    let command = answered_command(frame, got, pending)?;
    Ok((motor, Reply::from_data(command, d)?))
}

/// The command a reply carrying `got` answers when `pending` is waiting: `got` itself, or 0x9B
/// for a 0x9A reply to a pending 0x9B; else [`ProtocolError::ReplyMismatch`].
#[inline]
pub(crate) fn answered_command(
    frame: &CanFrame,
    got: Command,
    pending: Command,
) -> Result<Command, ProtocolError> {
    if got == pending {
        Ok(got)
    } else if pending == Command::ClearError && got == Command::ReadStatus1 {
        Ok(Command::ClearError)
    } else {
        Err(ProtocolError::ReplyMismatch {
            can_id: frame.id(),
            expected: pending,
            got,
        })
    }
}
