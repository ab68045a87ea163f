//! The one error type of the protocol layer: `Copy`, allocation-free, says exactly what was wrong.

/// Everything that can be wrong with a frame or a value of the RMD protocol.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ProtocolError {
    /// The identifier does not fit in a standard 11-bit CAN ID.
    #[error("CAN ID 0x{can_id:X} is not a standard 11-bit identifier")]
    InvalidCanId {
        /// The identifier as given.
        can_id: u32,
    },
    /// The frame does not carry the 8 data bytes every RMD frame has.
    #[error("CAN ID 0x{can_id:03X}: DLC {dlc}, every RMD frame has DLC 8")]
    WrongDlc {
        /// Identifier of the offending frame.
        can_id: u16,
        /// Its data length code.
        dlc: u8,
    },
}
