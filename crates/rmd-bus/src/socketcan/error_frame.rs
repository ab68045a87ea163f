//! Decoding SocketCAN error frames (`linux/can/error.h`) into [`BusEvent`]s.
//!
//! A CAN driver reports controller and bus problems as *error frames*: frames whose identifier
//! has `CAN_ERR_FLAG` set, whose other identifier bits say which classes of problem occurred,
//! and whose data bytes give details. One error frame often reports several things at once
//! (for example "error-passive" together with "receive overflow"), so decoding yields a small
//! list of events, in a fixed order: transmit timeout, lost arbitration, controller state and
//! buffer problems, protocol violation, transceiver, missing acknowledgement, bus-off,
//! restarted.
//!
//! ```
//! use rmd_bus::BusEvent;
//! use rmd_bus::socketcan::error_frame::decode_error_frame;
//!
//! // CAN_ERR_CRTL with CAN_ERR_CRTL_TX_PASSIVE in data[1], then CAN_ERR_BUSOFF.
//! let events = decode_error_frame(0x0000_0004, &[0, 0x20, 0, 0, 0, 0, 0, 0]);
//! assert_eq!(events.as_slice(), &[BusEvent::ErrorPassive]);
//! let events = decode_error_frame(0x0000_0040, &[0; 8]);
//! assert_eq!(events.as_slice(), &[BusEvent::BusOff]);
//! ```

use crate::BusEvent;

/// `CAN_ERR_TX_TIMEOUT`: transmission timed out (reported by the driver's watchdog).
pub const CAN_ERR_TX_TIMEOUT: u32 = 0x0000_0001;
/// `CAN_ERR_LOSTARB`: lost arbitration (bit number in `data[0]`).
pub const CAN_ERR_LOSTARB: u32 = 0x0000_0002;
/// `CAN_ERR_CRTL`: controller problem (details in `data[1]`).
pub const CAN_ERR_CRTL: u32 = 0x0000_0004;
/// `CAN_ERR_PROT`: protocol violation (type in `data[2]`, location in `data[3]`).
pub const CAN_ERR_PROT: u32 = 0x0000_0008;
/// `CAN_ERR_TRX`: transceiver status (details in `data[4]`).
pub const CAN_ERR_TRX: u32 = 0x0000_0010;
/// `CAN_ERR_ACK`: no acknowledgement received on transmission.
pub const CAN_ERR_ACK: u32 = 0x0000_0020;
/// `CAN_ERR_BUSOFF`: the controller went bus-off.
pub const CAN_ERR_BUSOFF: u32 = 0x0000_0040;
/// `CAN_ERR_BUSERROR`: a bus error (usually together with `CAN_ERR_PROT`).
pub const CAN_ERR_BUSERROR: u32 = 0x0000_0080;
/// `CAN_ERR_RESTARTED`: the controller was restarted.
pub const CAN_ERR_RESTARTED: u32 = 0x0000_0100;
/// `CAN_ERR_CNT`: `data[6]`/`data[7]` hold the TX/RX error counters (informational only).
pub const CAN_ERR_CNT: u32 = 0x0000_0200;

/// Every error class above: the error mask the backend subscribes to.
pub const ALL_ERROR_CLASSES: u32 = CAN_ERR_TX_TIMEOUT
    | CAN_ERR_LOSTARB
    | CAN_ERR_CRTL
    | CAN_ERR_PROT
    | CAN_ERR_TRX
    | CAN_ERR_ACK
    | CAN_ERR_BUSOFF
    | CAN_ERR_BUSERROR
    | CAN_ERR_RESTARTED
    | CAN_ERR_CNT;

// `data[1]` for CAN_ERR_CRTL.
const CRTL_RX_OVERFLOW: u8 = 0x01;
const CRTL_TX_OVERFLOW: u8 = 0x02;
const CRTL_RX_WARNING: u8 = 0x04;
const CRTL_TX_WARNING: u8 = 0x08;
const CRTL_RX_PASSIVE: u8 = 0x10;
const CRTL_TX_PASSIVE: u8 = 0x20;
const CRTL_ACTIVE: u8 = 0x40;

/// Most events one error frame can produce (every [`BusEvent`] variant at most once).
pub const MAX_EVENTS_PER_ERROR_FRAME: usize = 13;

/// The events one error frame decoded into: a fixed-capacity list, no allocation.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct ErrorFrameEvents {
    events: [BusEvent; MAX_EVENTS_PER_ERROR_FRAME],
    len: usize,
}

impl ErrorFrameEvents {
    const fn new() -> Self {
        Self {
            events: [BusEvent::ControllerProblem; MAX_EVENTS_PER_ERROR_FRAME],
            len: 0,
        }
    }

    fn push(&mut self, event: BusEvent) {
        if self.len < MAX_EVENTS_PER_ERROR_FRAME && !self.as_slice().contains(&event) {
            self.events[self.len] = event;
            self.len += 1;
        }
    }

    /// The decoded events, in the order described in the [module docs](self).
    pub fn as_slice(&self) -> &[BusEvent] {
        &self.events[..self.len]
    }

    /// Whether the frame reported nothing rmd-rt models (e.g. only error counters).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Decodes an error frame: `classes` is its identifier without `CAN_ERR_FLAG` (extra flag bits
/// are ignored), `data` its 8 data bytes.
///
/// Classes without a matching event (`CAN_ERR_CNT`, the counters) yield nothing; a controller
/// problem the driver did not specify yields [`BusEvent::ControllerProblem`].
pub fn decode_error_frame(classes: u32, data: &[u8; 8]) -> ErrorFrameEvents {
    let mut events = ErrorFrameEvents::new();
    if classes & CAN_ERR_TX_TIMEOUT != 0 {
        events.push(BusEvent::TxTimeout);
    }
    if classes & CAN_ERR_LOSTARB != 0 {
        events.push(BusEvent::ArbitrationLost);
    }
    if classes & CAN_ERR_CRTL != 0 {
        let crtl = data[1];
        if crtl & CRTL_RX_OVERFLOW != 0 {
            events.push(BusEvent::RxOverflow);
        }
        if crtl & CRTL_TX_OVERFLOW != 0 {
            events.push(BusEvent::TxOverflow);
        }
        if crtl & (CRTL_RX_WARNING | CRTL_TX_WARNING) != 0 {
            events.push(BusEvent::ErrorWarning);
        }
        if crtl & (CRTL_RX_PASSIVE | CRTL_TX_PASSIVE) != 0 {
            events.push(BusEvent::ErrorPassive);
        }
        if crtl & CRTL_ACTIVE != 0 {
            events.push(BusEvent::ErrorActive);
        }
        if crtl == 0 {
            events.push(BusEvent::ControllerProblem);
        }
    }
    if classes & (CAN_ERR_PROT | CAN_ERR_BUSERROR) != 0 {
        events.push(BusEvent::ProtocolViolation);
    }
    if classes & CAN_ERR_TRX != 0 {
        events.push(BusEvent::TransceiverError);
    }
    if classes & CAN_ERR_ACK != 0 {
        events.push(BusEvent::NoAck);
    }
    if classes & CAN_ERR_BUSOFF != 0 {
        events.push(BusEvent::BusOff);
    }
    if classes & CAN_ERR_RESTARTED != 0 {
        events.push(BusEvent::Restarted);
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(classes: u32, crtl: u8) -> Vec<BusEvent> {
        decode_error_frame(classes, &[0, crtl, 0, 0, 0, 0, 0, 0])
            .as_slice()
            .to_vec()
    }

    #[test]
    fn each_class_maps_to_its_event() {
        assert_eq!(decode(CAN_ERR_TX_TIMEOUT, 0), [BusEvent::TxTimeout]);
        assert_eq!(decode(CAN_ERR_LOSTARB, 0), [BusEvent::ArbitrationLost]);
        assert_eq!(decode(CAN_ERR_PROT, 0), [BusEvent::ProtocolViolation]);
        assert_eq!(decode(CAN_ERR_BUSERROR, 0), [BusEvent::ProtocolViolation]);
        assert_eq!(decode(CAN_ERR_TRX, 0), [BusEvent::TransceiverError]);
        assert_eq!(decode(CAN_ERR_ACK, 0), [BusEvent::NoAck]);
        assert_eq!(decode(CAN_ERR_BUSOFF, 0), [BusEvent::BusOff]);
        assert_eq!(decode(CAN_ERR_RESTARTED, 0), [BusEvent::Restarted]);
        assert_eq!(decode(CAN_ERR_CNT, 0), []);
    }

    #[test]
    fn controller_details_map_to_states_and_overflows() {
        assert_eq!(
            decode(CAN_ERR_CRTL, CRTL_RX_OVERFLOW),
            [BusEvent::RxOverflow]
        );
        assert_eq!(
            decode(CAN_ERR_CRTL, CRTL_TX_OVERFLOW),
            [BusEvent::TxOverflow]
        );
        assert_eq!(
            decode(CAN_ERR_CRTL, CRTL_RX_WARNING | CRTL_TX_WARNING),
            [BusEvent::ErrorWarning]
        );
        assert_eq!(
            decode(CAN_ERR_CRTL, CRTL_RX_PASSIVE),
            [BusEvent::ErrorPassive]
        );
        assert_eq!(decode(CAN_ERR_CRTL, CRTL_ACTIVE), [BusEvent::ErrorActive]);
        assert_eq!(decode(CAN_ERR_CRTL, 0), [BusEvent::ControllerProblem]);
    }

    #[test]
    fn one_frame_can_report_several_events_in_a_fixed_order() {
        let events = decode(
            CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_PROT | CAN_ERR_BUSERROR | CAN_ERR_ACK,
            CRTL_TX_PASSIVE | CRTL_RX_OVERFLOW,
        );
        assert_eq!(
            events,
            [
                BusEvent::RxOverflow,
                BusEvent::ErrorPassive,
                BusEvent::ProtocolViolation,
                BusEvent::NoAck,
                BusEvent::BusOff
            ]
        );
    }

    #[test]
    fn every_class_and_detail_at_once_fits() {
        let events = decode_error_frame(u32::MAX, &[0xFF; 8]);
        assert_eq!(events.as_slice().len(), 12);
        assert!(!events.is_empty());
    }
}
