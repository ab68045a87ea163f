//! The raw CAN frame every layer of rmd-rt passes around.

use crate::error::ProtocolError;

/// Highest standard (11-bit) CAN identifier.
pub const MAX_STANDARD_ID: u16 = 0x7FF;

/// One classic CAN data frame with a standard 11-bit identifier, as it is on the wire.
///
/// The RMD protocol only uses standard data frames with DLC 8, but a `CanFrame` can hold any
/// standard frame (DLC 0..=8) so that logs and buses can carry, and decoders can reject with a
/// clear error, whatever actually appeared on the bus.
///
/// ```
/// use rmd_protocol::CanFrame;
/// let frame = CanFrame::new(0x141, &[0x9C, 0, 0, 0, 0, 0, 0, 0]).unwrap();
/// assert_eq!(frame.id(), 0x141);
/// assert_eq!(frame.data(), &[0x9C, 0, 0, 0, 0, 0, 0, 0]);
/// ```
#[derive(Copy, Clone, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u16,
    len: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// Builds a frame from an identifier and 0..=8 payload bytes.
    ///
    /// Errors: [`ProtocolError::InvalidCanId`] for an identifier above 0x7FF,
    /// [`ProtocolError::WrongDlc`] for a payload longer than 8 bytes.
    pub fn new(id: u16, payload: &[u8]) -> Result<Self, ProtocolError> {
        if id > MAX_STANDARD_ID {
            return Err(ProtocolError::InvalidCanId { can_id: id as u32 });
        }
        if payload.len() > 8 {
            return Err(ProtocolError::WrongDlc {
                can_id: id,
                dlc: payload.len().min(u8::MAX as usize) as u8,
            });
        }
        let mut data = [0u8; 8];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Self {
            id,
            len: payload.len() as u8,
            data,
        })
    }

    /// Builds an 8-byte frame; the form every RMD command and reply takes.
    ///
    /// Errors: [`ProtocolError::InvalidCanId`] for an identifier above 0x7FF.
    pub fn with_data(id: u16, data: [u8; 8]) -> Result<Self, ProtocolError> {
        if id > MAX_STANDARD_ID {
            return Err(ProtocolError::InvalidCanId { can_id: id as u32 });
        }
        Ok(Self { id, len: 8, data })
    }

    /// An 8-byte frame on one of the protocol's own identifiers (all standard: at most 0x280),
    /// for the encoders, which cannot fail.
    pub(crate) const fn rmd(id: u16, data: [u8; 8]) -> Self {
        debug_assert!(id <= MAX_STANDARD_ID);
        Self { id, len: 8, data }
    }

    /// The 11-bit identifier.
    pub const fn id(&self) -> u16 {
        self.id
    }

    /// The data length code (number of payload bytes, 0..=8).
    pub const fn dlc(&self) -> u8 {
        self.len
    }

    /// The payload (`dlc()` bytes).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// The payload as a fixed array if the frame carries exactly 8 bytes.
    pub const fn data8(&self) -> Option<&[u8; 8]> {
        if self.len == 8 {
            Some(&self.data)
        } else {
            None
        }
    }
}

impl core::fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{self}")
    }
}

/// Formats the frame in candump's compact form, `ID#DATA` (e.g. `141#9C00000000000000`).
impl core::fmt::Display for CanFrame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:03X}#", self.id)?;
        for byte in self.data() {
            write!(f, "{byte:02X}")?;
        }
        Ok(())
    }
}
