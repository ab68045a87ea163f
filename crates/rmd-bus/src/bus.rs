//! The `CanBus` trait: what the loop needs from a CAN interface, and nothing more.

use core::marker::PhantomData;
use core::time::Duration;
#[cfg(target_os = "linux")]
use std::os::fd::BorrowedFd;

use rmd_protocol::CanFrame;

use crate::Timestamp;

/// A CAN interface the loop can drive: the simulator, Linux SocketCAN, or a wrapper around either
/// (a recorder, a fault injector).
///
/// Both methods are called from the real-time thread, so implementations must not allocate and
/// must not block, except `recv_until`, which waits at most until its absolute deadline.
pub trait CanBus {
    /// Queues `frame` for transmission and returns at once.
    ///
    /// A full transmit queue is [`BusError::TxQueueFull`]: the frame was not sent, and the caller
    /// decides what to do (a frame is never dropped silently).
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError>;

    /// Returns the next received frame or bus event, waiting for it at most until `deadline`
    /// (an absolute time on the bus's clock). `Ok(None)` means the deadline passed with nothing
    /// received. A deadline in the past polls: anything already received is returned, else `None`.
    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError>;

    /// Whether something can be received now, and if not, what a wait on several buses at once
    /// ([`ready::wait_any`](crate::ready::wait_any)) watches for this one. Never waits; called
    /// from the real-time thread.
    ///
    /// The default, [`Readiness::Alone`], says the bus can only be waited on by its own
    /// `recv_until` (a simulator that advances its time while it waits).
    fn readiness(&mut self) -> Readiness<'_> {
        Readiness::Alone
    }
}

impl<B: CanBus + ?Sized> CanBus for &mut B {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        (**self).send(frame)
    }
    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        (**self).recv_until(deadline)
    }
    fn readiness(&mut self) -> Readiness<'_> {
        (**self).readiness()
    }
}

impl<B: CanBus + ?Sized> CanBus for Box<B> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        (**self).send(frame)
    }
    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        (**self).recv_until(deadline)
    }
    fn readiness(&mut self) -> Readiness<'_> {
        (**self).readiness()
    }
}

/// What [`CanBus::readiness`] says.
#[derive(Copy, Clone, Debug)]
pub enum Readiness<'a> {
    /// Something can be received now: `recv_until` with a past deadline returns it.
    Ready,
    /// Nothing yet; a wait for this bus together with others watches this.
    Pending(WaitOn<'a>),
    /// The bus cannot be waited on together with others: wait on it alone, with `recv_until`.
    Alone,
}

/// What a wait on several buses at once watches for one bus: a file descriptor that becomes
/// readable when something may be received (a SocketCAN socket, a simulator's doorbell), and
/// the time the next item is known to arrive, if the bus knows it (a simulated bus computes its
/// replies ahead of their time on the wire).
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::{Timestamp, WaitOn};
/// let at = Timestamp::from_nanos(5_000);
/// let wait = WaitOn::arrival(at, Duration::from_micros(2));
/// assert_eq!(wait.next_arrival(), Some((at, Duration::from_micros(2))));
/// ```
#[derive(Copy, Clone, Debug)]
pub struct WaitOn<'a> {
    /// When the next item arrives (ns on the bus's clock), [`NO_ARRIVAL`] if not known. Plain
    /// integers: a wait over every bus compares them once per bus and wake-up.
    arrival_ns: u64,
    /// How long before the arrival the wait stops sleeping and spins, ns.
    spin_ns: u64,
    #[cfg(target_os = "linux")]
    fd: Option<BorrowedFd<'a>>,
    _fd: PhantomData<&'a ()>,
}

/// [`WaitOn::arrival_ns`] when no arrival is known (no clock reaches it: 584 years).
pub(crate) const NO_ARRIVAL: u64 = u64::MAX;

/// Nothing to watch: no descriptor, no known arrival.
impl Default for WaitOn<'_> {
    fn default() -> Self {
        Self {
            arrival_ns: NO_ARRIVAL,
            spin_ns: 0,
            #[cfg(target_os = "linux")]
            fd: None,
            _fd: PhantomData,
        }
    }
}

impl<'a> WaitOn<'a> {
    /// The next item arrives at `at`; the wait sleeps until `spin` before it, then busy-waits
    /// (zero: sleeps all the way).
    #[inline]
    pub fn arrival(at: Timestamp, spin: Duration) -> Self {
        Self::default().with_arrival(at, spin)
    }

    /// The same, and the next item arrives at `at` (see [`arrival`](Self::arrival)).
    #[inline]
    pub fn with_arrival(self, at: Timestamp, spin: Duration) -> Self {
        Self {
            arrival_ns: at.as_nanos().min(NO_ARRIVAL - 1),
            spin_ns: u64::try_from(spin.as_nanos()).unwrap_or(u64::MAX),
            ..self
        }
    }

    /// Something may be received when `fd` becomes readable.
    #[cfg(target_os = "linux")]
    pub fn readable(fd: BorrowedFd<'a>) -> Self {
        Self {
            fd: Some(fd),
            ..Self::default()
        }
    }

    /// The next item's arrival and spin margin, if known.
    pub fn next_arrival(&self) -> Option<(Timestamp, Duration)> {
        (self.arrival_ns != NO_ARRIVAL).then(|| {
            (
                Timestamp::from_nanos(self.arrival_ns),
                Duration::from_nanos(self.spin_ns),
            )
        })
    }

    /// The next item's arrival (ns), [`NO_ARRIVAL`] if not known.
    pub(crate) fn arrival_ns(&self) -> u64 {
        self.arrival_ns
    }

    /// The spin margin before the arrival, ns.
    pub(crate) fn spin_ns(&self) -> u64 {
        self.spin_ns
    }

    /// The file descriptor to watch, if any.
    #[cfg(target_os = "linux")]
    pub fn fd(&self) -> Option<BorrowedFd<'a>> {
        self.fd
    }
}

/// Something that came off the bus, with the time it was received.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Received {
    /// When it was received, on the bus's clock (for SocketCAN: the kernel's receive timestamp
    /// converted to that clock).
    pub at: Timestamp,
    /// What was received.
    pub message: BusMessage,
}

/// A received item: a data frame, or a controller/bus state event.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum BusMessage {
    /// A data frame.
    Frame(CanFrame),
    /// A bus or controller event (from a CAN error frame on SocketCAN).
    Event(BusEvent),
}

/// A change of state of the CAN controller or the bus, reported in band with the frames.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BusEvent {
    /// The controller went bus-off (too many transmit errors): nothing is sent until it restarts.
    BusOff,
    /// The controller is error-passive (error counters at or above 128).
    ErrorPassive,
    /// The error counters reached the warning level (96).
    ErrorWarning,
    /// The controller is back to error-active.
    ErrorActive,
    /// The controller was restarted after bus-off.
    Restarted,
    /// A transmission lost arbitration.
    ArbitrationLost,
    /// A transmission timed out (no acknowledgement, e.g. nobody else on the bus).
    TxTimeout,
    /// The controller's or the socket's receive buffer overflowed: frames were lost.
    RxOverflow,
    /// A protocol violation (bit, form, stuff error) was detected on the bus.
    ProtocolViolation,
    /// No acknowledgement was received for a transmitted frame.
    NoAck,
    /// A bus wiring error was reported by the transceiver.
    TransceiverError,
    /// The controller's transmit buffer overflowed: a frame queued to it was lost.
    TxOverflow,
    /// The controller reported a problem it did not specify further.
    ControllerProblem,
}

impl core::fmt::Display for BusEvent {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            BusEvent::BusOff => "bus-off",
            BusEvent::ErrorPassive => "error-passive",
            BusEvent::ErrorWarning => "error-warning",
            BusEvent::ErrorActive => "error-active",
            BusEvent::Restarted => "controller restarted",
            BusEvent::ArbitrationLost => "arbitration lost",
            BusEvent::TxTimeout => "transmit timeout",
            BusEvent::RxOverflow => "receive overflow",
            BusEvent::ProtocolViolation => "protocol violation",
            BusEvent::NoAck => "no acknowledgement",
            BusEvent::TransceiverError => "transceiver error",
            BusEvent::TxOverflow => "transmit overflow",
            BusEvent::ControllerProblem => "unspecified controller problem",
        })
    }
}

/// Why a bus operation failed. `Copy` and allocation-free: it is returned on the real-time path.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum BusError {
    /// The transmit queue is full; the frame was not sent.
    #[error("CAN transmit queue full: the frame was not sent (raise txqueuelen or send less)")]
    TxQueueFull,
    /// The controller is bus-off; nothing can be sent until it restarts.
    #[error(
        "CAN controller is bus-off: check wiring, termination and bit rate, then restart it \
         (e.g. `ip link set can0 type can restart-ms 100`)"
    )]
    BusOff,
    /// The interface went down or disappeared.
    #[error(
        "CAN interface is down or gone: bring it up (`ip link set can0 up type can bitrate 1000000`)"
    )]
    InterfaceDown,
    /// Any other operating-system error, by errno.
    #[error("CAN I/O error (errno {0})")]
    Io(i32),
}
