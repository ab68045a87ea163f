//! The Linux SocketCAN backend: a [`CanBus`] on a real (or virtual) CAN interface.
//!
//! [`SocketCanBus::open`] binds one raw CAN socket to one interface and sets it up for the
//! control loop:
//!
//! - **Filters in the kernel**: only standard data frames with the RMD reply identifiers
//!   ([`RMD_REPLY_IDS`], 0x141..=0x160) and whatever the [`SocketCanOptions`] add reach the
//!   process; extended and remote frames never do. The filtering costs the loop nothing.
//! - **No echo of our own frames** (`CAN_RAW_RECV_OWN_MSGS` off). Other sockets on the same
//!   host still see them (`CAN_RAW_LOOPBACK` on), so a simulator or `candump` on the same
//!   interface works.
//! - **Non-blocking send**: [`CanBus::send`] never waits. A full transmit path (the
//!   interface's queue, `ENOBUFS`, or the socket's send buffer, `EAGAIN`) is
//!   [`BusError::TxQueueFull`]; a downed interface is [`BusError::InterfaceDown`].
//! - **Bus-off**: after a [`BusEvent::BusOff`] has been received, `send` refuses with
//!   [`BusError::BusOff`] without trying. The kernel would accept the frame and never
//!   transmit it (a bus-off controller has no carrier; Linux discards frames queued to an
//!   interface without carrier and still reports success). The refusal ends with the next
//!   sign of a working controller: a
//!   [`BusEvent::Restarted`] or any other controller-state event, any data frame received, or
//!   a receive overflow (events may have been lost, so the state is unknown).
//! - **Deadline receive**: [`CanBus::recv_until`] waits with `ppoll`, whose nanosecond timeout
//!   runs on the kernel's high-resolution timers (not `SO_RCVTIMEO`, which rounds to
//!   scheduler ticks). The deadline is absolute on [`MonotonicClock`]; it is never returned
//!   before it (the only lateness is the thread's timer slack, 50 µs by default and 0 for
//!   real-time threads, plus scheduling latency).
//! - **Waiting with other buses**: [`CanBus::readiness`] gives the socket to watch, so that a
//!   loop driving several interfaces waits for all of them in one `ppoll`
//!   ([`ready::wait_any`](crate::ready::wait_any)).
//! - **Kernel receive timestamps** (`SO_TIMESTAMPNS`) on every frame, converted to the
//!   [`MonotonicClock`] time line: see [Receive timestamps](self#receive-timestamps) below.
//! - **Error frames as events**: with [`SocketCanOptions::error_events`] (default on), the
//!   driver's error frames arrive in band as [`BusMessage::Event`]s (bus-off, error-passive,
//!   warning, restarted, lost arbitration, TX timeout, overflows, ...; see
//!   [`error_frame`]). Frames the socket itself had to drop because the process read too
//!   slowly (`SO_RXQ_OVFL`) are reported as [`BusEvent::RxOverflow`] too, just before the
//!   first frame the kernel queued after the loss (the kernel attaches the drop count to
//!   that frame).
//! - **Interface down or removed**: the kernel reports it once as a socket error, which the
//!   next `send` or `recv_until` returns as [`BusError::InterfaceDown`]; while the interface
//!   stays down every `send` keeps failing that way, and `recv_until` simply receives
//!   nothing.
//! - **Draining at open**: frames queued while the socket was being set up, and whatever
//!   arrives during the [drain window](SocketCanOptions::drain_window), are discarded, so the
//!   loop never acts on stale replies (a USB adapter can deliver old frames after a
//!   reconnect). [`SocketCanBus::drain`] does the same later (e.g. after a restart).
//!
//! Neither `send` nor `recv_until` allocates: frames and control messages live in stack
//! buffers, and the few events one error frame expands to wait in a fixed-size queue.
//!
//! # Receive timestamps
//!
//! The kernel stamps each frame on `CLOCK_REALTIME` when its network stack receives it. At
//! read time the backend samples `CLOCK_MONOTONIC`, `CLOCK_REALTIME`, `CLOCK_MONOTONIC` and
//! subtracts the measured offset (sampled again when the thread was preempted between the
//! reads). The error is below 100 ns plus, if NTP slews the wall clock
//! meanwhile, at most 500 ppm of the time the frame waited in the socket; a wall-clock *step*
//! while frames wait is clamped so that timestamps never exceed the read time and never go
//! backwards. See [`Received::at`].
//!
//! ```no_run
//! use core::time::Duration;
//! use rmd_bus::socketcan::{SocketCanBus, SocketCanOptions};
//! use rmd_bus::{BusMessage, CanBus, CanFrame, Clock, MonotonicClock};
//!
//! let mut bus = SocketCanBus::open("can0", &SocketCanOptions::new())?;
//! // Read status 1 of motor 1.
//! bus.send(&CanFrame::with_data(0x141, [0x9A, 0, 0, 0, 0, 0, 0, 0])?)?;
//! let deadline = MonotonicClock.now() + Duration::from_micros(500);
//! while let Some(received) = bus.recv_until(deadline)? {
//!     match received.message {
//!         BusMessage::Frame(frame) => println!("{} at {:?}", frame, received.at),
//!         BusMessage::Event(event) => eprintln!("bus event: {event}"),
//!     }
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod error_frame;
mod filters;
mod io;
mod kernel_frame;
mod link;
mod open_error;
mod options;
mod pending;
mod rx_time;

use core::time::Duration;
use std::os::fd::{AsFd, BorrowedFd};

use nix::errno::Errno;
use nix::sys::socket::{setsockopt, sockopt};
use socketcan::{CanSocket, Socket, SocketOptions};

use crate::Timestamp;
use crate::{
    BusError, BusEvent, BusMessage, CanBus, CanFrame, Clock, MonotonicClock, Readiness, Received,
    WaitOn,
};

pub use error_frame::{ErrorFrameEvents, decode_error_frame};
pub use open_error::OpenError;
pub use options::{DEFAULT_DRAIN_WINDOW, IdFilter, RMD_REPLY_IDS, SocketCanOptions};

use filters::FilterProblem;
use kernel_frame::RawFrame;
use pending::Pending;
use rx_time::ClockSample;

/// Counters of what a [`SocketCanBus`] has seen, for diagnostics.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct SocketCanStats {
    /// Data frames handed out by `recv_until`.
    pub frames_received: u64,
    /// Error frames received (each yields one or more events).
    pub error_frames: u64,
    /// Datagrams that were neither a standard data frame nor an error frame (extended or
    /// remote frames, wrong size). The kernel filters keep this at zero.
    pub frames_ignored: u64,
    /// Frames the kernel dropped because the socket's receive buffer was full
    /// (`SO_RXQ_OVFL`, cumulative since open).
    pub kernel_drops: u32,
    /// Sends refused because the transmit path was full.
    pub tx_queue_full: u64,
    /// Data frames discarded by draining (at open and by [`SocketCanBus::drain`]).
    pub drained: u64,
    /// Events lost because too many arrived while draining (the queue holds 32).
    pub events_lost: u64,
}

/// A [`CanBus`] on one Linux SocketCAN interface, on the [`MonotonicClock`] time line.
///
/// See the [module documentation](self) for what it sets up and how it behaves.
#[derive(Debug)]
pub struct SocketCanBus {
    socket: CanSocket,
    iface: String,
    pending: Pending,
    /// Last receive time handed out, nanoseconds on `CLOCK_MONOTONIC`.
    last_rx: u64,
    bus_off: bool,
    stats: SocketCanStats,
}

impl SocketCanBus {
    /// Opens `iface` (e.g. `"can0"`, `"vcan0"`) with `options`, then drains it.
    ///
    /// Not real-time: it inspects the interface, allocates, and waits for the drain window. An
    /// interface that is up but not running (just brought up, or bus-off) gets two seconds to
    /// start running before the open fails with [`OpenError::NotRunning`].
    ///
    /// Errors: an [`OpenError`] saying what is wrong and how to fix it (missing interface,
    /// interface down or not running, not a CAN interface, permission denied, no CAN support in
    /// the kernel, invalid filters).
    pub fn open(iface: &str, options: &SocketCanOptions) -> Result<Self, OpenError> {
        if !link::valid_name(iface) {
            return Err(OpenError::InvalidName {
                iface: iface.to_owned(),
            });
        }
        let filters = filters::kernel_filters(options).map_err(|problem| match problem {
            FilterProblem::Invalid(filter) => OpenError::InvalidFilter { filter },
            FilterProblem::TooMany(count) => OpenError::TooManyFilters { count },
        })?;
        check_link(iface)?;

        let socket = CanSocket::open(iface)
            .map_err(|error| classify(iface, "opening a CAN raw socket", error))?;
        configure(&socket, options, &filters)
            .map_err(|(action, error)| classify(iface, action, error))?;

        let mut bus = Self {
            socket,
            iface: iface.to_owned(),
            pending: Pending::new(),
            last_rx: 0,
            bus_off: false,
            stats: SocketCanStats::default(),
        };
        bus.drain(options.drain_window_duration())
            .map_err(|error| OpenError::Io {
                iface: iface.to_owned(),
                action: "draining stale frames",
                source: bus_error_to_io(error),
            })?;
        Ok(bus)
    }

    /// The interface this bus is bound to.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// What the bus has seen so far.
    pub fn stats(&self) -> SocketCanStats {
        self.stats
    }

    /// Whether the controller is known to be bus-off: a [`BusEvent::BusOff`] was received and
    /// no sign of recovery since (a restart or other state event, a received data frame, or a
    /// receive overflow). While it is, `send` refuses with [`BusError::BusOff`].
    pub fn is_bus_off(&self) -> bool {
        self.bus_off
    }

    /// Discards every data frame already received and every one arriving within `window`
    /// from now; returns how many were discarded. Error events are kept for `recv_until`.
    ///
    /// Blocks for `window`: call it outside the real-time cycle (after opening, after a
    /// controller restart).
    pub fn drain(&mut self, window: Duration) -> Result<u64, BusError> {
        let end = MonotonicClock.now() + window;
        let mut drained = 0;
        loop {
            match self.pump(false)? {
                Pumped::Discarded => drained += 1,
                Pumped::Queued | Pumped::Ignored => {}
                Pumped::Empty => {
                    let now = MonotonicClock.now();
                    if now >= end {
                        break;
                    }
                    io::wait_readable(self.socket.as_fd(), end - now).map_err(rx_error)?;
                }
            }
        }
        self.stats.drained += drained;
        Ok(drained)
    }

    /// Reads one datagram into the pending queue (or discards it when draining).
    fn pump(&mut self, keep_frames: bool) -> Result<Pumped, BusError> {
        let Some(datagram) = io::read_datagram(self.socket.as_fd()).map_err(rx_error)? else {
            return Ok(Pumped::Empty);
        };
        let sample = ClockSample::now();
        let at = match datagram.rx_realtime {
            Some(rx) => rx_time::realtime_to_monotonic(rx, sample, self.last_rx),
            // The kernel always attaches the timestamp; fall back to the read time.
            None => sample.mono_after.max(self.last_rx),
        };
        self.last_rx = at;
        let at = Timestamp::from_nanos(at);

        if let Some(drops) = datagram.drops
            && drops != self.stats.kernel_drops
        {
            self.stats.kernel_drops = drops;
            self.track_state(BusEvent::RxOverflow);
            self.queue(at, BusMessage::Event(BusEvent::RxOverflow));
        }
        match datagram.frame.map(|bytes| kernel_frame::decode(&bytes)) {
            Some(RawFrame::Data(frame)) if keep_frames => {
                self.bus_off = false;
                self.stats.frames_received += 1;
                self.queue(at, BusMessage::Frame(frame));
                Ok(Pumped::Queued)
            }
            Some(RawFrame::Data(_)) => {
                self.bus_off = false;
                Ok(Pumped::Discarded)
            }
            Some(RawFrame::Error { classes, data }) => {
                self.stats.error_frames += 1;
                for &event in decode_error_frame(classes, &data).as_slice() {
                    self.track_state(event);
                    self.queue(at, BusMessage::Event(event));
                }
                Ok(Pumped::Queued)
            }
            Some(RawFrame::Unsupported) | None => {
                self.stats.frames_ignored += 1;
                Ok(Pumped::Ignored)
            }
        }
    }

    fn queue(&mut self, at: Timestamp, message: BusMessage) {
        if !self.pending.push(Received { at, message }) {
            self.stats.events_lost += 1;
        }
    }

    fn track_state(&mut self, event: BusEvent) {
        match event {
            BusEvent::BusOff => self.bus_off = true,
            BusEvent::Restarted
            | BusEvent::ErrorActive
            | BusEvent::ErrorWarning
            | BusEvent::ErrorPassive
            | BusEvent::RxOverflow => self.bus_off = false,
            _ => {}
        }
    }

    fn tx_error(&mut self, errno: Errno) -> BusError {
        match errno {
            Errno::EAGAIN | Errno::ENOBUFS => {
                self.stats.tx_queue_full += 1;
                BusError::TxQueueFull
            }
            other => rx_error(other),
        }
    }
}

/// What one [`SocketCanBus::pump`] did.
enum Pumped {
    /// Nothing was queued in the socket.
    Empty,
    /// Something was added to the pending queue.
    Queued,
    /// A data frame was discarded (draining).
    Discarded,
    /// A datagram the backend does not represent was skipped.
    Ignored,
}

impl CanBus for SocketCanBus {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if self.bus_off {
            return Err(BusError::BusOff);
        }
        io::write_frame(self.socket.as_fd(), &kernel_frame::encode(frame))
            .map_err(|e| self.tx_error(e))
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        loop {
            if let Some(received) = self.pending.pop() {
                return Ok(Some(received));
            }
            match self.pump(true)? {
                Pumped::Queued | Pumped::Discarded | Pumped::Ignored => continue,
                Pumped::Empty => {}
            }
            let now = MonotonicClock.now();
            if now >= deadline {
                return Ok(None);
            }
            io::wait_readable(self.socket.as_fd(), deadline - now).map_err(rx_error)?;
        }
    }

    fn readiness(&mut self) -> Readiness<'_> {
        if self.pending.is_empty() {
            Readiness::Pending(WaitOn::readable(self.socket.as_fd()))
        } else {
            Readiness::Ready
        }
    }
}

impl AsFd for SocketCanBus {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.socket.as_fd()
    }
}

/// A receive-side (or generic) errno as a [`BusError`].
fn rx_error(errno: Errno) -> BusError {
    match errno {
        Errno::ENETDOWN | Errno::ENODEV | Errno::ENXIO => BusError::InterfaceDown,
        other => BusError::Io(other as i32),
    }
}

fn bus_error_to_io(error: BusError) -> std::io::Error {
    match error {
        BusError::Io(errno) => std::io::Error::from_raw_os_error(errno),
        other => std::io::Error::other(other),
    }
}

/// How long [`check_link`] waits for an interface that is up but not yet running: the kernel
/// updates the operational state asynchronously (up to a second after a carrier change).
const RUNNING_GRACE: Duration = Duration::from_secs(2);

/// Checks that `iface` exists, is a CAN interface, and is up and running.
fn check_link(iface: &str) -> Result<(), OpenError> {
    let give_up = MonotonicClock.now() + RUNNING_GRACE;
    loop {
        let state = link::inspect(iface)
            .map_err(|errno| classify(iface, "listing interfaces", errno.into()))?;
        let Some(state) = state else {
            return Err(OpenError::InterfaceMissing {
                iface: iface.to_owned(),
            });
        };
        if let Some(link_type) = state.link_type
            && link_type != link::ARPHRD_CAN
        {
            return Err(OpenError::NotCan {
                iface: iface.to_owned(),
                link_type,
            });
        }
        if !state.up {
            return Err(OpenError::InterfaceDown {
                iface: iface.to_owned(),
            });
        }
        if state.running {
            return Ok(());
        }
        // Just brought up (or bus-off): give the kernel's link state a moment to settle.
        if MonotonicClock.now() >= give_up {
            return Err(OpenError::NotRunning {
                iface: iface.to_owned(),
            });
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Applies the socket options; on failure, what was being done and the error.
fn configure(
    socket: &CanSocket,
    options: &SocketCanOptions,
    filters: &[(u32, u32)],
) -> Result<(), (&'static str, std::io::Error)> {
    let step = |action: &'static str| move |error: std::io::Error| (action, error);
    let nix_step = |action: &'static str| move |errno: Errno| (action, std::io::Error::from(errno));
    socket
        .set_nonblocking(true)
        .map_err(step("making the socket non-blocking"))?;
    socket
        .set_filters(filters)
        .map_err(step("setting the CAN id filters"))?;
    let error_mask = if options.error_events_enabled() {
        error_frame::ALL_ERROR_CLASSES
    } else {
        0
    };
    socket
        .set_error_filter(error_mask)
        .map_err(step("setting the CAN error mask"))?;
    socket
        .set_loopback(true)
        .map_err(step("enabling local loopback"))?;
    socket
        .set_recv_own_msgs(false)
        .map_err(step("disabling the echo of own frames"))?;
    socket
        .set_recv_timestamp(true)
        .map_err(step("enabling receive timestamps"))?;
    setsockopt(socket, sockopt::RxqOvfl, &1).map_err(nix_step("enabling drop counts"))?;
    if let Some(bytes) = options.receive_buffer() {
        setsockopt(socket, sockopt::RcvBuf, &bytes)
            .map_err(nix_step("setting the receive buffer size"))?;
    }
    if let Some(bytes) = options.send_buffer() {
        setsockopt(socket, sockopt::SndBuf, &bytes)
            .map_err(nix_step("setting the send buffer size"))?;
    }
    Ok(())
}

/// Turns an OS error during open into the matching [`OpenError`].
fn classify(iface: &str, action: &'static str, error: std::io::Error) -> OpenError {
    let errno = error.raw_os_error().map(Errno::from_raw);
    match errno {
        Some(Errno::EAFNOSUPPORT | Errno::EPROTONOSUPPORT) => OpenError::CanUnsupported,
        Some(errno @ (Errno::EPERM | Errno::EACCES)) => OpenError::PermissionDenied {
            iface: iface.to_owned(),
            action,
            errno,
        },
        Some(Errno::ENODEV | Errno::ENXIO) => OpenError::InterfaceMissing {
            iface: iface.to_owned(),
        },
        _ => OpenError::Io {
            iface: iface.to_owned(),
            action,
            source: error,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bus_can_move_to_the_real_time_thread() {
        fn assert_send<T: Send>() {}
        assert_send::<SocketCanBus>();
    }

    #[test]
    fn errnos_map_to_typed_bus_errors() {
        assert_eq!(rx_error(Errno::ENETDOWN), BusError::InterfaceDown);
        assert_eq!(rx_error(Errno::ENODEV), BusError::InterfaceDown);
        assert_eq!(rx_error(Errno::EIO), BusError::Io(Errno::EIO as i32));
    }

    #[test]
    fn open_errors_are_classified_by_errno() {
        let os = |errno: Errno| std::io::Error::from_raw_os_error(errno as i32);
        assert!(matches!(
            classify("can0", "x", os(Errno::EAFNOSUPPORT)),
            OpenError::CanUnsupported
        ));
        assert!(matches!(
            classify("can0", "x", os(Errno::EPERM)),
            OpenError::PermissionDenied {
                errno: Errno::EPERM,
                ..
            }
        ));
        assert!(matches!(
            classify("can0", "x", os(Errno::EACCES)),
            OpenError::PermissionDenied { .. }
        ));
        assert!(matches!(
            classify("can0", "x", os(Errno::ENODEV)),
            OpenError::InterfaceMissing { .. }
        ));
        assert!(matches!(
            classify("can0", "x", os(Errno::EINVAL)),
            OpenError::Io { .. }
        ));
    }

    #[test]
    fn bad_names_and_filters_fail_before_touching_the_system() {
        assert!(matches!(
            SocketCanBus::open("not a name", &SocketCanOptions::new()),
            Err(OpenError::InvalidName { .. })
        ));
        assert!(matches!(
            SocketCanBus::open("can0", &SocketCanOptions::new().accept_id(0x800)),
            Err(OpenError::InvalidFilter { .. })
        ));
    }

    #[test]
    fn a_missing_interface_is_reported_as_such() {
        let error = SocketCanBus::open("rmdnope0", &SocketCanOptions::new()).unwrap_err();
        assert!(
            matches!(error, OpenError::InterfaceMissing { .. }),
            "{error}"
        );
    }
}
