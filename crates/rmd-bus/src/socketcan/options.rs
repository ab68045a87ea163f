//! What to ask of the kernel when opening a [`SocketCanBus`](super::SocketCanBus).

use core::ops::RangeInclusive;
use core::time::Duration;

/// The identifiers every RMD motor replies with (`0x140 + id` for motors 1..=32): always
/// accepted by the kernel filter.
pub const RMD_REPLY_IDS: RangeInclusive<u16> = 0x141..=0x160;

/// The default [drain window](SocketCanOptions::drain_window).
pub const DEFAULT_DRAIN_WINDOW: Duration = Duration::from_millis(10);

/// One extra set of standard identifiers to accept besides [`RMD_REPLY_IDS`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum IdFilter {
    /// Every identifier in `first..=last`.
    Range {
        /// First identifier accepted.
        first: u16,
        /// Last identifier accepted.
        last: u16,
    },
    /// Every identifier `x` with `x & mask == id & mask` (the kernel's own filter form).
    Masked {
        /// The identifier to match.
        id: u16,
        /// Which bits of it must match (0x7FF: exactly `id`).
        mask: u16,
    },
}

/// Options of [`SocketCanBus::open`](super::SocketCanBus::open). Built with chained calls; the
/// defaults suit the control loop.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::socketcan::SocketCanOptions;
/// // A simulator on the same bus also needs the requests: the 0x280 multi-motor command and
/// // the single-motor ids, which are the same as the reply ids.
/// let options = SocketCanOptions::new()
///     .accept_id(0x280)
///     .drain_window(Duration::ZERO);
/// assert_eq!(options.extra_filters().len(), 1);
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SocketCanOptions {
    extra_filters: Vec<IdFilter>,
    error_events: bool,
    drain_window: Duration,
    receive_buffer_bytes: Option<usize>,
    send_buffer_bytes: Option<usize>,
}

impl Default for SocketCanOptions {
    fn default() -> Self {
        Self {
            extra_filters: Vec::new(),
            error_events: true,
            drain_window: DEFAULT_DRAIN_WINDOW,
            receive_buffer_bytes: None,
            send_buffer_bytes: None,
        }
    }
}

impl SocketCanOptions {
    /// The defaults: only [`RMD_REPLY_IDS`], error events on, a
    /// [`DEFAULT_DRAIN_WINDOW`] drain, the kernel's socket buffer sizes.
    pub fn new() -> Self {
        Self::default()
    }

    /// Also accepts the standard identifier `id` (checked at open: at most 0x7FF).
    #[must_use]
    pub fn accept_id(self, id: u16) -> Self {
        self.accept(IdFilter::Range {
            first: id,
            last: id,
        })
    }

    /// Also accepts every standard identifier in `ids`.
    #[must_use]
    pub fn accept_ids(self, ids: RangeInclusive<u16>) -> Self {
        self.accept(IdFilter::Range {
            first: *ids.start(),
            last: *ids.end(),
        })
    }

    /// Also accepts every identifier `x` with `x & mask == id & mask`.
    #[must_use]
    pub fn accept_masked(self, id: u16, mask: u16) -> Self {
        self.accept(IdFilter::Masked { id, mask })
    }

    /// Also accepts what `filter` describes.
    #[must_use]
    pub fn accept(mut self, filter: IdFilter) -> Self {
        self.extra_filters.push(filter);
        self
    }

    /// Whether CAN error frames are delivered as [`BusEvent`](crate::BusEvent)s (default on).
    #[must_use]
    pub fn error_events(mut self, on: bool) -> Self {
        self.error_events = on;
        self
    }

    /// How long [`open`](super::SocketCanBus::open) keeps discarding received frames before
    /// it returns: stale frames a USB adapter still delivers after a reconnect. Zero discards
    /// only what is already queued. Error events received meanwhile are kept.
    #[must_use]
    pub fn drain_window(mut self, window: Duration) -> Self {
        self.drain_window = window;
        self
    }

    /// Sets the socket's receive buffer (`SO_RCVBUF`; the kernel doubles the value and caps it
    /// at `net.core.rmem_max`).
    #[must_use]
    pub fn receive_buffer_bytes(mut self, bytes: usize) -> Self {
        self.receive_buffer_bytes = Some(bytes);
        self
    }

    /// Sets the socket's send buffer (`SO_SNDBUF`; the kernel doubles the value and caps it at
    /// `net.core.wmem_max`). A small one makes sends fail with
    /// [`BusError::TxQueueFull`](crate::BusError::TxQueueFull) sooner when the interface
    /// cannot keep up.
    #[must_use]
    pub fn send_buffer_bytes(mut self, bytes: usize) -> Self {
        self.send_buffer_bytes = Some(bytes);
        self
    }

    /// The extra identifier filters, in the order they were added.
    pub fn extra_filters(&self) -> &[IdFilter] {
        &self.extra_filters
    }

    /// Whether error frames are delivered as events.
    pub fn error_events_enabled(&self) -> bool {
        self.error_events
    }

    /// The drain window at open.
    pub fn drain_window_duration(&self) -> Duration {
        self.drain_window
    }

    /// The requested `SO_RCVBUF`, if any.
    pub fn receive_buffer(&self) -> Option<usize> {
        self.receive_buffer_bytes
    }

    /// The requested `SO_SNDBUF`, if any.
    pub fn send_buffer(&self) -> Option<usize> {
        self.send_buffer_bytes
    }
}
