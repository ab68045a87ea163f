//! The three system calls of the real-time path, on stack buffers: non-blocking `send`,
//! non-blocking `recvmsg` with the timestamp and drop-count control messages, and `ppoll`.
//! None of them allocates.

use std::io::IoSliceMut;
use std::os::fd::{AsRawFd, BorrowedFd};

use core::time::Duration;

use nix::errno::Errno;
use nix::poll::{PollFd, PollFlags, ppoll};
use nix::sys::socket::{ControlMessageOwned, MsgFlags, recvmsg, send};
use nix::sys::time::TimeSpec;

use super::kernel_frame::CAN_MTU;
use super::rx_time::timespec_nanos;

/// Longest single `ppoll` wait; longer waits loop (keeps the `timespec` in range).
const MAX_SINGLE_WAIT: Duration = Duration::from_secs(3600);

/// Room for `SCM_TIMESTAMPNS` (32 bytes) and `SO_RXQ_OVFL` (24 bytes) control messages, with
/// headroom, aligned for `cmsghdr`.
#[repr(C, align(8))]
struct ControlBuffer([u8; 128]);

/// One datagram read from the socket.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Datagram {
    /// The `struct can_frame` bytes, if the datagram had exactly that size.
    pub(crate) frame: Option<[u8; CAN_MTU]>,
    /// The kernel's receive time on `CLOCK_REALTIME`, in nanoseconds (`SCM_TIMESTAMPNS`).
    pub(crate) rx_realtime: Option<u64>,
    /// The socket's cumulative drop count (`SO_RXQ_OVFL`), when the kernel reported one.
    pub(crate) drops: Option<u32>,
}

/// Reads one datagram without blocking: `Ok(None)` when nothing is queued.
pub(crate) fn read_datagram(fd: BorrowedFd<'_>) -> Result<Option<Datagram>, Errno> {
    let mut bytes = [0u8; CAN_MTU];
    let mut control = ControlBuffer([0; 128]);
    loop {
        let mut iov = [IoSliceMut::new(&mut bytes)];
        let result = recvmsg::<()>(
            fd.as_raw_fd(),
            &mut iov,
            Some(&mut control.0),
            MsgFlags::MSG_DONTWAIT | MsgFlags::MSG_TRUNC,
        );
        let message = match result {
            Ok(message) => message,
            Err(Errno::EINTR) => continue,
            Err(Errno::EAGAIN) => return Ok(None),
            Err(errno) => return Err(errno),
        };
        let whole_frame = message.bytes == CAN_MTU;
        let mut rx_realtime = None;
        let mut drops = None;
        // A truncated control buffer (cannot happen with this size) only loses the metadata.
        if let Ok(messages) = message.cmsgs() {
            for control_message in messages {
                match control_message {
                    ControlMessageOwned::ScmTimestampns(ts) => {
                        rx_realtime = Some(timespec_nanos(ts.tv_sec(), ts.tv_nsec()));
                    }
                    ControlMessageOwned::RxqOvfl(count) => drops = Some(count),
                    _ => {}
                }
            }
        }
        return Ok(Some(Datagram {
            frame: whole_frame.then_some(bytes),
            rx_realtime,
            drops,
        }));
    }
}

/// Writes one `struct can_frame` without blocking.
pub(crate) fn write_frame(fd: BorrowedFd<'_>, bytes: &[u8; CAN_MTU]) -> Result<(), Errno> {
    loop {
        match send(fd.as_raw_fd(), bytes, MsgFlags::MSG_DONTWAIT) {
            Ok(CAN_MTU) => return Ok(()),
            // A raw CAN socket sends whole datagrams or nothing.
            Ok(_) => return Err(Errno::EIO),
            Err(Errno::EINTR) => continue,
            Err(errno) => return Err(errno),
        }
    }
}

/// Waits until the socket is readable (or has a pending error) or `timeout` passes, with the
/// kernel's high-resolution timer (nanosecond request, rounded only by the thread's timer
/// slack). A signal ends the wait early; callers loop on their absolute deadline.
pub(crate) fn wait_readable(fd: BorrowedFd<'_>, timeout: Duration) -> Result<(), Errno> {
    let mut fds = [PollFd::new(fd, PollFlags::POLLIN)];
    let timeout = TimeSpec::from_duration(timeout.min(MAX_SINGLE_WAIT));
    match ppoll(&mut fds, Some(timeout), None) {
        Ok(_) | Err(Errno::EINTR) => {}
        Err(errno) => return Err(errno),
    }
    if fds[0]
        .revents()
        .is_some_and(|revents| revents.contains(PollFlags::POLLNVAL))
    {
        return Err(Errno::EBADF);
    }
    Ok(())
}
