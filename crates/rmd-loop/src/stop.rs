//! Stop requests: what other threads ask of a running loop (with a
//! [`Stopper`](crate::Stopper)).
//!
//! A request is a [`StopRequest`]; the loop reads it at the start of every tick (and between
//! start-up probes) and ends with the matching [`StopReason`]. An emergency stop is never
//! downgraded by a later, gentler request.

use std::sync::atomic::{AtomicU8, Ordering};

use crate::report::StopReason;

/// A request to end the loop.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum StopRequest {
    /// Stop: zero torque, then motor off, then report.
    Stop,
    /// The owner of the loop went away (its handle was dropped): stop as for [`Stop`](Self::Stop).
    HandleDropped,
    /// Emergency stop: as [`Stop`](Self::Stop), reported as an emergency.
    EmergencyStop,
}

impl StopRequest {
    fn code(self) -> u8 {
        match self {
            StopRequest::Stop => 1,
            StopRequest::HandleDropped => 2,
            StopRequest::EmergencyStop => 3,
        }
    }

    fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(StopRequest::Stop),
            2 => Some(StopRequest::HandleDropped),
            3 => Some(StopRequest::EmergencyStop),
            _ => None,
        }
    }
}

impl From<StopRequest> for StopReason {
    fn from(request: StopRequest) -> Self {
        match request {
            StopRequest::Stop => StopReason::Requested,
            StopRequest::HandleDropped => StopReason::HandleDropped,
            StopRequest::EmergencyStop => StopReason::EmergencyStop,
        }
    }
}

/// The pending stop request of a loop (lock-free; read by the loop thread every tick).
#[derive(Debug, Default)]
pub(crate) struct StopSignal(AtomicU8);

impl StopSignal {
    /// Records `request`; an emergency stop is never replaced, any request replaces none.
    pub(crate) fn request(&self, request: StopRequest) {
        let code = request.code();
        let _ = self
            .0
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |current| {
                let emergency = StopRequest::EmergencyStop.code();
                (current == 0 || (code == emergency && current != emergency)).then_some(code)
            });
    }

    /// The pending request, if any.
    #[inline]
    pub(crate) fn pending(&self) -> Option<StopRequest> {
        StopRequest::from_code(self.0.load(Ordering::Acquire))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_emergency_stop_is_never_downgraded() {
        let s = StopSignal::default();
        assert_eq!(s.pending(), None);
        s.request(StopRequest::Stop);
        assert_eq!(s.pending(), Some(StopRequest::Stop));
        s.request(StopRequest::HandleDropped);
        assert_eq!(s.pending(), Some(StopRequest::Stop));
        s.request(StopRequest::EmergencyStop);
        assert_eq!(s.pending(), Some(StopRequest::EmergencyStop));
        s.request(StopRequest::Stop);
        assert_eq!(s.pending(), Some(StopRequest::EmergencyStop));
    }
}
