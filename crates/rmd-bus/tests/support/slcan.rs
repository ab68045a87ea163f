//! An slcan interface (the kernel's serial-line CAN driver, as used by many USB-serial CAN
//! adapters) whose "serial line" is a pseudo-terminal the test controls: whatever the test
//! writes to the terminal, the driver receives from its adapter (frames, state changes, error
//! reports); whatever the driver transmits, the test reads. If the test stops reading, the
//! line backs up and the driver stops its transmit queue, exactly like a real adapter that
//! cannot get frames onto the bus.
//!
//! Attaching the line discipline and asking for the interface name are two ioctls no safe
//! wrapper covers: this module is the tests' only unsafe code.
#![allow(unsafe_code)]

use std::os::fd::{AsRawFd, OwnedFd};

use nix::fcntl::{FcntlArg, OFlag, fcntl};
use nix::libc;

use super::ip;

/// `N_SLCAN`, the slcan line discipline number (`linux/tty.h`).
const N_SLCAN: libc::c_int = 17;

nix::ioctl_write_ptr_bad!(set_line_discipline, libc::TIOCSETD, libc::c_int);
nix::ioctl_read_bad!(interface_name, libc::SIOCGIFNAME, [u8; 16]);

/// An slcan interface on a pseudo-terminal; removed on drop.
pub struct Slcan {
    pub name: String,
    /// The adapter's side of the serial line.
    master: OwnedFd,
    /// The driver's side (the line discipline lives on it); closing it removes the interface.
    slave: Option<OwnedFd>,
}

impl Slcan {
    /// Creates the interface and brings it up.
    pub fn up() -> Self {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        // SAFETY: `pty.slave` is an open terminal descriptor for the whole call, and the
        // pointer refers to a live c_int the kernel only reads.
        unsafe { set_line_discipline(pty.slave.as_raw_fd(), &N_SLCAN) }
            .expect("attach the slcan line discipline (is slcan.ko loaded? are we root?)");
        let mut name = [0u8; 16];
        // SAFETY: the slcan line discipline answers SIOCGIFNAME by copying at most
        // IFNAMSIZ (16) bytes, NUL included, into the 16-byte buffer we pass.
        unsafe { interface_name(pty.slave.as_raw_fd(), &mut name) }.expect("SIOCGIFNAME");
        let len = name.iter().position(|&b| b == 0).unwrap_or(name.len());
        let name = String::from_utf8_lossy(&name[..len]).into_owned();
        fcntl(&pty.master, FcntlArg::F_SETFL(OFlag::O_NONBLOCK)).expect("non-blocking master");
        ip(&["link", "set", &name, "up"]);
        Self {
            name,
            master: pty.master,
            slave: Some(pty.slave),
        }
    }

    /// Makes the "adapter" report `line` (an slcan message without the trailing CR), e.g.
    /// `t1418...` (a frame), `sb256256` (bus-off), `e1a` (ACK error).
    pub fn adapter_says(&self, line: &str) {
        let message = format!("{line}\r");
        let written = nix::unistd::write(&self.master, message.as_bytes()).expect("pty write");
        assert_eq!(written, message.len());
    }

    /// Everything the driver has transmitted to the adapter so far (non-blocking).
    pub fn adapter_reads(&self) -> Vec<u8> {
        let mut all = Vec::new();
        let mut buf = [0u8; 4096];
        loop {
            match nix::unistd::read(&self.master, &mut buf) {
                Ok(0) | Err(nix::errno::Errno::EAGAIN) => return all,
                Ok(n) => all.extend_from_slice(&buf[..n]),
                Err(e) => panic!("pty read failed: {e}"),
            }
        }
    }
}

impl Drop for Slcan {
    fn drop(&mut self) {
        // Closing the driver's side detaches the line discipline and unregisters the
        // interface.
        self.slave.take();
    }
}
